"""Steps decided from the hands' error in the waist frame (Evrard et al. 2009, III-D)."""

import math

import numpy as np
import pytest

from drake_sot.footsteps import Footstep, StepLimits
from drake_sot.hand_steps import HandStepRule, hand_error

LEFT, RIGHT = Footstep(0.0, 0.095, 0.0, "left"), Footstep(0.0, -0.095, 0.0, "right")
RULE = HandStepRule(reference=(0.35, 0.0), threshold=0.05)


def _hands(mid_xy, z=0.9, half_width=0.2, yaw=0.0):
    lateral = np.array([-math.sin(yaw), math.cos(yaw)]) * half_width
    mid = np.asarray(mid_xy, dtype=float)
    return np.r_[mid - lateral, z, mid + lateral, z]


def _walk(rule, hands, left, right, n=60):
    """Footprints decided one by one until none is: (errors before each step, steps)."""
    feet, last, errors, steps = {"left": left, "right": right}, None, [], []
    for _ in range(n):
        errors.append(np.linalg.norm(rule.error(hands, feet["left"], feet["right"])))
        step = rule.next_footprint(hands, feet["left"], feet["right"], last)
        if step is None:
            return errors, steps, feet
        rule.limits.check(feet["left" if step.side == "right" else "right"], step)  # bounds respected
        steps.append(step)
        feet[step.side], last = step, step.side
    raise AssertionError(f"no convergence in {n} steps; errors {errors[-5:]}")


def test_the_error_is_the_hands_midpoint_in_the_waist_frame_minus_the_reference():
    left, right = Footstep(1.0, 2.1, math.pi / 2, "left"), Footstep(1.2, 2.1, math.pi / 2, "right")
    # Waist at (1.1, 2.1) facing +y: a point 0.5 m further in +y is 0.5 m forward.
    e = hand_error(_hands([1.1, 2.6], yaw=math.pi / 2), left, right, np.array([0.35, 0.0]))
    np.testing.assert_allclose(e, [0.15, 0.0], atol=1e-12)


@pytest.mark.parametrize("seed", range(20))
def test_no_step_while_the_error_is_below_the_threshold(seed):
    rng = np.random.default_rng(seed)
    radius = rng.uniform(0, 0.999 * RULE.threshold)
    angle = rng.uniform(-math.pi, math.pi)
    mid = np.array(RULE.reference) + radius * np.array([math.cos(angle), math.sin(angle)])
    assert RULE.next_footprint(_hands(mid), LEFT, RIGHT, None) is None
    assert RULE.next_footprint(_hands(mid), LEFT, RIGHT, "left") is None


@pytest.mark.parametrize(
    "target",
    [(2.35, 0.0), (0.35, -0.5), (2.35, -0.5), (-0.6, 0.3), (1.0, 1.0), (0.37, 0.3)],
)
def test_each_step_reduces_the_error_within_the_limits_until_below_the_threshold(target):
    errors, steps, feet = _walk(RULE, _hands(target), LEFT, RIGHT)
    assert len(steps) > 0
    assert np.all(np.diff(errors) < 0)  # every step reduces the error
    assert errors[-1] < RULE.threshold
    # The stance ends where the hands are at the reference, within the threshold.
    mid = 0.5 * (feet["left"].xy + feet["right"].xy)
    assert np.linalg.norm(np.asarray(target) - np.array(RULE.reference) - mid) < RULE.threshold


def test_two_metres_ahead_is_walked_forward_in_strides_within_the_limit():
    limits = StepLimits(max_stride=0.25)
    rule = HandStepRule(reference=(0.35, 0.0), threshold=0.05, limits=limits)
    _, steps, _ = _walk(rule, _hands([2.35, 0.0]), LEFT, RIGHT)
    x = [s.x for s in steps]
    assert np.all(np.diff(x) >= -1e-12)  # always forward
    # Strides of at most 0.25 m from the other foot: the 2 m take at least 2 / 0.25 = 8 steps.
    assert len(steps) >= 8
    assert {s.side for s in steps} == {"left", "right"}


def test_a_sideways_error_starts_with_the_foot_on_its_side():
    step = RULE.next_footprint(_hands([0.35, -0.5]), LEFT, RIGHT, None)
    assert step.side == "right" and step.y < RIGHT.y


def test_bad_rules_are_refused_by_name():
    with pytest.raises(ValueError, match="threshold"):
        HandStepRule(threshold=0.0)
    with pytest.raises(ValueError, match="reference"):
        HandStepRule(reference=(float("nan"), 0.0))
