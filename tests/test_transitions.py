"""Tests of drake_sot.transitions: eq. 12's profile, the alpha(t) schedule and named priorities
(Liu, Lober, Padois 2016)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot.transitions import AlphaSchedule, AlphaTransition, Priorities, smooth_step

SETTINGS = settings(max_examples=100, deadline=None)

# -------------------------------------------------------------------------------------------
# smooth_step
# -------------------------------------------------------------------------------------------


def test_profile_values() -> None:
    """0.5 - 0.5 cos(pi u) by hand: u = 0, 1/3, 1/2, 2/3, 1 -> 0, 1/4, 1/2, 3/4, 1; clamped outside."""
    t1, t2 = 2.0, 5.0
    for t, expected in [
        (-1.0, 0.0),
        (2.0, 0.0),
        (3.0, 0.25),
        (3.5, 0.5),
        (4.0, 0.75),
        (5.0, 1.0),
        (9.0, 1.0),
    ]:
        assert smooth_step(t, t1, t2) == pytest.approx(expected, abs=1e-15)
        assert isinstance(smooth_step(t, t1, t2), float)
    ts = np.array([[-1.0, 2.0, 3.0], [3.5, 4.0, 9.0]])
    np.testing.assert_allclose(smooth_step(ts, t1, t2), [[0.0, 0.0, 0.25], [0.5, 0.75, 1.0]], atol=1e-15)


def test_zero_slope_at_both_ends_and_pi_over_two_t_in_the_middle() -> None:
    t1, t2, h = 1.0, 1.6, 1e-6
    for t in (t1, t2):
        slope_left = (smooth_step(t, t1, t2) - smooth_step(t - h, t1, t2)) / h
        slope_right = (smooth_step(t + h, t1, t2) - smooth_step(t, t1, t2)) / h
        assert abs(slope_left) < 1e-4 and abs(slope_right) < 1e-4  # O(h) for a zero slope
    mid = 0.5 * (t1 + t2)
    slope = (smooth_step(mid + h, t1, t2) - smooth_step(mid - h, t1, t2)) / (2 * h)
    assert slope == pytest.approx(math.pi / (2 * (t2 - t1)), rel=1e-6)


@SETTINGS
@given(st.floats(-10, 10), st.floats(0.0, 5.0), st.floats(-20, 20))
def test_scalar_and_array_agree_and_stay_in_zero_one(t1: float, duration: float, t: float) -> None:
    t2 = t1 + duration
    s = smooth_step(t, t1, t2)
    assert 0.0 <= s <= 1.0
    assert smooth_step(np.array([t]), t1, t2)[0] == pytest.approx(s, abs=1e-15)
    assert smooth_step(t, t1, t2) <= smooth_step(t + 0.1, t1, t2)  # non-decreasing


def test_zero_duration_is_a_step_at_t1() -> None:
    assert smooth_step(0.999, 1.0, 1.0) == 0.0
    assert smooth_step(1.0, 1.0, 1.0) == 1.0
    np.testing.assert_array_equal(smooth_step(np.array([0.5, 1.0, 2.0]), 1.0, 1.0), [0.0, 1.0, 1.0])


@pytest.mark.parametrize(
    "args, match",
    [
        ((0.0, 2.0, 1.0), r"t2 >= t1, got t1 = 2.0, t2 = 1.0"),
        ((0.0, np.nan, 1.0), r"t1 = nan: must be a finite number"),
        ((np.inf, 0.0, 1.0), r"t = inf: must be a finite number"),
        ((np.array([0.0, np.nan]), 0.0, 1.0), r"t contains NaN"),
    ],
)
def test_smooth_step_validation(args, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        smooth_step(*args)


# -------------------------------------------------------------------------------------------
# AlphaSchedule
# -------------------------------------------------------------------------------------------

NAMES = ["com", "lh", "lhf", "posture"]


def schedule() -> AlphaSchedule:
    """CoM above all, posture below all, lh above lhf, lhf deactivated (alpha_ii = 1)."""
    alpha = np.zeros((4, 4))
    alpha[1:, 0] = 1.0  # everything under the CoM
    alpha[3, :3] = 1.0  # posture under everything
    alpha[2, 1] = 1.0  # lhf under lh
    alpha[2, 2] = 1.0  # lhf deactivated
    return AlphaSchedule(NAMES, alpha)


def test_initial_values_hold_without_transitions() -> None:
    s = schedule()
    np.testing.assert_array_equal(s.at(0.0), s.initial)
    np.testing.assert_array_equal(s.at(1e6), s.initial)
    assert s.alpha(3.0, "lhf", "lh") == 1.0 and s.end_time == -np.inf


def test_set_follows_eq_12_from_the_current_value() -> None:
    s = schedule()
    s.set("lhf", "lhf", 0.0, start=1.0, duration=0.6)  # activate the force task gradually
    assert s.alpha(0.5, "lhf", "lhf") == 1.0
    assert s.alpha(1.0, "lhf", "lhf") == 1.0
    assert s.alpha(1.3, "lhf", "lhf") == pytest.approx(0.5, abs=1e-15)
    assert s.alpha(1.45, 2, 2) == pytest.approx(1.0 - (0.5 - 0.5 * math.cos(math.pi * 0.45 / 0.6)), abs=1e-15)
    assert s.alpha(1.6, "lhf", "lhf") == 0.0 and s.alpha(10.0, "lhf", "lhf") == 0.0
    assert s.end_time == pytest.approx(1.6)


def test_switch_keeps_the_sum_and_swaps() -> None:
    s = schedule()
    s.switch(
        "lh", "lhf", start=2.0, duration=0.6
    )  # lhf rises above lh: alpha[lh, lhf] 0 -> 1, alpha[lhf, lh] 1 -> 0
    for t in np.linspace(1.5, 3.0, 61):
        a = s.at(t)
        assert a[1, 2] + a[2, 1] == pytest.approx(1.0, abs=1e-15)
    assert (s.alpha(1.9, "lh", "lhf"), s.alpha(1.9, "lhf", "lh")) == (0.0, 1.0)
    assert (s.alpha(2.6, "lh", "lhf"), s.alpha(2.6, "lhf", "lh")) == (1.0, 0.0)
    s.switch("lhf", "lh", start=4.0, duration=0.3)  # and back
    assert (s.alpha(4.3, "lh", "lhf"), s.alpha(4.3, "lhf", "lh")) == (0.0, 1.0)
    assert s.alpha(4.15, "lh", "lhf") == pytest.approx(0.5, abs=1e-12)


def test_many_pairs_at_once_match_their_own_profiles() -> None:
    s = schedule()
    s.set("lhf", "lhf", 0.0, start=1.0, duration=0.6)
    s.switch("lh", "lhf", start=1.2, duration=1.0)
    s.set("posture", "posture", 0.4, start=0.0, duration=2.0)
    s.set("com", "lh", 0.3, start=0.5, duration=0.0)
    t = 1.5
    expected = s.initial
    expected[2, 2] = 1.0 - smooth_step(t, 1.0, 1.6)
    expected[1, 2] = smooth_step(t, 1.2, 2.2)
    expected[2, 1] = 1.0 - smooth_step(t, 1.2, 2.2)
    expected[3, 3] = 0.4 * smooth_step(t, 0.0, 2.0)
    expected[0, 1] = 0.3
    np.testing.assert_allclose(s.at(t), expected, atol=1e-15)


def test_chained_transitions_are_continuous_and_smooth_when_not_overlapping() -> None:
    s = AlphaSchedule(["a", "b"], np.zeros((2, 2)))
    s.set("a", "b", 1.0, start=0.0, duration=1.0)
    s.set("a", "b", 0.2, start=1.5, duration=0.5)  # starts from 1.0
    s.set("a", "b", 0.6, start=1.75, duration=1.0)  # interrupts the previous one: from its value at 1.75
    assert s.transitions[1].start_value == 1.0
    assert s.transitions[2].start_value == pytest.approx(1.0 - 0.8 * 0.5, abs=1e-15)
    ts = np.linspace(-0.5, 3.5, 4001)
    values = np.array([s.alpha(t, "a", "b") for t in ts])
    assert np.abs(np.diff(values)).max() < 4e-3  # no jump (max slope pi/2 / 0.5 * 1e-3 per step)
    h = 1e-7
    for junction in (1.0, 1.5, 2.75):
        left = (s.alpha(junction, 0, 1) - s.alpha(junction - h, 0, 1)) / h
        right = (s.alpha(junction + h, 0, 1) - s.alpha(junction, 0, 1)) / h
        assert abs(left) < 1e-5 and abs(right) < 1e-5


def test_a_transition_at_the_same_start_replaces_the_previous_one() -> None:
    s = AlphaSchedule(["a", "b"], np.zeros((2, 2)))
    s.set("a", "b", 1.0, start=1.0, duration=1.0)
    s.set("a", "b", 0.5, start=1.0, duration=2.0)
    assert s.alpha(3.0, "a", "b") == 0.5 and s.at(3.0)[0, 1] == 0.5
    assert s.at(2.0)[0, 1] == pytest.approx(0.25, abs=1e-15)


@SETTINGS
@given(st.data())
def test_at_equals_the_scalar_evaluation(data: st.DataObject) -> None:
    n = data.draw(st.integers(1, 4))
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    s = AlphaSchedule([f"t{k}" for k in range(n)], rng.random((n, n)))
    starts = {}
    for _ in range(data.draw(st.integers(0, 12))):
        i, j = int(rng.integers(n)), int(rng.integers(n))
        start = starts.get((i, j), -1.0) + float(rng.choice([0.0, rng.uniform(0.0, 1.5)]))
        starts[(i, j)] = start
        s.set(
            i, j, float(rng.random()), start=start, duration=float(rng.choice([0.0, rng.uniform(0.0, 1.0)]))
        )
    for t in (
        list(rng.uniform(-2.0, 8.0, 20))
        + [tr.start for tr in s.transitions]
        + [tr.end for tr in s.transitions]
    ):
        scalar = np.array([[s.alpha(t, i, j) for j in range(n)] for i in range(n)])
        np.testing.assert_allclose(s.at(t), scalar, atol=1e-15)
        assert ((s.at(t) >= 0.0) & (s.at(t) <= 1.0)).all()


def test_validation() -> None:
    with pytest.raises(ValueError, match=r"repeated: 'a'"):
        AlphaSchedule(["a", "b", "a"], np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"expected \(2, 2\)"):
        AlphaSchedule(["a", "b"], np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"initial\[0, 1\] \(alpha of 'a' w.r.t. 'b'\) = 1.5"):
        AlphaSchedule(["a", "b"], np.array([[0.0, 1.5], [0.0, 0.0]]))
    with pytest.raises(ValueError, match=r"initial\[1, 0\]"):
        AlphaSchedule(["a", "b"], np.array([[0.0, 0.0], [np.nan, 0.0]]))
    s = AlphaSchedule(["a", "b"], np.array([[0.0, 0.0], [1.0, 0.0]]))
    with pytest.raises(ValueError, match=r"unknown task 'c'; known: a, b$"):
        s.set("a", "c", 1.0, start=0.0, duration=1.0)
    with pytest.raises(ValueError, match=r"task index 2 out of range"):
        s.alpha(0.0, 2, 0)
    with pytest.raises(ValueError, match=r"a task is a name or an index, got True"):
        s.alpha(0.0, True, 0)
    with pytest.raises(ValueError, match=r"alpha\['a', 'b'\] = 1.1 must be in \[0, 1\]"):
        s.set("a", "b", 1.1, start=0.0, duration=1.0)
    with pytest.raises(ValueError, match=r"duration = -1.0 s: must be finite and >= 0"):
        s.set("a", "b", 1.0, start=0.0, duration=-1.0)
    with pytest.raises(ValueError, match=r"start = nan: must be a finite number"):
        s.set("a", "b", 1.0, start=np.nan, duration=1.0)
    s.set("a", "b", 1.0, start=2.0, duration=1.0)
    with pytest.raises(ValueError, match=r"chronological order"):
        s.set("a", "b", 0.0, start=1.0, duration=1.0)
    with pytest.raises(ValueError, match=r"switch needs two different tasks"):
        s.switch("a", "a", start=5.0, duration=1.0)
    with pytest.raises(
        ValueError, match=r"alpha\[i, j\] = alpha\[j, i\] = 1.0, swapping them changes nothing"
    ):
        s.switch("a", "b", start=5.0, duration=1.0)
    with pytest.raises(ValueError, match=r"would precede it"):
        s.switch("b", "a", start=1.0, duration=1.0)
    assert len(s.transitions) == 1  # nothing half-scheduled by the refused switch
    with pytest.raises(ValueError, match=r"t = inf: must be a finite number"):
        s.at(np.inf)


def test_transitions_are_alpha_transitions() -> None:
    s = schedule()
    tr = s.set("lh", "lhf", 0.5, start=1.0, duration=2.0)
    assert isinstance(tr, AlphaTransition)
    assert s.transitions == (tr,)
    assert tr.at(2.0) == pytest.approx(0.25)  # halfway: 0 + 0.5 (0.5 - 0.5 cos(pi / 2))


# -------------------------------------------------------------------------------------------
# Priorities: alpha with its task names
# -------------------------------------------------------------------------------------------


def test_priorities_in_another_order_is_the_permuted_matrix() -> None:
    alpha = schedule().initial
    p = Priorities(tuple(NAMES), alpha)
    order = ["posture", "lhf", "com", "lh"]
    got = p.in_order(order)
    for a, i in enumerate(order):  # entry by entry, by name
        for b, j in enumerate(order):
            assert got[a, b] == alpha[NAMES.index(i), NAMES.index(j)]
    np.testing.assert_array_equal(p.in_order(NAMES), alpha)
    assert not p.alpha.flags.writeable  # the value on a port cannot be changed under a consumer


def test_schedule_gives_its_priorities_with_the_names() -> None:
    s = schedule()
    s.switch("lh", "lhf", start=0.0, duration=2.0)
    p = s.priorities(1.0)
    assert p.task_names == tuple(NAMES)
    np.testing.assert_array_equal(p.alpha, s.at(1.0))


@pytest.mark.parametrize(
    "order, match",
    [
        (["com", "lh", "lhf", "posture", "head"], r"no priority for task\(s\) \['head'\]"),
        (
            ["com", "lh", "posture"],
            r"priorities name unknown task\(s\) \['lhf'\]; known tasks: com, lh, posture",
        ),
        (["com", "lh", "lhf", "posture", "lh"], r"repeated task names"),
    ],
)
def test_priorities_refuse_names_that_do_not_match(order, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Priorities(tuple(NAMES), schedule().initial).in_order(order)


def test_priorities_validation() -> None:
    with pytest.raises(ValueError, match=r"repeated: 'a'"):
        Priorities(("a", "a"), np.zeros((2, 2)))
    with pytest.raises(TypeError, match=r"task_names\[1\] = 3 is not a string"):
        Priorities(("a", 3), np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"alpha has shape \(3, 3\) but there are 2 tasks"):
        Priorities(("a", "b"), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"alpha\[1, 0\] \(alpha of 'b' w.r.t. 'a'\) = nan"):
        Priorities(("a", "b"), np.array([[0.0, 0.0], [np.nan, 0.0]]))
