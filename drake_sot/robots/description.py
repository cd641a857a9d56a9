"""A robot as data: what every scenario asks of a robot, by logical name.

A :class:`RobotDescription` is one frozen value per robot: its model file and package
map, the logical frames the scenarios use (soles, ankles, wrists, hands, head, waist,
pelvis, torso), the sole contact geometry, the force/torque sensor welds, the
half-sitting configuration, PD gains, effort and joint limits, the joints frozen at
load and the simple collision shapes. :mod:`drake_sot.robots.loading` turns one into
bodies in a ``MultibodyPlant``; the embedded primitive-shape humanoid is one instance
(its model is built in code: ``model_file`` is None).

No pydrake import here.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from drake_sot import validation
from drake_sot.footsteps import StepLimits, StepTiming
from drake_sot.robots.errors import RobotFileError, RobotFileMissing
from drake_sot.robots.model_tree import ModelJoint
from drake_sot.robots.urdf import AddedWeld
from drake_sot.validation import shown

#: The logical frames every robot gives (sole = the sole plane under the ankle, x
#: forward; hand = the tool point of the hand; head_camera = optical axis z forward,
#: x right, y down).
LOGICAL_FRAMES = (
    "pelvis",
    "waist",
    "torso",
    "head",
    "head_camera",
    "left_foot",
    "right_foot",
    "left_ankle",
    "right_ankle",
    "left_wrist",
    "right_wrist",
    "left_hand",
    "right_hand",
)
#: Roll-pitch-yaw [rad] of a camera frame (z forward, x right, y down) on a link (x forward, z up).
OPTICAL_RPY = (-math.pi / 2, 0.0, -math.pi / 2)
#: The force/torque sensors every robot gives.
FORCE_SENSORS = ("left_ankle", "right_ankle", "left_wrist", "right_wrist")

#: The bounds of a description's numbers, checked when a description is made (from a file or
#: in Python), before any reaches Drake (whose assertions end the interpreter): a value beyond
#: is a typo, never a humanoid. Offsets [m] and angles [rad] of frames, welds and shapes:
OFFSET_BOUND = 100.0
#: The largest side of a sole [m] and radius of its contact spheres [m].
SOLE_BOUND = 2.0
CONTACT_RADIUS_BOUND = 0.1
#: The largest dimension of a collision shape [m].
SHAPE_BOUND = 10.0
#: The largest stiffness [N m/rad], damping [N m s/rad], effort [N m] and rotor inertia
#: [kg m^2] of a drive (TALOS's knee: 10^4, 120, 300, 0.1).
DRIVE_BOUNDS = {"kp": 1e7, "kd": 1e6, "effort": 1e6, "rotor_inertia": 1e3}


def check_number(
    what: str, value, low: float, high: float, *, open_low: bool = False, unit: str = ""
) -> float:
    """``value`` as a float in [``low``, ``high``] (and > ``low`` with ``open_low``), or a
    ValueError naming ``what`` and the value (:func:`drake_sot.validation.bounded`: NaN, a bool,
    a string, an integer beyond float range refused)."""
    number = validation.bounded(what, value, low, high, unit=unit)
    if open_low and not number > low:
        raise ValueError(f"{what} = {shown(value)}: must be > {low:g}{' ' + unit if unit else ''}")
    return number


def check_numbers(what: str, values, size: int, low: float, high: float, **kwargs) -> None:
    """Each of ``size`` ``values`` checked by :func:`check_number` (``what[i]`` named)."""
    if not isinstance(values, tuple | list) or len(values) != size:
        raise ValueError(f"{what} = {shown(values)}: must be {size} numbers")
    for i, value in enumerate(values):
        check_number(f"{what}[{i}]", value, low, high, **kwargs)


def check_offset(what: str, xyz, rpy) -> None:
    """A position ``xyz`` [m] and roll-pitch-yaw ``rpy`` [rad] within ±:data:`OFFSET_BOUND`."""
    check_numbers(f"{what}.xyz", xyz, 3, -OFFSET_BOUND, OFFSET_BOUND)
    check_numbers(f"{what}.rpy", rpy, 3, -OFFSET_BOUND, OFFSET_BOUND)


def xml_root(path: Path, what: str) -> ET.Element:
    """The root element of the XML file ``path`` (an SRDF, said by ``what``).

    Raises:
        RobotFileMissing: ``path`` is not a file.
        RobotFileError: it is not well-formed XML (truncated, garbage), naming it and where.
    """
    if not Path(path).is_file():
        raise RobotFileMissing(f"{what} {path} does not exist")
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise RobotFileError(f"{what} {path}: not well-formed XML ({exc}): truncated or corrupt?") from None


@dataclass(frozen=True)
class FrameSpec:
    """A frame fixed on a frame of the model (a link's, or one the model defines): position
    ``xyz`` [m] and roll-pitch-yaw ``rpy`` [rad] in ``parent``. With both zero the logical
    frame *is* ``parent``; otherwise the loader adds a frame named ``sot_<logical name>``."""

    parent: str
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not (isinstance(self.parent, str) and self.parent):
            raise ValueError(f"frame parent = {shown(self.parent)}: must be a non-empty string")
        check_offset(f"frame on {self.parent!r}", self.xyz, self.rpy)


@dataclass(frozen=True)
class Drive:
    """The position servo of a joint: PD gains ``kp`` [N m/rad], ``kd`` [N m s/rad], its
    actuator's effort limit [N m] and the rotor inertia reflected at the joint [kg m^2]."""

    kp: float
    kd: float
    effort: float
    rotor_inertia: float = 0.0

    def __post_init__(self) -> None:
        for key in ("kp", "kd", "effort", "rotor_inertia"):
            check_number(
                f"drive {key}", getattr(self, key), 0.0, DRIVE_BOUNDS[key], open_low=key in ("kp", "effort")
            )


@dataclass(frozen=True)
class CollisionShape:
    """A simple collision shape on a body (for falls and contact with the world, not the
    soles): ``kind`` "box" (dims = lx, ly, lz), "sphere" (r) or "capsule" (r, length along z)."""

    body: str
    kind: str
    dims: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        dims = {"box": 3, "sphere": 1, "capsule": 2}.get(self.kind)
        if dims is None:
            raise ValueError(f"collision shape kind = {shown(self.kind)}: must be box, sphere or capsule")
        what = f"collision shape on {self.body!r}"
        check_numbers(f"{what}.dims", self.dims, dims, 0.0, SHAPE_BOUND, open_low=True, unit="m")
        check_offset(what, self.xyz, self.rpy)


@dataclass(frozen=True)
class RobotDescription:
    """Everything the builders need to know of a robot.

    Attributes:
        name: the name ``--robot`` takes ("embedded", "talos", "g1").
        title: one line for ``drake-sot list --robots``.
        model_file: the model (a URDF, an SDF or an MJCF); None for the embedded humanoid (built in code).
        packages: package name → directory, for the model's ``package://`` URIs.
        base_body: the floating base body (the pelvis).
        frames: logical name (:data:`LOGICAL_FRAMES`) → where it is.
        sole_size: (length along x, width along y) [m] of the sole, centred on the sole frame.
        contact_radius: radius [m] of the four corner contact spheres under each sole.
        force_sensors: logical sensor (:data:`FORCE_SENSORS`) → the weld joint that reads it.
        added_welds: sensor links welded where the model has none.
        half_sitting: joint name → angle [rad] of the reference posture; every moving joint.
        drives: joint name → its servo; every moving joint.
        joint_limits: joint name → (lower, upper) [rad], as in the model.
        frozen_joints: model joints made fixed at load (grippers, mimic linkages).
        collision: simple collision shapes of the body (besides the soles).
        step_timing: the walking scenarios' step timing on this robot.
        step_limits: the reachability of a step on this robot (checked by the walking planner).
    """

    name: str
    title: str
    model_file: Path | None
    packages: Mapping[str, Path]
    base_body: str
    frames: Mapping[str, FrameSpec]
    sole_size: tuple[float, float]
    contact_radius: float
    force_sensors: Mapping[str, str]
    half_sitting: Mapping[str, float]
    drives: Mapping[str, Drive]
    joint_limits: Mapping[str, tuple[float, float]]
    added_welds: tuple[AddedWeld, ...] = ()
    frozen_joints: tuple[str, ...] = ()
    collision: tuple[CollisionShape, ...] = field(default=())
    step_timing: StepTiming = StepTiming()
    step_limits: StepLimits = StepLimits()

    def __post_init__(self) -> None:
        try:
            check_numbers("sole_size", self.sole_size, 2, 0.0, SOLE_BOUND, open_low=True, unit="m")
            check_number(
                "contact_radius", self.contact_radius, 0.0, CONTACT_RADIUS_BOUND, open_low=True, unit="m"
            )
            for weld in self.added_welds:
                check_offset(f"added weld {weld.name!r}", weld.xyz, (0.0, 0.0, 0.0))
            for name, drive in self.drives.items():
                if not isinstance(drive, Drive):
                    raise ValueError(f"drive of joint {name!r} = {shown(drive)}: must be a Drive")
            for name, limits in self.joint_limits.items():
                lower, upper = limits
                if not (lower <= upper):  # NaN refused
                    raise ValueError(f"joint_limits[{name!r}] = {limits!r}: lower must be <= upper")
        except ValueError as exc:
            raise ValueError(f"robot {self.name!r}: {exc}") from None
        missing = [f for f in LOGICAL_FRAMES if f not in self.frames]
        if missing:
            raise ValueError(f"robot {self.name!r}: logical frames {missing} are not given")
        missing = [s for s in FORCE_SENSORS if s not in self.force_sensors]
        if missing:
            raise ValueError(f"robot {self.name!r}: force sensors {missing} are not given")
        for what, table in (("half-sitting angle", self.half_sitting), ("drive", self.drives)):
            missing = sorted(set(self.joint_limits) - set(table))
            if missing:
                raise ValueError(f"robot {self.name!r}: no {what} for joints {missing}")
        outside = [
            (j, a, self.joint_limits[j])
            for j, a in self.half_sitting.items()
            if not (self.joint_limits[j][0] <= a <= self.joint_limits[j][1])
        ]
        if outside:
            raise ValueError(f"robot {self.name!r}: half-sitting angles outside the limits: {outside}")
        for name in ("frames", "packages", "force_sensors", "half_sitting", "drives", "joint_limits"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))


