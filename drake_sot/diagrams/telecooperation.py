"""Scenario ``telecooperation``: a remote operator walks the humanoid while it carries a board
with a partner (Evrard et al. 2009), in one diagram.

**Coupling (section II, Fig. 2).** Only the end-effectors are coupled, through a
:class:`~drake_sot.systems.channel.Channel` (140 ms one way by default, the Munich-Tsukuba
link): the master sends the operator's forces on the handles (and the head and gripper
references), the slave sends its hand positions back.

**Master site (IV).** :class:`~drake_sot.systems.master.MasterSite`: two eq. 8-9 admittance
arms on a base placed for the best manipulability; :class:`~drake_sot.systems.master.Operator`:
the operator's hands pulled by a spring-damper towards an intention, the body walking.

**Slave site (III-E).** The stack, highest priority first: joint limits (an inequality),
self-collision avoidance (``taskSelfCollision``, an inequality, unless ``self_collision`` is
off: see below), e_walk (``taskLF``, ``taskRF``: both feet 6D from the pattern generator), e_com
(``taskCom``: x, y from the generator), the waist's orientation (``taskWaist``, from the
generator), e_zr and e_zl (hand altitudes at their initial height, pushed by a sequencer when
the pattern generator walks and removed when it stops), e_fr and e_fl (admittance-controlled
hands, eq. 4, f = the wrist sensor's external wrench + the master's force), e_head (head
orientation from the master), e_grip (the gripper joints to the master's aperture), the CoM's
height (``taskComZ``, added here: the paper's e_com says nothing of z), the posture. The pattern
generator is a planner fed by a :class:`~drake_sot.systems.hand_steps.StepDecider` (III-C,
III-D): one footprint per executed step, four ahead, decided from the hands' error in the waist
frame.

**Remote site.** A light board (1.5 m long, as wide as the hands are apart, 2 kg), a free body
held by both robot hands and, at its far end, by the co-operator, an impedance
(:class:`~drake_sot.systems.partner.Hold`) to a trajectory of their own.

**Self-collision.** ``taskSelfCollision`` keeps the robot's own collision shapes apart (the arms
against the torso and the legs, the hands against each other, as in the other kinematic
scenarios), without rows between the two legs, which the footsteps keep apart. It sees the
robot's shapes only: the board is a model instance of its own in the simulated plant, not the
robot's, and has no collision geometry, so neither the board nor the hands against it are rows
(the hands hold it through the grasp's springs). In the whole walk at 140 ms, the pairs that come
within ``d_i`` are the forearms and the torso (late in the walk, from 20 s on): with the
co-operator leading, the left forearm comes to 4.7 mm of the torso at 48 s without the task,
1.4 cm with it; with the operator leading, 1.9 cm either way (the simulated robot's shapes).

What holds (``tests/diagrams/test_telecooperation_*.py``): standing interaction at 0, 140 and
300 ms one way stays up and bounded, the hands within 2 cm of the operator's; walking at
140 ms with either leader, no step is decided below the threshold and each one reduces the
error, the board stays in the hands, the hands stay within 5 cm of the operator's, the robot's
shapes stay the self-collision margin (1 cm) apart, the altitude tasks are in the stack only
while walking; 20 s of walking at 0 and 300 ms stay bounded. The
whole walk holds with either leader. When the co-operator leads (pulling the board forward)
the stabilizer takes the hands' measured wrenches (the LIPM with external forces,
:mod:`drake_sot.stabilization` eq. 4-6); with the operator leading it does not
(``benchmarks/README.md`` has the measurements).
The replay shows the robot, the board and, as translucent blue spheres (``ghost_paths``), the
operator's hands: the handles' positions ``MasterSite.hands`` = x_S + x_Δ (eq. 9; the operator's
hands hold the handles), in the master's world, identified with the slave's; they lead the
robot's hands by the delay. The co-operator is drawn as a translucent orange sphere
(``cooperator_ghost_path``) where their hand means the board's far end to be (their impedance's
target, ``Partner.targets``, logged as ``cooperator_target``). The two-process mode's slave has
no master, hence no operator ghosts.

**The wrist-force bursts** (co-operator leading, 140 ms; ``telecooperation_fig7.png``, third
panel): the force measured at the wrists bursts to ±15 N in 33 Hz oscillations of 0.3 s, at
7, 11, 15, 19 and 23 s (every 4 s), while the operator's force stays near 2 N. Measured on that
run (the ripple: the force less its 0.05 s moving mean, RMS over each 1 s window): the ripple's
median is 0.24 N, the bursts 11-18 times it, at both wrists. They are no contact chatter (the
board's grasp is a bushing, it has no contact), no step impact (the landings are in the median)
and no packet of the link (their age stays at 0.145 s, the delay and a tick); they are the
hierarchy at a joint limit:

- the robot's body lags the stance its steps are decided from by 15-20 cm (at 20 s the pelvis
  at x = 0.60 m, the planned stance at 0.76 m: the steps queued ahead), so the hands carry the
  board 0.56 m ahead of the pelvis instead of 0.37 m; the reach comes from the chest (pitch up
  to 0.6 rad) and the elbows (from -1.07 rad to -0.03 rad);
- the chest's lean is bounded by e_head: the neck is at its limit (``head_pitch`` -0.504 rad,
  the limit -0.524 less taskJL's 0.02 margin), so the head follows the operator's pitch only
  through the chest; when the operator's nod looks up (-0.1 rad, every 4 s) during the left
  foot's single support (the right foot swinging), the chest leans 0.41 rad instead of 0.6
  and the right elbow reaches its bound (-0.03 rad: its limit 0, the straight arm, less the
  margin);
- with the elbow held at its bound, the wrists and the shoulders' yaw chatter: the right
  wrist's pitch and yaw, the shoulder's yaw change their velocity by 5.5, 4.1 and 3.1 rad/s RMS
  from a tick to the next (0.01 before the burst).

The chattering level is not the hands': the solver's problems of the ticks of the burst at 7 s,
replayed, give the wrists' velocities jumping between their limits (±5 rad/s) from a tick to
the next, and they stay below 1 rad/s when ``taskComZ`` alone is damped
(:func:`~drake_sot.hqp.solve_hqp`'s ``damping``, μ = 0.1 m/rad), not when the hands' tasks are.
With an elbow held, the levels above (the feet, the CoM's x and y, the waist, the hands, the
head) leave the CoM's height almost only to the wrists, a singular value of that level near
zero: its exact least squares asks for them at full speed, the sign flipping each tick. Damping
``taskComZ`` (μ = 0.1 m/rad, the other levels exact) removes the bursts at 7-23 s with the
co-operator leading (the ripple's largest 1 s window 2.2 and 4.3 times its median at the right
and the left wrist, the left's at 43-44 s; 17.6 and 19.5 times before, at 15 s), but it is not
used: the stabilizer's CoM offset then sits at its bound 56 % of that walk (37 % without), and
with μ = 0.01 or 0.03 that walk fell at 54.6 or 52.8 s.

Varied one at a time on the same run: without the nod (the head's pitch 0) the bursts at 7-23 s
are gone, one is left at 9 s (the left elbow at its bound, 9 times the median; that run fell
at 56.9 s, the co-operator-led balance being marginal); with the elbows held 0.3 rad bent by
another joint-limit level under taskJL, the chatter moved to that bound and went on through the
walk (the median ripple 3.9 N). The chatter is a level that an active joint bound leaves
singular, in the solver, not the straight arm's singularity, nor physics. The operator leading has one such
burst, at 6.5-7.5 s (the left elbow at its bound, 11 times the median of 0.21 N). Milder ones
(3-9 times the median, 2-6 Hz) come with the feet late in the walk: the swing foot touching
down before the planned landing (48 and 57 s with the co-operator leading, 46 s with the
operator; at 57.4 s the stance foot's force drops from 700 to 34 N for a tick), a lift-off
(51 s) and the altitude tasks' removal as the walk stops (56.3 s), both with the operator.
``tests/diagrams/test_telecooperation_walking.py`` measures the ripple (an expected failure
while the bursts are there).

Why the walk fell before, and what fixed it (the arms carried in front with position-only
hand tasks, the hands' wrenches in the stabilizer's model, a spring in z in the hands'
admittance): ``benchmarks/README.md``.

The constants below (gains, masses, timings, distances) are the fields of
:class:`TelecooperationConfig`; ``build(config=)`` takes another than ``DEFAULT_CONFIG``.

Choices where the paper is silent:

- The robot carries the board in front: it starts in half-sitting with the upper arms down and
  the elbows bent by 1.3 rad (``carry_joints``; hands 0.34 m in front of the ankles, 0.84 m
  high), away from the straight-arm singularity of the half-sitting arms.
- e_fr and e_fl control the hands' positions only (the eq.-4 admittance's translation): with a
  6D hand task on each 6-joint arm nothing was left for the posture, and the robot fell 8 s
  into the walk even in the carrying posture; the grasp's torques are weak anyway (5 N m/rad).
  Eq. 4 has no spring; the hands' admittance here has one in z only (300 N/m: it bounds the
  wind-up of the board's weight while the altitude tasks hold the hands, ``benchmarks/README.md``).
- The grasp is a stiff 6D spring-damper (a ``LinearBushingRollPitchYaw``) between each hand
  frame and the board, set at the hands' initial poses, the board reaching forward; the board
  has no collision geometry. The
  gripper joints follow e_grip but do not act on the grasp.
- The master and slave worlds are identified (x_S is used as a master-world position); the
  master's base rotation is left out of eq. 9.
- The leader lifts the board by 5 cm and sets it back (1-3 s, standing interaction), then
  walks 2 m forward and 0.5 m sideways, all at 0.05 m/s (a slow walk, as in the paper); the
  follower moves along the same path 1 s later, through a softer impedance.
  ``--leader operator``: the operator leads (the default); ``--leader cooperator``:
  the co-operator leads (the paper's Fig. 7).
- The head's reference is the operator's head: yaw 0, pitch nodding by 0.1 rad at 0.25 Hz;
  the aperture opens from 0.1 to 0.5 rad between 1 and 2 s.
- The step rule: reference = the hands' initial midpoint in the waist frame, threshold 5 cm,
  strides up to 0.2 m.
- ``admittance="weighted"`` (``--admittance weighted``), III-B's eq. 5-7: the virtual mass of each
  hand's translation is, at every tick, the hand point's apparent inertia Λ = (J_v A⁻¹ J_vᵀ)⁻¹,
  with A the whole (floating-base) robot model's inertia matrix at the reference configuration
  and J_v the hand point's translation Jacobian, as the paper writes it (the feet's contact is not
  in A); the damping stays ``hand_damping``. The other half of eq. 5-7, the A-weighted
  pseudo-inverse, is not used: in this strict hierarchy the posture task at the bottom takes up
  every degree of freedom the tasks above leave (its Jacobian, the joints, is injective on the
  feet tasks' null space), and then the hierarchy's solution does not depend on the weight of
  any level's pseudo-inverse (up to the solver's damping); so the joints do not move as eq. 7
  says (A q̈ = Jᵀ f − B_q q̇), only the hand's reference does (Λ r̈ + B ṙ = f).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.geometry import Box, Meshcat, Rgba
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, LinearBushingRollPitchYaw, SpatialInertia
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import Demultiplexer, Multiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_sot import validation
from drake_sot.channel import DEFAULT_DELAY, MAX_DELAY, LinkConfig
from drake_sot.diagrams.balance import add_zmp_estimator, connect_hand_wrenches
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import SELF_COLLISION, Scenario, ScenarioHandles, ScenarioSetup
from drake_sot.diagrams.tasks import HAND_SCALE, PARTNER_COLOUR
from drake_sot.diagrams.telecooperation_plots import plot_telecooperation
from drake_sot.diagrams.walking import add_walking
from drake_sot.footsteps import StepLimits
from drake_sot.hand_steps import HandStepRule, stance_frame
from drake_sot.master import piecewise_linear_path
from drake_sot.models import half_sitting_configuration, make_control_model
from drake_sot.models.humanoid import HumanoidInfo
from drake_sot.parameters import Parameter
from drake_sot.sequencing import Above, Below, Push, Rm, State, Transition, Up
from drake_sot.stabilization import StabilizerGains
from drake_sot.systems.channel import Channel
from drake_sot.systems.hand_steps import StepDecider
from drake_sot.systems.marker import MeshcatMarker
from drake_sot.systems.master import MasterSite, Operator
from drake_sot.systems.partner import Hold, Partner
from drake_sot.systems.replay_view import Arrow, ArrowGroup
from drake_sot.systems.sequencer import TaskSequencer
from drake_sot.systems.telecoop import (
    MASTER_BOUNDS,
    MASTER_SIGNALS,
    MASTER_SIZE,
    HandPositions,
    SlaveReferences,
)

LEADERS = ("operator", "cooperator")
#: The hands' admittance (III-B): ``plain``, eq. 4 with the fixed virtual mass of
#: ``hand_mass``; ``weighted``, eq. 5-7, the translation's virtual mass the hand's apparent
#: inertia Λ = (J A⁻¹ Jᵀ)⁻¹ at every tick (see the docstring).
ADMITTANCES = ("plain", "weighted")
LEADER = Parameter(
    "leader",
    "choice",
    "operator",
    "who leads the walk, the remote operator or the co-operator",
    choices=LEADERS,
)
DELAY = Parameter(
    "delay", "float", DEFAULT_DELAY, "one-way delay of the link", minimum=0.0, maximum=MAX_DELAY, unit="s"
)
JITTER = Parameter(
    "jitter",
    "float",
    0.0,
    "half-width of the link's uniform jitter on each packet's delay "
    f"(delay + jitter at most {MAX_DELAY:g} s)",
    minimum=0.0,
    maximum=MAX_DELAY,
    unit="s",
)
LOSS = Parameter(
    "loss",
    "float",
    0.0,
    "probability that a packet of the link is lost (the newest packet that has arrived is held)",
    minimum=0.0,
    maximum=1.0,
    maximum_excluded=True,
)
ADMITTANCE = Parameter(
    "admittance",
    "choice",
    "plain",
    "the hands' admittance, plain (a fixed virtual mass) or weighted (the virtual mass is the hand's "
    "apparent inertia, Evrard et al. 2009 eq. 5-7)",
    choices=ADMITTANCES,
)
#: The hands, right first: the order of ALTITUDE_TASKS, HAND_TASKS and of the hands' stacked
#: positions the master and the slave exchange (not footsteps' left-first SIDES).
HANDS = ("right", "left")
ALTITUDE_TASKS = ("e_zr", "e_zl")
HAND_TASKS = ("e_fr", "e_fl")
STACK = (
    "taskJL",
    "taskLF",
    "taskRF",
    "taskCom",
    "taskWaist",
    *HAND_TASKS,
    "e_head",
    "e_grip",
    "taskComZ",
    "taskPosture",
)
GRIPPERS = ("r_gripper", "l_gripper")


@dataclass(frozen=True)
class TelecooperationConfig:
    """The constants of the tele-cooperation's three sites (see the module docstring for the
    choices); :data:`DEFAULT_CONFIG` is the scenario's.

    Attributes:
        interact_at: [s] when the leader lifts the board by ``lift``, then sets it back, standing.
        lift: [m] how high the leader lifts the board.
        speed: [m/s] the leader's speed, lifting and walking.
        path: [m] the leader's displacement waypoints, walking (from where it stands).
        lag: [s] the follower's lag behind the leader.
        leader_impedance: (stiffness [N/m], damping [N s/m]) of the leader's pull on what it holds.
        follower_impedance: (stiffness [N/m], damping [N s/m]) of the follower's, softer.
        board_length: [m] the board's length (its width is the hands' distance).
        board_mass: [kg] the board's mass.
        board_thickness: [m] the board's thickness.
        grasp_force: (stiffness [N/m], damping [N s/m]) of the grasp's bushings in translation.
        grasp_torque: (stiffness [N m/rad], damping [N m s/rad]) of the grasp's bushings in rotation.
        hand_mass: (6,) the hands' admittance virtual mass [kg, kg m²] (``plain``; translation first).
        hand_damping: (6,) the hands' admittance damping [N s/m, N m s/rad].
        hand_stiffness: (6,) the hands' admittance stiffness [N/m, N m/rad]: z only (see the docstring).
        stabilizer: the balance stabilizer's gains, its CoM offset bounded at 3 cm.
        carry_shoulder_pitch: [rad] the carrying posture's shoulder pitch (the upper arms down).
        carry_elbow: [rad] the carrying posture's elbows, bent so that the forearms point forward
            (the hands in front of the waist, far from the straight-arm singularity).
        master_mass: [kg] the master arms' admittance mass (eq. 8-9).
        master_damping: [N s/m] the master arms' admittance damping.
        master_stiffness: [N/m] the master arms' admittance stiffness.
        ghost_paths: the Meshcat paths of the operator's hands in the replay, [right, left].
        ghost_radius: [m] their spheres' radius.
        ghost_colour: their colour (r, g, b, alpha in [0, 1]).
        cooperator_ghost_path: the Meshcat path of the co-operator's hand in the replay.
        cooperator_ghost_radius: [m] its sphere's radius.
        cooperator_colour: its colour (r, g, b, alpha in [0, 1]).
        step_limits: the strides the step decider may ask for.
        step_threshold: [m] the hands' error below which no step is decided.
        settle: [s] simulated after the follower's end of the walk.
    """

    interact_at: float = 1.0
    lift: float = 0.05
    speed: float = 0.05
    path: tuple[tuple[float, float, float], ...] = ((2.0, 0.0, 0.0), (2.0, -0.5, 0.0))
    lag: float = 1.0
    leader_impedance: tuple[float, float] = (200.0, 40.0)
    follower_impedance: tuple[float, float] = (80.0, 30.0)
    board_length: float = 1.5
    board_mass: float = 2.0
    board_thickness: float = 0.03
    grasp_force: tuple[float, float] = (800.0, 60.0)
    grasp_torque: tuple[float, float] = (5.0, 0.2)
    hand_mass: tuple[float, ...] = (4.0, 4.0, 4.0, 0.2, 0.2, 0.2)
    hand_damping: tuple[float, ...] = (150.0, 150.0, 150.0, 4.0, 4.0, 4.0)
    hand_stiffness: tuple[float, ...] = (0.0, 0.0, 300.0, 0.0, 0.0, 0.0)
    stabilizer: StabilizerGains = StabilizerGains(max_offset=0.03)
    carry_shoulder_pitch: float = 0.0
    carry_elbow: float = -1.3
    master_mass: float = 2.0
    master_damping: float = 60.0
    master_stiffness: float = 400.0
    ghost_paths: tuple[str, str] = ("/drake_sot/operator/right_hand", "/drake_sot/operator/left_hand")
    ghost_radius: float = 0.04
    ghost_colour: tuple[float, float, float, float] = (0.2, 0.45, 0.95, 0.35)
    cooperator_ghost_path: str = "/drake_sot/cooperator/hand"
    cooperator_ghost_radius: float = 0.05
    cooperator_colour: tuple[float, float, float, float] = (0.95, 0.55, 0.15, 0.45)
    step_limits: StepLimits = StepLimits(max_stride=0.2)
    step_threshold: float = 0.05
    settle: float = 4.0

    @property
    def walk_at(self) -> float:
        """[s] when the leader starts walking (the lift done)."""
        return self.interact_at + 2 * self.lift / self.speed

    @property
    def duration(self) -> float:
        """[s] the scenario's duration: the follower's walk along ``path``, then ``settle``."""
        points = np.array(((0.0, 0.0, 0.0), *self.path))
        length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
        return self.walk_at + self.lag + length / self.speed + self.settle

    @property
    def carry_joints(self) -> dict[str, float]:
        """The carrying posture's joints by name: both shoulders' pitch and both elbows [rad]."""
        values = (("shoulder_pitch", self.carry_shoulder_pitch), ("elbow", self.carry_elbow))
        return {f"{side}_{joint}": value for side in "rl" for joint, value in values}

    @property
    def hand_admittance(self) -> dict[str, tuple[float, ...]]:
        """The hands' admittance as ``add_admittance_task`` takes it (mass, damping, stiffness)."""
        return {"mass": self.hand_mass, "damping": self.hand_damping, "stiffness": self.hand_stiffness}


