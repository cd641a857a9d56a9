"""The ``reach`` scenario in physics: outcomes measured on the simulated plant."""

import numpy as np
import pytest
from joint_limits import limit_excess

from drake_sot.diagrams import reach
from drake_sot.diagrams.scenario import run_scenario


@pytest.fixture(scope="module")
def reach_run(tmp_path_factory):
    output = run_scenario(reach.SCENARIO, tmp_path_factory.mktemp("reach"), duration=6.0, record=False)
    assert output.result.completed, output.result.failure
    return output


def _frame_positions(output, frame_key, times):
    """World position of a humanoid frame in the *simulated* plant at the logged samples nearest ``times``."""
    built, arrays = output.setup.built, output.arrays
    plant = built.plant
    context = plant.CreateDefaultContext()
    frame = plant.GetFrameByName(built.info.frames[frame_key], built.info.model_instance)
    out = []
    for t in times:
        k = int(np.argmin(np.abs(arrays["time"] - t)))
        plant.SetPositions(context, built.info.model_instance, arrays["q"][k])
        out.append(frame.CalcPoseInWorld(context).translation())
    return np.array(out)


def test_right_hand_reaches_its_target_by_3s(reach_run):
    target = reach_run.setup.targets["right_hand"].translation()
    p = _frame_positions(reach_run, "right_hand", [0.0, 3.0])
    assert np.linalg.norm(p[0] - target) == pytest.approx(np.linalg.norm(reach.RIGHT_HAND_OFFSET), abs=0.01)
    assert np.linalg.norm(p[1] - target) < 0.01


def test_left_hand_reaches_its_target_by_5s(reach_run):
    target = reach_run.setup.targets["left_hand"].translation()
    p = _frame_positions(reach_run, "left_hand", [2.99, 4.995])
    assert np.linalg.norm(p[0] - target) > 0.2  # it had not moved before the push
    assert np.linalg.norm(p[1] - target) < 0.01


def test_feet_do_not_slide_and_the_robot_stands(reach_run):
    times = reach_run.arrays["time"]
    for foot in ("left_foot", "right_foot"):
        p = _frame_positions(reach_run, foot, times[::10])
        slide = np.linalg.norm(p[:, :2] - p[0, :2], axis=1)
        assert slide.max() < 0.002, f"{foot} slid {1000 * slide.max():.2f} mm"
    pelvis_z = reach_run.arrays["q"][:, 6]
    assert pelvis_z.min() > 0.6


def test_left_hand_task_pushed_then_removed(reach_run):
    built, context = reach_run.setup.built, reach_run.context
    assert "taskLH" not in built.sot.list(context)
    t, e_lh = reach_run.arrays["time"], reach_run.arrays["error/taskLH"]
    assert np.all(np.isnan(e_lh[t < 2.99]))  # out of the stack before the push
    assert np.all(np.isfinite(e_lh[(t > 3.01) & (t < 4.99)]))  # in it between push and rm
    assert np.all(np.isnan(e_lh[t > 5.01]))  # out again after rm
    labels = list(reach_run.arrays["event_label"])
    assert labels.index("push taskLH") < labels.index("up taskLH") < labels.index("rm taskLH")
    # The logged stack: taskLH enters above the posture at 3 s and leaves at 5 s.
    stacks = dict(zip(np.round(reach_run.arrays["stack_time"], 3), reach_run.arrays["stack"], strict=True))
    assert stacks[3.0].split(" > ")[-2:] == ["taskLH", "taskPosture"]
    assert "taskLH" not in stacks[5.0] and "taskLH" not in stacks[0.0]


def test_no_joint_passes_its_position_or_velocity_limit(reach_run):
    """Joint position and velocity limits on top of the stack (solver "hqp"), measured on the plant."""
    excess = limit_excess(reach_run.setup.built, reach_run.arrays)
    assert excess.position < 1e-3, f"{excess.position_joint} {excess.position:.4f} rad past its limit"
    assert excess.velocity < 1e-3, f"{excess.velocity_joint} {excess.velocity:.4f} rad/s past its limit"
    # The reference stays the margin (0.02 rad) inside: the plant alone would not tell (Drake's
    # discrete plant holds a joint at its limit; without the limit tasks reach's reference went
    # 0.079 rad past chest_pitch's while the plant stayed within 3e-8 rad of it).
    assert excess.reference <= -0.02 + 1e-9, f"reference {excess.reference_joint} {excess.reference:.4f}"
