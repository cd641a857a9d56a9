"""Walking building blocks: the pattern generator, the walking tasks (feet, CoM through the
balance stabilizer, waist, hands held to the waist), the stance anchor, the ``walk`` stack's
diagram with its step script, and the walk's analysis and ZMP plot. The walking scenarios
(``walk``, ``walk_long``, ``walk_then_interact``, ``telecooperation``) and the script
entities build on these.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import System

from drake_sot.diagrams.balance import add_stabilizer, add_zmp_estimator
from drake_sot.diagrams.humanoid import HumanoidSoT, HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import TimedCommand
from drake_sot.diagrams.scenario import ScenarioHandles, ScenarioSetup
from drake_sot.diagrams.walk_plots import plot_walk
from drake_sot.footsteps import SIDES, Footstep, StepLimits, alternating_steps
from drake_sot.parameters import Parameter
from drake_sot.robots import EMBEDDED
from drake_sot.stabilization import StabilizerGains
from drake_sot.support import signed_distance_inside, sole_corners, support_polygon
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.systems.stance_anchor import StanceAnchor

#: The embedded robot's step timing (each robot's is ``RobotDescription.step_timing``).
TIMING = EMBEDDED.step_timing
START = 0.5  # [s] when the steps are given
#: The balance stabilizer between the pattern generator and the CoM task, on unless switched off.
STABILIZER = Parameter("stabilizer", "bool", True, "the balance stabilizer")
STACK = (
    "taskJL",
    "taskLF",
    "taskRF",
    "taskCom",
    "taskWaist",
    "taskRHwaist",
    "taskLHwaist",
    "taskPosture",
)


def footstep(X: RigidTransform, side: str) -> Footstep:
    """The footprint of a sole pose."""
    return Footstep(X.translation()[0], X.translation()[1], RollPitchYaw(X.rotation()).yaw_angle(), side)


def forward_steps(left: Footstep, right: Footstep, n: int, stride: float) -> list[Footstep]:
    """``n`` steps of ``stride`` [m] forward, right foot first, each relative to the other foot,
    at the stance width of ``left`` and ``right``."""
    return alternating_steps(left, right, n, stride=stride, first_side="right")


def add_pattern_generator(
    b: HumanoidSoTBuilder, name: str = "pg", limits: StepLimits | None = None
) -> tuple[PatternGenerator, Footstep, Footstep]:
    """A pattern generator ``name`` standing on the robot's initial footprints, its CoM height
    the initial CoM's, ticking at the control period, with the robot's step timing and the
    step ``limits`` (None: the robot's). Returns it and the initial footprints."""
    left, right = (
        footstep(b.initial_pose("left_foot"), "left"),
        footstep(b.initial_pose("right_foot"), "right"),
    )
    com0 = b.initial_com()
    pg = b.builder.AddSystem(
        PatternGenerator(
            left,
            right,
            com_height=com0[2],
            dt=b.control_period,
            timing=b.robot.step_timing,
            limits=b.robot.step_limits if limits is None else limits,
            com=com0[:2],
            name=name,
        )
    )
    return pg, left, right


def add_walking(
    b: HumanoidSoTBuilder,
    limits: StepLimits | None = None,
    *,
    anchored: bool = False,
    stabilizer: bool = True,
    stabilizer_gains: StabilizerGains = StabilizerGains(),
) -> tuple[PatternGenerator, Footstep, Footstep]:
    """The pattern generator and the walking tasks: joint position and velocity limits
    (an inequality task: the stack needs ``solver="hqp"``), left and right foot 6D
    and CoM xy (references and velocity feed-forward from the generator, through the
    balance stabilizer unless ``stabilizer`` is False), waist orientation, both hands held
    relative to the waist. Returns the generator (step ``limits``, None: the robot's) and the
    initial footprints; ``stabilizer_gains``: the stabilizer's gains and limits.

    ``anchored``: the feet, CoM and waist references pass through a ``StanceAnchor``
    (re-anchored on the measured stance foot at each lift-off, so that landing errors
    do not add up; :mod:`drake_sot.anchoring`). The stabilizer sits before the anchor: it
    compares the generator's CoM and ZMP with the measured CoM and ZMP, all in the robot's
    world, and its corrected CoM is then mapped into the reference's world like the other
    references. (Fed the anchored CoM, it would read the anchor's drift, the accumulated
    difference between the two worlds, as a DCM error, and hold its CoM offset at
    (1 + k_ξ/ω)/(k_ξ/ω) ≈ 2.2 times the drift: the random walk fell when that offset
    reached 8 cm, 3.5 cm of drift after 2 minutes.)
    """
    pg, left, right = add_pattern_generator(b, limits=limits)
    b.add_com_task("taskCom", selection="110", gain=20.0)
    com: System = pg  # the CoM reference in the robot's world
    if stabilizer:  # DCM feedback between the generator and the CoM task
        references = {name: pg.GetOutputPort(name) for name in ("com", "com_vel", "zmp")}
        com = add_stabilizer(b, "taskCom", references, gains=stabilizer_gains, connect=False)
    refs = add_stance_anchor(b, pg, com) if anchored else pg
    for name, port in (("com", "sdes"), ("com_vel", "sdes_dot")):
        b.builder.Connect(
            (refs if anchored else com).GetOutputPort(name), b.features["taskCom"].GetInputPort(port)
        )
    b.add_joint_position_limits_task("taskJL", velocity_scale=1.0)
    for task_name, foot in (("taskLF", "left_foot"), ("taskRF", "right_foot")):
        b.add_op_point_task(task_name, foot, gain=20.0)
        b.builder.Connect(refs.GetOutputPort(foot), b.features[task_name].GetInputPort("position_des"))
        b.builder.Connect(
            refs.GetOutputPort(foot + "_vel"), b.features[task_name].GetInputPort("velocity_des")
        )
    b.add_op_point_task("taskWaist", "pelvis", selection="000111", gain=10.0)
    b.builder.Connect(refs.GetOutputPort("waist"), b.features["taskWaist"].GetInputPort("position_des"))
    b.add_relative_task("taskRHwaist", "right_hand", "pelvis", gain=5.0)
    b.add_relative_task("taskLHwaist", "left_hand", "pelvis", gain=5.0)
    return pg, left, right


def add_stance_anchor(b: HumanoidSoTBuilder, pg: PatternGenerator, com: System | None = None) -> StanceAnchor:
    """A ``StanceAnchor`` fed by ``pg`` (its CoM reference, ``com`` and ``com_vel``, by ``com``
    when given: e.g. the balance stabilizer's corrected one; None: ``pg``'s), the reference soles
    (``dyn`` operational points) and the simulated plant's body poses; its ``drift`` is logged."""
    anchor = b.builder.AddSystem(
        StanceAnchor(
            b.plant,
            b.info.model_instance,
            {side: b.info.frames[f"{side}_foot"] for side in SIDES},
            period=b.control_period,
        )
    )
    for port in ("left_foot", "right_foot", "left_foot_vel", "right_foot_vel", "waist", "phase"):
        b.builder.Connect(pg.GetOutputPort(port), anchor.GetInputPort(port))
    for port in ("com", "com_vel"):
        b.builder.Connect((pg if com is None else com).GetOutputPort(port), anchor.GetInputPort(port))
    for side in SIDES:
        op = b.op_point(f"{side}_foot")
        b.builder.Connect(b.dyn.GetOutputPort(op), anchor.GetInputPort(f"{side}_foot_reference"))
    b.builder.Connect(b.plant.get_body_poses_output_port(), anchor.GetInputPort("body_poses"))
    b.log("drift", anchor.GetOutputPort("drift"))
    return anchor


def build_walk(
    steps_of: Callable[[Footstep, Footstep], list[Footstep]],
    *,
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    anchored: bool = False,
    stabilizer: bool = True,
    robot: str = "embedded",
    command_server: bool = False,
    footstep_source: Callable[[Footstep, Footstep, StepLimits], System] | None = None,
    self_collision: bool = True,
) -> ScenarioSetup:
    """A walking diagram (the ``walk`` stack, the ZMP estimator, logs) and its script: at
    ``START`` the steps ``steps_of(left, right)`` (made from the initial footprints) are given
    to the generator, when there are some. ``anchored``, ``stabilizer``: see :func:`add_walking`;
    ``robot``: a name of ``drake_sot.robots.ROBOTS``; ``command_server``: see
    :func:`~drake_sot.diagrams.scenario.build_scenario`. ``footstep_source(left, right, limits)``:
    a system that decides the footprints as the walk goes (its ``planned_feet`` input is fed the
    generator's, its ``next_footprint`` output feeds the generator's; ``limits`` are the robot's
    step limits). ``self_collision``: the self-collision task just below the joint limits (see
    :meth:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder.below_joint_limits`), without rows
    between the legs: the pattern generator's footprints keep them apart."""
    b = HumanoidSoTBuilder(meshcat=meshcat, pushes=pushes, robot=robot)
    pg, left, right = add_walking(b, anchored=anchored, stabilizer=stabilizer)
    if footstep_source is not None:
        source = b.builder.AddSystem(footstep_source(left, right, b.robot.step_limits))
        b.builder.Connect(pg.GetOutputPort("planned_feet"), source.GetInputPort("planned_feet"))
        b.builder.Connect(source.GetOutputPort("next_footprint"), pg.GetInputPort("next_footprint"))
    b.add_posture_task("taskPosture", gain=1.0)

    zmp = add_zmp_estimator(b)
    for name, port in (
        ("zmp", zmp.GetOutputPort("zmp")),
        ("zmp_ref", pg.GetOutputPort("zmp_ref")),
        ("com_ref", pg.GetOutputPort("com")),
        ("contacts", pg.GetOutputPort("contacts")),
        ("phase", pg.GetOutputPort("phase")),
    ):
        b.log(name, port)
    built = b.build(
        stack=b.below_joint_limits(STACK, self_collision, leg_pairs=False),
        load=pg.GetOutputPort("load"),
        dynamic_feedforward=True,
        solver="hqp",
        command_server=command_server,
    )
    steps = steps_of(left, right)
    commands = (
        [TimedCommand(START, f"add {len(steps)} steps", lambda c: pg.add_steps(c, steps))] if steps else []
    )
    duration = START + len(steps) * b.robot.step_timing.period + 2.0
    return ScenarioSetup(
        built=built,
        commands=commands,
        duration=duration,
        extras=ScenarioHandles(pattern_generator=pg, steps=steps),
    )


@dataclass
class WalkAnalysis:
    """Physical outcomes of a walk, per logged sample.

    Attributes:
        soles: side → (T, 3) measured sole [x, y, yaw] of the simulated plant.
        zmp_margin: (T,) signed distance [m] of the measured ZMP inside the support
            polygon of the soles in contact (per the generator's contact phase); NaN
            where the ZMP is undefined.
        polygons: (T,) list of support polygons (k, 2).
        com: (T, 3) CoM of the simulated plant.
    """

    soles: dict[str, np.ndarray]
    zmp_margin: np.ndarray
    polygons: list[np.ndarray]
    com: np.ndarray


def analyse(built: HumanoidSoT, arrays: dict[str, np.ndarray]) -> WalkAnalysis:
    """Measure soles, CoM and the ZMP's place in the support polygon from the run's logs."""
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    frames = {
        side: plant.GetFrameByName(info.frames[f"{side}_foot"], info.model_instance)
        for side in ("left", "right")
    }
    T = len(arrays["time"])
    soles = {side: np.zeros((T, 3)) for side in frames}
    com = np.zeros((T, 3))
    polygons, margin = [], np.full(T, np.nan)
    for k in range(T):
        plant.SetPositions(context, info.model_instance, arrays["q"][k])
        corners = []
        for i, (side, frame) in enumerate(frames.items()):
            X = frame.CalcPoseInWorld(context)
            soles[side][k] = (*X.translation()[:2], RollPitchYaw(X.rotation()).yaw_angle())
            if arrays["contacts"][k, i] > 0.5:
                corners.append(sole_corners(*soles[side][k], info.sole_size))
        com[k] = plant.CalcCenterOfMassPositionInWorld(context)
        polygon = support_polygon(corners)
        polygons.append(polygon)
        if np.all(np.isfinite(arrays["zmp"][k])):
            margin[k] = signed_distance_inside(polygon, arrays["zmp"][k])
    return WalkAnalysis(soles=soles, zmp_margin=margin, polygons=polygons, com=com)


def zmp_plot_writer(scenario: str) -> Callable[[ScenarioSetup, dict[str, np.ndarray], Path], dict[str, Path]]:
    """A scenario's ``extra_plots``: the walking plot (ZMP reference, measured ZMP, CoM and
    support polygon) as ``<scenario>_zmp.png``."""

    def write_plots(setup: ScenarioSetup, arrays: dict[str, np.ndarray], out_dir: Path) -> dict[str, Path]:
        analysis = analyse(setup.built, arrays)
        path = Path(out_dir) / f"{scenario}_zmp.png"
        plot_walk(
            arrays["time"],
            arrays["zmp_ref"],
            arrays["zmp"],
            arrays["com_ref"],
            analysis.com,
            analysis.polygons,
            [sole_corners(s.x, s.y, s.yaw, setup.built.info.sole_size) for s in setup.extras.steps],
            path,
        )
        return {f"{scenario}_zmp": path}

    return write_plots
