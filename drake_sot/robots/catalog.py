"""The robots ``--robot`` knows: the embedded humanoid, and TALOS and the Unitree G1 of
``example-robot-data`` (the optional extra ``drake_sot[robots]``).

:func:`get_robot` returns a :class:`~drake_sot.robots.description.RobotDescription` by
name; the file-based ones are read once (limits from the URDF, TALOS's half-sitting from
its SRDF) and cached. Without ``example-robot-data`` installed they raise
:class:`RobotDataMissing`, which says how to install it.
"""

from __future__ import annotations

import functools
import importlib.metadata
import math
import os
from collections.abc import Callable
from pathlib import Path

from drake_sot.errors import DrakeSotError, UnknownNameError
from drake_sot.footsteps import StepTiming
from drake_sot.robots.description import (
    OPTICAL_RPY,
    CollisionShape,
    Drive,
    FrameSpec,
    RobotDescription,
    drives_by_pattern,
    srdf_group_state,
)
from drake_sot.robots.description_file import is_robot_path, load_description
from drake_sot.robots.model_tree import model_joints
from drake_sot.robots.urdf import AddedWeld

#: Environment variable naming the ``robots`` directory of example-robot-data (overrides
#: the installed package; a directory that does not exist reads as "not installed").
DATA_ENV = "DRAKE_SOT_EXAMPLE_ROBOT_DATA"
#: What to run when example-robot-data is missing.
INSTALL_HINT = "pip install 'drake_sot[robots]'  (i.e. example-robot-data==6.0.0 and trimesh)"


class RobotDataMissing(DrakeSotError, RuntimeError):
    """A robot's model files are not installed; the message says how to install them."""