#: The scenario's configuration.
DEFAULT_CONFIG = TelecooperationConfig()


def carrying_configuration(config: TelecooperationConfig = DEFAULT_CONFIG) -> np.ndarray:
    """(nq,) the robot's half-sitting configuration with the forearms forward
    (``config.carry_joints``)."""
    plant, info = make_control_model()
    q = half_sitting_configuration(plant, info)
    for joint, value in config.carry_joints.items():
        q[plant.GetJointByName(joint, info.model_instance).position_start()] = value
    return q


def _initial_hands(config: TelecooperationConfig) -> dict[str, RigidTransform]:
    plant, info = make_control_model()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, carrying_configuration(config))
    return {
        side: plant.GetFrameByName(info.frames[f"{side}_hand"]).CalcPoseInWorld(context) for side in HANDS
    }


def _add_board(
    plant: MultibodyPlant, info: HumanoidInfo, hands: dict[str, RigidTransform], config: TelecooperationConfig
) -> None:
    """The board, a free body in its own model instance, gripped by both hands (bushings)."""
    instance = plant.AddModelInstance("board")
    p_r, p_l = hands["right"].translation(), hands["left"].translation()
    width = float(np.linalg.norm(p_l - p_r))
    board = plant.AddRigidBody(
        "board",
        instance,
        SpatialInertia.SolidBoxWithMass(
            config.board_mass, config.board_length, width, config.board_thickness
        ),
    )
    X_WB = RigidTransform(0.5 * (p_r + p_l) + [0.5 * config.board_length, 0.0, 0.0])
    plant.SetDefaultFloatingBaseBodyPose(board, X_WB)
    plant.RegisterVisualGeometry(
        board,
        RigidTransform(),
        Box(config.board_length, width, config.board_thickness),
        "board",
        np.array([0.6, 0.45, 0.3, 1.0]),
    )
    for side in HANDS:
        hand = plant.GetFrameByName(info.frames[f"{side}_hand"], info.model_instance)
        grip = plant.AddFrame(
            FixedOffsetFrame(f"board_{side}_grip", board.body_frame(), X_WB.InvertAndCompose(hands[side]))
        )
        (kf, df), (kt, dt) = config.grasp_force, config.grasp_torque
        plant.AddForceElement(LinearBushingRollPitchYaw(hand, grip, [kt] * 3, [dt] * 3, [kf] * 3, [df] * 3))


