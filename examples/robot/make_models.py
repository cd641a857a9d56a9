"""Writes ``humanoid.urdf``: the embedded humanoid's tables (:mod:`drake_sot.models.humanoid`) as a
URDF file, the robot that ``humanoid.toml`` describes and the guide "Your own robot" walks.

The same links (mass, inertia about the centre of mass, one primitive shape as the visual),
revolute joints (axis, limits, effort and velocity limits) and force/torque sensor welds as the
robot built in code, so that it walks with the gains known to work on it; but loaded as any
user's robot is, through its model file and description. Run once when the tables change::

    python examples/robot/make_urdf.py
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from drake_sot.models import humanoid

HERE = Path(__file__).resolve().parent


def _numbers(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


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
        _, about_origin = humanoid._shape_and_inertia(link)
        about_com = about_origin.Shift(about_origin.get_com())
        inertia = about_com.CalcRotationalInertia().CopyToFullMatrix3()
        inertial = ET.SubElement(element, "inertial")
        ET.SubElement(inertial, "origin", xyz=_numbers(link.centre), rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=f"{link.mass:.9g}")
        ET.SubElement(
            inertial,
            "inertia",
            **{
                key: f"{inertia[i, j]:.9g}"
                for key, (i, j) in {
                    "ixx": (0, 0),
                    "ixy": (0, 1),
                    "ixz": (0, 2),
                    "iyy": (1, 1),
                    "iyz": (1, 2),
                    "izz": (2, 2),
                }.items()
            },  # fmt: skip
        )
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
        drive = humanoid.DRIVES[joint.name.removeprefix("r_").removeprefix("l_")]
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
    ET.indent(robot)
    comment = "<!-- Written by examples/robot/make_urdf.py from drake_sot.models.humanoid: do not edit. -->"
    return f'<?xml version="1.0"?>\n{comment}\n{ET.tostring(robot, encoding="unicode")}\n'


if __name__ == "__main__":
    (HERE / "humanoid.urdf").write_text(urdf_text())