def data_root(robot: str = "this robot") -> Path:
    """The ``robots`` directory of example-robot-data (``$DRAKE_SOT_EXAMPLE_ROBOT_DATA`` or the
    installed wheel's ``cmeel.prefix/share/example-robot-data/robots``).

    Raises RobotDataMissing when it is not there.
    """
    env = os.environ.get(DATA_ENV)
    if env:
        root = Path(env)
    else:
        try:
            distribution = importlib.metadata.distribution("example-robot-data")
        except importlib.metadata.PackageNotFoundError:
            raise RobotDataMissing(
                f"{robot} needs the package example-robot-data, which is not installed: {INSTALL_HINT}"
            ) from None
        root = Path(distribution.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    if not root.is_dir():
        raise RobotDataMissing(f"{robot}: example-robot-data directory {root} does not exist: {INSTALL_HINT}")
    return root


@functools.cache
def _embedded() -> RobotDescription:
    """The embedded primitive-shape humanoid (built in code by ``models.humanoid.load_humanoid``;
    imported here, not at module level: the catalog imports no pydrake, so that the peer
    benchmark, in a virtual environment without Drake, reads TALOS from it)."""
    from drake_sot.models.humanoid import CONTACT_RADIUS, DRIVES, FRAMES, JOINTS, SENSORS, SOLE

    frames = {key: FrameSpec(name) for key, name in FRAMES.items()}
    sensors = {name: name for name, *_ in SENSORS}
    drives = {}
    for j in JOINTS:
        d = DRIVES[j.name.removeprefix("r_").removeprefix("l_")]
        drives[j.name] = Drive(kp=d.kp, kd=d.kd, effort=d.effort, rotor_inertia=d.rotor_inertia)
    return RobotDescription(
        name="embedded",
        title="the embedded HRP-2-class humanoid built from primitive shapes (58 kg, 30 joints)",
        model_file=None,
        packages={},
        base_body="pelvis",
        frames=frames,
        sole_size=SOLE,
        contact_radius=CONTACT_RADIUS,
        force_sensors={
            "left_ankle": sensors["l_ankle_ft"],
            "right_ankle": sensors["r_ankle_ft"],
            "left_wrist": sensors["l_wrist_ft"],
            "right_wrist": sensors["r_wrist_ft"],
        },
        half_sitting={j.name: j.half_sitting for j in JOINTS},
        drives=drives,
        joint_limits={j.name: j.limits for j in JOINTS},
        step_timing=StepTiming(single_support=0.7, double_support=0.1, step_height=0.05),
    )


def __getattr__(name: str) -> RobotDescription:
    """``EMBEDDED``, the embedded humanoid's description, built on first use."""
    if name == "EMBEDDED":
        return _embedded()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _frames(
    *,
    pelvis: str,
    torso: str,
    head: str,
    head_camera: FrameSpec,
    foot: str,
    ankle: str,
    wrist: str,
    hand: FrameSpec,
) -> dict[str, FrameSpec]:
    """The logical frames of a robot whose left and right links differ by a word (``{side}``
    in ``foot``, ``ankle``, ``wrist`` and ``hand``'s parent); the waist is the pelvis."""
    frames = {
        "pelvis": FrameSpec(pelvis),
        "waist": FrameSpec(pelvis),
        "torso": FrameSpec(torso),
        "head": head,
        "head_camera": head_camera,
    }
    for side in ("left", "right"):
        frames[f"{side}_foot"] = FrameSpec(foot.format(side=side))
        frames[f"{side}_ankle"] = FrameSpec(ankle.format(side=side))
        frames[f"{side}_wrist"] = FrameSpec(wrist.format(side=side))
        frames[f"{side}_hand"] = FrameSpec(hand.parent.format(side=side), hand.xyz, hand.rpy)
    return frames


def _limbs(**shapes: CollisionShape) -> tuple[CollisionShape, ...]:
    """The limb shapes of both sides: each of ``shapes`` (a body name with ``{side}``, its
    position mirrored in y for the right side) on the left and on the right."""
    limbs = []
    for side in ("left", "right"):
        for shape in shapes.values():
            x, y, z = shape.xyz
            roll, pitch, yaw = shape.rpy
            mirrored = side == "right"
            limbs.append(
                CollisionShape(
                    shape.body.format(side=side),
                    shape.kind,
                    shape.dims,
                    (x, -y if mirrored else y, z),
                    (-roll if mirrored else roll, pitch, -yaw if mirrored else yaw),
                )
            )
    return tuple(limbs)


@functools.cache
def talos() -> RobotDescription:
    """PAL Robotics' TALOS (``talos_full_v2.urdf``; half-sitting from ``talos.srdf``).

    Gains: the embedded robot's, scaled up for a 93 kg robot on the legs and torso; the
    effort limits are the URDF's.
    """
    root = data_root("robot 'talos'")
    model = root / "talos_data" / "robots" / "talos_full_v2.urdf"
    parts = (
        "",
        "_inner_double",
        "_fingertip_1",
        "_fingertip_2",
        "_motor_single",
        "_inner_single",
        "_fingertip_3",
    )
    frozen = tuple(f"gripper_{side}{part}_joint" for side in ("left", "right") for part in parts)
    joints = model_joints(model, frozen)
    half_sitting = srdf_group_state(root / "talos_data" / "srdf" / "talos.srdf", "half_sitting")
    gains = {
        #  pattern            kp      kd    rotor inertia
        r"leg_.*_[1-3]_": (8000.0, 100.0, 0.10),
        r"leg_.*_4_": (10000.0, 120.0, 0.10),
        r"leg_.*_[56]_": (8000.0, 120.0, 0.05),
        r"torso_": (3000.0, 40.0, 0.10),
        r"head_": (50.0, 2.0, 0.005),
        r"arm_.*_[1-4]_": (400.0, 8.0, 0.02),
        r"arm_.*_[5-7]_": (30.0, 1.0, 0.005),
    }
    return RobotDescription(
        name="talos",
        title="PAL Robotics TALOS (example-robot-data talos_full_v2; 93 kg, 30 joints, grippers frozen)",
        model_file=model,
        packages={"example-robot-data": root.parent},
        base_body="base_link",
        frames=_frames(
            pelvis="base_link",
            torso="torso_2_link",
            head=FrameSpec("head_2_link"),
            head_camera=FrameSpec("rgbd_rgb_optical_frame"),
            foot="{side}_sole_link",
            ankle="leg_{side}_6_link",
            wrist="arm_{side}_7_link",
            hand=FrameSpec("gripper_{side}_base_link", (0.0, 0.0, -0.10)),
        ),
        sole_size=(0.21, 0.13),
        contact_radius=0.01,  # the embedded robot's
        force_sensors={
            "left_ankle": "leg_left_sole_fix_joint",
            "right_ankle": "leg_right_sole_fix_joint",
            "left_wrist": "wrist_left_ft_joint",
            "right_wrist": "wrist_right_ft_joint",
        },
        half_sitting={name: half_sitting[name] for name in joints},
        drives=drives_by_pattern(joints, gains),
        joint_limits={name: (j.lower, j.upper) for name, j in joints.items()},
        frozen_joints=frozen,
        collision=(
            # fitted to the bounding boxes of the visual meshes (in each link's frame)
            CollisionShape("base_link", "box", (0.30, 0.44, 0.19), (-0.045, 0.0, -0.085)),
            CollisionShape("torso_2_link", "box", (0.30, 0.45, 0.44), (-0.06, 0.0, 0.175)),
            CollisionShape("head_2_link", "sphere", (0.12,), (0.006, 0.0, 0.184)),
            *_limbs(
                # the joint origins along each link: hip 0.38 m above the knee, knee 0.325 m
                # above the ankle, shoulder 0.273 m above the elbow, elbow 0.264 m above the
                # wrist; the thigh and the shank carry their actuators on the outer side; their
                # inner sides are 5 cm from the hip's axis (the meshes' 7-8 cm would leave the
                # two legs 1 cm apart: they knocked together in the walk's turn)
                thigh=CollisionShape("leg_{side}_3_link", "capsule", (0.06, 0.35), (0.005, 0.01, -0.19)),
                thigh_motor=CollisionShape(
                    "leg_{side}_3_link", "box", (0.13, 0.16, 0.40), (0.005, 0.115, -0.19)
                ),
                shank=CollisionShape("leg_{side}_4_link", "capsule", (0.055, 0.28), (0.007, 0.01, -0.15)),
                shank_motor=CollisionShape(
                    "leg_{side}_4_link", "box", (0.12, 0.13, 0.36), (0.007, 0.10, -0.15)
                ),
                upper_arm=CollisionShape("arm_{side}_3_link", "capsule", (0.07, 0.22), (0.01, 0.01, -0.17)),
                forearm=CollisionShape("arm_{side}_4_link", "capsule", (0.075, 0.16), (-0.02, 0.0, -0.17)),
                hand=CollisionShape("gripper_{side}_base_link", "sphere", (0.08,), (0.0, 0.0, -0.08)),
            ),
        ),
    )


@functools.cache
def g1() -> RobotDescription:
    """Unitree G1 (``g1_29dof_rev_1_0.urdf``). The model has no ankle force sensor and no
    sole frame: a light sole link is welded under each ankle-roll link, on the plane of
    the model's four foot contact spheres, and its weld reads the ankle force. The model
    ships no SRDF: the half-sitting posture is the knees-bent stance given here.

    Steps are slower than the embedded robot's (0.8 s single, 0.2 s double support): on
    the 6 cm wide soles of the model, the 0.7 s / 0.1 s steps put the measured ZMP on the
    outer edge of the stance sole (the foot rolling on it) in ~1 % of the samples of the
    ``walk`` scenario's turn; 0.8 s / 0.2 s keeps it inside throughout.
    """
    root = data_root("robot 'g1'")
    model = root / "g1_description" / "urdf" / "g1_29dof_rev_1_0.urdf"
    joints = model_joints(model)
    stance = {
        "hip_pitch": -0.35,
        "knee": 0.70,
        "ankle_pitch": -0.35,
        "shoulder_pitch": 0.25,
        "elbow": 0.60,
    }
    rolls = {"left_shoulder_roll_joint": 0.20, "right_shoulder_roll_joint": -0.20}
    half_sitting = {
        name: rolls.get(name, next((a for k, a in stance.items() if f"_{k}_joint" in name), 0.0))
        for name in joints
    }
    gains = {
        #  pattern                 kp      kd   rotor inertia
        r"hip_|ankle_": (2500.0, 40.0, 0.02),
        r"knee_": (3000.0, 50.0, 0.03),
        r"waist_": (1500.0, 30.0, 0.02),
        r"shoulder_|elbow_": (150.0, 4.0, 0.01),
        r"wrist_": (20.0, 0.5, 0.002),
    }
    sole = {
        side: AddedWeld(
            f"{side}_ankle_ft", f"{side}_ankle_roll_link", f"{side}_sole_link", (0.035, 0.0, -0.035)
        )
        for side in ("left", "right")
    }
    return RobotDescription(
        name="g1",
        title="Unitree G1 (example-robot-data g1_29dof_rev_1_0; 33 kg, 29 joints)",
        model_file=model,
        packages={"example-robot-data": root.parent},
        base_body="pelvis",
        frames=_frames(
            pelvis="pelvis",
            torso="torso_link",
            head=FrameSpec("head_link", (0.005, 0.0, 0.43)),  # the link's origin is at the waist
            head_camera=FrameSpec("d435_link", rpy=OPTICAL_RPY),
            foot="{side}_sole_link",
            ankle="{side}_ankle_roll_link",
            wrist="{side}_wrist_yaw_link",
            hand=FrameSpec("{side}_rubber_hand", (0.08, 0.0, 0.0)),
        ),
        sole_size=(0.17, 0.06),
        contact_radius=0.005,
        force_sensors={
            "left_ankle": sole["left"].name,
            "right_ankle": sole["right"].name,
            "left_wrist": "left_hand_palm_joint",
            "right_wrist": "right_hand_palm_joint",
        },
        added_welds=(sole["left"], sole["right"]),
        half_sitting=half_sitting,
        drives=drives_by_pattern(joints, gains),
        joint_limits={name: (j.lower, j.upper) for name, j in joints.items()},
        collision=(
            # fitted to the bounding boxes of the visual meshes (in each link's frame)
            CollisionShape("pelvis", "box", (0.12, 0.20, 0.16), (0.0, 0.0, -0.07)),
            CollisionShape("torso_link", "box", (0.14, 0.22, 0.25), (0.0, 0.0, 0.20)),
            CollisionShape("head_link", "sphere", (0.10,), (0.005, 0.0, 0.43)),
            *_limbs(
                hip=CollisionShape("{side}_hip_pitch_link", "box", (0.082, 0.10, 0.117), (0.0, 0.05, -0.02)),
                # the thigh's axis runs from the hip-yaw link's origin to the knee, 0.194 m
                # away along (-0.078, 0, -0.177); the knee is 0.30 m above the ankle; the elbow
                # 0.08 m below the shoulder-yaw link; the wrist 0.10 m along the forearm's x
                thigh=CollisionShape(
                    "{side}_hip_yaw_link", "capsule", (0.055, 0.15), (-0.039, 0.0, -0.089), (0.0, 0.415, 0.0)
                ),
                shank=CollisionShape("{side}_knee_link", "capsule", (0.05, 0.22), (0.01, 0.0, -0.15)),
                upper_arm=CollisionShape(
                    "{side}_shoulder_yaw_link", "capsule", (0.04, 0.12), (0.008, 0.0, -0.04)
                ),
                forearm=CollisionShape(
                    "{side}_elbow_link",
                    "capsule",
                    (0.035, 0.18),
                    (0.09, 0.0, -0.005),
                    (0.0, math.pi / 2, 0.0),
                ),
                hand=CollisionShape("{side}_rubber_hand", "box", (0.13, 0.066, 0.106), (0.066, -0.015, 0.01)),
            ),
        ),
        step_timing=StepTiming(single_support=0.8, double_support=0.2, step_height=0.05),
    )


#: The robots by name, each a function that returns its description.
ROBOTS: dict[str, Callable[[], RobotDescription]] = {
    "embedded": _embedded,
    "talos": talos,
    "g1": g1,
}


def get_robot(name: str | Path | RobotDescription) -> RobotDescription:
    """The description of robot ``name``: one of :data:`ROBOTS`, or a path to a description file
    (``.toml``) or to a model file with its description beside it (see
    :func:`~drake_sot.robots.description_file.load_description`); a description passes through.

    Raises :class:`~drake_sot.errors.UnknownNameError` (a ValueError and a KeyError) for an
    unknown name that is no path (listing the known names),
    RobotDataMissing when its model files are not installed, and for a path what
    :func:`~drake_sot.robots.description_file.load_description` raises (RobotFileMissing,
    RobotDescriptionError, RobotFileError: each naming the file).
    """
    if isinstance(name, RobotDescription):
        return name
    if isinstance(name, Path) or is_robot_path(name):
        return load_description(name)
    if name not in ROBOTS:
        raise UnknownNameError("robot", name, ROBOTS)
    return ROBOTS[name]()
