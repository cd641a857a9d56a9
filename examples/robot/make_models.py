"""Writes ``humanoid.urdf``, ``humanoid.sdf`` and ``humanoid.xml`` (MJCF): the embedded humanoid's
tables (:mod:`drake_sot.models.humanoid`) as a model file of each format Drake parses, the robot
that ``humanoid.toml``, ``humanoid_sdf.toml`` and ``humanoid_mjcf.toml`` describe and the guide
"Your own robot" walks. The descriptions of the SDF and the MJCF are that of the URDF (written by
hand) with their own name, title, model file and, for the MJCF, the names Drake gives its welds.

The same links (mass, inertia about the centre of mass, one primitive shape as the visual),
revolute joints (axis, limits, effort and velocity limits) and force/torque sensor welds as the
robot built in code, so that it walks with the gains known to work on it; but loaded as any
user's robot is, through its model file and description. The three files are one robot written
three ways, as their authors would: the URDF's joints carry their limits, the SDF's links are
placed on their parents (``relative_to``), the MJCF nests its bodies, frees the pelvis with
``<freejoint>``, gives angles in radians, sensor bodies without a joint (welded) and the efforts
as its motors' ``forcerange``. Run once when the tables change::

    python examples/robot/make_models.py
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from drake_sot.models import humanoid
from drake_sot.robots.model_tree import weld_name

HERE = Path(__file__).resolve().parent
#: The inertia matrix entries of the three formats, by (row, column).
_INERTIA = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}


def _numbers(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _inertia(link) -> dict[str, str]:
    """The link's inertia about its centre of mass [kg m^2], by URDF attribute name."""
    _, about_origin = humanoid._shape_and_inertia(link)
    about_com = about_origin.Shift(about_origin.get_com())
    inertia = about_com.CalcRotationalInertia().CopyToFullMatrix3()
    return {key: f"{inertia[i, j]:.9g}" for key, (i, j) in _INERTIA.items()}


def _drive(joint):
    """The joint's drive in the embedded tables (one per left/right pair)."""
    return humanoid.DRIVES[joint.name.removeprefix("r_").removeprefix("l_")]


def _text(root: ET.Element) -> str:
    ET.indent(root)
    comment = "<!-- Written by examples/robot/make_models.py from drake_sot.models.humanoid: do not edit. -->"
    return f'<?xml version="1.0"?>\n{comment}\n{ET.tostring(root, encoding="unicode")}\n'


def urdf_text() -> str:
    """The URDF of the embedded humanoid, as text."""
    robot = ET.Element("robot", name="humanoid")
    colours = {}
    for link in humanoid.LINKS:
        colours.setdefault(tuple(link.colour.rgba), f"colour_{len(colours)}")
    for rgba, name in colours.items():
        ET.SubElement(ET.SubElement(robot, "material", name=name), "color", rgba=_numbers(rgba))
    for link in humanoid.LINKS:
        element = ET.SubElement(robot, "link", name=link.name)
        inertial = ET.SubElement(element, "inertial")
        ET.SubElement(inertial, "origin", xyz=_numbers(link.centre), rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=f"{link.mass:.9g}")
        ET.SubElement(inertial, "inertia", **_inertia(link))
        visual = ET.SubElement(element, "visual")
        ET.SubElement(visual, "origin", xyz=_numbers(link.centre), rpy="0 0 0")
        geometry = ET.SubElement(visual, "geometry")
        kind, *dims = link.shape
        if kind == "box":
            ET.SubElement(geometry, "box", size=_numbers(dims))
        elif kind == "cylinder":
            ET.SubElement(geometry, "cylinder", radius=f"{dims[0]:.9g}", length=f"{dims[1]:.9g}")
        else:
            ET.SubElement(geometry, "sphere", radius=f"{dims[0]:.9g}")
        ET.SubElement(visual, "material", name=colours[tuple(link.colour.rgba)])
    for joint in humanoid.JOINTS:
        drive = _drive(joint)
        element = ET.SubElement(robot, "joint", name=joint.name, type="revolute")
        ET.SubElement(element, "parent", link=joint.parent)
        ET.SubElement(element, "child", link=joint.child)
        ET.SubElement(element, "origin", xyz=_numbers(joint.position), rpy="0 0 0")
        ET.SubElement(element, "axis", xyz=_numbers(humanoid._AXES[joint.axis]))
        ET.SubElement(
            element,
            "limit",
            lower=f"{joint.limits[0]:.9g}",
            upper=f"{joint.limits[1]:.9g}",
            effort=f"{drive.effort:.9g}",
            velocity=f"{drive.velocity:.9g}",
        )
    for name, parent, child, drop in humanoid.SENSORS:
        element = ET.SubElement(robot, "joint", name=name, type="fixed")
        ET.SubElement(element, "parent", link=parent)
        ET.SubElement(element, "child", link=child)
        ET.SubElement(element, "origin", xyz=_numbers((0.0, 0.0, -drop)), rpy="0 0 0")
    return _text(robot)


