"""The embedded humanoid: an HRP-2-class robot built from primitive shapes.

The model is built programmatically with MultibodyPlant APIs (no files to load),
so that every dimension, mass and gain lives in the tables below and nowhere else.
It has the kinematic structure of HRP-2 (a 6-dof leg, a 2-dof waist, a 2-dof neck,
6-dof arms and a 1-dof gripper per hand) and the HRP-2 axis conventions:
x forward, y left, z up; *pitch* joints turn about +y, *roll* joints about +x and
*yaw* joints about +z, so that HRP-2's half-sitting angles mean the same posture
here: negative hip pitch and positive knee bend the legs (knees forward), the
ankle pitch brings the sole back flat; positive shoulder pitch swings the upper
arm back (15 deg), a negative elbow bends the forearm forward (net 15 deg forward,
so the hand is slightly in front of the shoulder), a negative right / positive
left shoulder roll opens the arms away from the body (10 deg). In half-sitting
the pelvis is 0.649 m high, the soles are at x = 0.0095, y = +/-0.095.

Frames and bodies. Every link frame sits on the axis of the joint that moves it
and is aligned with the world in the zero configuration (the robot standing
straight, arms down). The pelvis frame lies midway between the two hip centres,
where the three hip axes of each leg intersect; the ankle axes intersect 0.105 m
above the centre of the sole. The four 6-axis force/torque sensors are weld
joints (``r_ankle_ft``, ``l_ankle_ft`` between the ankle-roll link and the foot,
``r_wrist_ft``, ``l_wrist_ft`` between the wrist-pitch link and the hand); read
them with ``plant.get_reaction_forces_output_port()``.

State layout. The pelvis is the floating base (its free joint is added by
``Finalize``), so q = [qw, qx, qy, qz, x, y, z, joints...] and
v = [wx, wy, wz, vx, vy, vz, joints...]. Drake numbers the joints of a tree
depth first, so the joint order in q and v equals the actuator order for the
28 limb, waist and neck joints, but each gripper (a child of the hand) follows
its own wrist: ``..., r_wrist_pitch, r_gripper, l_shoulder_pitch, ...,
l_wrist_pitch, l_gripper``, whereas the actuator order puts both grippers last.
Use ``plant.MakeActuationMatrix()`` / ``MakeStateSelectorMatrix`` or joint
``position_start()`` to map between the two orders.

Contact. The feet stand on four 1 cm spheres at the corners of each sole whose
lowest points lie on the sole plane (point contact + SAP stands well on them and
stays fast; standing, the soles sink ~0.2 mm into the ground). :func:`add_body_collision`
gives the rest of the body simple convex shapes (``COLLISION_LINKS``: the link's own
box, a capsule for a cylinder, and a box over each foot raised 1 cm above the sole so
that it never takes part in standing or walking), so that a fallen robot lies on the
ground; collisions between neighbouring links are filtered.

Drives. Every actuator carries the reflected inertia of its motor and harmonic
gear (``DRIVES``, 0.001-0.1 kg m^2 at the joint, as on a robot with 1:100-1:200
gears); it is part of the controller's model too, so simulated and modelled
dynamics agree. It is there for realism: SAP stands the robot just as well
without it (same tracking error, same speed), and no joint damping is needed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import NamedTuple

import numpy as np
from pydrake.geometry import (
    Box,
    Capsule,
    CollisionFilterDeclaration,
    Cylinder,
    GeometrySet,
    Rgba,
    SceneGraph,
    Shape,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    ModelInstanceIndex,
    PdControllerGains,
    RevoluteJoint,
    RigidBody,
    SpatialInertia,
    WeldJoint,
)


class _Link(NamedTuple):
    """A rigid link: one uniform-density shape is both its inertia and its visual."""

    name: str
    mass: float
    shape: tuple  # ("box", lx, ly, lz) | ("cylinder", radius, length along z) | ("sphere", r)
    centre: tuple[float, float, float]  # of the shape, in the link frame
    colour: Rgba


class _Joint(NamedTuple):
    """An actuated revolute joint; the child link's frame is the joint frame."""

    name: str
    parent: str
    child: str
    position: tuple[float, float, float]  # of the joint frame in the parent link frame
    axis: str  # "x" (roll), "y" (pitch), "z" (yaw), "-y"
    limits: tuple[float, float]
    half_sitting: float