def _waypoints(walk: bool, config: TelecooperationConfig) -> tuple[tuple[float, float, float], ...]:
    """The leader's displacement waypoints: lift, set back, then (``walk``) the walk."""
    return ((0.0, 0.0, config.lift), (0.0, 0.0, 0.0), *(config.path if walk else ()))


def _references() -> TrajectorySource:
    """The operator's head ``[yaw, pitch]`` [rad] and the gripper aperture [rad] over time."""
    times = np.arange(0.0, 60.0, 0.25)
    values = np.vstack(
        [
            np.zeros_like(times),
            0.1 * np.sin(2 * math.pi * 0.25 * times),
            np.interp(times, [1.0, 2.0], [0.1, 0.5]),
        ]
    )
    return TrajectorySource(PiecewisePolynomial.FirstOrderHold(times, values))


# --- the master site, shared with the two-process mode (telecoop_master) -----------------------
@dataclass(frozen=True)
class MasterSide:
    """The master site's systems in a diagram: ``sent`` outputs what goes to the slave, the
    signals of :data:`~drake_sot.systems.telecoop.MASTER_SIGNALS` in their order (forces right,
    left (3, 3) [N]; head yaw, pitch (2,) [rad]; aperture (1,) [rad]); ``master.slave_hands``
    is left for the link to feed."""

    master: MasterSite
    operator: Operator
    head_grip: TrajectorySource
    sent: Multiplexer


