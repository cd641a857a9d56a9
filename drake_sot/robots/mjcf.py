"""MJCF (MuJoCo) fixes applied in memory, the MJCF twin of :mod:`drake_sot.robots.urdf` (the file
on disk is never edited): :func:`prepare_mjcf` returns the fixed text and the fixes it applied,
one sentence each.

- every ``<geom>`` gets ``contype="0" conaffinity="0"``: Drake's MJCF parser registers a geom
  as collision geometry unless both are 0 (the robot description gives simple shapes); its
  visual stays (unless ``group`` > 2, as in MuJoCo); the geoms stay, as they give the mass of a
  body without ``<inertial>``;
- ``<actuator>`` elements are removed: Drake's parser adds a ``<motor>``'s or ``<position>``'s
  actuator (a position one with its own gains), and the loader adds one per moving joint with
  the robot's drive; so are ``<sensor>``, ``<tendon>``, ``<equality>``, ``<contact>`` and
  ``<keyframe>`` (the controller knows no tendon nor closed loop; the collision filters are the
  loader's);
- each joint's ``actuatorfrcrange``, read by :mod:`~drake_sot.robots.model_tree` as its effort
  limit, is removed (Drake does not read it and warns);
- the frozen joints are removed: Drake welds a body without a joint to its parent;
- mesh assets: a file path is made absolute (the text is parsed from memory; MuJoCo's rule:
  the compiler's ``meshdir``, else the model's directory) and goes through ``mesh_file``
  (converted to OBJ, scale baked in; Drake's MJCF parser reads OBJ only); with ``mesh_file``
  None (a plant without SceneGraph) the mesh geoms of bodies with an ``<inertial>`` and the
  assets no geom uses then are removed;
- light sensor bodies are added where the model has none (``AddedWeld``): a jointless body in
  the parent body, whose weld Drake names ``<parent>_welds_to_<child>`` (the weld's name must
  be that).

Not read by Drake and so not by the robot either: MuJoCo's solver settings (``<option>``'s
contact parameters, ``solref``/``solimp``), joint ``armature`` (the description's
``rotor_inertia`` is the robot's), ``<site>`` elements, ``ref`` positions. No pydrake import here.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from pathlib import Path

from drake_sot.robots.model_tree import weld_name
from drake_sot.robots.urdf import ADDED_LINK_INERTIA, ADDED_LINK_MASS, AddedWeld, mesh_scale

#: The top-level elements removed (see the module docstring for why).
_REMOVED = ("actuator", "sensor", "tendon", "equality", "contact", "keyframe")


def prepare_mjcf(
    text: str,
    *,
    directory: Path,
    mesh_file: Callable[[Path, tuple[float, float, float]], str] | None,
    frozen_joints: Sequence[str] = (),
    added_welds: Sequence[AddedWeld] = (),
) -> tuple[str, list[str]]:
    """Apply the fixes listed in the module docstring to the MJCF ``text``.

    Args:
        text: the MJCF as read from its file.
        directory: the model file's directory (for relative mesh files).
        mesh_file: (source mesh, scale) → the path of the mesh to load (a converted OBJ, scale
            baked in); None drops the mesh geoms that give no mass.
        frozen_joints: joints to remove, welding their bodies (must exist).
        added_welds: sensor bodies to add (their parents must exist, their names must not, the
            weld's name must be the one Drake gives).

    Returns:
        The fixed MJCF text and the fixes applied (a fix that found nothing to change is not listed).

    Raises:
        ValueError: a frozen joint or an added weld's parent is not in the model, an added body
            exists already, an added weld not named as Drake names it (naming them).
        RobotFileMissing: a mesh file that is not there.
    """
    fixes: list[str] = []
    root = ET.fromstring(text)
    bodies = {body.get("name"): body for body in root.iter("body")}
    joint_parent = {joint.get("name"): body for body in bodies.values() for joint in body.findall("joint")}
    missing = sorted(set(frozen_joints) - set(joint_parent))
    if missing:
        raise ValueError(f"frozen joints {missing} are not in the model; joints: {sorted(joint_parent)}")

    for name in frozen_joints:
        body = joint_parent[name]
        body.remove(next(j for j in body.findall("joint") if j.get("name") == name))
    if frozen_joints:
        fixes.append(f"{len(frozen_joints)} frozen joints removed (their bodies welded)")

    for tag in _REMOVED:
        elements = root.findall(tag)
        for element in elements:
            root.remove(element)
        if elements:
            fixes.append(f"{len(elements)} <{tag}> elements removed")
    ranges = 0
    for joint in root.iter("joint"):
        for key in ("actuatorfrcrange", "actuatorfrclimited"):
            if joint.attrib.pop(key, None) is not None:
                ranges += 1
    if ranges:
        fixes.append(f"{ranges} joint actuatorfrcrange attributes removed (read as effort limits)")

    geoms = 0
    for geom in root.iter("geom"):
        if geom.get("contype") != "0" or geom.get("conaffinity") != "0":
            geom.set("contype", "0")
            geom.set("conaffinity", "0")
            geoms += 1
    if geoms:
        fixes.append(f"{geoms} geoms made visual only (simple collision shapes from the description)")

    if mesh_file is None:
        dropped = 0
        for body in bodies.values():
            if body.find("inertial") is None:
                continue
            for geom in body.findall("geom"):
                if "mesh" in geom.attrib:
                    body.remove(geom)
                    dropped += 1
        used = {geom.get("mesh") for geom in root.iter("geom")}
        for asset in root.findall("asset"):
            for mesh in asset.findall("mesh"):
                if (mesh.get("name") or Path(mesh.get("file", "")).stem) not in used:
                    asset.remove(mesh)
        if dropped:
            fixes.append(f"{dropped} mesh geoms dropped (no geometry wanted, the bodies' mass is given)")
    compiler = root.find("compiler")
    meshdir = (
        Path(compiler.get("meshdir") or compiler.get("assetdir") or "") if compiler is not None else Path()
    )
    converted = 0
    for mesh in root.findall("asset/mesh"):
        if "file" not in mesh.attrib:
            continue
        source = directory / meshdir / mesh.get("file")
        if mesh_file is None:
            mesh.set("file", str(source))
            continue
        mesh.set("name", mesh.get("name") or Path(mesh.get("file")).stem)
        mesh.set("file", mesh_file(source, mesh_scale(mesh.attrib.pop("scale", None))))
        converted += 1
    if converted:
        fixes.append(f"{converted} mesh assets converted to OBJ (scale baked in)")

    for weld in added_welds:
        if weld.parent not in bodies:
            raise ValueError(f"added weld {weld.name!r}: no body {weld.parent!r} in the model")
        if weld.child in bodies:
            raise ValueError(f"added weld {weld.name!r}: body {weld.child!r} exists already")
        drake_name = weld_name("mjcf", weld.parent, weld.child, weld.name)
        if weld.name != drake_name:
            raise ValueError(
                f"added weld {weld.name!r}: Drake names the weld of an MJCF body {drake_name!r}; name it so"
            )
        body = ET.SubElement(
            bodies[weld.parent], "body", name=weld.child, pos=" ".join(repr(float(v)) for v in weld.xyz)
        )
        i = repr(ADDED_LINK_INERTIA)
        ET.SubElement(body, "inertial", pos="0 0 0", mass=repr(ADDED_LINK_MASS), diaginertia=f"{i} {i} {i}")
    if added_welds:
        fixes.append(f"{len(added_welds)} sensor bodies welded where the model has none")
    return ET.tostring(root, encoding="unicode"), fixes
