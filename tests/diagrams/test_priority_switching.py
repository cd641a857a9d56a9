"""priority_switching in physics (fixed base, torque control): the priority swap shows in the errors."""

import numpy as np
import pytest

from drake_sot.diagrams import priority_switching as ps
from drake_sot.diagrams.scenario import run_scenario


@pytest.fixture(scope="module")
def switched(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("ps")
    output = run_scenario(ps.SCENARIO, out_dir, record=False)
    assert output.result.completed, output.result.failure
    return output, out_dir


def _mean(arrays, errors, start, end):
    t = arrays["time"]
    window = (t >= start) & (t <= end)
    return {name: float(np.mean(e[window])) for name, e in errors.items()}


def test_the_task_with_priority_has_the_smaller_steady_error(switched):
    output, _ = switched
    arrays = output.arrays
    errors = ps.task_errors(arrays)
    before = _mean(arrays, errors, ps.SWITCH_AT - 1.0, ps.SWITCH_AT)
    after = _mean(arrays, errors, ps.DURATION - 1.5, ps.DURATION)
    # Before: the left hand has priority over the head; after: the head over the left hand.
    assert before["taskLH"] < 0.5 * before["taskHead"]
    assert after["taskHead"] < 0.5 * after["taskLH"]
    assert before["taskHead"] > 0.01  # a real conflict: the head had to give way by centimetres
    assert np.all(arrays["status"] == 0)  # the QP was feasible throughout


def test_alphas_follow_the_smooth_profile(switched):
    output, _ = switched
    arrays = output.arrays
    n = len(ps.TASKS)
    alpha = arrays["alpha"].reshape(-1, n, n)
    head, lh = ps.TASKS.index("taskHead"), ps.TASKS.index("taskLH")
    t = arrays["time"]
    s = np.clip((t - ps.SWITCH_AT) / ps.SWITCH_DURATION, 0.0, 1.0)
    np.testing.assert_allclose(alpha[:, lh, head], 0.5 - 0.5 * np.cos(np.pi * s), atol=1e-12)  # eq. 12
    np.testing.assert_allclose(alpha[:, head, lh] + alpha[:, lh, head], 1.0, atol=1e-12)


def test_figure_10_is_written(switched):
    _, out_dir = switched
    assert (out_dir / "priority_switching_errors.png").stat().st_size > 1000
