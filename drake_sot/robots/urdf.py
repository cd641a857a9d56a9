"""URDF fixes applied in memory, so that a robot of ``example-robot-data`` loads in Drake
as shipped (the files on disk are never edited).

:func:`prepare_urdf` returns the fixed text and the list of fixes it applied (each a
sentence naming what it changed and how many times), for the log and the tests:

- ``package:///pkg/…`` (an empty host: 93 typos in ``talos_full_v2.urdf``) → ``package://pkg/…``;
- every ``package://`` URI is resolved through the robot's own package map (the URIs say
  ``example-robot-data`` while the package.xml names ``example_robot_descriptions``), a mesh
  path against the model's directory; an unknown package or a missing file is an error
  naming it;
- a material defined twice with different colours (TALOS's ``DarkGrey``) keeps its
  first top-level definition; the inline redefinitions lose their colour;
- joints with a ``<mimic>`` element and the robot's frozen joints (TALOS's gripper
  linkage) become fixed: Drake refuses a mimic joint whose leader has no degree of
  freedom, and the scenarios drive no gripper;
- ``<transmission>`` and ``<gazebo>`` elements are removed: the loader adds one actuator
  per moving joint with the robot's gains;
- the ``friction`` attribute of ``<dynamics>`` is removed (MultibodyPlant has no joint
  friction and warns once per joint);
- ``<collision>`` elements are removed (the robot description gives simple shapes:
  sole spheres and convex body shapes);
- visual meshes go through ``mesh_file`` (conversion to OBJ with the scale baked in), or
  are removed when ``mesh_file`` is None (a plant without SceneGraph);
- light sensor links are welded where the model has none (``AddedWeld``: e.g. a sole
  link under each G1 ankle, whose weld reads the ankle force).

No pydrake import here: XML in, XML out.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Container, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from drake_sot.errors import UnknownNameError
from drake_sot.robots.errors import RobotFileMissing

#: Mass [kg] and inertia [kg m^2] of an added sensor link (Drake needs a positive mass
#: on a body at the end of a weld only for a floating one; a small one keeps it well posed).
ADDED_LINK_MASS = 0.01
ADDED_LINK_INERTIA = 1e-6


@dataclass(frozen=True)
class AddedWeld:
    """A link the model lacks, welded to ``parent`` at ``xyz`` [m] (axes of the parent):
    the weld joint ``name`` then reads the force through it, as a force/torque sensor."""

    name: str
    parent: str
    child: str
    xyz: tuple[float, float, float]


def geometry_fixes(collisions: int, meshes: int, visuals_dropped: int) -> list[str]:
    """The sentences of the geometry fixes of a URDF or an SDF: ``collisions`` collision elements
    removed, ``meshes`` visual meshes converted, ``visuals_dropped`` visuals dropped (none said
    for a count of 0)."""
    return [
        sentence
        for count, sentence in (
            (collisions, f"{collisions} <collision> elements removed (simple shapes from the description)"),
            (meshes, f"{meshes} visual meshes converted to OBJ (scale baked in)"),
            (visuals_dropped, f"{visuals_dropped} visuals dropped (no geometry wanted)"),
        )
        if count
    ]


def check_added_weld(weld: AddedWeld, links: Container[str], joints: Container[str]) -> None:
    """Raise ValueError (naming the weld and the link) when ``weld``'s parent is not one of the
    model's ``links`` or its link or joint exists already."""
    if weld.parent not in links:
        raise ValueError(f"added weld {weld.name!r}: no link {weld.parent!r} in the model")
    if weld.child in links or weld.name in joints:
        raise ValueError(f"added weld {weld.name!r}: link {weld.child!r} or joint exists already")


def resolve_package_uri(uri: str, packages: Mapping[str, Path]) -> Path:
    """The file of a ``package://name/relative/path`` URI through ``packages`` (name → directory).

    Raises :class:`~drake_sot.errors.UnknownNameError` (a ValueError) for an unknown package
    name (listing the known ones) and
    RobotFileMissing (a FileNotFoundError) for a file that is not there (naming it).
    """
    rest = uri.removeprefix("package://").lstrip("/")
    name, _, relative = rest.partition("/")
    if name not in packages:
        raise UnknownNameError("package", name, packages, where=f"URI {uri!r}")
    path = Path(packages[name]) / relative
    if not path.is_file():
        raise RobotFileMissing(f"URI {uri!r}: file {path} does not exist")
    return path


def mesh_source(uri: str, directory: Path | None, packages: Mapping[str, Path]) -> Path:
    """The file of a mesh URI: ``package://`` (through ``packages``), else ``file://`` or a path
    relative to ``directory`` (the model file's, as Drake reads a model from its file).

    Raises UnknownNameError for an unknown package, RobotFileMissing for a file not there, and
    ValueError for a path when no ``directory`` is given (each naming the URI).
    """
    if uri.startswith("package://"):
        return resolve_package_uri(uri, packages)
    if directory is None:
        raise ValueError(f"mesh URI {uri!r}: a path, and no model directory to read it from")
    path = Path(directory) / uri.removeprefix("file://")
    if not uri.strip() or not path.is_file():
        raise RobotFileMissing(f"mesh URI {uri!r}: file {path} does not exist")
    return path


