"""SDF fixes applied in memory, the SDF twin of :mod:`drake_sot.robots.urdf` (the file on disk is
never edited): :func:`prepare_sdf` returns the fixed text and the fixes it applied, one sentence
each.

- ``<collision>`` elements are removed (the robot description gives simple shapes);
- the frozen joints become fixed (their ``<axis>`` removed);
- every joint limit's ``<effort>`` is set to 0: Drake's SDF parser adds an actuator to each
  joint with a non-zero effort limit, and the loader adds one per moving joint with the
  robot's drive;
- visual meshes go through ``mesh_file`` (``package://`` resolved through the robot's package
  map, a relative URI against the model's directory, as the text is parsed from memory), or
  are removed when ``mesh_file`` is None; a ``<plugin>`` or ``<sensor>`` is removed (Drake
  reads neither);
- light sensor links are welded where the model has none (``AddedWeld``): a link placed on
  its parent and a fixed joint of the weld's name.

What the tree reader (:mod:`drake_sot.robots.model_tree`) refuses (nested models,
``<include>``) is not met here: the description is read first. No pydrake import here.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from drake_sot.robots.urdf import (
    ADDED_LINK_INERTIA,
    ADDED_LINK_MASS,
    AddedWeld,
    check_added_weld,
    geometry_fixes,
    mesh_scale,
    mesh_source,
)


def prepare_sdf(
    text: str,
    *,
    directory: Path,
    packages: Mapping[str, Path],
    mesh_file: Callable[[Path, tuple[float, float, float]], str] | None,
    frozen_joints: Sequence[str] = (),
    added_welds: Sequence[AddedWeld] = (),
) -> tuple[str, list[str]]:
    """Apply the fixes listed in the module docstring to the SDF ``text`` of one model.

    Args:
        text: the SDF as read from its file.
        directory: the model file's directory (for relative mesh URIs).
        packages: package name → directory, for ``package://`` URIs.
        mesh_file: (source mesh, scale) → the URI of the mesh to load (a converted OBJ,
            scale baked in); None drops the visuals.
        frozen_joints: joints to make fixed (must exist).
        added_welds: sensor links to add (their parents must exist, their names must not).

    Returns:
        The fixed SDF text and the fixes applied (a fix that found nothing to change is not listed).

    Raises:
        ValueError: a frozen joint or an added weld's parent is not in the model, an added
            link or joint exists already (naming it); the text is not one model under <sdf>.
        UnknownNameError, RobotFileMissing: a mesh URI whose package or file is unknown.
    """
    fixes: list[str] = []
    root = ET.fromstring(text)
    models = root.findall("model")
    if len(models) != 1:
        raise ValueError(f"an SDF robot is one <model> under <sdf>; it has {len(models)}")
    model = models[0]
    links = {link.get("name"): link for link in model.findall("link")}
    joints = {joint.get("name"): joint for joint in model.findall("joint")}
    missing = sorted(set(frozen_joints) - set(joints))
    if missing:
        raise ValueError(f"frozen joints {missing} are not in the model; joints: {sorted(joints)}")

    for name in frozen_joints:
        joint = joints[name]
        joint.set("type", "fixed")
        for axis in joint.findall("axis"):
            joint.remove(axis)
    if frozen_joints:
        fixes.append(f"{len(frozen_joints)} frozen joints made fixed")

    efforts = 0
    for joint in model.findall("joint"):
        if joint.get("type") not in ("revolute", "continuous", "prismatic"):
            continue
        axis = joint.find("axis")
        axis = ET.SubElement(joint, "axis") if axis is None else axis
        limit = axis.find("limit")
        limit = ET.SubElement(axis, "limit") if limit is None else limit
        effort = limit.find("effort")
        effort = ET.SubElement(limit, "effort") if effort is None else effort
        if (effort.text or "").strip() != "0":  # absent, it is -1: unlimited, and actuated
            effort.text = "0"
            efforts += 1
    if efforts:
        fixes.append(f"{efforts} joint effort limits set to 0 (the loader adds the actuators)")

    removed = {"collision": 0, "sensor": 0, "plugin": 0}
    meshes = visuals_dropped = 0
    for parent in (model, *links.values()):
        for tag in ("sensor", "plugin"):
            for element in parent.findall(tag):
                parent.remove(element)
                removed[tag] += 1
    for link in links.values():
        for collision in link.findall("collision"):
            link.remove(collision)
            removed["collision"] += 1
        for visual in link.findall("visual"):
            if mesh_file is None:
                link.remove(visual)
                visuals_dropped += 1
                continue
            mesh = visual.find("geometry/mesh")
            if mesh is None:
                continue
            uri = mesh.find("uri")
            source = mesh_source((uri.text or "").strip() if uri is not None else "", directory, packages)
            scale = mesh.find("scale")
            uri.text = mesh_file(source, mesh_scale(None if scale is None else scale.text))
            if scale is not None:
                mesh.remove(scale)
            meshes += 1
    if removed["sensor"] or removed["plugin"]:
        fixes.append(f"{removed['sensor']} <sensor> and {removed['plugin']} <plugin> elements removed")
    fixes += geometry_fixes(removed["collision"], meshes, visuals_dropped)

    for weld in added_welds:
        check_added_weld(weld, links, joints)
        link = ET.SubElement(model, "link", name=weld.child)
        ET.SubElement(link, "pose", relative_to=weld.parent).text = (
            " ".join(repr(float(v)) for v in weld.xyz) + " 0 0 0"
        )
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "mass").text = repr(ADDED_LINK_MASS)
        inertia = ET.SubElement(inertial, "inertia")
        for key in ("ixx", "iyy", "izz"):
            ET.SubElement(inertia, key).text = repr(ADDED_LINK_INERTIA)
        joint = ET.SubElement(model, "joint", name=weld.name, type="fixed")
        ET.SubElement(joint, "parent").text = weld.parent
        ET.SubElement(joint, "child").text = weld.child
    if added_welds:
        fixes.append(f"{len(added_welds)} sensor links welded where the model has none")
    return ET.tostring(root, encoding="unicode"), fixes
