"""TALOS and the Unitree G1 in physics, in the scenarios beyond standing, reaching and walking
(``test_robot_physics.py``): the case study's interaction, the generalized projector's priority
switching and table pounding, the alpha sweep.

Every outcome is measured on the simulated plant (not on the controller's reference).
"""

from __future__ import annotations

import numpy as np
import pytest
from robot_data import robot_or_skip

from drake_sot.diagrams import alpha_sweep
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