def mesh_scale(text: str | None) -> tuple[float, float, float]:
    """The three scale factors of a mesh's ``scale`` (1 or 3 numbers; None: unit scale); a
    ValueError names a text of another count."""
    if text is None:
        return (1.0, 1.0, 1.0)
    values = [float(v) for v in text.split()]
    if len(values) == 1:
        values *= 3
    if len(values) != 3:
        raise ValueError(f"mesh scale {text!r}: needs 1 or 3 numbers")
    return (values[0], values[1], values[2])


def prepare_urdf(
    text: str,
    *,
    packages: Mapping[str, Path],
    mesh_file: Callable[[Path, tuple[float, float, float]], str] | None,
    frozen_joints: Sequence[str] = (),
    added_welds: Sequence[AddedWeld] = (),
    directory: Path | None = None,
) -> tuple[str, list[str]]:
    """Apply the fixes listed in the module docstring to URDF ``text``.

    Args:
        text: the URDF as read from its file.
        packages: package name → directory, for ``package://`` URIs.
        directory: the model file's directory, for mesh file names that are paths.
        mesh_file: (source mesh, scale) → the URI of the mesh to load (a converted OBJ,
            scale baked in); None drops the visuals.
        frozen_joints: joints to make fixed (must exist).
        added_welds: sensor links to add (their parents must exist, their names must not).

    Returns:
        The fixed URDF text and the fixes applied, one sentence each (a fix that found
        nothing to change is not listed).
    """
    fixes: list[str] = []
    typos = text.count("package:///")
    if typos:
        text = text.replace("package:///", "package://")
        fixes.append(f"{typos} 'package:///' URIs (empty host) read as 'package://'")
    root = ET.fromstring(text)

    links = {link.get("name") for link in root.findall("link")}
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    missing = sorted(set(frozen_joints) - set(joints))
    if missing:
        raise ValueError(f"frozen joints {missing} are not in the model; joints: {sorted(joints)}")

    # Materials: the first top-level definition of a name wins.
    colours: dict[str, str] = {}
    for material in root.findall("material"):
        colour = material.find("color")
        if colour is not None:
            colours.setdefault(material.get("name"), colour.get("rgba"))
    dropped = 0
    for link in root.findall("link"):
        for material in link.iter("material"):
            colour = material.find("color")
            if colour is None:
                continue
            name = material.get("name")
            if name in colours and colours[name] != colour.get("rgba"):
                material.remove(colour)
                dropped += 1
            else:
                colours.setdefault(name, colour.get("rgba"))
    if dropped:
        fixes.append(f"{dropped} conflicting redefinitions of a material's colour dropped (first one kept)")

    frozen = 0
    for name, joint in joints.items():
        if joint.get("type") == "fixed" or (joint.find("mimic") is None and name not in frozen_joints):
            continue
        joint.set("type", "fixed")
        for child in list(joint):
            if child.tag in ("mimic", "limit", "axis", "dynamics", "safety_controller"):
                joint.remove(child)
        frozen += 1
    if frozen:
        fixes.append(f"{frozen} mimic or frozen joints made fixed")

    for tag in ("transmission", "gazebo"):
        elements = root.findall(tag)
        for element in elements:
            root.remove(element)
        if elements:
            fixes.append(f"{len(elements)} <{tag}> elements removed")

    frictions = 0
    for dynamics in root.iter("dynamics"):
        if "friction" in dynamics.attrib:
            del dynamics.attrib["friction"]
            frictions += 1
    if frictions:
        fixes.append(f"{frictions} joint friction attributes removed (MultibodyPlant has no joint friction)")

    collisions = meshes = visuals_dropped = 0
    for link in root.findall("link"):
        for collision in link.findall("collision"):
            link.remove(collision)
            collisions += 1
        for visual in link.findall("visual"):
            if mesh_file is None:
                link.remove(visual)
                visuals_dropped += 1
                continue
            mesh = visual.find("geometry/mesh")
            if mesh is None:
                continue
            source = mesh_source(mesh.get("filename", ""), directory, packages)
            mesh.set("filename", mesh_file(source, mesh_scale(mesh.get("scale"))))
            mesh.attrib.pop("scale", None)
            meshes += 1
    fixes += geometry_fixes(collisions, meshes, visuals_dropped)

    for weld in added_welds:
        check_added_weld(weld, links, joints)
        link = ET.SubElement(root, "link", name=weld.child)
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "mass", value=repr(ADDED_LINK_MASS))
        i = repr(ADDED_LINK_INERTIA)
        ET.SubElement(inertial, "inertia", ixx=i, iyy=i, izz=i, ixy="0", ixz="0", iyz="0")
        joint = ET.SubElement(root, "joint", name=weld.name, type="fixed")
        ET.SubElement(joint, "parent", link=weld.parent)
        ET.SubElement(joint, "child", link=weld.child)
        ET.SubElement(joint, "origin", xyz=" ".join(repr(float(v)) for v in weld.xyz), rpy="0 0 0")
    if added_welds:
        fixes.append(f"{len(added_welds)} sensor links welded where the model has none")
    return ET.tostring(root, encoding="unicode"), fixes