def initial_master_values() -> dict[str, np.ndarray]:
    """What the slave holds of the master's signals before the first packet, by name: no force,
    the head level, the grippers at half-sitting."""
    plant, info = make_control_model()
    q0 = half_sitting_configuration(plant, info)
    values = {name: np.zeros(size) for name, (size, _) in MASTER_SIGNALS.items()}
    values["gripper"][0] = q0[plant.GetJointByName(GRIPPERS[0]).position_start()]
    return values


def link_configs(
    delay: float, jitter: float = 0.0, loss: float = 0.0, seed: int = 0
) -> tuple[LinkConfig, LinkConfig]:
    """The link's two directions, forward (master → slave, seed ``2 seed``) and backward (seed
    ``2 seed + 1``), each with the one-way ``delay`` [s], the jitter's half-width ``jitter`` [s]
    and the probability ``loss`` that a packet is lost: the one-process ``Channel`` and the
    two-process master draw the same packets from them.

    Raises:
        ValueError: a value :class:`~drake_sot.channel.LinkConfig` refuses (naming it), e.g.
            ``delay + jitter`` over ``MAX_DELAY`` or a negative ``seed``.
    """
    seed = validation.positive_int("seed", seed, minimum=0)
    return (
        LinkConfig(delay=delay, jitter=jitter, loss=loss, seed=2 * seed),
        LinkConfig(delay=delay, jitter=jitter, loss=loss, seed=2 * seed + 1),
    )


