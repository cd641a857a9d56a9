"""priority_switching in physics (fixed base, torque control): the priority swap shows in the errors."""

import numpy as np
import pytest

from drake_sot.diagrams import priority_switching as ps
from drake_sot.diagrams.run import simulate
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.transitions import AlphaSchedule


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
    assert np.all(arrays["status"] == 0)  # optimal throughout, no task short of its wrench


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


def test_the_order_of_the_motion_tasks_changes_nothing():
    """Priorities are matched by name: the same scenario with the tasks handed to the
    controller in another order gives the same torques, motion and errors (by name)."""
    runs = []
    for order in (ps.TASKS, tuple(reversed(ps.TASKS))):
        alpha = AlphaSchedule(list(ps.TASKS), ps.initial_alpha())
        alpha.switch("taskHead", "taskLH", start=0.3, duration=0.4)  # a switch within the run
        setup = ps.build_with(alpha, duration=1.0, motion_order=order)
        simulator = setup.built.create_simulator()
        assert simulate(simulator, 1.0).completed
        context = simulator.get_context()
        loggers = setup.built.loggers
        errors = loggers["errors"].FindLog(context).data()
        runs.append(
            (
                loggers["tau"].FindLog(context).data(),
                loggers["state"].FindLog(context).data(),
                {name: errors[sl] for name, sl in setup.built.error_slices().items()},
                setup.built.error_slices(),
            )
        )
    (tau_a, x_a, e_a, slices_a), (tau_b, x_b, e_b, slices_b) = runs
    assert slices_a["taskJL"] != slices_b["taskJL"]  # the layouts do differ
    assert np.abs(tau_a).max() > 1.0  # the arm really moves
    np.testing.assert_allclose(tau_b, tau_a, atol=1e-6)
    np.testing.assert_allclose(x_b, x_a, atol=1e-9)
    for name in ps.TASKS:
        np.testing.assert_allclose(e_b[name], e_a[name], atol=1e-9)