class _Drive(NamedTuple):
    """Motor and gear of a joint, and the gains of its position-controlled servo."""

    effort: float  # actuator effort limit
    velocity: float  # symmetric joint velocity limit
    kp: float
    kd: float
    rotor_inertia: float  # reflected at the joint (rotor inertia x gear ratio^2)


# ======================================================================================
# The model in one table. Lengths in m, masses in kg, angles in rad, velocities in
# rad/s, efforts in N m, PD gains in N m/rad and N m s/rad.
# ======================================================================================

#: Leg geometry (HRP-2): hip centres at y = +/-HIP_Y level with the pelvis origin;
#: the thigh hangs THIGH_Y further out along the hip-pitch axis (so the feet stand at
#: y = +/-0.095 with a 6 cm gap between the soles); thigh and shank lengths, height of
#: the ankle axes above the sole.
HIP_Y = 0.06
THIGH_Y = 0.035
THIGH = 0.30
SHANK = 0.30
ANKLE_HEIGHT = 0.105
#: The ankle force sensor sits this far below the ankle axes, the wrist sensor this
#: far below the wrist axes; the hand tool point is HAND_TOOL beyond the wrist axes.
ANKLE_FT_DROP = 0.03
WRIST_FT_DROP = 0.03
HAND_TOOL = 0.10
#: Sole (length along x, width along y), centred under the ankle; contact spheres.
SOLE = (0.23, 0.13)
CONTACT_RADIUS = 0.01
FRICTION = CoulombFriction(static_friction=1.0, dynamic_friction=0.8)
#: Upper body: chest joints above the pelvis origin, shoulders and neck on the torso.
CHEST_Z = 0.35
SHOULDER_Y = 0.25
SHOULDER_Z = 0.18
NECK_Z = 0.32
HEAD_PITCH_Z = 0.06
UPPER_ARM = 0.25
FOREARM = 0.25

_SHELL = Rgba(0.86, 0.88, 0.92, 1.0)  # light silver panels
_MOTOR = Rgba(0.30, 0.33, 0.38, 1.0)  # dark joint housings
_BLUE = Rgba(0.16, 0.40, 0.78, 1.0)  # accents
_SOLE = Rgba(0.12, 0.12, 0.14, 1.0)  # rubber soles, sensors
_VISOR = Rgba(0.10, 0.12, 0.16, 1.0)  # head

_L, _J = _Link, _Joint

# fmt: off
#: Links of the centre and the right side; the left side mirrors the right (y -> -y).
#: Masses: HRP-2 is 58 kg with a heavy chest (computers, batteries) and heavy thighs.
_CENTRE_LINKS = (
    #  link                     mass  shape (inertia and visual)               shape centre in the link frame                 colour
    _L("pelvis",                10.0, ("box", 0.20, 0.26, 0.18),               (0.0, 0.0, 0.07),                              _SHELL),
    _L("chest_link",             1.5, ("cylinder", 0.08, 0.16),                (0.0, 0.0, -0.08),                             _MOTOR),
    _L("torso",                 16.0, ("box", 0.24, 0.34, 0.34),               (0.0, 0.0, 0.15),                              _SHELL),
    _L("neck",                   0.3, ("cylinder", 0.035, 0.06),               (0.0, 0.0, 0.03),                              _MOTOR),
    _L("head",                   2.2, ("box", 0.16, 0.14, 0.14),               (0.01, 0.0, 0.05),                             _VISOR),
)
_RIGHT_LINKS = (
    _L("r_hip_yaw_link",         0.5, ("cylinder", 0.05, 0.06),                (0.0, 0.0, 0.03),                              _MOTOR),
    _L("r_hip_roll_link",        0.8, ("sphere", 0.055),                       (0.0, 0.0, 0.0),                               _MOTOR),
    _L("r_thigh",                4.0, ("box", 0.10, 0.10, THIGH),              (0.0, 0.0, -THIGH / 2),                        _SHELL),
    _L("r_shank",                2.0, ("box", 0.09, 0.09, SHANK),              (0.0, 0.0, -SHANK / 2),                        _SHELL),
    _L("r_ankle_pitch_link",     0.3, ("sphere", 0.045),                       (0.0, 0.0, 0.0),                               _MOTOR),
    _L("r_ankle_roll_link",      0.3, ("box", 0.08, 0.08, ANKLE_FT_DROP),      (0.0, 0.0, -ANKLE_FT_DROP / 2),                _SOLE),
    _L("r_foot",                 1.2, ("box", *SOLE, 0.04),                    (0.0, 0.0, ANKLE_FT_DROP - ANKLE_HEIGHT + 0.02), _BLUE),
    _L("r_shoulder_pitch_link",  0.6, ("box", 0.08, 0.10, 0.08),               (0.0, 0.04, 0.0),                              _MOTOR),
    _L("r_shoulder_roll_link",   0.6, ("sphere", 0.05),                        (0.0, 0.0, 0.0),                               _MOTOR),
    _L("r_upper_arm",            1.6, ("cylinder", 0.045, UPPER_ARM),          (0.0, 0.0, -UPPER_ARM / 2),                    _SHELL),
    _L("r_forearm",              1.0, ("cylinder", 0.04, FOREARM),             (0.0, 0.0, -FOREARM / 2),                      _SHELL),
    _L("r_wrist_yaw_link",       0.3, ("sphere", 0.035),                       (0.0, 0.0, 0.0),                               _MOTOR),
    _L("r_wrist_pitch_link",     0.2, ("box", 0.05, 0.06, WRIST_FT_DROP),      (0.0, 0.0, -WRIST_FT_DROP / 2),                _SOLE),
    _L("r_hand",                 0.4, ("box", 0.04, 0.08, 0.12),               (0.0, 0.0, -0.06),                             _BLUE),
    _L("r_finger",               0.1, ("box", 0.015, 0.06, 0.08),              (0.0, 0.0, -0.04),                             _MOTOR),
)

