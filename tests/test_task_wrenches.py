"""Tests of drake_sot.task_wrenches (paper 004, eq. 2-3) against hand computations."""

from __future__ import annotations

import numpy as np
import pytest

from drake_sot.task_wrenches import PIForceController, pd_wrench

# -------------------------------------------------------------------------------------------
# eq. 2
# -------------------------------------------------------------------------------------------


def test_pd_wrench_with_scalar_vector_and_matrix_gains() -> None:
    e, edot = np.array([1.0, -2.0, 0.5]), np.array([0.1, 0.0, -1.0])
    # scalar: 10 e + 2 edot
    np.testing.assert_allclose(pd_wrench(e, edot, 10.0, 2.0), [10.2, -20.0, 3.0])
    # diagonal: (10, 20, 30) e + (1, 2, 3) edot = (10.1, -40, 12)
    np.testing.assert_allclose(pd_wrench(e, edot, [10.0, 20.0, 30.0], [1.0, 2.0, 3.0]), [10.1, -40.0, 12.0])
    # matrix K_P = [[2, 1, 0], [1, 2, 0], [0, 0, 4]]: K_P e = (0, -3, 2); K_D = 0
    kp = np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 4.0]])
    np.testing.assert_allclose(pd_wrench(e, edot, kp, 0.0), [0.0, -3.0, 2.0])


def test_pd_wrench_pulls_toward_the_goal_with_the_sot_error_negated() -> None:
    """The SoT features give e_sot = s - s*; with s below the goal the wrench must push up."""
    s, s_star, kp = np.array([0.2]), np.array([0.5]), 100.0
    e_sot = s - s_star
    w = pd_wrench(-e_sot, np.zeros(1), kp, 0.0)
    assert w[0] == pytest.approx(30.0)
    # and it damps the motion: moving up at 1 m/s with a fixed goal, edot = -ds/dt
    assert pd_wrench(np.zeros(1), -np.array([1.0]), 0.0, 5.0)[0] == pytest.approx(-5.0)


