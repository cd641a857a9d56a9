"""Tests of drake_sot.task_wrenches (Liu, Lober, Padois 2016, eq. 2-3) against hand computations
and closed loops: errors are current minus desired (the module's one sign convention)."""

from __future__ import annotations

import numpy as np
import pytest

from drake_sot.task_wrenches import pd_wrench, pi_force_wrench

# -------------------------------------------------------------------------------------------
# eq. 2
# -------------------------------------------------------------------------------------------


def test_pd_wrench_with_scalar_vector_and_matrix_gains() -> None:
    e, edot = np.array([1.0, -2.0, 0.5]), np.array([0.1, 0.0, -1.0])
    # scalar: -(10 e + 2 edot)
    np.testing.assert_allclose(pd_wrench(e, edot, 10.0, 2.0), [-10.2, 20.0, -3.0])
    # diagonal: -((10, 20, 30) e + (1, 2, 3) edot) = -(10.1, -40, 12)
    np.testing.assert_allclose(pd_wrench(e, edot, [10.0, 20.0, 30.0], [1.0, 2.0, 3.0]), [-10.1, 40.0, -12.0])
    # matrix K_P = [[2, 1, 0], [1, 2, 0], [0, 0, 4]]: K_P e = (0, -3, 2); K_D = 0
    kp = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 4.0]])
    np.testing.assert_allclose(pd_wrench(e, edot, kp, 0.0), [0.0, 3.0, -2.0])


def test_pd_wrench_drives_a_unit_mass_to_its_goal() -> None:
    """A unit mass at s = 0.2 with its goal at 0.5, pushed by w = pd_wrench(s - s*, v): it must
    settle on the goal (with the opposite sign it would run away)."""
    s, v, goal, dt = 0.2, 0.0, 0.5, 1e-3
    for _ in range(5000):
        w = pd_wrench(np.array([s - goal]), np.array([v]), 100.0, 20.0)[0]
        v += w * dt
        s += v * dt
    assert s == pytest.approx(goal, abs=1e-6)
    # the first push is toward the goal: +k_p (s* - s)
    assert pd_wrench(np.array([0.2 - goal]), np.zeros(1), 100.0, 0.0)[0] == pytest.approx(30.0)