def initial_link_values(config: TelecooperationConfig = DEFAULT_CONFIG) -> tuple[np.ndarray, np.ndarray]:
    """What each side holds before the first packet: the master's signals as one vector (in the
    order of ``MASTER_SIGNALS``, :func:`initial_master_values`) and the slave's hands
    ``[right; left]`` [m] at their initial position."""
    hands = _initial_hands(config)
    forward = np.concatenate(list(initial_master_values().values()))
    return forward, np.concatenate([hands[side].translation() for side in HANDS])


def add_master_site(
    builder: DiagramBuilder,
    x_s0: np.ndarray,
    leader: str,
    walk: bool,
    period: float,
    config: TelecooperationConfig = DEFAULT_CONFIG,
) -> MasterSide:
    """The master site (IV): the arms and base, the operator (leading or following the
    co-operator), the head and gripper references, wired together; ``x_s0`` the slave's hands."""
    operator_lag = 0.0 if leader == "operator" else config.lag
    waypoints = _waypoints(walk, config)
    path = piecewise_linear_path(
        [0.0, 0.0, 0.0], waypoints, config.speed, t0=config.interact_at + operator_lag
    )
    body0 = np.array([0.0, 0.0, 0.9])
    k_op, b_op = config.leader_impedance if leader == "operator" else config.follower_impedance

    def intention(t: float) -> tuple[np.ndarray, np.ndarray]:
        p, v = path(t)
        return x_s0 + np.tile(p, 2), np.tile(v, 2)

    def body(t: float) -> tuple[np.ndarray, np.ndarray]:
        p, v = path(t)
        return body0 + p, v

    master = builder.AddSystem(
        MasterSite(
            x_s0,
            period=period,
            mass=config.master_mass,
            damping=config.master_damping,
            stiffness=config.master_stiffness,
        )
    )
    operator = builder.AddSystem(Operator(intention, body, stiffness=k_op, damping=b_op, period=period))
    builder.Connect(operator.GetOutputPort("forces"), master.GetInputPort("handle_forces"))
    builder.Connect(master.GetOutputPort("hands"), operator.GetInputPort("hands"))
    builder.Connect(master.GetOutputPort("hand_velocities"), operator.GetInputPort("hand_velocities"))
    head_grip = builder.AddSystem(_references())
    head_grip.set_name("head_and_grip")
    sent = builder.AddSystem(Multiplexer([6, 3]))
    builder.Connect(master.GetOutputPort("forces"), sent.get_input_port(0))
    builder.Connect(head_grip.get_output_port(), sent.get_input_port(1))

    return MasterSide(master, operator, head_grip, sent)


