"""TALOS and the Unitree G1 in physics: they stand, reach and walk under the kinematic SoT.

Every outcome is measured on the simulated plant (not on the controller's reference):
the pelvis pose, the hand against its target, the landed soles against the planned
footprints, the ZMP of the ankle force sensors against the support polygon of the soles.
"""

from __future__ import annotations

import numpy as np
import pytest
from landings import landing_errors
from robot_data import robot_or_skip
from standing import assert_stands

from drake_sot.diagrams import alpha_sweep, reach, walk, walking
from drake_sot.diagrams import priority_switching as ps
from drake_sot.diagrams import table_pounding as tp
from drake_sot.diagrams import walk_then_interact as wti
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow
ROBOTS = ("talos", "g1")
#: The joints of the left arm, from the torso to the hand (as the models name them).
LEFT_ARM = {
    "talos": [f"arm_left_{k}_joint" for k in range(1, 8)]
    + ["wrist_left_ft_joint", "wrist_left_tool_joint", "gripper_left_base_link_joint"],
    "g1": [
        f"left_{j}_joint"
        for j in (
            "shoulder_pitch",
            "shoulder_roll",
            "shoulder_yaw",
            "elbow",
            "wrist_roll",
            "wrist_pitch",
            "wrist_yaw",
        )
    ]
    + ["left_hand_palm_joint"],
}


@pytest.mark.parametrize("name", ROBOTS)
def test_stands_5s_with_the_pelvis_within_1cm(name):
    robot_or_skip(name)
    assert_stands(name)


@pytest.mark.parametrize("name", ROBOTS)
def test_reach_brings_the_right_hand_within_1cm_of_its_target(name, tmp_path):
    robot_or_skip(name)
    output = run_scenario(reach.SCENARIO, tmp_path, duration=3.0, record=False, parameters={"robot": name})
    assert output.result.completed, output.result.failure
    built = output.setup.built
    target = output.setup.targets["right_hand"].translation()
    hand = built.frame_pose(output.context, "right_hand").translation()
    assert np.linalg.norm(hand - target) < 0.01, (
        f"{name}: right hand {np.linalg.norm(hand - target):.4f} m off"
    )


@pytest.fixture(scope="module", params=ROBOTS)
def walk_run(request, tmp_path_factory):
    robot_or_skip(request.param)
    output = run_scenario(
        walk.SCENARIO,
        tmp_path_factory.mktemp(f"walk_{request.param}"),
        record=False,
        parameters={"robot": request.param},
    )
    assert output.result.completed, (request.param, output.result.failure, output.result.fell)
    return request.param, output, walking.analyse(output.setup.built, output.arrays)


def test_walk_lands_every_step_within_2cm_of_its_footprint(walk_run):
    name, output, analysis = walk_run
    steps = output.setup.extras.steps
    assert len(steps) == 13
    for side, off, yaw_error in landing_errors(output.arrays, analysis.soles, steps):
        assert off < 0.02, f"{name}: {side} foot landed {off:.3f} m off"
        assert yaw_error < 3.0


def test_walk_keeps_the_zmp_in_the_support_polygon_99_percent(walk_run):
    name, _, analysis = walk_run
    margin = analysis.zmp_margin[np.isfinite(analysis.zmp_margin)]
    assert margin.size > 0.9 * analysis.zmp_margin.size  # the feet carried the robot throughout
    inside = np.mean(margin >= 0.0)
    assert inside >= 0.99, f"{name}: ZMP inside the support polygon in {100 * inside:.1f} % of samples"


def test_walk_ends_upright_where_planned(walk_run):
    name, output, _ = walk_run
    steps = output.setup.extras.steps
    last = {s.side: s for s in steps}
    planned_xy = 0.5 * np.array([last["left"].x + last["right"].x, last["left"].y + last["right"].y])
    q_end = output.arrays["q"][-1]
    assert np.linalg.norm(q_end[4:6] - planned_xy) < 0.05, name
    assert q_end[6] > 0.9 * output.arrays["q"][0, 6], f"{name}: the pelvis sank"


@pytest.mark.parametrize("name", ROBOTS)
def test_walk_then_interact_switches_to_compliant_hands_that_follow_the_partner(name, tmp_path):
    robot_or_skip(name)
    output = run_scenario(wti.SCENARIO, tmp_path, record=False, parameters={"robot": name})
    assert output.result.completed, (output.result.failure, output.result.fell)
    arrays = output.arrays
    t = arrays["time"]
    assert arrays["transitions"][-1, 0] == 2  # standing -> walking -> interacting
    hands = wti.hand_positions(output.setup, arrays)
    grip = np.searchsorted(t, wti.GRIP_AT)
    pulled = np.searchsorted(t, wti.GRIP_AT + 2.0)  # the partner's grip is 8 cm forward then
    for side in ("right", "left"):
        moved = hands[side][pulled] - hands[side][grip]
        assert moved[0] > 0.04, f"{name}: {side} hand did not follow the pull ({moved[0]:.3f} m)"
    assert arrays["q"][:, 6].min() > 0.9 * arrays["q"][0, 6], f"{name}: the pelvis sank"
    assert np.all(arrays["fault/taskForce"] == 0) and np.all(arrays["fault/taskForceLH"] == 0)


