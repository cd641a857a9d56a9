"""The case study end to end in physics: walk, the decision rule switches tasks, the hands comply."""

import numpy as np
import pytest
from joint_limits import limit_excess

from drake_sot.diagrams import walk_then_interact as wti
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.diagrams.tasks import SELF_COLLISION_TASK

# Run on every Python the package claims: the case study walks to its end there too.
pytestmark = pytest.mark.compat


@pytest.fixture(scope="module")
def case_study(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("wti")
    output = run_scenario(wti.SCENARIO, out_dir, record=False)
    assert output.result.completed, output.result.failure
    return output, out_dir


def _stacks(arrays):
    return [(t, s.split(" > ")) for t, s in zip(arrays["stack_time"], arrays["stack"], strict=True)]


def test_walking_tasks_removed_and_force_tasks_pushed_after_the_walk(case_study):
    output, _ = case_study
    arrays = output.arrays
    stacks = _stacks(arrays)
    assert stacks[0][1] == [
        wti.STACK[0],
        SELF_COLLISION_TASK,
        *wti.STACK[1:],
    ]  # walking, the task on by default
    t_switch, after = stacks[-1]
    for task in wti.WALKING_TASKS:
        assert task not in after
    for task in wti.FORCE_TASKS:
        assert after.index(task) < after.index("taskPosture")  # pushed, then raised above the posture
    # The switch came after the walk ended, at the decision rule's next 1 s check.
    t = arrays["time"]
    walk_end = t[np.flatnonzero(arrays["in_process"][:, 0] > 0.5)[-1]]
    # Recorded at the first tick after a check instant (every 1 s), at most one check after the walk.
    check = np.floor(t_switch)
    assert t_switch - check <= 0.005 + 1e-9
    assert walk_end < check <= walk_end + 1.0 + 1e-9
    assert arrays["transitions"][-1, 0] == 2  # standing -> walking -> interacting
    assert np.all(np.isnan(arrays["error/taskForce"][t < t_switch - 0.01]))
    assert np.all(np.isfinite(arrays["error/taskForce"][t > t_switch + 0.01]))


def test_hands_comply_with_the_partner_and_the_robot_stays_up(case_study):
    output, _ = case_study
    arrays = output.arrays
    t = arrays["time"]
    hands = wti.hand_positions(output.setup, arrays)
    grip = np.searchsorted(t, wti.GRIP_AT)
    pulled = np.searchsorted(t, wti.GRIP_AT + 2.0)  # the partner's grip is 8 cm forward then
    for side in ("right", "left"):
        moved = hands[side][pulled] - hands[side][grip]
        assert moved[0] > 0.04, f"{side} hand did not follow the pull ({moved[0]:.3f} m)"
    assert arrays["q"][:, 6].min() > 0.6
    assert np.all(arrays["fault/taskForce"] == 0) and np.all(arrays["fault/taskForceLH"] == 0)


def test_artefacts(case_study):
    _, out_dir = case_study
    for name in (
        "walk_then_interact.svg",
        "walk_then_interact.png",
        "walk_then_interact.npz",
        "walk_then_interact_hands.png",
    ):
        assert (out_dir / name).stat().st_size > 1000, name


def test_no_joint_passes_its_position_or_velocity_limit(case_study):
    """Joint position and velocity limits on top of the stack (solver "hqp") through the walk, the
    switch of tasks and the partner's pulls, measured on the plant."""
    output, _ = case_study
    excess = limit_excess(output.setup.built, output.arrays)
    assert excess.position < 1e-3, f"{excess.position_joint} {excess.position:.4f} rad past its limit"
    assert excess.velocity < 1e-3, f"{excess.velocity_joint} {excess.velocity:.4f} rad/s past its limit"
    # The reference stays the margin (0.02 rad) inside: the plant alone would not tell (Drake's
    # discrete plant holds a joint at its limit; without the limit tasks reach's reference went
    # 0.079 rad past chest_pitch's while the plant stayed within 3e-8 rad of it).
    assert excess.reference <= -0.02 + 1e-9, f"reference {excess.reference_joint} {excess.reference:.4f}"