#: Drives by joint kind (the joint name without its "r_"/"l_" prefix).
#: PD gains: the DRAKE_NOTES.md values, but the knee stiffened to 2500/40 (gravity sag
#: 0.013 rad instead of 0.022) and the ankle damped with kd = 60 (the whole-body sway
#: about the ankles, ~0.9 Hz, has a damping ratio of ~0.3 instead of ~0.1).
DRIVES = {
    #                    effort vmax    kp      kd    rotor
    "hip_yaw":     _Drive(100.0, 4.0, 5000.0, 60.0, 0.05),
    "hip_roll":    _Drive(200.0, 4.0, 5000.0, 60.0, 0.10),
    "hip_pitch":   _Drive(250.0, 5.0, 5000.0, 60.0, 0.10),
    "knee":        _Drive(300.0, 6.0, 6000.0, 80.0, 0.10),
    "ankle_pitch": _Drive(200.0, 5.0, 5000.0, 80.0, 0.05),
    "ankle_roll":  _Drive(120.0, 4.0, 5000.0, 80.0, 0.05),
    "chest_yaw":   _Drive(150.0, 3.0, 1000.0, 20.0, 0.05),
    "chest_pitch": _Drive(250.0, 3.0, 1000.0, 20.0, 0.10),
    "head_yaw":    _Drive( 15.0, 3.0,   50.0,  2.0, 0.005),
    "head_pitch":  _Drive( 15.0, 3.0,   50.0,  2.0, 0.005),
    "shoulder_pitch": _Drive(80.0, 4.0, 200.0,  5.0, 0.02),
    "shoulder_roll":  _Drive(80.0, 4.0, 200.0,  5.0, 0.02),
    "shoulder_yaw":   _Drive(40.0, 4.0, 200.0,  5.0, 0.01),
    "elbow":       _Drive( 60.0, 4.0,  150.0,  4.0, 0.01),
    "wrist_yaw":   _Drive( 20.0, 5.0,   30.0,  1.0, 0.005),
    "wrist_pitch": _Drive( 20.0, 5.0,   30.0,  1.0, 0.005),
    "gripper":     _Drive(  5.0, 2.0,    5.0,  0.2, 0.001),
}