@pytest.mark.parametrize("name", ROBOTS)
def test_priority_switching_gives_the_priority_task_the_smaller_error(name, tmp_path):
    """The generalized projector on the fixed base: before the switch the left hand has
    priority over the head, after it the head over the left hand (Liu, Lober, Padois 2016,
    fig. 10); the left hand's target is as far beyond the arm's reach on each robot."""
    robot_or_skip(name)
    output = run_scenario(ps.SCENARIO, tmp_path, record=False, parameters={"robot": name})
    assert output.result.completed, output.result.failure
    arrays = output.arrays
    t, errors = arrays["time"], ps.task_errors(arrays)

    def mean(start, end):
        window = (t >= start) & (t <= end)
        return {task: float(np.mean(e[window])) for task, e in errors.items()}

    before, after = mean(ps.SWITCH_AT - 1.0, ps.SWITCH_AT), mean(ps.DURATION - 1.5, ps.DURATION)
    assert before["taskLH"] < 0.5 * before["taskHead"]
    assert after["taskHead"] < 0.5 * after["taskLH"]
    assert before["taskHead"] > 0.01  # a real conflict
    assert np.all(arrays["status"][t > 0.05] == 0)  # optimal once the first ticks are past
    # The target, measured on the plant at half-sitting: out of the arm's reach from each of
    # its shoulder joints (farther than the chain of joint origins from there to the hand).
    built = output.setup.built
    plant, context = built.plant, built.plant.CreateDefaultContext()
    plant.SetPositions(context, arrays["q"][0])
    points = [
        plant.GetJointByName(j).frame_on_child().CalcPoseInWorld(context).translation()
        for j in LEFT_ARM[name]
    ]
    points.append(plant.GetFrameByName(built.info.frames["left_hand"]).CalcPoseInWorld(context).translation())
    target = output.setup.targets["left_hand"].translation()
    for k in range(3):
        chain = sum(np.linalg.norm(b - a) for a, b in zip(points[k:], points[k + 1 :], strict=False))
        assert np.linalg.norm(target - points[k]) > chain, (name, LEFT_ARM[name][k])


@pytest.mark.parametrize("name", ROBOTS)
def test_table_pounding_presses_30_newtons_without_foot_slip(name, tmp_path):
    """The generalized projector on the standing robot: each hand in turn presses the spring
    table with 30 N (Liu, Lober, Padois 2016, 4.1), the soles do not slip."""
    robot_or_skip(name)
    output = run_scenario(tp.SCENARIO, tmp_path, record=False, parameters={"robot": name})
    assert output.result.completed, (output.result.failure, output.result.fell)
    arrays, built = output.arrays, output.setup.built
    t, force = arrays["time"], arrays["table_force"][:, 0]
    for phase, after in zip(tp.DEFAULT_CONFIG.phases, tp.DEFAULT_CONFIG.phases[1:], strict=False):
        if phase.name.endswith("contact"):  # the last second of each contact phase: settled
            window = (t >= after.start - 1.0) & (t < after.start)
            assert np.all(np.abs(force[window] - tp.DEFAULT_CONFIG.force) < 3.0), (
                f"{name}: {phase.hand} hand force outside 30 ± 3 N"
            )
    context = built.plant.CreateDefaultContext()
    for foot in ("left_foot", "right_foot"):
        frame = built.plant.GetFrameByName(built.info.frames[foot], built.info.model_instance)
        xy = []
        for qk in arrays["q"][::20]:
            built.plant.SetPositions(context, built.info.model_instance, qk)
            xy.append(frame.CalcPoseInWorld(context).translation()[:2])
        assert np.max(np.linalg.norm(np.array(xy) - xy[0], axis=1)) < 0.005, f"{name}: the {foot} slipped"
    # Optimal throughout, but for a task short of its wrench (status 1, never infeasible or
    # failed) for at most 20 ms as a phase starts: TALOS at the right hand's release (4.5 s),
    # two ticks, as the force task hands over to the position task.
    status = arrays["status"][:, 0]
    since_phase = np.min(
        [np.where(t >= p.start, t - p.start, np.inf) for p in tp.DEFAULT_CONFIG.phases], axis=0
    )
    assert np.all(status[since_phase > 0.02 + 1e-9] == 0), f"{name}: status {np.unique(status)}"
    assert np.all(status <= 1)


def test_alpha_sweep_on_talos_gives_the_task_with_priority_the_smaller_steady_error(tmp_path):
    """The sweep's corners on TALOS, through its worker processes: with the left hand over the
    head (α_lh,head = 0, α_head,lh = 1) the left hand's steady error is the smaller, with
    the head over the left hand the head's; with both restricting each other neither wins
    outright, and the sweep ran on TALOS, not on the embedded robot."""
    robot_or_skip("talos")
    files = alpha_sweep.run(tmp_path, grid=(0.0, 1.0), duration=3.0, workers=2, robot="talos")
    sweep = np.load(files.files["npz"])
    head, lh = sweep["head_error"], sweep["lh_error"]
    assert sweep["done"].all()
    assert lh[0, 1] < 0.5 * head[0, 1], (lh[0, 1], head[0, 1])  # the left hand has priority
    assert head[1, 0] < 0.5 * lh[1, 0], (head[1, 0], lh[1, 0])  # the head has priority
    embedded = alpha_sweep.steady_errors(0.0, 1.0, duration=3.0)
    assert not np.allclose(embedded, (head[0, 1], lh[0, 1]), rtol=0.05)
