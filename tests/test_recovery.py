"""drake_sot.recovery: the DCM's excess over a polygon, the longest swing that still captures
the DCM (against a numerical integration of the LIPM), and the hip strategy's lean."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from drake_sot.footsteps import WALKING_BOUNDS, StepLimits
from drake_sot.models.humanoid import SOLE
from drake_sot.recovery import LeanProfile, dcm_excess, lean_axis, longest_capturing_swing

SQUARE = np.array([[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]])


@pytest.mark.parametrize(
    ("dcm", "excess"),
    [
        ((0.05, -0.02), (0.0, 0.0)),
        ((0.3, 0.05), (0.2, 0.0)),
        ((0.2, -0.25), (0.1, -0.15)),
        ((0.0, 0.1), (0, 0)),
    ],
)
def test_the_excess_is_the_way_out_of_the_polygon(dcm, excess):
    np.testing.assert_allclose(dcm_excess(SQUARE, dcm), excess, atol=1e-12)


def _escape_time(dcm: float, stance_zmp: float, reach: float, omega: float) -> float:
    """When ξ̇ = ω (ξ − p), integrated numerically from ``dcm``, reaches ``reach`` [s]."""

    def reached(t, xi):
        return xi[0] - reach

    reached.terminal = True
    sol = solve_ivp(
        lambda t, xi: omega * (xi - stance_zmp), (0.0, 10.0), [dcm], events=reached, rtol=1e-10, atol=1e-12
    )
    return float(sol.t_events[0][0])


@pytest.mark.parametrize(
    ("dcm", "stance_zmp", "reach"), [(0.17, -0.04, 0.31), (0.05, 0.0, 0.4), (-0.1, 0.1, -0.3)]
)
def test_the_longest_capturing_swing_is_when_the_dcm_runs_out_of_reach(dcm, stance_zmp, reach):
    omega = 3.49
    expected = (  # the negative side integrated as its mirror image
        _escape_time(dcm, stance_zmp, reach, omega)
        if dcm > stance_zmp
        else _escape_time(-dcm, -stance_zmp, -reach, omega)
    )
    assert longest_capturing_swing(dcm, stance_zmp, reach, omega) == pytest.approx(expected, rel=1e-6)


def test_a_dcm_already_out_of_reach_is_not_captured_and_bad_values_are_refused():
    assert longest_capturing_swing(0.5, 0.0, 0.4, 3.5) == 0.0
    assert longest_capturing_swing(-0.1, 0.0, 0.4, 3.5) == 0.0  # the reach is on the other side
    with pytest.raises(ValueError, match="dcm = 0.1 m: equal to stance_zmp"):
        longest_capturing_swing(0.1, 0.1, 0.4, 3.5)
    with pytest.raises(ValueError, match="omega = 0.0 1/s"):
        longest_capturing_swing(0.1, 0.0, 0.4, 0.0)
    with pytest.raises(ValueError, match="reach = nan"):
        longest_capturing_swing(0.1, 0.0, float("nan"), 3.5)


def test_a_350_N_torso_push_standing_cannot_be_captured_by_a_step_the_walk_allows():
    """The numbers of the module's docstring, from the robot's geometry: feet 0.19 m apart,
    the DCM 0.17 m out after the push (35 N·s over 57.8 kg and ω), the stance ZMP at the right
    sole's inner edge less the stabilizer's 1 cm margin, the left sole landing at the widest
    step from the right one."""
    half_width = 0.095
    omega = math.sqrt(9.81 / 0.8066)
    dcm = 35.0 / 57.8 / omega
    assert dcm == pytest.approx(0.17, abs=0.005)
    stance_zmp = -half_width + SOLE[1] / 2 + 0.01
    reach = -half_width + StepLimits().max_width + SOLE[1] / 2 - 0.01
    swing = longest_capturing_swing(dcm, stance_zmp, reach, omega)
    assert 0.1 < swing < WALKING_BOUNDS.single_support.low


def test_the_lean_rises_holds_and_comes_back_smoothly():
    profile = LeanProfile(angle=0.3, rise=0.2, hold=0.5, back=1.0)
    assert profile.duration == pytest.approx(1.7)
    assert profile.at(0.0) == (0.0, 0.0)
    assert profile.at(0.1)[0] == pytest.approx(0.15)  # the quintic is symmetric
    assert profile.at(0.2) == (0.3, 0.0) and profile.at(0.6) == (0.3, 0.0)
    assert profile.at(0.7 + 0.5)[0] == pytest.approx(0.15)
    assert profile.at(1.7) == (0.0, 0.0) and profile.at(5.0) == (0.0, 0.0)
    h = 1e-6
    for t in (0.03, 0.1, 0.17, 0.9, 1.2, 1.6):
        rate = (profile.at(t + h)[0] - profile.at(t - h)[0]) / (2 * h)
        assert profile.at(t)[1] == pytest.approx(rate, rel=1e-5, abs=1e-9), t
    # the peak rate of a quintic over T: 1.875 angle / T
    assert max(profile.at(t)[1] for t in np.linspace(0, 0.2, 201)) == pytest.approx(
        1.875 * 0.3 / 0.2, rel=1e-4
    )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"angle": 0.0}, "angle = 0.0 rad: must be > 0"),
        ({"angle": 2.0}, "angle = 2.0 rad: must be in"),
        ({"rise": float("nan")}, "rise = nan s"),
        ({"hold": -1.0}, "hold = -1.0 s"),
        ({"threshold": -0.01}, "threshold = -0.01 m"),
    ],
)
def test_a_bad_lean_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        LeanProfile(**kwargs)


@pytest.mark.parametrize("direction", [(0.0, 1.0), (0.0, -2.0), (1.0, 1.0), (-0.3, 0.1)])
def test_a_positive_rotation_about_the_lean_axis_moves_the_top_along_the_direction(direction):
    axis = lean_axis(np.array(direction))
    top = Rotation.from_rotvec(0.2 * axis).apply([0.0, 0.0, 1.0])
    d = np.array(direction) / np.hypot(*direction)
    np.testing.assert_allclose(top[:2], math.sin(0.2) * d, atol=1e-12)
    with pytest.raises(ValueError, match="direction"):
        lean_axis(np.zeros(2))