def master_logs(side: MasterSide) -> tuple[tuple[str, OutputPort], ...]:
    """The master site's logs, by name."""
    return (
        ("operator_forces", side.operator.GetOutputPort("forces")),
        ("operator_hands", side.master.GetOutputPort("hands")),
        ("operator_intention", side.operator.GetOutputPort("intention")),
        ("operator_body", side.operator.GetOutputPort("body")),
        ("master_base", side.master.GetOutputPort("base")),
        ("master_offsets", side.master.GetOutputPort("offsets")),
        ("head_grip_ref", side.head_grip.get_output_port()),
    )


def add_ghosts(
    builder: DiagramBuilder,
    meshcat: Meshcat,
    hands: OutputPort,
    config: TelecooperationConfig = DEFAULT_CONFIG,
) -> None:
    """The operator's hands ``hands`` (6,) [m] ``[right; left]`` drawn as translucent spheres
    (``config.ghost_paths``) in ``meshcat`` and its recording."""
    split = builder.AddSystem(Demultiplexer([3, 3]))
    split.set_name("operator_hands_split")
    builder.Connect(hands, split.get_input_port())
    for k, path in enumerate(config.ghost_paths):
        ghost = builder.AddSystem(
            MeshcatMarker(meshcat, path, radius=config.ghost_radius, rgba=Rgba(*config.ghost_colour))
        )
        builder.Connect(split.get_output_port(k), ghost.GetInputPort("position"))


def add_cooperator_ghost(
    builder: DiagramBuilder,
    meshcat: Meshcat,
    target: OutputPort,
    config: TelecooperationConfig = DEFAULT_CONFIG,
) -> None:
    """The co-operator's hand drawn as a translucent orange sphere (``config.cooperator_ghost_path``) at
    ``target`` (3,) [m], where their impedance pulls the board's far end (``Partner.targets``)."""
    ghost = builder.AddSystem(
        MeshcatMarker(
            meshcat,
            config.cooperator_ghost_path,
            radius=config.cooperator_ghost_radius,
            rgba=Rgba(*config.cooperator_colour),
        )
    )
    builder.Connect(target, ghost.GetInputPort("position"))


# --- end of the master site ---