@pytest.mark.parametrize(
    "args, match",
    [
        ((np.ones(3), np.ones(2), 1.0, 1.0), r"error_rate must have shape \(3,\), got \(2,\)"),
        ((np.ones((3, 1)), np.ones(3), 1.0, 1.0), r"error must have shape a vector"),
        ((np.array([np.nan, 0.0]), np.ones(2), 1.0, 1.0), r"error of shape \(2,\) contains NaN"),
        (
            (np.ones(2), np.ones(2), [1.0, 2.0, 3.0], 1.0),
            r"kp must be a scalar, a \(2,\) vector or a \(2, 2\) matrix",
        ),
        ((np.ones(2), np.ones(2), 1.0, -1.0), r"kd = -1.0 must be >= 0"),
        ((np.ones(2), np.ones(2), np.array([[1.0, 2.0], [0.0, 1.0]]), 1.0), r"kp must be a symmetric"),
        (
            (np.ones(2), np.ones(2), np.array([[1.0, 2.0], [2.0, 1.0]]), 1.0),
            r"kp must be positive semidefinite",
        ),
        ((np.ones(2), np.ones(2), np.inf, 1.0), r"kp contains NaN or Inf"),
    ],
)
def test_pd_wrench_validation(args, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        pd_wrench(*args)


# -------------------------------------------------------------------------------------------
# eq. 3
# -------------------------------------------------------------------------------------------


def test_pi_force_controller_by_hand() -> None:
    """w = w* + 2 e_w + 10 I with I += e_w dt, dt = 0.1, w* = 30 N."""
    pi = PIForceController(1, kp=2.0, ki=10.0)
    w = pi.step([30.0], [20.0], 0.1)  # e = 10, I = 1: 30 + 20 + 10
    assert w == pytest.approx([60.0])
    w = pi.step([30.0], [25.0], 0.1)  # e = 5, I = 1.5: 30 + 10 + 15
    assert w == pytest.approx([55.0])
    w = pi.step([30.0], [40.0], 0.1)  # e = -10, I = 0.5: 30 - 20 + 5
    assert w == pytest.approx([15.0])
    assert pi.integral == pytest.approx([0.5])
    pi.reset()
    assert pi.integral == pytest.approx([0.0])
    assert pi.step([30.0], [30.0], 0.1) == pytest.approx([30.0])  # feed-forward only at zero error


def test_pi_with_matrix_and_vector_gains() -> None:
    ki = np.array([[2.0, 1.0], [1.0, 2.0]])
    pi = PIForceController(2, kp=[1.0, 3.0], ki=ki)
    w = pi.step([1.0, 0.0], [0.0, 1.0], 0.5)  # e = (1, -1), I = (0.5, -0.5), K_I I = (0.5, -0.5)
    np.testing.assert_allclose(w, [1.0 + 1.0 + 0.5, 0.0 - 3.0 - 0.5])


def test_anti_windup_clamps_and_reports() -> None:
    pi = PIForceController(2, kp=0.0, ki=1.0, integral_limit=[1.0, 10.0])
    for _ in range(3):
        w = pi.step([0.0, 0.0], [-2.0, -2.0], 0.25)  # e = (2, 2): +0.5 per step
    np.testing.assert_allclose(pi.integral, [1.0, 1.5])  # first: 0.5, 1.0 (on the bound), 1.5 -> clamped to 1
    np.testing.assert_allclose(w, [1.0, 1.5])
    np.testing.assert_array_equal(pi.saturated, [True, False])
    assert pi.saturation_count == 1  # step 3 only: reaching the bound exactly is not clamping
    pi.step([0.0, 0.0], [2.0, 2.0], 0.25)  # e = -2: back inside, no clamp
    np.testing.assert_allclose(pi.integral, [0.5, 1.0])
    np.testing.assert_array_equal(pi.saturated, [False, False])
    assert pi.saturation_count == 1
    pi.reset()
    assert pi.saturation_count == 0 and not pi.saturated.any()


def test_without_limit_the_integral_is_never_clamped() -> None:
    pi = PIForceController(1, kp=0.0, ki=1.0)
    for _ in range(100):
        pi.step([1e3], [0.0], 1.0)
    assert pi.integral == pytest.approx([1e5]) and pi.saturation_count == 0 and pi.integral_limit is None


def test_reset_to_a_value() -> None:
    pi = PIForceController(2, kp=0.0, ki=1.0, integral_limit=2.0)
    pi.reset([1.0, -1.0])
    np.testing.assert_allclose(pi.step([0.0, 0.0], [0.0, 0.0], 0.1), [1.0, -1.0])
    with pytest.raises(ValueError, match=r"exceeds integral_limit"):
        pi.reset([3.0, 0.0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"dim": 0, "kp": 1.0, "ki": 1.0}, r"dim must be an integer >= 1, got 0"),
        ({"dim": 2, "kp": [1.0], "ki": 1.0}, r"kp must be a scalar, a \(2,\) vector"),
        ({"dim": 2, "kp": 1.0, "ki": -1.0}, r"ki = -1.0 must be >= 0"),
        (
            {"dim": 2, "kp": 1.0, "ki": 1.0, "integral_limit": 0.0},
            r"integral_limit = 0.0 must be finite and > 0",
        ),
        (
            {"dim": 2, "kp": 1.0, "ki": 1.0, "integral_limit": [1.0, 2.0, 3.0]},
            r"integral_limit must be a scalar or a \(2,\)",
        ),
    ],
)
def test_pi_construction_validation(kwargs, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        PIForceController(**kwargs)


def test_pi_step_validation() -> None:
    pi = PIForceController(2, kp=1.0, ki=1.0)
    with pytest.raises(ValueError, match=r"w_measured must have shape \(2,\), got \(3,\)"):
        pi.step(np.zeros(2), np.zeros(3), 0.1)
    with pytest.raises(ValueError, match=r"w_des of shape \(2,\) contains NaN"):
        pi.step([np.nan, 0.0], np.zeros(2), 0.1)
    with pytest.raises(ValueError, match=r"dt must be finite and > 0, got 0.0"):
        pi.step(np.zeros(2), np.zeros(2), 0.0)
    np.testing.assert_array_equal(pi.integral, [0.0, 0.0])  # a refused step changes nothing
