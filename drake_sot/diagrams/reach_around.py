"""Scenario ``reach_around``: the right hand reaches around the body and a table, the
self-collision task (Kanoun, Lamiraux, Wieber 2011) keeping every pair of collision shapes apart.

The robot stands on its two feet beside a table (a box fixed in the world, with collision, in
front of its right side; :class:`~drake_sot.systems.self_collision.Obstacle`). Stack (highest
priority first, solved by ``solve_hqp``): joint position and velocity limits (velocity bounds
over the control period that stop each joint 0.02 rad inside its limits, clipped to a fraction
:data:`VELOCITY_SCALE` of its velocity limits: the first-order distance damper lets fast
shapes get inside its margin), self-collision avoidance (``taskSelfCollision``: the robot's own
pairs and each shape against the table, ξ = :data:`XI`; unless ``self_collision`` is off),
left foot 6D, right foot 6D, CoM xy, the pelvis 6D and the torso's orientation (both held: free,
the legs stretched as the hand rose and lifted and tilted the pelvis 5 cm into TALOS's left
forearm, and a turning torso swings the left arm; the simulated body, slower than its
reference, then went 1 cm further than it), right hand position (its orientation free),
posture. Script: the right hand's
target moves to each of :func:`targets`, every :data:`DWELL` seconds from :data:`START`:

- behind the left shoulder, inside the body (deliberately unreachable: no pose puts the hand
  there without a collision; the hand ends pressed against the body);
- across the body, in front of the chest (reachable);
- under the table's near edge (reachable).

The hand's gain is adaptive (:data:`HAND_GAIN`): bounded far from the target, so that the arm
swings slowly enough for the simulated robot to follow its reference (the task holds the
reference's shapes apart, the actuators' tracking error is on top), high near it. The torque
feed-forward is the reference motion's inverse dynamics (``dynamic_feedforward``): with the
static one, the arm the motion does not command swung into its thigh, 3.3 mm closer than its
reference (the embedded humanoid; 4.8 mm on TALOS). The hand's level is damped
(:data:`HAND_DAMPING`) against the chatter of a hand held against the body.

Every position is made from the robot's own geometry: its shoulders (the joints where the arms
leave the torso's body) and its arm's length (right shoulder to right hand at half-sitting), so
the same script fits the embedded humanoid, TALOS and the G1. Without the task the hand goes
straight at the first target, into the chest.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import TimedCommand
from drake_sot.diagrams.scenario import ROBOT, SELF_COLLISION, Scenario, ScenarioSetup
from drake_sot.gains import AdaptiveGain
from drake_sot.models import half_sitting_configuration
from drake_sot.robots import get_robot, make_robot_control_model
from drake_sot.systems.self_collision import Obstacle

STACK = ("taskJL", "taskLF", "taskRF", "taskCom", "taskWaist", "taskChest", "taskRH", "taskPosture")
#: The fraction of the joints' velocity limits the joint-limit level allows.
VELOCITY_SCALE = 0.1
#: The right hand's gain: 3 /s at the target, 0.2 /s far from it (at 0.3 /s the hand pressed
#: harder on the body at the unreachable target: the G1's reference arm chattered against its
#: torso and its feet slipped under the feed-forward of that motion, 6.5 mm).
HAND_GAIN = AdaptiveGain.from_limits(at_zero=3.0, at_infinity=0.2, slope_at_zero=15.0)
#: [m/s] the damper's ξ, stiffer than the default: the hand pulled into the body slides along
#: its boxes, and with 0.2 m/s the reference went 5 mm inside the margin (the embedded
#: humanoid; ``benchmarks/README.md``, bench_self_collision.py, on the damper's first order).
XI = 3.0
#: [m] the damper's activation distance, larger than the default: the rows then slow a closing
#: pair from further away (ḋ >= -ξ (d - d_s) / (d_i - d_s)).
D_I = 0.08
#: The hand level's damping μ (``solve_hqp(damping=)``): the target behind the shoulder holds the
#: hand against the body, where the rows at their bounds leave the hand's level nearly singular
#: and its exact step flipped sign from tick to tick (the G1's reference arm at up to 1480 rad/s²,
#: 245 rad/s² median over that target; its simulated arm 1 cm off its reference); 0.035 was not
#: enough on the G1. The cost: a slower convergence where the arm is stretched (TALOS's hand
#: across the body 1.1 cm off after 4 s, 0.7 cm after 5 s: hence :data:`DWELL`).
HAND_DAMPING = 0.05
START = 0.5  # [s] the first target
DWELL = 5.0  # [s] between two targets


@dataclass(frozen=True)
class Target:
    """A position of the right hand.

    Attributes:
        name: its key in the setup's ``targets``.
        label: what it is, for the script's log.
        position: (3,) in the world frame [m].
        reachable: some pose of the robot puts the hand there with every pair of shapes
            ``d_s`` apart (False: the point is inside a shape of the robot).
    """

    name: str
    label: str
    position: np.ndarray
    reachable: bool


@dataclass(frozen=True)
class Geometry:
    """The robot's dimensions the targets and the table are made from, at half-sitting, in
    the world frame: the shoulders' centres (the joints where each arm leaves the torso's body)
    [m], the right arm's length (right shoulder to right hand) [m], the torso frame's
    position, the right hand's position and the pelvis's height [m]."""

    left_shoulder: np.ndarray
    right_shoulder: np.ndarray
    arm: float
    torso: np.ndarray
    right_hand: np.ndarray
    pelvis_height: float


def geometry(robot: str) -> Geometry:
    """The :class:`Geometry` of ``robot`` (a name of ``drake_sot.robots.ROBOTS``).

    Raises what :func:`~drake_sot.robots.make_robot_control_model` raises.
    """
    plant, info = make_robot_control_model(get_robot(robot))
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    torso = plant.GetFrameByName(info.frames["torso"])

    def shoulder(side: str) -> np.ndarray:
        body = plant.GetFrameByName(info.frames[f"{side}_hand"]).body()
        joint = None
        while body.index() != torso.body().index():
            joint = next(
                plant.get_joint(j)
                for j in plant.GetJointIndices(info.model_instance)
                if plant.get_joint(j).child_body().index() == body.index()
            )
            body = joint.parent_body()
        return joint.frame_on_child().CalcPoseInWorld(context).translation()

    hand = plant.GetFrameByName(info.frames["right_hand"]).CalcPoseInWorld(context).translation()
    right = shoulder("right")
    return Geometry(
        left_shoulder=shoulder("left"),
        right_shoulder=right,
        arm=float(np.linalg.norm(hand - right)),
        torso=torso.CalcPoseInWorld(context).translation(),
        right_hand=hand,
        pelvis_height=float(
            plant.GetFrameByName(info.frames["pelvis"]).CalcPoseInWorld(context).translation()[2]
        ),
    )


def table(g: Geometry) -> Obstacle:
    """The table: a 4 cm top whose near edge is 0.6 arm in front of the right shoulder,
    its underside 0.3 arm below the shoulder, 60 % of an arm deep and wide, centred on the
    right hand's y."""
    thickness, depth = 0.04, 0.6 * g.arm
    edge = g.right_shoulder[0] + 0.6 * g.arm
    underside = g.right_shoulder[2] - 0.3 * g.arm
    centre = [edge + depth / 2, g.right_hand[1], underside + thickness / 2]
    return Obstacle("table", (depth, 0.6 * g.arm, thickness), RigidTransform(centre))