def sdf_text() -> str:
    """The SDF of the embedded humanoid, as text: each link placed on its parent link."""
    root = ET.Element("sdf", version="1.9")
    model = ET.SubElement(root, "model", name="humanoid")
    placed = {j.child: (j.parent, j.position) for j in humanoid.JOINTS}
    placed |= {child: (parent, (0.0, 0.0, -drop)) for _, parent, child, drop in humanoid.SENSORS}
    for link in humanoid.LINKS:
        element = ET.SubElement(model, "link", name=link.name)
        if link.name in placed:
            parent, xyz = placed[link.name]
            ET.SubElement(element, "pose", relative_to=parent).text = f"{_numbers(xyz)} 0 0 0"
        inertial = ET.SubElement(element, "inertial")
        ET.SubElement(inertial, "pose").text = f"{_numbers(link.centre)} 0 0 0"
        ET.SubElement(inertial, "mass").text = f"{link.mass:.9g}"
        inertia = ET.SubElement(inertial, "inertia")
        for key, value in _inertia(link).items():
            ET.SubElement(inertia, key).text = value
        visual = ET.SubElement(element, "visual", name=f"{link.name}_visual")
        ET.SubElement(visual, "pose").text = f"{_numbers(link.centre)} 0 0 0"
        geometry = ET.SubElement(visual, "geometry")
        kind, *dims = link.shape
        shape = ET.SubElement(geometry, kind)
        if kind == "box":
            ET.SubElement(shape, "size").text = _numbers(dims)
        elif kind == "cylinder":
            ET.SubElement(shape, "radius").text = f"{dims[0]:.9g}"
            ET.SubElement(shape, "length").text = f"{dims[1]:.9g}"
        else:
            ET.SubElement(shape, "radius").text = f"{dims[0]:.9g}"
        ET.SubElement(ET.SubElement(visual, "material"), "diffuse").text = _numbers(link.colour.rgba)
    for joint in humanoid.JOINTS:
        drive = _drive(joint)
        element = ET.SubElement(model, "joint", name=joint.name, type="revolute")
        ET.SubElement(element, "parent").text = joint.parent
        ET.SubElement(element, "child").text = joint.child
        axis = ET.SubElement(element, "axis")
        ET.SubElement(axis, "xyz").text = _numbers(humanoid._AXES[joint.axis])
        limit = ET.SubElement(axis, "limit")
        ET.SubElement(limit, "lower").text = f"{joint.limits[0]:.9g}"
        ET.SubElement(limit, "upper").text = f"{joint.limits[1]:.9g}"
        ET.SubElement(limit, "effort").text = f"{drive.effort:.9g}"
        ET.SubElement(limit, "velocity").text = f"{drive.velocity:.9g}"
    for name, parent, child, _ in humanoid.SENSORS:
        element = ET.SubElement(model, "joint", name=name, type="fixed")
        ET.SubElement(element, "parent").text = parent
        ET.SubElement(element, "child").text = child
    return _text(root)