#: Actuated joints of the right side and the centre; the left side mirrors the right
#: (y -> -y; roll and yaw limits and half-sitting angles change sign). HRP-2 limits.
_O = (0.0, 0.0, 0.0)
_RIGHT_LEG = (
    #  joint               parent                   child                    position in parent              axis  limits           half-sitting
    _J("r_hip_yaw",        "pelvis",                "r_hip_yaw_link",        (0.0, -HIP_Y, 0.0),             "z",  (-0.785, 0.524), 0.0),
    _J("r_hip_roll",       "r_hip_yaw_link",        "r_hip_roll_link",       _O,                             "x",  (-0.611, 0.349), 0.0),
    _J("r_hip_pitch",      "r_hip_roll_link",       "r_thigh",               (0.0, -THIGH_Y, 0.0),           "y",  (-2.182, 0.733), -0.453786),
    _J("r_knee",           "r_thigh",               "r_shank",               (0.0, 0.0, -THIGH),             "y",  (0.0, 2.618),    0.872665),
    _J("r_ankle_pitch",    "r_shank",               "r_ankle_pitch_link",    (0.0, 0.0, -SHANK),             "y",  (-1.309, 0.733), -0.418879),
    _J("r_ankle_roll",     "r_ankle_pitch_link",    "r_ankle_roll_link",     _O,                             "x",  (-0.349, 0.611), 0.0),
)
_TRUNK = (
    _J("chest_yaw",        "pelvis",                "chest_link",            (0.0, 0.0, CHEST_Z),            "z",  (-0.785, 0.785), 0.0),
    _J("chest_pitch",      "chest_link",            "torso",                 _O,                             "y",  (-0.087, 1.047), 0.0),
    _J("head_yaw",         "torso",                 "neck",                  (0.0, 0.0, NECK_Z),             "z",  (-0.785, 0.785), 0.0),
    _J("head_pitch",       "neck",                  "head",                  (0.0, 0.0, HEAD_PITCH_Z),       "y",  (-0.524, 0.785), 0.0),
)
_RIGHT_ARM = (
    _J("r_shoulder_pitch", "torso",                 "r_shoulder_pitch_link", (0.0, -SHOULDER_Y, SHOULDER_Z), "y",  (-3.142, 1.047), 0.261799),
    _J("r_shoulder_roll",  "r_shoulder_pitch_link", "r_shoulder_roll_link",  _O,                             "x",  (-1.658, 0.175), -0.174533),
    _J("r_shoulder_yaw",   "r_shoulder_roll_link",  "r_upper_arm",           _O,                             "z",  (-1.606, 1.606), 0.0),
    _J("r_elbow",          "r_upper_arm",           "r_forearm",             (0.0, 0.0, -UPPER_ARM),         "y",  (-2.356, 0.0),   -0.523599),
    _J("r_wrist_yaw",      "r_forearm",             "r_wrist_yaw_link",      (0.0, 0.0, -FOREARM),           "z",  (-1.606, 1.606), 0.0),
    _J("r_wrist_pitch",    "r_wrist_yaw_link",      "r_wrist_pitch_link",    _O,                             "y",  (-1.658, 1.658), 0.0),
)
#: The finger hinges at the front edge of the palm; positive opens (axis -y).
_RIGHT_GRIPPER = (
    _J("r_gripper",        "r_hand",                "r_finger",              (0.02, 0.0, -0.08),             "-y", (-0.28, 1.05),   0.1),
)
# fmt: on

#: Weld joints that are force/torque sensors: (name, parent link, child link, drop).
_RIGHT_SENSORS = (
    ("r_ankle_ft", "r_ankle_roll_link", "r_foot", ANKLE_FT_DROP),
    ("r_wrist_ft", "r_wrist_pitch_link", "r_hand", WRIST_FT_DROP),
)
#: Operational frames: name -> (link, position in the link frame); axes = link axes.
OPERATIONAL_FRAMES = {
    "r_sole": ("r_foot", (0.0, 0.0, -(ANKLE_HEIGHT - ANKLE_FT_DROP))),
    "l_sole": ("l_foot", (0.0, 0.0, -(ANKLE_HEIGHT - ANKLE_FT_DROP))),
    "r_hand_tool": ("r_hand", (0.0, 0.0, -(HAND_TOOL - WRIST_FT_DROP))),
    "l_hand_tool": ("l_hand", (0.0, 0.0, -(HAND_TOOL - WRIST_FT_DROP))),
}
#: The head camera (a pinhole, for ``FeatureVisualPoint``): on the front face of the head box,
#: centred, with the computer-vision axes: z_C, the optical axis, along the head's +x (forward),
#: x_C along -y (image right), y_C along -z (image down). Columns of R_HC are x_C, y_C, z_C in
#: the head frame. The logical frame "head_camera".
HEAD_CAMERA = RigidTransform(
    RotationMatrix(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])), [0.09, 0.0, 0.05]
)
#: Logical frame names (what scenarios, tasks and pushes ask for; every one of
#: :data:`drake_sot.robots.description.LOGICAL_FRAMES`) -> frame names of this model.
FRAMES = MappingProxyType(
    {
        "pelvis": "pelvis",
        "waist": "pelvis",
        "torso": "torso",
        "head": "head",
        "head_camera": "head_camera",
        "left_foot": "l_sole",
        "right_foot": "r_sole",
        "left_ankle": "l_ankle_roll_link",
        "right_ankle": "r_ankle_roll_link",
        "left_wrist": "l_wrist_pitch_link",
        "right_wrist": "r_wrist_pitch_link",
        "left_hand": "l_hand_tool",
        "right_hand": "r_hand_tool",
    }
)  # fmt: skip
#: Links that collide with their own shape (a cylinder becomes a capsule of the same
#: radius and axis length, whose caps round its ends), right side and centre; the left
#: side mirrors the right. The feet collide through their sole spheres and FOOT_GUARD.
_RIGHT_COLLISION_LINKS = ("r_thigh", "r_shank", "r_upper_arm", "r_forearm", "r_hand", "r_finger")
#: Height above the sole plane [m] of the bottom of the box that covers each foot's sides
#: and top (the sole spheres carry the robot; this box only meets the ground when the
#: foot lies on its side or upside down).
FOOT_GUARD = 0.01
_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0), "-y": (0.0, -1.0, 0.0)}