def targets(g: Geometry, top: Obstacle) -> list[Target]:
    """The right hand's targets, in their order (module docstring), from the robot's geometry
    ``g`` and the table ``top``: behind the left shoulder, inside the torso (unreachable);
    across the body, in front of the chest's middle, 0.45 arm ahead of the shoulders and 0.35
    arm below them; under the table's near edge, 0.2 arm below its underside (0.78 arm from
    the right shoulder: within reach)."""
    ls, rs, a = g.left_shoulder, g.right_shoulder, g.arm
    edge = top.pose.translation()[0] - top.size[0] / 2
    underside = top.pose.translation()[2] - top.size[2] / 2
    return [
        Target(
            "behind_shoulder",
            "behind the left shoulder",
            np.array([ls[0] - 0.08 * a, 0.6 * ls[1], ls[2]]),
            False,
        ),
        Target(
            "across_body",
            "across the body",
            np.array([ls[0] + 0.45 * a, 0.0, ls[2] - 0.35 * a]),
            True,
        ),
        Target("under_table", "under the table's edge", np.array([edge, rs[1], underside - 0.2 * a]), True),
    ]


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    robot: str = "embedded",
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``reach_around`` diagram and its script on ``robot`` (a name of
    ``drake_sot.robots.ROBOTS``), with ``pushes``, with or without the self-collision task;
    ``command_server``: see :func:`~drake_sot.diagrams.scenario.build_scenario`. The setup's
    ``targets`` are the right hand's, by name (:func:`targets`; their orientation is the hand's
    initial one, not controlled)."""
    g = geometry(robot)
    top = table(g)
    b = HumanoidSoTBuilder(meshcat=meshcat, pushes=pushes, robot=robot, obstacles=(top,))
    b.add_joint_position_limits_task("taskJL", velocity_scale=VELOCITY_SCALE)
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    b.add_op_point_task("taskWaist", "pelvis", gain=3.0)
    b.add_op_point_task("taskChest", "torso", selection="000111", gain=3.0)
    b.add_op_point_task("taskRH", "right_hand", selection="111000", gain=HAND_GAIN)
    b.add_posture_task("taskPosture", gain=1.0)
    stack = b.below_joint_limits(STACK, self_collision, d_i=D_I, xi=XI)
    built = b.build(
        stack=stack,
        solver="hqp",
        command_server=command_server,
        dynamic_feedforward=True,
        damping={"taskRH": HAND_DAMPING},
    )
    R = b.initial_pose("right_hand").rotation()
    goals = targets(g, top)
    poses = {t.name: RigidTransform(R, t.position) for t in goals}

    def go(name: str):
        return lambda context: built.set_desired(context, "taskRH", poses[name])

    commands = [
        TimedCommand(START + k * DWELL, f"taskRH to {t.label}", go(t.name)) for k, t in enumerate(goals)
    ]
    return ScenarioSetup(built=built, commands=commands, duration=START + len(goals) * DWELL, targets=poses)


SCENARIO = Scenario(
    name="reach_around",
    description="the right hand reaches behind the left shoulder, across the body and under a table's edge",
    build=build,
    parameters=(ROBOT, SELF_COLLISION),
    servable=True,
)