def srdf_group_state(path: Path, state: str) -> dict[str, float]:
    """The joint angles [rad] of group state ``state`` of an SRDF file (one-value joints only:
    the root joint's pose is not an angle).

    Raises RobotFileMissing or RobotFileError (see :func:`xml_root`) naming the file.
    """
    for element in xml_root(path, "SRDF file").findall("group_state"):
        if element.get("name") == state:
            angles = {}
            for joint in element.findall("joint"):
                values = joint.get("value").split()
                if len(values) == 1:
                    angles[joint.get("name")] = float(values[0])
            return angles
    raise ValueError(f"SRDF {path}: no group_state {state!r}")


def drives_by_pattern(
    joints: Mapping[str, ModelJoint], table: Mapping[str, tuple[float, float, float]]
) -> dict[str, Drive]:
    """A drive for every joint: the first regular expression of ``table`` (pattern → (kp, kd,
    rotor inertia)) that the joint name matches, with the joint's effort limit in the model
    (which must give one).

    Raises ValueError naming the joints that no pattern matches.
    """
    drives, unmatched = {}, []
    for name, joint in joints.items():
        match = next((gains for pattern, gains in table.items() if re.search(pattern, name)), None)
        if match is None:
            unmatched.append(name)
            continue
        kp, kd, rotor = match
        drives[name] = Drive(kp=kp, kd=kd, effort=joint.effort, rotor_inertia=rotor)
    if unmatched:
        raise ValueError(f"no drive pattern matches joints {unmatched}; patterns: {list(table)}")
    return drives