# ======================================================================================


def _mirror_name(name: str) -> str:
    """The left-side name of a right-side name ("r_knee" -> "l_knee"); others unchanged."""
    return "l_" + name[2:] if name.startswith("r_") else name


def _mirror_link(link: _Link) -> _Link:
    """The left twin of a right-side link (reflected through the sagittal plane)."""
    x, y, z = link.centre
    return link._replace(name=_mirror_name(link.name), centre=(x, -y, z))


def _mirror_joint(joint: _Joint) -> _Joint:
    """The left twin of a right-side joint: roll and yaw angles change sign."""
    x, y, z = joint.position
    flip = joint.axis.lstrip("-") in ("x", "z")  # roll and yaw change sign
    lo, hi = joint.limits
    return joint._replace(
        name=_mirror_name(joint.name),
        parent=_mirror_name(joint.parent),
        child=_mirror_name(joint.child),
        position=(x, -y, z),
        limits=(-hi, -lo) if flip else (lo, hi),
        half_sitting=-joint.half_sitting if flip else joint.half_sitting,
    )


#: All links, centre, right side, left side.
LINKS: tuple[_Link, ...] = _CENTRE_LINKS + _RIGHT_LINKS + tuple(map(_mirror_link, _RIGHT_LINKS))
#: All actuated joints in actuator order (the order they are added to the plant).
JOINTS: tuple[_Joint, ...] = (
    _RIGHT_LEG
    + tuple(map(_mirror_joint, _RIGHT_LEG))
    + _TRUNK
    + _RIGHT_ARM
    + tuple(map(_mirror_joint, _RIGHT_ARM))
    + _RIGHT_GRIPPER
    + tuple(map(_mirror_joint, _RIGHT_GRIPPER))
)
#: All force/torque sensor welds, right then left.
SENSORS = _RIGHT_SENSORS + tuple(
    (_mirror_name(n), _mirror_name(p), _mirror_name(c), d) for n, p, c, d in _RIGHT_SENSORS
)
#: Links whose own shape collides in :func:`add_body_collision` (besides the feet).
COLLISION_LINKS: tuple[str, ...] = (
    ("pelvis", "torso", "head") + _RIGHT_COLLISION_LINKS + tuple(map(_mirror_name, _RIGHT_COLLISION_LINKS))
)


@dataclass(frozen=True)
class HumanoidInfo:
    """What a controller needs to know about the humanoid added to a plant.

    Attributes:
        model_instance: the robot's model instance.
        base_body: name of the floating base body ("pelvis").
        actuated_joints: the 30 actuated joint names in actuator order (the order of
            the actuation input and of the desired-state input ``[q_d; v_d]``).
        frames: logical name -> frame name: "pelvis", "torso", "head" (body frames),
            "left_foot"/"right_foot" (soles), "left_hand"/"right_hand" (hand tools),
            "head_camera" (the pinhole camera of the head, optical axis z: see ``HEAD_CAMERA``).
        force_sensors: "left_ankle", "right_ankle", "left_wrist", "right_wrist" ->
            name of the weld joint whose reaction force is the sensor reading.
        half_sitting: joint name -> HRP-2 half-sitting angle (rad).
        mass: total mass of the robot (kg).
        sole_size: (length, width) [m] of each sole, centred on its sole frame.
        robot: the name of the robot's description (``drake_sot.robots``).
    """

    model_instance: ModelInstanceIndex
    base_body: str
    actuated_joints: tuple[str, ...]
    frames: Mapping[str, str]
    force_sensors: Mapping[str, str]
    half_sitting: Mapping[str, float]
    mass: float
    sole_size: tuple[float, float] = SOLE
    robot: str = "embedded"