@pytest.mark.parametrize(
    "args, match",
    [
        ((np.ones(3), np.ones(2), 1.0, 1.0), r"error_rate must have shape \(3,\), got shape \(2,\)"),
        ((np.ones((3, 1)), np.ones(3), 1.0, 1.0), r"error must have shape \(n,\)"),
        ((np.array([np.nan, 0.0]), np.ones(2), 1.0, 1.0), r"error = .*contains NaN"),
        (
            (np.ones(2), np.ones(2), [1.0, 2.0, 3.0], 1.0),
            r"kp must be a scalar, a \(2,\) vector or a \(2, 2\) matrix",
        ),
        ((np.ones(2), np.ones(2), 1.0, -1.0), r"kd = -1.0: must be >= 0"),
        ((np.ones(2), np.ones(2), 1.0, np.nan), r"kd = nan: contains NaN"),
        ((np.ones(2), np.ones(2), np.array([[1.0, 2.0], [0.0, 1.0]]), 1.0), r"kp must be a symmetric"),
        (
            (np.ones(2), np.ones(2), np.array([[1.0, 2.0], [2.0, 1.0]]), 1.0),
            r"kp must be positive semidefinite",
        ),
        ((np.ones(2), np.ones(2), np.inf, 1.0), r"kp = inf: contains NaN or Inf"),
    ],
)
def test_pd_wrench_validation(args, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        pd_wrench(*args)


# -------------------------------------------------------------------------------------------
# eq. 3
# -------------------------------------------------------------------------------------------


def test_pi_force_wrench_by_hand() -> None:
    """w = w* - 2 e_w - 10 I with e_w = measured - w*, I += e_w dt, dt = 0.1, w* = 30 N."""
    integral = np.zeros(1)
    expected = (
        (20.0, -1.0, 60.0),  # e = -10, I = -1: 30 + 20 + 10
        (25.0, -1.5, 55.0),  # e = -5, I = -1.5: 30 + 10 + 15
        (40.0, -0.5, 15.0),  # e = 10, I = -0.5: 30 - 20 + 5
    )
    for measured, i_after, w in expected:
        step = pi_force_wrench([30.0], [measured], integral, 0.1, 2.0, 10.0)
        np.testing.assert_allclose(step.error, [measured - 30.0])
        np.testing.assert_allclose(step.integral, [i_after])
        np.testing.assert_allclose(step.wrench, [w])
        integral = step.integral
    assert pi_force_wrench([30.0], [30.0], np.zeros(1), 0.1, 2.0, 10.0).wrench == pytest.approx([30.0])


def test_pi_with_matrix_and_vector_gains() -> None:
    ki = np.array([[2.0, 1.0], [1.0, 2.0]])
    step = pi_force_wrench([1.0, 0.0], [0.0, 1.0], np.zeros(2), 0.5, [1.0, 3.0], ki)
    # e = (-1, 1), I = (-0.5, 0.5), K_I I = (-0.5, 0.5): w = w* - (-1, 3) - (-0.5, 0.5)
    np.testing.assert_allclose(step.wrench, [1.0 + 1.0 + 0.5, 0.0 - 3.0 - 0.5])


def test_pi_force_loop_settles_on_the_desired_force() -> None:
    """A first-order environment (the measured force follows the commanded wrench with a
    time constant of 25 ms) under table_pounding's gains: the force settles on w* = 30 N."""
    integral, measured, dt = np.zeros(1), np.zeros(1), 0.005
    for _ in range(2000):
        step = pi_force_wrench([30.0], measured, integral, dt, 0.5, 4.0)
        integral = step.integral
        measured = measured + dt / 0.025 * (step.wrench - measured)
    assert measured[0] == pytest.approx(30.0, abs=1e-6)


def test_anti_windup_integrates_in_proportion_to_the_activity() -> None:
    """A deactivated task (activity 0: alpha_ii = 1) keeps its integral; half active, half rate."""
    e = np.array([5.0, -2.0])  # measured - desired
    for activity, expected in ((0.0, [0.0, 0.0]), (0.5, [0.25, -0.1]), (1.0, [0.5, -0.2])):
        integral = np.zeros(2)
        for _ in range(10):
            integral = pi_force_wrench(np.zeros(2), e, integral, 0.01, 0.0, 1.0, activity=activity).integral
        np.testing.assert_allclose(integral, expected)  # 10 steps of activity · e · 0.01
    # Per row: two tasks stacked in one call, one off and one on.
    step = pi_force_wrench(np.zeros(2), e, np.zeros(2), 0.01, 0.0, 1.0, activity=[0.0, 1.0])
    np.testing.assert_allclose(step.integral, [0.0, -0.02])


def test_pi_step_validation() -> None:
    with pytest.raises(ValueError, match=r"w_measured must have shape \(2,\), got shape \(3,\)"):
        pi_force_wrench(np.zeros(2), np.zeros(3), np.zeros(2), 0.1, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"w_des = .*contains NaN"):
        pi_force_wrench([np.nan, 0.0], np.zeros(2), np.zeros(2), 0.1, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"dt = 0.0 s: must be finite and > 0"):
        pi_force_wrench(np.zeros(2), np.zeros(2), np.zeros(2), 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"activity = \[1.5 1.5\]: every value must be in \[0, 1\]"):
        pi_force_wrench(np.zeros(2), np.zeros(2), np.zeros(2), 0.1, 1.0, 1.0, activity=1.5)
    with pytest.raises(ValueError, match=r"activity = \[nan nan\]"):
        pi_force_wrench(np.zeros(2), np.zeros(2), np.zeros(2), 0.1, 1.0, 1.0, activity=np.nan)
    with pytest.raises(ValueError, match=r"activity must be a scalar or 2 values, got 3"):
        pi_force_wrench(np.zeros(2), np.zeros(2), np.zeros(2), 0.1, 1.0, 1.0, activity=[1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"ki = -1.0: must be >= 0"):
        pi_force_wrench(np.zeros(2), np.zeros(2), np.zeros(2), 0.1, 1.0, -1.0)
    with pytest.raises(ValueError, match=r"integral must have shape \(2,\)"):
        pi_force_wrench(np.zeros(2), np.zeros(2), np.zeros(1), 0.1, 1.0, 1.0)