def build(
    meshcat: Meshcat | None = None,
    leader: str = "operator",
    delay: float = DEFAULT_DELAY,
    pushes: Sequence[ExternalPush] = (),
    walk: bool = True,
    remote: bool = False,
    admittance: str = "plain",
    jitter: float = 0.0,
    loss: float = 0.0,
    command_server: bool = False,
    config: TelecooperationConfig = DEFAULT_CONFIG,
    seed: int = 0,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``telecooperation`` diagram (its constants ``config``); ``leader`` is
    ``"operator"`` or ``"cooperator"``, ``delay`` the one-way delay [s] of both directions
    (0-0.3), ``pushes`` on the robot;
    ``walk=False``: the leader only lifts and sets back the board (standing interaction);
    ``remote=True``: the slave side only, what the master sends written to the command server's
    signals ``remote.<name>`` of ``MASTER_SIGNALS`` (see ``telecoop_slave``; ``delay`` is then
    the master process's, and so are ``jitter`` and ``loss``); ``admittance``: the hands'
    admittance, one of :data:`ADMITTANCES`; ``jitter`` [s], ``loss`` (a probability in [0, 1)):
    the link's, both directions (:func:`link_configs`, with ``seed``, an int >= 0, drawing their
    packets' jitter and loss); ``command_server``: see
    :func:`~drake_sot.diagrams.scenario.build_scenario` (``remote=True`` has one whatever it says);
    ``self_collision``: the self-collision task just below the joint limits (see
    :meth:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder.below_joint_limits`), without rows
    between the legs; the sequencer's stacks have it in every state.

    Raises:
        ValueError: ``leader``, ``admittance`` or ``delay`` out of what is accepted (naming the
            value and the accepted ones), or a link value ``jitter``, ``loss``, ``seed`` that
            :func:`link_configs` refuses."""
    leader, admittance, delay = LEADER.check(leader), ADMITTANCE.check(admittance), DELAY.check(delay)
    forward_link, backward_link = link_configs(delay, jitter, loss, seed)
    hands0 = _initial_hands(config)
    b = HumanoidSoTBuilder(
        meshcat=meshcat,
        pushes=pushes,
        before_finalize=lambda plant, info: _add_board(plant, info, hands0, config),
        q0=carrying_configuration(config),
    )
    builder = b.builder
    pg, left, right = add_walking(b, limits=config.step_limits, stabilizer_gains=config.stabilizer)
    x_s0 = np.concatenate([hands0[side].translation() for side in HANDS])

    # --- slave side: the seven tasks ------------------------------------------------------
    # The CoM's height, below the hands: without it the least-norm motion of the hands lowers
    # the whole body (the robot squats under the board's weight and to reach forward); above
    # the hands, it drives the arms into the body (a 100 N contact at the wrists).
    b.add_com_task("taskComZ", selection="001", gain=5.0)
    for task_name, side in zip(ALTITUDE_TASKS, HANDS, strict=True):
        b.add_op_point_task(task_name, f"{side}_hand", selection="001000", gain=5.0)
    admittances = {
        task_name: b.add_admittance_task(
            task_name, side, selection="111000", weighted=admittance == "weighted", **config.hand_admittance
        )
        for task_name, side in zip(HAND_TASKS, HANDS, strict=True)
    }
    # The co-operator leading: the balance stabilizer's model has the hands' measured wrenches (the
    # board's weight and the co-operator's pull); without them it answered the pull by moving the
    # CoM forward. Not with the operator leading: there it made the walk fall at 23.2 s (not yet
    # understood), whereas without it that walk completes.
    if leader == "cooperator":
        connect_hand_wrenches(
            b,
            builder.GetMutableSubsystemByName("stabilizer"),
            {
                side: admittances[task].GetOutputPort("wrench_external")
                for task, side in zip(HAND_TASKS, HANDS, strict=True)
            },
        )
    b.add_op_point_task("e_head", "head", selection="000111", gain=5.0)
    b.add_posture_task("e_grip", GRIPPERS, gain=5.0)
    b.add_posture_task("taskPosture", gain=1.0)
    references = builder.AddSystem(SlaveReferences(b.control_plant, b.q0, GRIPPERS))
    for task_name, side in zip(HAND_TASKS, HANDS, strict=True):
        builder.Connect(
            references.GetOutputPort(f"wrench_ref_{side}"), admittances[task_name].GetInputPort("wrench_ref")
        )
    builder.Connect(references.GetOutputPort("head_pose"), b.features["e_head"].GetInputPort("position_des"))
    builder.Connect(references.GetOutputPort("posture"), b.features["e_grip"].GetInputPort("sdes"))
    hand_positions = builder.AddSystem(HandPositions())
    for side in HANDS:
        builder.Connect(
            b.dyn.GetOutputPort(b.op_point(f"{side}_hand")), hand_positions.GetInputPort(f"{side}_hand")
        )

    # The task's defaults (d_s = 1 cm, d_i = 5 cm, ξ = 0.2 m/s) hold the forearms off the torso in
    # the walks (the module docstring); no leg pairs, the footsteps keep the legs apart.
    stack = b.below_joint_limits(STACK, self_collision, leg_pairs=False)

    # e_zr, e_zl only while walking: pushed above the hands' admittance tasks, then removed.
    def raise_above_hands(task: str):
        return (Push(task), *(Up(task) for _ in range(len(stack) - stack.index(HAND_TASKS[0]))))

    sequencer = builder.AddSystem(
        TaskSequencer(
            [
                State("standing", entry=(), transitions=(Transition(Above("in_process", 0.5), "walking"),)),
                State(
                    "walking",
                    entry=(*raise_above_hands("e_zr"), *raise_above_hands("e_zl")),
                    transitions=(Transition(Below("in_process", 0.5), "stopped"),),
                ),
                State(
                    "stopped",
                    entry=tuple(Rm(t) for t in ALTITUDE_TASKS),
                    transitions=(Transition(Above("in_process", 0.5), "walking"),),
                ),
            ],
            "standing",
            tasks=list(b.tasks),
            stack=stack,
            period=b.control_period,
            name="walking_switch",
        )
    )
    builder.Connect(pg.GetOutputPort("in_process"), sequencer.GetInputPort("in_process"))

    # Walking as a planner: the next footprint from the hands' error in the waist frame.
    centre, _ = stance_frame(left, right)
    reference = 0.5 * (x_s0[:2] + x_s0[3:5]) - centre
    rule = HandStepRule(
        reference=tuple(reference), threshold=config.step_threshold, limits=config.step_limits
    )
    decider = builder.AddSystem(StepDecider(rule))
    builder.Connect(hand_positions.GetOutputPort("positions"), decider.GetInputPort("hands"))
    builder.Connect(pg.GetOutputPort("planned_feet"), decider.GetInputPort("planned_feet"))
    builder.Connect(decider.GetOutputPort("next_footprint"), pg.GetInputPort("next_footprint"))

    # --- the link: a Channel and the master site here, or (remote) the server's writable -----
    initial, _ = initial_link_values(config)
    link_logs: tuple[tuple[str, OutputPort], ...]
    received: dict[str, OutputPort] = {}
    if remote:  # the master site is another process (telecoop_master): it writes, and delays
        for name, value in initial_master_values().items():
            size, units = MASTER_SIGNALS[name]
            received[name] = b.declare_writable(name, size, units, value, bound=MASTER_BOUNDS[name])
        link_logs = ()
        extras = ScenarioHandles(wait_for_client=True, paced_by_client=True)
    else:
        channel = builder.AddSystem(
            Channel(
                MASTER_SIZE,
                6,
                forward=forward_link,
                backward=backward_link,
                period=b.control_period,
                forward_initial=initial,
                backward_initial=x_s0,
            )
        )
        split = builder.AddSystem(Demultiplexer([size for size, _ in MASTER_SIGNALS.values()]))
        builder.Connect(channel.GetOutputPort("forward_out"), split.get_input_port())
        received = {name: split.get_output_port(i) for i, name in enumerate(MASTER_SIGNALS)}
        builder.Connect(hand_positions.GetOutputPort("positions"), channel.GetInputPort("backward_in"))
        side = add_master_site(builder, x_s0, leader, walk, b.control_period, config)
        builder.Connect(channel.GetOutputPort("backward_out"), side.master.GetInputPort("slave_hands"))
        builder.Connect(side.sent.get_output_port(), channel.GetInputPort("forward_in"))
        if meshcat is not None:  # the operator's hands as ghosts in the replay
            add_ghosts(builder, meshcat, side.master.GetOutputPort("hands"), config)
        link_logs = (
            *master_logs(side),
            ("received_by_master", channel.GetOutputPort("backward_out")),
            ("delay_forward", channel.GetOutputPort("forward_age")),
            ("delay_backward", channel.GetOutputPort("backward_age")),
        )
        extras = ScenarioHandles(channel=channel, master=side.master, operator=side.operator)
    for name, port in received.items():
        builder.Connect(port, references.GetInputPort(name))
    link_logs = (*link_logs, *((f"received_by_slave/{name}", port) for name, port in received.items()))
    # --- end of the link ---

    # --- remote site: the co-operator holds the board's far end ----------------------------
    cooperator_lag = config.lag if leader == "operator" else 0.0
    k_co, b_co = config.follower_impedance if leader == "operator" else config.leader_impedance
    t = config.interact_at + cooperator_lag
    waypoints = _waypoints(walk, config)
    keyframes = [(0.0, (0.0, 0.0, 0.0)), (t, (0.0, 0.0, 0.0))]
    previous = np.zeros(3)
    for point in waypoints:
        t += float(np.linalg.norm(np.array(point) - previous)) / config.speed
        keyframes.append((t, point))
        previous = np.array(point)
    cooperator = builder.AddSystem(
        Partner(
            b.plant,
            {"board": [Hold(0.0, 1e6, tuple(keyframes), stiffness=k_co, damping=b_co)]},
            points={"board": (0.5 * config.board_length, 0.0, 0.0)},
            period=b.control_period,
        )
    )
    cooperator.set_name("cooperator")
    builder.Connect(b.plant.get_body_poses_output_port(), cooperator.GetInputPort("body_poses"))
    builder.Connect(
        b.plant.get_body_spatial_velocities_output_port(), cooperator.GetInputPort("body_spatial_velocities")
    )
    b.apply_spatial_forces(cooperator.GetOutputPort("spatial_forces"))
    b.draw_forces(
        ArrowGroup(
            "cooperator",
            "the co-operator's pull on the board's far end",
            PARTNER_COLOUR,
            HAND_SCALE,
            3,
            (Arrow("board", (0.5 * config.board_length, 0.0, 0.0), 0),),
        ),
        cooperator.GetOutputPort("forces"),
    )
    if meshcat is not None:
        add_cooperator_ghost(builder, meshcat, cooperator.GetOutputPort("targets"), config)

    # --- logs ----------------------------------------------------------------------------------
    board_instance = b.plant.GetModelInstanceByName("board")
    zmp = add_zmp_estimator(b)
    for name, port in (
        ("zmp", zmp.GetOutputPort("zmp")),
        ("foot_forces", zmp.GetOutputPort("foot_forces")),
        ("board_state", b.plant.get_state_output_port(board_instance)),
        ("cooperator_force", cooperator.GetOutputPort("forces")),
        ("cooperator_target", cooperator.GetOutputPort("targets")),
        *link_logs,  # (two-process mode: the master's logs are the master's)
        ("robot_hands", hand_positions.GetOutputPort("positions")),
        ("step_error", decider.GetOutputPort("error")),
        ("planned_stance", decider.GetOutputPort("stance")),
        ("in_process", pg.GetOutputPort("in_process")),
        ("phase", pg.GetOutputPort("phase")),
    ):
        b.log(name, port)
    for task_name, admittance_system in admittances.items():
        b.log(f"wrench/{task_name}", admittance_system.GetOutputPort("wrench_external"))
        b.log(f"reference_velocity/{task_name}", admittance_system.GetOutputPort("velocity_des"))
        b.log(f"virtual_mass/{task_name}", admittance_system.GetOutputPort("virtual_mass"))
    built = b.build(
        stack=stack,
        load=pg.GetOutputPort("load"),
        dynamic_feedforward=True,
        stack_source=sequencer.GetOutputPort("stack"),
        solver="hqp",
        command_server=command_server,
    )
    return ScenarioSetup(
        built=built,
        commands=[],
        duration=config.duration,
        extras=dataclasses.replace(
            extras,  # the link's
            pattern_generator=pg,
            decider=decider,
            rule=rule,
            sequencer=sequencer,
            admittances=admittances,
            leader=leader,
            delay=delay,
            admittance=admittance,
            grippers=GRIPPERS,
        ),
    )


def arm_speeds(setup: ScenarioSetup, v: np.ndarray) -> np.ndarray:
    """(T, 4) [rad/s] the speeds of the carrying joints (the shoulders' pitch, the elbows) from the
    robot's logged velocities ``v`` (T, the robot's nv), e.g. ``arrays["v"]``."""
    plant, instance = setup.built.plant, setup.built.info.model_instance
    columns = []
    for joint in DEFAULT_CONFIG.carry_joints:  # their names; any configuration has the same
        unit = np.zeros(plant.num_velocities())
        unit[plant.GetJointByName(joint, instance).velocity_start()] = 1.0
        columns.append(int(np.argmax(plant.GetVelocitiesFromArray(instance, unit))))
    return v[:, columns]


def write_plots(setup: ScenarioSetup, arrays: dict[str, np.ndarray], out_dir: Path) -> dict[str, Path]:
    """The Fig.-7-like plot, the force transparency and the steps (see ``telecooperation_plots``)."""
    path = Path(out_dir) / "telecooperation_fig7.png"
    plot_telecooperation(arrays, setup.extras.leader, setup.extras.delay, path)
    return {"fig7": path}


SCENARIO = Scenario(
    name="telecooperation",
    description="a remote operator (140 ms away) and a co-operator carry a board with the walking humanoid",
    build=build,
    extra_plots=write_plots,
    parameters=(LEADER, DELAY, ADMITTANCE, JITTER, LOSS, SELF_COLLISION),
    servable=True,
)