def _shape_and_inertia(link: _Link) -> tuple[Shape, SpatialInertia]:
    """The link's shape and its spatial inertia about the link origin."""
    kind, *dims = link.shape
    if kind == "box":
        shape, inertia = Box(*dims), SpatialInertia.SolidBoxWithMass(link.mass, *dims)
    elif kind == "cylinder":
        shape = Cylinder(*dims)
        inertia = SpatialInertia.SolidCylinderWithMass(link.mass, *dims, [0.0, 0.0, 1.0])
    elif kind == "sphere":
        shape, inertia = Sphere(*dims), SpatialInertia.SolidSphereWithMass(link.mass, *dims)
    else:
        raise ValueError(f"link {link.name!r}: unknown shape kind {kind!r}")
    return shape, inertia.Shift(-np.asarray(link.centre))


def _half_sitting_pelvis_height() -> float:
    """Pelvis height when both soles are flat on the ground in half-sitting.

    The legs bend in the sagittal plane only (yaw and roll are zero), the thigh at
    the hip-pitch angle, the shank at hip pitch + knee from the vertical.
    """
    angle = {j.name: j.half_sitting for j in _RIGHT_LEG}
    hip = -angle["r_hip_pitch"]
    shank = hip - angle["r_knee"]
    return ANKLE_HEIGHT + THIGH * math.cos(hip) + SHANK * math.cos(shank)


def load_humanoid(
    plant: MultibodyPlant,
    *,
    name: str = "sot_humanoid",
    pd_gains: bool = True,
    collision: bool = True,
) -> HumanoidInfo:
    """Add the humanoid to a plant that is not finalized yet; does not finalize it.

    Args:
        plant: the plant to add the robot to (discrete or continuous).
        name: name of the new model instance.
        pd_gains: give every actuator its PD gains (position control through
            ``plant.get_desired_state_input_port(info.model_instance)``, which then
            MUST be connected or the controllers are off); False for torque control.
        collision: register the foot contact spheres (only if the plant has a
            SceneGraph; visual geometry is registered whenever it has one).

    Returns:
        The HumanoidInfo of the new robot. Default joint angles are the half-sitting
        ones and the default pelvis pose stands the robot on z = 0.
    """
    if plant.is_finalized():
        raise RuntimeError("load_humanoid needs a plant that is not finalized yet")
    instance = plant.AddModelInstance(name)
    geometry = plant.geometry_source_is_registered()

    bodies: dict[str, RigidBody] = {}
    for link in LINKS:
        shape, inertia = _shape_and_inertia(link)
        body = plant.AddRigidBody(link.name, instance, inertia)
        bodies[link.name] = body
        if geometry:
            plant.RegisterVisualGeometry(
                body, RigidTransform(link.centre), shape, f"{link.name}_visual", link.colour.rgba
            )

    def frame_on(link: str, name: str, position: tuple[float, float, float]) -> FixedOffsetFrame:
        return plant.AddFrame(FixedOffsetFrame(name, bodies[link].body_frame(), RigidTransform(position)))

    for j in JOINTS:
        joint = plant.AddJoint(
            RevoluteJoint(
                j.name,
                frame_on(j.parent, f"{j.name}_parent", j.position),
                bodies[j.child].body_frame(),
                _AXES[j.axis],
                *j.limits,
            )
        )
        drive = DRIVES[j.name.removeprefix("r_").removeprefix("l_")]
        joint.set_velocity_limits([-drive.velocity], [drive.velocity])
        joint.set_default_angle(j.half_sitting)
        actuator = plant.AddJointActuator(j.name, joint, drive.effort)
        actuator.set_default_rotor_inertia(drive.rotor_inertia)
        if pd_gains:
            actuator.set_controller_gains(PdControllerGains(p=drive.kp, d=drive.kd))

    for sensor, parent, child, drop in SENSORS:
        plant.AddJoint(
            WeldJoint(
                sensor,
                frame_on(parent, f"{sensor}_parent", (0.0, 0.0, -drop)),
                bodies[child].body_frame(),
                RigidTransform(),
            )
        )

    for frame, (link, position) in OPERATIONAL_FRAMES.items():
        frame_on(link, frame, position)
    plant.AddFrame(FixedOffsetFrame("head_camera", bodies["head"].body_frame(), HEAD_CAMERA))

    if geometry and collision:
        half_length, half_width = SOLE[0] / 2, SOLE[1] / 2
        for side in ("r", "l"):
            sole = np.asarray(OPERATIONAL_FRAMES[f"{side}_sole"][1])
            for i, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
                centre = sole + (sx * half_length, sy * half_width, CONTACT_RADIUS)
                plant.RegisterCollisionGeometry(
                    bodies[f"{side}_foot"], RigidTransform(centre), Sphere(CONTACT_RADIUS),
                    f"{side}_sole_contact_{i}", FRICTION,
                )  # fmt: skip

    plant.SetDefaultFloatingBaseBodyPose(
        bodies["pelvis"], RigidTransform([0.0, 0.0, _half_sitting_pelvis_height()])
    )
    return HumanoidInfo(
        model_instance=instance,
        base_body="pelvis",
        actuated_joints=tuple(j.name for j in JOINTS),
        frames=FRAMES,
        force_sensors=MappingProxyType(
            {
                "left_ankle": "l_ankle_ft",
                "right_ankle": "r_ankle_ft",
                "left_wrist": "l_wrist_ft",
                "right_wrist": "r_wrist_ft",
            }
        ),  # fmt: skip
        half_sitting=MappingProxyType({j.name: j.half_sitting for j in JOINTS}),
        mass=sum(link.mass for link in LINKS),
    )


