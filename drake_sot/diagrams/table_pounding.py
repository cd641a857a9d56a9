"""Scenario ``table_pounding`` (Liu, Lober, Padois 2016, 4.1): the torque-controlled humanoid stands and
presses a spring-mounted table with one hand, then the other, with smooth priority changes.

The table top slides vertically on a spring of 2000 N/m and a damper of 89 N·s/m; the
hand force is measured from the spring's displacement, as in the paper. The 18 tasks of
the paper adapted to the model: CoM xy (strictly highest), right/left hand position (3-D
each) and orientation (3-D each), right/left hand force (1-D, vertical), head
orientation (1-D, yaw), back posture (chest, 2-D), whole-body posture (30-D, lowest), and
the four 3-D contact forces of each foot. A scripted state machine — idle, rh-reaching,
rh-contact, rh-release, lh-reaching, lh-contact, lh-release — moves the hand targets and,
on entering a contact state, activates the hand's force task and raises it over the
hand's position task over ``transition`` seconds (eq. 12); on release it does the reverse.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.geometry import Box, CollisionFilterDeclaration, GeometrySet, SceneGraph, Sphere
from pydrake.math import RigidTransform
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    PrismaticJoint,
    PrismaticSpring,
    RigidBody,
    SpatialInertia,
)
from pydrake.systems.primitives import ConstantVectorSource

from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import TimedCommand
from drake_sot.diagrams.scenario import ROBOT, Scenario, ScenarioHandles, ScenarioSetup
from drake_sot.diagrams.table_pounding_plots import plot_table_pounding
from drake_sot.diagrams.torque_humanoid import TorqueHumanoidBuilder
from drake_sot.models import HumanoidInfo
from drake_sot.parameters import Parameter
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.systems.priority_schedule import PrioritySchedule
from drake_sot.transitions import AlphaSchedule

MOTION = ("taskCom", "taskRH", "taskLH", "taskRHo", "taskLHo", "taskHead", "taskBack", "taskPosture")
FORCES = ("taskRHF", "taskLHF")
TASKS = MOTION + FORCES


@dataclass(frozen=True)
class PoundingPhase:
    """A state of the machine: when it starts [s], its name, the hand that acts."""

    start: float
    name: str
    hand: str | None


@dataclass(frozen=True)
class TablePoundingConfig:
    """The constants of ``table_pounding``; :data:`DEFAULT_CONFIG` is the scenario's.

    Attributes:
        stiffness: [N/m] the table's spring (the paper's table).
        damping: [N s/m] the table's damper (the paper's table).
        force: [N] the force each hand presses the table with.
        surface: [m] the table surface's height at rest.
        table_x: [m] the table's front and back edges.
        table_mass: [kg] the table top's mass.
        thickness: [m] the table top's thickness.
        hand_radius: [m] the collision sphere at each hand tool point.
        hand_x: [m] how far ahead each hand presses.
        hand_y: [m] how far aside each hand presses (mirrored: -y right, +y left).
        gains: (task, kp [1/s²], kd [1/s]) per motion task, per unit of task-space inertia.
        force_pi: (kp, ki) of the force tasks (Liu, Lober, Padois 2016 eq. 3).
        phases: the state machine's script: reaching 1.5 s (over the table, then down),
            contact 2 s, release 1 s.
        duration: [s] the scenario's duration.
    """

    stiffness: float = 2000.0
    damping: float = 89.0
    force: float = 30.0
    surface: float = 0.65
    table_x: tuple[float, float] = (0.25, 0.55)
    table_mass: float = 1.0
    thickness: float = 0.04
    hand_radius: float = 0.03
    hand_x: float = 0.40
    hand_y: float = 0.30
    gains: tuple[tuple[str, float, float], ...] = (
        ("taskCom", 100.0, 20.0),
        ("taskRH", 100.0, 20.0),
        ("taskLH", 100.0, 20.0),
        ("taskRHo", 50.0, 14.0),
        ("taskLHo", 50.0, 14.0),
        ("taskHead", 50.0, 14.0),
        ("taskBack", 25.0, 10.0),
        ("taskPosture", 16.0, 8.0),
    )
    force_pi: tuple[float, float] = (0.5, 4.0)
    phases: tuple[PoundingPhase, ...] = (
        PoundingPhase(0.0, "idle", None),
        PoundingPhase(1.0, "rh-reaching", "right"),
        PoundingPhase(2.5, "rh-contact", "right"),
        PoundingPhase(4.5, "rh-release", "right"),
        PoundingPhase(5.5, "lh-reaching", "left"),
        PoundingPhase(7.0, "lh-contact", "left"),
        PoundingPhase(9.0, "lh-release", "left"),
    )
    duration: float = 10.5

    @property
    def rest(self) -> float:
        """[m] the slide's rest position under the table top's weight."""
        return -self.table_mass * 9.81 / self.stiffness


#: The scenario's configuration.
DEFAULT_CONFIG = TablePoundingConfig()
#: The priority rearrangement period; the paper also uses 0.015 s.
TRANSITION = Parameter(
    "transition",
    "float",
    0.6,
    "priority rearrangement period (the paper also uses 0.015)",
    minimum=0.0,
    unit="s",
)


def _add_table(plant: MultibodyPlant, info: HumanoidInfo, config: TablePoundingConfig) -> None:
    """The spring-mounted table top (its own model instance) and spheres on the hand tool points."""
    table = plant.AddModelInstance("table")
    (front, back), thickness = config.table_x, config.thickness
    depth, width = back - front, 0.9
    top = plant.AddRigidBody(
        "table_top", table, SpatialInertia.SolidBoxWithMass(config.table_mass, depth, width, thickness)
    )
    base = plant.AddFrame(
        FixedOffsetFrame(
            "table_base",
            plant.world_frame(),
            RigidTransform([0.5 * (front + back), 0.0, config.surface - thickness / 2]),
        )
    )
    slide = plant.AddJoint(
        PrismaticJoint("table_slide", base, top.body_frame(), [0.0, 0.0, 1.0], damping=config.damping)
    )
    slide.set_default_translation(config.rest)  # every context starts with the table at rest on its spring
    plant.AddForceElement(PrismaticSpring(slide, 0.0, config.stiffness))
    box = Box(depth, width, thickness)
    plant.RegisterVisualGeometry(top, RigidTransform(), box, "table_visual", [0.55, 0.42, 0.30, 1.0])
    plant.RegisterCollisionGeometry(top, RigidTransform(), box, "table_collision", CoulombFriction(0.8, 0.6))
    for side in ("right", "left"):
        frame = plant.GetFrameByName(info.frames[f"{side}_hand"], info.model_instance)
        plant.RegisterCollisionGeometry(
            frame.body(),
            frame.GetFixedPoseInBodyFrame(),
            Sphere(config.hand_radius),
            f"{side}_hand_collision",
            CoulombFriction(0.8, 0.6),
        )


def _press_with_the_spheres_only(plant: MultibodyPlant, scene_graph: SceneGraph, info: HumanoidInfo) -> None:
    """The table meets the hands only through the spheres at their tool points (the paper's
    contact points): the whole-body shapes of the hands and fingers (every body from the
    hand tool point's body down the kinematic tree), which reach 2 to 6 cm beyond the
    spheres on the embedded robot, are filtered against it."""
    inspector = scene_graph.model_inspector()
    shapes = [
        g
        for side in ("right", "left")
        for body in _bodies_below(plant, info, info.frames[f"{side}_hand"])
        for g in plant.GetCollisionGeometriesForBody(body)
        if not isinstance(inspector.GetShape(g), Sphere)
    ]
    table = plant.GetCollisionGeometriesForBody(plant.GetBodyByName("table_top"))
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration().ExcludeBetween(GeometrySet(shapes), GeometrySet(table))
    )


def _bodies_below(plant: MultibodyPlant, info: HumanoidInfo, frame: str) -> list[RigidBody]:
    """The body of ``frame`` and every body below it in the robot's kinematic tree."""
    children: dict[int, list[RigidBody]] = {}
    for index in plant.GetJointIndices(info.model_instance):
        joint = plant.get_joint(index)
        children.setdefault(int(joint.parent_body().index()), []).append(joint.child_body())
    bodies = [plant.GetFrameByName(frame, info.model_instance).body()]
    for body in bodies:  # grows while it is walked: breadth first
        bodies.extend(children.get(int(body.index()), []))
    return bodies


def back_joints(plant: MultibodyPlant, info: HumanoidInfo) -> list[str]:
    """The actuated joints between the robot's base and its torso, from the base up (the
    embedded robot's chest yaw and pitch, TALOS's torso_1 and torso_2)."""
    parent_joint = {
        int(plant.get_joint(index).child_body().index()): plant.get_joint(index)
        for index in plant.GetJointIndices(info.model_instance)
    }
    base = plant.GetBodyByName(info.base_body, info.model_instance).index()
    body = plant.GetFrameByName(info.frames["torso"], info.model_instance).body()
    path = []
    while body.index() != base:
        joint = parent_joint[int(body.index())]
        if joint.name() in info.actuated_joints:
            path.append(joint.name())
        body = joint.parent_body()
    return path[::-1]


class TableForce(SotLeafSystem):
    """The force on the table from its spring's displacement, as in the paper: the spring's
    ``stiffness`` [N/m] and its ``rest`` position [m] under the table top's weight.

    Input ports:
        table_state: ``[q; v]`` (2,) of the table's slide [m, m/s].
    Output ports:
        force: (1,) [N] downward force on the table top (k·(rest − q): positive when pressed).
        applied: (1,) [N] the same as the vertical wrench the pressing hand applies (−force),
            for a force task's ``<name>_measured`` input.
    """

    def __init__(self, stiffness: float, rest: float) -> None:
        super().__init__()
        state = self.DeclareVectorInputPort("table_state", 2)
        ticket = {self.input_port_ticket(state.get_index())}
        force = lambda c: stiffness * (rest - state.Eval(c)[0])  # noqa: E731
        self.DeclareVectorOutputPort(
            "force", 1, lambda c, out: out.SetFromVector([force(c)]), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "applied", 1, lambda c, out: out.SetFromVector([-force(c)]), prerequisites_of_calc=ticket
        )


def initial_alpha() -> np.ndarray:
    """α over TASKS (row i: how task i is restricted by each task), as in the paper's 4.1."""
    n = len(TASKS)
    k = {name: i for i, name in enumerate(TASKS)}
    alpha = np.zeros((n, n))
    for name in TASKS:
        if name != "taskCom":
            alpha[k[name], k["taskCom"]] = 1.0  # the CoM is strictly above everything
        if name != "taskPosture":
            alpha[k["taskPosture"], k[name]] = 1.0  # the posture strictly below
    for lower in ("taskRHo", "taskLHo", "taskBack", "taskHead"):  # below hand position and force tasks
        for upper in ("taskRH", "taskLH", "taskRHF", "taskLHF"):
            alpha[k[lower], k[upper]] = 1.0
    for force, hand in (("taskRHF", "taskRH"), ("taskLHF", "taskLH")):
        alpha[k[force], k[force]] = 1.0  # deactivated
        alpha[k[force], k[hand]] = 1.0  # strictly below the hand's position task
    return alpha


def build(
    meshcat=None,
    transition: float = 0.6,
    pushes: Sequence[ExternalPush] = (),
    robot: str = "embedded",
    config: TablePoundingConfig = DEFAULT_CONFIG,
) -> ScenarioSetup:
    """Build ``table_pounding`` (its constants ``config``) with a priority-rearrangement period
    of ``transition`` [s] (finite, >= 0; ValueError naming it otherwise, before anything is
    built) and ``pushes`` on ``robot`` (a name of ``drake_sot.robots.ROBOTS``). The table
    stands where it stands for the embedded robot (surface 0.65 m high, presses 0.40 m ahead):
    TALOS and the G1 reach it too."""
    transition = TRANSITION.check(transition)
    b = TorqueHumanoidBuilder(
        meshcat=meshcat,
        before_finalize=lambda plant, info: _add_table(plant, info, config),
        pushes=pushes,
        robot=robot,
    )
    _press_with_the_spheres_only(b.plant, b.scene_graph, b.info)
    X = {side: b.initial_pose(f"{side}_hand") for side in ("right", "left")}
    b.add_com_task("taskCom", selection="110")
    b.add_op_point_task("taskRH", "right_hand", selection="111000", desired=X["right"])
    b.add_op_point_task("taskLH", "left_hand", selection="111000", desired=X["left"])
    # One pose feature per hand: its position, orientation and force tasks select rows of it.
    b.add_op_point_task("taskRHo", "right_hand", selection="000111", feature_of="taskRH")
    b.add_op_point_task("taskLHo", "left_hand", selection="000111", feature_of="taskLH")
    b.add_op_point_task("taskHead", "head", selection="000001")
    b.add_posture_task("taskBack", back_joints(b.control_plant, b.control_info))
    b.add_posture_task("taskPosture")
    # Force tasks: only their Jacobian row is used.
    b.add_op_point_task("taskRHF", "right_hand", selection="001000", feature_of="taskRH")
    b.add_op_point_task("taskLHF", "left_hand", selection="001000", feature_of="taskLH")
    schedule = b.builder.AddSystem(PrioritySchedule(AlphaSchedule(list(TASKS), initial_alpha())))
    table = b.plant.GetModelInstanceByName("table")
    force = b.builder.AddSystem(TableForce(config.stiffness, config.rest))
    force.set_name("table_force")
    b.builder.Connect(b.plant.get_state_output_port(table), force.GetInputPort("table_state"))
    desired = b.builder.AddSystem(ConstantVectorSource([-config.force]))  # the hand pushes down
    b.log("alpha", schedule.GetOutputPort("alpha"))
    b.log("table_force", force.GetOutputPort("force"))
    gains = {name: (kp, kd) for name, kp, kd in config.gains}
    built = b.build(
        motion=[(name, *gains[name]) for name in MOTION],
        force=[(name, *config.force_pi) for name in FORCES],
        force_inputs={name: (desired.get_output_port(), force.GetOutputPort("applied")) for name in FORCES},
        priorities=schedule.GetOutputPort("priorities"),
    )
    return ScenarioSetup(
        built=built,
        commands=_script(built, schedule, X, transition, config),
        duration=config.duration,
        extras=ScenarioHandles(schedule=schedule, transition=transition, desired_force=config.force),
    )


def _script(built, schedule, X, transition: float, config: TablePoundingConfig) -> list[TimedCommand]:
    """The state machine as timed commands: hand targets and priority rearrangements (by task name)."""

    def target(side: str, height: float) -> RigidTransform:
        y = -config.hand_y if side == "right" else config.hand_y
        z = config.surface + config.hand_radius + height
        return RigidTransform(X[side].rotation(), [config.hand_x, y, z])

    def move(side: str, height: float):
        task = "taskRH" if side == "right" else "taskLH"
        return lambda c: built.features[task].set_desired(c, target(side, height))

    def priorities(side: str, contact: bool):
        hand, force = ("taskRH", "taskRHF") if side == "right" else ("taskLH", "taskLHF")
        on, off = (0.0, 1.0) if contact else (1.0, 0.0)

        def apply(c):
            schedule.set(c, force, force, on, duration=transition)  # activate / deactivate
            schedule.set(c, hand, force, off, duration=transition)  # the force over the position
            schedule.set(c, force, hand, on, duration=transition)

        return apply

    commands = []
    for phase in config.phases:
        side = phase.hand
        if phase.name.endswith("reaching"):
            commands += [
                TimedCommand(phase.start, f"{phase.name}: over the table", move(side, 0.08)),
                TimedCommand(phase.start + 0.8, f"{phase.name}: down", move(side, 0.0)),
            ]
        elif phase.name.endswith("contact"):
            commands.append(TimedCommand(phase.start, phase.name, priorities(side, True)))
        elif phase.name.endswith("release"):
            commands += [
                TimedCommand(phase.start, phase.name, priorities(side, False)),
                TimedCommand(phase.start, f"{phase.name}: up", move(side, 0.08)),
            ]
    return commands


def write_plots(setup: ScenarioSetup, arrays: dict[str, np.ndarray], out_dir: Path) -> dict[str, Path]:
    """Figures 4-7: α, desired and real hand forces, CoM and hand position errors, τᵀτ."""
    names = setup.extras.schedule.task_names  # the order of the logged alpha
    k = {name: i for i, name in enumerate(names)}
    alpha = arrays["alpha"].reshape(-1, len(names), len(names))
    alphas = {
        "α_rhf,rhf": alpha[:, k["taskRHF"], k["taskRHF"]],
        "α_rh,rhf": alpha[:, k["taskRH"], k["taskRHF"]],
        "α_lhf,lhf": alpha[:, k["taskLHF"], k["taskLHF"]],
        "α_lh,lhf": alpha[:, k["taskLH"], k["taskLHF"]],
    }
    errors = {
        name: np.linalg.norm(arrays[f"error/{name}"], axis=1) for name in ("taskCom", "taskRH", "taskLH")
    }
    path = Path(out_dir) / "table_pounding_figures.png"
    plot_table_pounding(
        arrays["time"],
        alphas,
        setup.extras.desired_force,
        arrays["table_force"][:, 0],
        errors,
        np.sum(arrays["tau"] ** 2, axis=1),
        setup.extras.transition,
        path,
    )
    return {"figures": path}


SCENARIO = Scenario(
    name="table_pounding",
    description="torque control: press a spring table with each hand in turn, 18 tasks, "
    "smooth priority changes (Liu, Lober, Padois 2016, 4.1)",
    build=build,
    extra_plots=write_plots,
    parameters=(TRANSITION, ROBOT),
)