def mjcf_text() -> str:
    """The MJCF of the embedded humanoid, as text: nested bodies, the pelvis free."""
    root = ET.Element("mujoco", model="humanoid")
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    links = {link.name: link for link in humanoid.LINKS}
    joints = {j.child: j for j in humanoid.JOINTS}
    children: dict[str, list[tuple[str, tuple[float, float, float]]]] = {}
    for j in humanoid.JOINTS:
        children.setdefault(j.parent, []).append((j.child, j.position))
    for _, parent, child, drop in humanoid.SENSORS:
        children.setdefault(parent, []).append((child, (0.0, 0.0, -drop)))

    def body(parent: ET.Element, name: str, pos: tuple[float, float, float]) -> None:
        link = links[name]
        element = ET.SubElement(parent, "body", name=name, pos=_numbers(pos))
        if name in joints:
            joint = joints[name]
            ET.SubElement(
                element,
                "joint",
                name=joint.name,
                type="hinge",
                axis=_numbers(humanoid._AXES[joint.axis]),
                range=_numbers(joint.limits),
            )
        elif parent.tag == "worldbody":
            ET.SubElement(element, "freejoint")
        inertia = _inertia(link)
        ET.SubElement(
            element,
            "inertial",
            pos=_numbers(link.centre),
            mass=f"{link.mass:.9g}",
            fullinertia=" ".join(inertia[k] for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")),
        )
        kind, *dims = link.shape
        size = (
            [d / 2 for d in dims] if kind == "box" else [dims[0], dims[1] / 2] if kind == "cylinder" else dims
        )
        ET.SubElement(
            element,
            "geom",
            type=kind,
            size=_numbers(size),
            pos=_numbers(link.centre),
            rgba=_numbers(link.colour.rgba),
        )
        for child, position in children.get(name, []):
            body(element, child, position)

    welded = {child for _, _, child, _ in humanoid.SENSORS}
    (base,) = [link.name for link in humanoid.LINKS if link.name not in joints and link.name not in welded]
    body(ET.SubElement(root, "worldbody"), base, (0.0, 0.0, 0.0))
    actuators = ET.SubElement(root, "actuator")
    for joint in humanoid.JOINTS:
        effort = f"{_drive(joint).effort:.9g}"
        ET.SubElement(
            actuators, "motor", name=f"{joint.name}_motor", joint=joint.name, forcerange=f"-{effort} {effort}"
        )
    return _text(root)


def description_text(fmt: str, model: str) -> str:
    """``humanoid.toml`` made the description of the ``fmt`` model file ``model``."""
    text = (HERE / "humanoid.toml").read_text()
    what = {"sdf": "SDF", "mjcf": "MJCF"}[fmt]
    text = "# Written by examples/robot/make_models.py from humanoid.toml: do not edit.\n" + text
    text = text.replace("# The description of humanoid.urdf", f"# The description of {model}")
    text = text.replace("--robot examples/robot/humanoid.toml", f"--robot examples/robot/humanoid_{fmt}.toml")
    text = text.replace("the effort limits are the URDF's", f"the effort limits are the {what}'s")
    text = text.replace('name = "humanoid-urdf"', f'name = "humanoid-{fmt}"')
    text = text.replace(
        "humanoid.urdf (58 kg, 30 joints), from its URDF", f"{model} (58 kg, 30 joints), from its {what}"
    )
    text = text.replace('model = "humanoid.urdf"', f'model = "{model}"')
    for name, parent, child, _ in humanoid.SENSORS:
        text = text.replace(f'= "{name}"', f'= "{weld_name(fmt, parent, child, name)}"')
    return text


if __name__ == "__main__":
    (HERE / "humanoid.urdf").write_text(urdf_text())
    (HERE / "humanoid.sdf").write_text(sdf_text())
    (HERE / "humanoid.xml").write_text(mjcf_text())
    (HERE / "humanoid_sdf.toml").write_text(description_text("sdf", "humanoid.sdf"))
    (HERE / "humanoid_mjcf.toml").write_text(description_text("mjcf", "humanoid.xml"))