def add_ground(plant: MultibodyPlant) -> None:
    """Add the ground z = 0: a 20 m x 20 m x 1 m collision box whose top face is z = 0,
    with FRICTION, and a 10 m x 10 m visual slab. Needs a plant with a SceneGraph.

    A box rather than a HalfSpace: with point contact the two behave the same within
    the box, and a rigid HalfSpace makes Drake warn on every plant that it is not
    supported for deformable contact."""
    if not plant.geometry_source_is_registered():
        raise RuntimeError("add_ground needs a MultibodyPlant registered with a SceneGraph")
    world = plant.world_body()
    plant.RegisterCollisionGeometry(
        world, RigidTransform([0.0, 0.0, -0.5]), Box(20.0, 20.0, 1.0), "ground_collision", FRICTION
    )
    plant.RegisterVisualGeometry(
        world, RigidTransform([0.0, 0.0, -0.01]), Box(10.0, 10.0, 0.02), "ground_visual",
        Rgba(0.55, 0.60, 0.55, 1.0).rgba,
    )  # fmt: skip


def add_body_collision(plant: MultibodyPlant, scene_graph: SceneGraph, info: HumanoidInfo) -> None:
    """Give the whole body collision shapes, so that a fallen robot lies on the ground.

    Registers on the plant (before ``Finalize``), with FRICTION: the shape of each of
    ``COLLISION_LINKS`` (pelvis, torso, head, thighs, shanks, upper arms, forearms, hands,
    fingers; a cylinder as a capsule of the same radius and axis length) and, over each
    foot, a box of the sole's length and width from ``FOOT_GUARD`` above the sole plane
    to the top of the foot (the sole spheres still carry the robot alone). Then it
    excludes, in ``scene_graph``, the collisions between *neighbouring* colliding links:
    each colliding link and its nearest colliding ancestor in the kinematic tree (e.g. the
    pelvis and a thigh, across the hip's shape-less yaw and roll links; a shank and its
    foot), whose shapes overlap or touch as the joints between them move; a finger counts
    as part of its hand (one gripper, filtered against the forearm; Drake itself filters
    the finger's hinge, as every pair of bodies a joint connects). Every other pair
    collides: an arm with the torso, a hand with a thigh, one leg with the other.

    Raises RuntimeError when the plant is finalized or has no SceneGraph.
    """
    if plant.is_finalized():
        raise RuntimeError("add_body_collision needs a plant that is not finalized yet")
    if not plant.geometry_source_is_registered():
        raise RuntimeError("add_body_collision needs a MultibodyPlant registered with a SceneGraph")
    instance = info.model_instance
    links = {link.name: link for link in LINKS}
    for name in COLLISION_LINKS:
        link = links[name]
        kind, *dims = link.shape
        shape = {"box": Box, "cylinder": Capsule, "sphere": Sphere}[kind](*dims)
        plant.RegisterCollisionGeometry(
            plant.GetBodyByName(name, instance),
            RigidTransform(link.centre),
            shape,
            f"{name}_collision",
            FRICTION,
        )
    foot = links["r_foot"]
    foot_top = foot.centre[2] + foot.shape[3] / 2  # top of the foot's box, in the foot frame
    for side in ("r", "l"):
        sole_z = OPERATIONAL_FRAMES[f"{side}_sole"][1][2]
        height = foot_top - (sole_z + FOOT_GUARD)
        plant.RegisterCollisionGeometry(
            plant.GetBodyByName(f"{side}_foot", instance),
            RigidTransform([0.0, 0.0, sole_z + FOOT_GUARD + height / 2]),
            Box(*SOLE, height),
            f"{side}_foot_guard_collision",
            FRICTION,
        )
    parent = {j.child: j.parent for j in JOINTS} | {child: p for _, p, child, _ in SENSORS}
    # A finger and its hand are one gripper: it is filtered against the forearm as the hand is.
    units = {name: {name} for name in (*COLLISION_LINKS, "r_foot", "l_foot") if not name.endswith("_finger")}
    for side in ("r", "l"):
        units[f"{side}_hand"].add(f"{side}_finger")
    declaration = CollisionFilterDeclaration()
    for name, members in units.items():
        ancestor = parent.get(name)
        while ancestor is not None and ancestor not in units:
            ancestor = parent.get(ancestor)
        if ancestor is not None:
            declaration.ExcludeBetween(
                _collision_set(plant, instance, members), _collision_set(plant, instance, units[ancestor])
            )
    scene_graph.collision_filter_manager().Apply(declaration)


