"""The random walk's rule: reproducible from its seed, every step within the step limits, a stop
in every period, and back towards home once beyond its radius."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drake_sot.footsteps import Footstep, StepLimits
from drake_sot.random_steps import RandomStepRule

LEFT, RIGHT = Footstep(0.0, 0.1, 0.0, "left"), Footstep(0.0, -0.1, 0.0, "right")


def _walk(rule: RandomStepRule, n: int, left=LEFT, right=RIGHT, time=0.0):
    feet, last, steps = {"left": left, "right": right}, None, []
    for _ in range(n):
        step = rule.next_footprint(feet["left"], feet["right"], last, time)
        feet[step.side], last = step, step.side
        steps.append(step)
    return steps


def test_the_same_seed_walks_the_same_steps_and_another_seed_others():
    a, b = _walk(RandomStepRule(7, 0.2), 50), _walk(RandomStepRule(7, 0.2), 50)
    assert a == b
    assert _walk(RandomStepRule(8, 0.2), 50) != a


def test_every_step_is_within_the_limits_and_the_feet_alternate():
    limits = StepLimits()
    for seed in range(20):
        steps = _walk(RandomStepRule(seed, 0.2, limits=limits), 200)
        feet = {"left": LEFT, "right": RIGHT}
        for step in steps:
            stance = feet["left" if step.side == "right" else "right"]
            limits.check(stance, step)  # raises naming the limit otherwise
            feet[step.side] = step
        assert [s.side for s in steps[:4]] == ["right", "left", "right", "left"]


def test_the_walk_stays_near_home():
    """Beyond the home radius the steps lead back: over long walks the feet' midpoint stays within
    the radius plus the few steps it takes to turn round (1 m)."""
    for seed in range(10):
        rule = RandomStepRule(seed, 0.2, home_radius=1.0)
        steps = _walk(rule, 600)
        far = max(math.hypot(s.x, s.y) for s in steps)
        assert far < rule.home_radius + 1.0, (seed, far)


def test_no_step_during_a_stop():
    rule = RandomStepRule(0, 0.2, pause_period=20.0, pause=4.0)
    for time in (16.0, 17.5, 19.99, 36.0, 399.0):
        assert rule.next_footprint(LEFT, RIGHT, None, time) is None, time
    for time in (0.0, 15.99, 20.0, 35.0):
        assert rule.next_footprint(LEFT, RIGHT, None, time) is not None, time


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"seed": -1}, "seed = -1"),
        ({"seed": 1.5}, "seed = 1.5"),
        ({"width": 0.05}, "width = 0.05"),
        ({"width": math.nan}, "width = nan"),
        ({"max_turn": -0.1}, "max_turn = -0.1"),
        ({"home_radius": 0.0}, "home_radius = 0"),
        ({"pause": 30.0}, "pause_period = 20.0 s: must exceed pause = 30.0 s"),
        ({"home": (0.0, np.inf)}, "home"),
    ],
)
def test_a_bad_value_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(".", r"\.")):
        RandomStepRule(**{"seed": 0, "width": 0.2, **kwargs})
