"""The measuring side of the studies on real runs: the metrics a worker returns agree with what
the physics and the control law say, computed independently."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drake_sot.diagrams.reach import RIGHT_HAND_OFFSET
from drake_sot.diagrams.study_runs import SETTLED, measure

pytestmark = pytest.mark.slow


def test_the_right_hand_settles_in_the_time_of_its_exponential_decay():
    """ė = -λ e: the hand's error, |offset| when the target moves, falls under SETTLED after
    ln(|offset| / SETTLED) / λ (the other tasks barely slow it: 15 %)."""
    for gain in (5.0, 10.0):
        metrics = measure("reach", {"rh_gain": gain}, 2.5, 0)
        expected = math.log(np.linalg.norm(RIGHT_HAND_OFFSET) / SETTLED) / gain
        assert metrics["rh_settle_time"] == pytest.approx(expected, rel=0.15), gain
        assert metrics["survived"] is True and math.isnan(metrics["fall_time"])


def test_a_hard_push_on_the_walk_is_a_fall_after_the_push_and_none_without():
    calm = measure("walk", {"push_force": 0.0}, 3.0, 0)
    assert calm["survived"] is True and math.isnan(calm["fall_time"])
    assert calm["min_pelvis_height"] > 0.5  # [m] the embedded humanoid's pelvis stands at ~0.65 m
    pushed = measure(
        "walk", {"push_force": 800.0, "push_direction": 90.0, "push_time": 2.3, "stabilizer": True}, 5.0, 0
    )
    assert pushed["survived"] is False
    assert 2.3 < pushed["fall_time"] < 5.0
    assert pushed["min_pelvis_height"] < 0.4  # the fall monitor's threshold: it lies on the ground


def test_a_push_after_the_end_and_an_undeclared_parameter_are_refused():
    with pytest.raises(ValueError, match="starts after the run's end"):
        measure("walk", {"push_force": 100.0, "push_time": 2.0}, 1.0, 0)
    with pytest.raises(
        ValueError, match="scenario 'reach': unknown parameter 'stabilizer'; known: push_direction"
    ):
        measure("reach", {"stabilizer": True}, 1.0, 0)
    with pytest.raises(KeyError, match="unknown study target 'nope'; known: priority_switching, reach, walk"):
        measure("nope", {}, 1.0, 0)