def _collision_set(plant: MultibodyPlant, instance: ModelInstanceIndex, links: set[str]) -> GeometrySet:
    """The collision geometries of ``links``."""
    ids = [
        g for link in links for g in plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link, instance))
    ]
    return GeometrySet(ids)


def half_sitting_configuration(plant: MultibodyPlant, info: HumanoidInfo) -> np.ndarray:
    """The full position vector q (size plant.num_positions()) of a finalized plant
    with the robot in half-sitting: joints at ``info.half_sitting``, the pelvis upright
    at x = y = 0 and at the height that puts both soles flat on z = 0. The positions
    of other model instances keep their default values."""
    context = plant.CreateDefaultContext()
    for joint, angle in info.half_sitting.items():
        plant.GetJointByName(joint, info.model_instance).set_angle(context, angle)
    pelvis = plant.GetBodyByName(info.base_body, info.model_instance)
    if not pelvis.is_floating_base_body():  # welded by weld_base: the joints are all there is
        return plant.GetPositions(context)
    plant.SetFloatingBaseBodyPoseInWorldFrame(context, pelvis, RigidTransform())
    sole_heights = [
        plant.GetFrameByName(info.frames[foot], info.model_instance).CalcPoseInWorld(context).translation()[2]
        for foot in ("left_foot", "right_foot")
    ]
    plant.SetFloatingBaseBodyPoseInWorldFrame(
        context, pelvis, RigidTransform([0.0, 0.0, -np.mean(sole_heights)])
    )
    return plant.GetPositions(context)


def sole_corner_points(sole_size: tuple[float, float] = SOLE) -> np.ndarray:
    """The 4 corners (4, 3) [m] of a sole of ``sole_size`` (length, width; default the
    embedded robot's) in its sole frame (on the sole plane z = 0)."""
    half_length, half_width = sole_size[0] / 2, sole_size[1] / 2
    return np.array([[sx * half_length, sy * half_width, 0.0] for sx in (1, -1) for sy in (1, -1)])


def weld_base(plant: MultibodyPlant, info: HumanoidInfo) -> None:
    """Weld the pelvis to the world where half-sitting puts it (soles on z = 0): the
    fixed-base robot of the paper's real-iCub experiments. Call before ``Finalize``."""
    plant.WeldFrames(
        plant.world_frame(),
        plant.GetBodyByName(info.base_body, info.model_instance).body_frame(),
        RigidTransform([0.0, 0.0, _half_sitting_pelvis_height()]),
    )


def make_control_model(*, fixed_base: bool = False) -> tuple[MultibodyPlant, HumanoidInfo]:
    """The controller's kinematic and dynamic model (the SoT "dyn" entity's model):
    a finalized continuous (time_step = 0) MultibodyPlant holding only the humanoid,
    without SceneGraph (so no geometry) and without PD gains; with ``fixed_base`` the
    pelvis is welded as by :func:`weld_base`."""
    plant = MultibodyPlant(time_step=0.0)
    info = load_humanoid(plant, pd_gains=False, collision=False)
    if fixed_base:
        weld_base(plant, info)
    plant.Finalize()
    return plant, info
