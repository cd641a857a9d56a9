"""The numbers of a model file checked before Drake reads them: masses, inertias, origins, shapes.

Drake's parsers take a NaN inertia or a negative mass with a warning and simulate on, or stop the
interpreter with an assertion (an MJCF ``<inertial mass="0">``); a 1e308 origin reaches the
controller as NaN. :func:`check_model_values` refuses such a model first, with one line naming
the file, the element (the link, joint or body it belongs to), the attribute and the value.

The rules, in every format (URDF attributes, SDF element texts, MJCF attributes and the
``<default>`` classes that give them):

- a number is a finite float; positions, sizes and lengths within ±:data:`LENGTH_BOUND` m,
  angles (and an MJCF orientation's numbers) within ±:data:`ANGLE_BOUND` (rad or degrees);
- a mass is in [0, :data:`MASS_BOUND`] kg, a geom density in [0, :data:`DENSITY_BOUND`] kg/m^3;
  the moments and products of an inertia within ±:data:`INERTIA_BOUND` kg m^2, and its
  principal moments >= 0 (to a relative :data:`NEGATIVE_SLACK` and an absolute
  :data:`INERTIA_FLOOR`). A principal moment above the sum of the other two is left to Drake's
  warning: models in use ship such inertias (the PR2's, the Go1's), and Drake simulates them
  (a negative moment, as in ``romeo_laas_small.urdf``'s body, is refused);
- a body of zero mass has zero inertia (a frame link, as TALOS's camera frames); an MJCF
  ``<inertial>`` mass is > 0 (Drake's MJCF parser asserts on zero);
- a shape's dimensions are >= 0 and a mesh's scale factors non-zero; joint damping, friction,
  armature and stiffness >= 0; a joint range or limit is not NaN and its lower side is not
  above its upper side;
- an MJCF mesh asset's file exists and a geom's mesh names an asset (Drake ignores a geom of
  an unknown mesh with a warning).

No pydrake import here: XML in, a RobotFileError out.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from drake_sot.robots.errors import RobotFileError, RobotFileMissing

#: The largest coordinate of a position, a size or a length in a model [m]: a humanoid is a
#: couple of metres tall; 1e308 m reached the controller as NaN.
LENGTH_BOUND = 100.0
#: The largest angle, or number of an orientation, in a model (radians or degrees).
ANGLE_BOUND = 1000.0
#: The largest mass of a body [kg]: a humanoid's links weigh grams to tens of kilograms.
MASS_BOUND = 1e4
#: The largest moment or product of inertia of a body [kg m^2].
INERTIA_BOUND = 1e4
#: The largest density of an MJCF geom [kg/m^3] (osmium: 22,600).
DENSITY_BOUND = 1e5
#: The largest joint damping [N m s/rad], friction [N m], stiffness [N m/rad] or armature [kg m^2].
JOINT_BOUND = 1e6
#: How negative a principal moment of inertia may be, relative to the largest (rounding of the
#: products of inertia written with few digits).
NEGATIVE_SLACK = 1e-6
#: An inertia this small [kg m^2] is zero (a gram at 30 micrometres): iCub's head has a product
#: of 2.4e-35.
INERTIA_FLOOR = 1e-12

#: Kinds of number: (lowest, highest, what is accepted).
_KINDS = {
    "length": (-LENGTH_BOUND, LENGTH_BOUND, f"finite, within ±{LENGTH_BOUND:g} m"),
    "angle": (-ANGLE_BOUND, ANGLE_BOUND, f"finite, within ±{ANGLE_BOUND:g}"),
    "size": (0.0, LENGTH_BOUND, f"in [0, {LENGTH_BOUND:g}] m"),
    "scale": (-LENGTH_BOUND, LENGTH_BOUND, f"non-zero, within ±{LENGTH_BOUND:g}"),
    "mass": (0.0, MASS_BOUND, f"in [0, {MASS_BOUND:g}] kg"),
    "inertia": (-INERTIA_BOUND, INERTIA_BOUND, f"finite, within ±{INERTIA_BOUND:g} kg m^2"),
    "density": (0.0, DENSITY_BOUND, f"in [0, {DENSITY_BOUND:g}] kg/m^3"),
    "joint": (0.0, JOINT_BOUND, f"in [0, {JOINT_BOUND:g}]"),
    "limit": (-math.inf, math.inf, "not NaN"),
    "range": (-math.inf, math.inf, "two numbers, not NaN, lower <= upper"),
}
#: How many numbers an attribute or text holds (None: any count) and their kind; a pose is
#: (x, y, z, then angles), checked apart.
_URDF = {
    ("origin", "xyz"): (3, "length"),
    ("origin", "rpy"): (3, "angle"),
    ("mass", "value"): (1, "mass"),
    **{("inertia", key): (1, "inertia") for key in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")},
    ("box", "size"): (3, "size"),
    ("sphere", "radius"): (1, "size"),
    ("cylinder", "radius"): (1, "size"),
    ("cylinder", "length"): (1, "size"),
    ("capsule", "radius"): (1, "size"),
    ("capsule", "length"): (1, "size"),
    ("mesh", "scale"): (None, "scale"),
    ("axis", "xyz"): (3, "length"),
    ("limit", "lower"): (1, "limit"),
    ("limit", "upper"): (1, "limit"),
    ("limit", "effort"): (1, "limit"),
    ("limit", "velocity"): (1, "limit"),
    ("dynamics", "damping"): (1, "joint"),
    ("dynamics", "friction"): (1, "joint"),
}
_SDF = {
    ("inertial", "mass"): (1, "mass"),
    **{("inertia", key): (1, "inertia") for key in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")},
    ("box", "size"): (3, "size"),
    ("sphere", "radius"): (1, "size"),
    ("cylinder", "radius"): (1, "size"),
    ("cylinder", "length"): (1, "size"),
    ("capsule", "radius"): (1, "size"),
    ("capsule", "length"): (1, "size"),
    ("mesh", "scale"): (3, "scale"),
    ("axis", "xyz"): (3, "length"),
    ("limit", "lower"): (1, "limit"),
    ("limit", "upper"): (1, "limit"),
    ("limit", "effort"): (1, "limit"),
    ("limit", "velocity"): (1, "limit"),
    ("dynamics", "damping"): (1, "joint"),
    ("dynamics", "friction"): (1, "joint"),
}
_ORIENTATION = {"quat": 4, "axisangle": 4, "euler": 3, "xyaxes": 6, "zaxis": 3}
_MJCF = {
    **{(tag, "pos"): (3, "length") for tag in ("body", "inertial", "geom", "joint", "site", "camera")},
    **{(tag, key): (n, "angle") for tag in ("body", "inertial", "geom") for key, n in _ORIENTATION.items()},
    ("inertial", "mass"): (1, "mass"),
    ("inertial", "diaginertia"): (3, "inertia"),
    ("inertial", "fullinertia"): (6, "inertia"),
    ("geom", "size"): (None, "size"),
    ("geom", "fromto"): (6, "length"),
    ("geom", "mass"): (1, "mass"),
    ("geom", "density"): (1, "density"),
    ("joint", "axis"): (3, "length"),
    ("joint", "range"): (2, "range"),
    ("joint", "damping"): (1, "joint"),
    ("joint", "frictionloss"): (1, "joint"),
    ("joint", "armature"): (1, "joint"),
    ("joint", "stiffness"): (1, "joint"),
    ("mesh", "scale"): (3, "scale"),
}
#: The elements whose name says where a number is.
_OWNERS = ("link", "joint", "body", "frame", "model", "default", "visual", "geom")


def check_model_values(path: str | Path, fmt: str, root: ET.Element) -> None:
    """Refuse the model of format ``fmt`` ("urdf", "sdf", "mjcf") whose XML ``root`` was read
    from ``path`` when one of its numbers breaks the rules of the module docstring.

    Raises:
        RobotFileError: one line naming ``path``, the element (its link, joint or body), the
            attribute or element, the value and what is accepted.
        RobotFileMissing: an MJCF mesh file that does not exist (naming it).
    """
    checker = _Checker(Path(path), fmt)
    checker.walk(root, "the model")
    if fmt == "mjcf":
        checker.mjcf_meshes(root)


class _Checker:
    def __init__(self, path: Path, fmt: str) -> None:
        self.path = path
        self.fmt = fmt

    def error(self, where: str, what: str, value: str, accepted: str) -> RobotFileError:
        shown = value if len(value) <= 60 else value[:57] + "..."
        return RobotFileError(
            f"robot model file {self.path}: {where}: {what} = {shown!r}: must be {accepted}"
        )

    def numbers(self, where: str, what: str, text: str, count: int | None, kind: str) -> list[float]:
        low, high, accepted = _KINDS[kind]
        try:
            values = [float(v) for v in text.split()]
        except ValueError:
            values = None
        if values is None or (count is not None and len(values) != count) or not values:
            need = f"{count} numbers" if count is not None and count > 1 else "a number"
            raise self.error(where, what, text, f"{need} ({accepted})")
        for v in values:
            ok = low <= v <= high if kind != "limit" else not math.isnan(v)
            if kind == "scale":
                ok = ok and v != 0.0
            if not ok:
                raise self.error(
                    where, what, text, accepted if count == 1 else f"{count or 'numbers'} ({accepted})"
                )
        if kind == "range" and not (values[0] <= values[1]):
            raise self.error(where, what, text, accepted)
        return values

    def walk(self, element: ET.Element, where: str) -> None:
        if element.tag in _OWNERS and (element.get("name") or element.get("class")):
            where = f"{element.tag} {element.get('name') or element.get('class')!r}"
        if self.fmt == "sdf":
            self.sdf(element, where)
        else:
            rules = _URDF if self.fmt == "urdf" else _MJCF
            for key, text in element.attrib.items():
                rule = rules.get((element.tag, key))
                if rule is not None:
                    self.numbers(where, f"<{element.tag}> {key}", text, *rule)
        for child in element:
            self.walk(child, where)
        if element.tag == "inertial":  # its numbers checked one by one above
            self.inertial(element, where)

    def mjcf_meshes(self, root: ET.Element) -> None:
        """Each mesh asset's file exists (MuJoCo's rule: under the compiler's ``meshdir``, else
        ``assetdir``, relative to the model's directory); each geom's mesh is an asset's name."""
        compiler = root.find("compiler")
        meshdir = (compiler.get("meshdir") or compiler.get("assetdir") or "") if compiler is not None else ""
        names = set()
        for mesh in root.findall("asset/mesh"):
            file = mesh.get("file")
            names.add(mesh.get("name") or (Path(file).stem if file else None))
            if file is not None and not (self.path.parent / meshdir / file).is_file():
                raise RobotFileMissing(
                    f"robot model file {self.path}: mesh {mesh.get('name') or file!r}: file "
                    f"{self.path.parent / meshdir / file} does not exist"
                )
        for geom in root.iter("geom"):
            if "mesh" in geom.attrib and geom.get("mesh") not in names:
                raise self.error(
                    "geom " + repr(geom.get("name") or "(unnamed)"), "<geom> mesh", geom.get("mesh"),
                    f"the name of a mesh asset ({', '.join(sorted(n for n in names if n)) or 'none'})",
                )  # fmt: skip

    def sdf(self, element: ET.Element, where: str) -> None:
        for child in element:
            if child.tag == "pose" and (child.text or "").strip():
                count = 7 if child.get("rotation_format") == "quat_xyzw" else 6
                values = self.numbers(where, "<pose>", child.text, count, "limit")
                for value, kind in zip(values, ["length"] * 3 + ["angle"] * (count - 3), strict=True):
                    if not (_KINDS[kind][0] <= value <= _KINDS[kind][1]):
                        accepted = f"x y z {_KINDS['length'][2]}, angles {_KINDS['angle'][2]}"
                        raise self.error(where, "<pose>", child.text, f"{count} numbers ({accepted})")
            rule = _SDF.get((element.tag, child.tag))
            if rule is not None:
                self.numbers(where, f"<{element.tag}><{child.tag}>", child.text or "", *rule)

    def inertial(self, element: ET.Element, where: str) -> None:
        """The mass and the inertia of one ``<inertial>`` together."""
        if self.fmt == "urdf":
            mass_element, inertia = element.find("mass"), element.find("inertia")
            mass = float(mass_element.get("value", "0")) if mass_element is not None else 0.0
            inertia_matrix = _matrix(
                *(float(inertia.get(k, "0")) if inertia is not None else 0.0 for k in _KEYS)
            )
        elif self.fmt == "sdf":
            mass = float(element.findtext("mass", "1").strip() or "1")  # SDFormat's defaults
            inertia = element.find("inertia")
            defaults = {"ixx": "1", "iyy": "1", "izz": "1"}
            inertia_matrix = _matrix(*(float(_text(inertia, k, defaults.get(k, "0"))) for k in _KEYS))
        else:
            mass = float(element.get("mass", "nan"))
            if not (mass > 0.0):
                raise self.error(
                    where, "<inertial> mass", element.get("mass", ""), "> 0 kg (Drake's MJCF reading)"
                )
            if "fullinertia" in element.attrib:
                xx, yy, zz, xy, xz, yz = (float(v) for v in element.get("fullinertia").split())
                inertia_matrix = _matrix(xx, yy, zz, xy, xz, yz)
            elif "diaginertia" in element.attrib:
                inertia_matrix = np.diag([float(v) for v in element.get("diaginertia").split()])
            else:
                raise self.error(where, "<inertial>", "", "given a diaginertia or a fullinertia")
        moments = np.linalg.eigvalsh(inertia_matrix)
        largest = float(np.max(np.abs(moments)))
        if mass == 0.0 and largest > 0.0:
            raise self.error(
                where,
                "<inertial>",
                f"mass 0, inertia {_shown(inertia_matrix)}",
                "a zero inertia with a zero mass (a massless frame link), or the link given its mass",
            )
        if not (moments[0] >= -(NEGATIVE_SLACK * largest + INERTIA_FLOOR)):  # NaN refused above
            raise self.error(
                where,
                "<inertial> inertia",
                _shown(inertia_matrix),
                f"positive semi-definite (principal moments {', '.join(f'{m:g}' for m in moments)} kg m^2)",
            )


_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")


def _text(element: ET.Element | None, tag: str, default: str) -> str:
    text = element.findtext(tag) if element is not None else None
    return text.strip() if text is not None and text.strip() else default


def _matrix(xx: float, yy: float, zz: float, xy: float, xz: float, yz: float) -> np.ndarray:
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def _shown(inertia_matrix: np.ndarray) -> str:
    return (
        "["
        + ", ".join(
            f"{v:g}"
            for v in (
                inertia_matrix[0, 0],
                inertia_matrix[1, 1],
                inertia_matrix[2, 2],
                inertia_matrix[0, 1],
                inertia_matrix[0, 2],
                inertia_matrix[1, 2],
            )
        )
        + "]"
    )
