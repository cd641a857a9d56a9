"""The ``reach_around`` scenario in physics, on every robot, with and without the self-collision
task: the least signed distance of the simulated plant's pairs of collision shapes at every
logged sample, the hand at the reachable targets, the joints within their limits."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from joint_limits import limit_excess

from drake_sot.diagrams import reach_around
from drake_sot.diagrams.scenario import ScenarioOutput, run_scenario
from drake_sot.robots import RobotDataMissing, get_robot

ROBOTS = ("embedded", "talos", "g1")
D_S = 0.01  # [m] the task's margin (add_self_collision_task's default, which the scenario keeps)
SLACK = 0.002  # [m] how far inside the margin the simulated shapes may come
#: The ground's shape in the simulated world (``drake_sot.models.add_ground``): the soles stand on it.
GROUND = "ground_collision"


@dataclass(frozen=True)
class Closest:
    """Over a run: the least signed distance [m] of any pair of shapes, when and which."""

    distance: float
    time: float
    pair: tuple[str, str]


def closest_pairs(output: ScenarioOutput, configuration: str = "q") -> Closest:
    """The least signed distance of the pairs the simulated plant's SceneGraph may collide
    (its collision filters), but the ground's (the soles stand on it) and the soles' against the
    table, at every logged sample: the logged state put in a context of the built diagram, the
    distances asked of the SceneGraph's own query port. ``configuration``: the log of the
    simulated q (``"q"``), or of the reference (``"q_ref"``)."""
    built, arrays = output.setup.built, output.arrays
    plant = built.plant
    scene_graph = built.diagram.GetSubsystemByName("scene_graph")
    context = built.diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    scene_context = scene_graph.GetMyContextFromRoot(context)
    inspector = scene_graph.model_inspector()
    feet = {
        g
        for side in ("left", "right")
        for g in plant.GetCollisionGeometriesForBody(
            plant.GetFrameByName(built.info.frames[f"{side}_foot"], built.info.model_instance).body()
        )
    }
    best = Closest(np.inf, np.nan, ("", ""))
    for t, q in zip(arrays["time"], arrays[configuration], strict=True):
        plant.SetPositions(plant_context, built.info.model_instance, q)
        query = scene_graph.get_query_output_port().Eval(scene_context)
        for p in query.ComputeSignedDistancePairwiseClosestPoints(max_distance=D_S):
            names = (inspector.GetName(p.id_A), inspector.GetName(p.id_B))
            if GROUND in names or ({p.id_A, p.id_B} & feet and "table_collision" in names):
                continue
            if p.distance < best.distance:
                best = Closest(p.distance, float(t), names)
    return best


@dataclass(frozen=True)
class Run:
    """One simulation of the scenario and what the tests read off it."""

    robot: str
    output: ScenarioOutput
    closest: Closest


def _run(robot: str, self_collision: bool, tmp_path_factory) -> Run:
    try:
        get_robot(robot)
    except RobotDataMissing as error:
        pytest.skip(str(error))
    output = run_scenario(
        reach_around.SCENARIO,
        tmp_path_factory.mktemp(f"reach_around_{robot}_{self_collision}"),
        # Without the task only the first target's time: the hand goes into the chest at once.
        duration=None if self_collision else reach_around.START + reach_around.DWELL,
        record=False,
        parameters={"robot": robot, "self_collision": self_collision},
        log_window=None,
    )
    return Run(robot, output, closest_pairs(output))


@pytest.fixture(scope="module", params=ROBOTS)
def runs(request, tmp_path_factory) -> dict[bool, Run]:
    """The scenario on one robot with the task (True) and without it (False)."""
    return {on: _run(request.param, on, tmp_path_factory) for on in (True, False)}


def test_with_the_task_no_pair_comes_closer_than_the_margin_less_2_mm(runs):
    """The simulated shapes, not the reference's: the reference kept d_s apart, plus what the
    actuators lag behind it. (Closest on 2026-11-27: the embedded humanoid 8.9 mm, TALOS 9.9 mm,
    the G1 8.6 mm, its right hand against its torso at the unreachable target.)"""
    run = runs[True]
    assert run.output.result.completed, run.output.result.failure
    assert run.closest.distance >= D_S - SLACK, f"with the task: {run.closest}"


def test_without_the_task_shapes_touch(runs):
    """The same script without the task, up to the second target: the hand goes into the body,
    shapes come inside the margin less 2 mm (the simulated contact keeps them from going deep)."""
    assert runs[False].closest.distance < D_S - SLACK, f"without the task: {runs[False].closest}"


def _sample(output: ScenarioOutput, time: float):
    """A context of the built diagram whose plant is in the logged state nearest ``time``."""
    built, arrays = output.setup.built, output.arrays
    context = built.diagram.CreateDefaultContext()
    k = int(np.argmin(np.abs(arrays["time"] - time)))
    built.plant.SetPositions(
        built.plant.GetMyMutableContextFromRoot(context), built.info.model_instance, arrays["q"][k]
    )
    return context


def test_the_hand_reaches_the_reachable_targets_and_the_others_are_inside_the_body(runs):
    """At the end of each reachable target's time the hand is within 1 cm of it; an unreachable
    one lies inside one of the robot's shapes at the start (half-sitting, before the hand moves:
    no pose of the hand there is free of collision), measured on the simulated plant's
    SceneGraph."""
    output = runs[True].output
    built = output.setup.built
    scene_graph = built.diagram.GetSubsystemByName("scene_graph")
    g = reach_around.geometry(runs[True].robot)
    goals = reach_around.targets(g, reach_around.table(g))
    assert {t.reachable for t in goals} == {True, False}
    start = _sample(output, 0.0)
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(start))
    for k, target in enumerate(goals):
        if target.reachable:
            context = _sample(output, reach_around.START + (k + 1) * reach_around.DWELL - 0.05)
            off = np.linalg.norm(built.frame_pose(context, "right_hand").translation() - target.position)
            assert off < 0.01, f"{target.name}: the hand {100 * off:.1f} cm off"
        else:
            inside = min(d.distance for d in query.ComputeSignedDistanceToPoint(target.position, 1.0))
            assert inside < 0.0, f"{target.name}: {100 * inside:.1f} cm outside every shape"


def test_joint_limits_hold_with_the_task(runs):
    """The simulated joints within their limits and the reference the joint-limit task's margin
    (0.02 rad) inside them, to rounding. (Without the task the hand pushed into the chest can
    force a joint past its limit: the embedded humanoid's r_shoulder_yaw by 1.2 mrad.)"""
    excess = limit_excess(runs[True].output.setup.built, runs[True].output.arrays)
    assert excess.position < 1e-3, f"{excess.position_joint} {excess.position:.4f} rad past its limit"
    assert excess.reference <= -0.02 + 1e-6, f"reference {excess.reference_joint} {excess.reference:.6f}"
