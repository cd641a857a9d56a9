"""Tests of the strict hierarchy with inequalities, drake_sot.hqp.solve_hqp.

The reference is a cascade written here with scipy only (lstsq, null_space), exact up to
rounding: each level minimises its slack with the levels above held at their optimum, over
candidate solutions made by guessing, for every inequality row, whether it holds
strictly (dropped) or binds at its lower or upper bound (kept as an equality there). For
one guess, the candidate is the lexicographic least-squares solution of the equality
hierarchy so formed, of minimum norm. The true optimum is one of the candidates: with
the guess that matches it, each level's least-squares cost bounds its true slack
(``(a q̇ - bound)² >= dist(a q̇, [l, u])²``) and equals it at the optimum, so that
candidate is lexicographically at least as good as the optimum, hence the optimum (it
is unique, thanks to the last level, the norm of q̇). The cascade over candidates: keep
those whose level-1 slack is minimal, among them those whose level-2 slack is minimal,
and so on, then the smallest norm. It costs 3^(inequality rows) least-squares
hierarchies: the problems have at most 5 inequality rows.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import daqp
import numpy as np
import pytest
import scipy.linalg
from hypothesis import event, example, given, settings
from hypothesis import strategies as st
from random_hierarchies import Level3, random_hierarchy
from test_hierarchy import stacks

from drake_sot import hqp
from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import _inequalities_idle, solve_hqp

SETTINGS = settings(max_examples=120, deadline=None)


# --- the independent reference ----------------------------------------------------------


def equality_hierarchy(levels: list[tuple[np.ndarray, np.ndarray]], n: int) -> np.ndarray:
    """Lexicographic least squares of minimum norm (scipy lstsq and null_space, from scratch)."""
    x, N = np.zeros(n), np.eye(n)
    for A, t in levels:
        if not A.shape[0] or not N.shape[1]:
            continue
        B = A @ N
        if np.linalg.norm(B, 2) <= 1e-9:
            continue
        x = x + N @ scipy.linalg.lstsq(B, t - A @ x, cond=1e-9)[0]
        N = N @ scipy.linalg.null_space(B, rcond=1e-9)
    return x - N @ (N.T @ x)


def slacks(levels: list[Level3], x: np.ndarray) -> list[float]:
    """Per level, ||J x - clip(J x, l, u)||², then ||x||²: the lexicographic objective."""
    out = []
    for J, lo, hi in levels:
        v = J @ x
        out.append(float(np.sum((v - np.clip(v, lo, hi)) ** 2)))
    return out + [float(x @ x)]


def cascade(levels: list[Level3], n: int) -> np.ndarray:
    """The lexicographic optimum by a cascade over the candidates (module docstring)."""
    inequality_rows = [
        (k, i) for k, (_, lo, hi) in enumerate(levels) for i in range(lo.size) if lo[i] < hi[i]
    ]
    guesses = [
        [0] + ([1] if np.isfinite(levels[k][2][i]) else []) + ([-1] if np.isfinite(levels[k][1][i]) else [])
        for k, i in inequality_rows
    ]
    candidates = []
    for guess in itertools.product(*guesses):
        binds = dict(zip(inequality_rows, guess, strict=True))
        hierarchy = []
        for k, (J, lo, hi) in enumerate(levels):
            rows, targets = [], []
            for i in range(J.shape[0]):
                side = 2 if lo[i] == hi[i] else binds[(k, i)]
                if side:
                    rows.append(i)
                    targets.append(hi[i] if side in (1, 2) else lo[i])
            hierarchy.append((J[rows], np.array(targets)))
        x = equality_hierarchy(hierarchy, n)
        candidates.append((slacks(levels, x), x))
    for level in range(len(levels) + 1):  # each level keeps the candidates that minimise its slack
        best = min(f[level] for f, _ in candidates)
        candidates = [(f, x) for f, x in candidates if f[level] <= best + 1e-12 * (1.0 + best)]
    return candidates[0][1]


# --- random problems --------------------------------------------------------------------


@dataclass(frozen=True)
class Problem:
    levels: list[Level3]
    n: int


@st.composite
def problems(draw: st.DrawFn, max_inequalities: int = 5) -> Problem:
    """1-4 levels of 1-3 rows on 2-7 joints; each row an equality, a two-sided or a one-sided
    inequality; some rows repeat a row of a level above with other bounds (conflicts,
    parallel constraints); at most ``max_inequalities`` inequality rows in all."""
    n = draw(st.integers(2, 7))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    levels: list[Level3] = []
    inequalities = 0
    for _ in range(draw(st.integers(1, 4))):
        m = draw(st.integers(1, 3))
        J = rng.normal(size=(m, n))
        if levels and draw(st.booleans()):  # repeat a row from above
            J_src = levels[rng.integers(len(levels))][0]
            J[rng.integers(m)] = J_src[rng.integers(J_src.shape[0])]
        lo, hi = np.empty(m), np.empty(m)
        for i in range(m):
            kind = draw(st.sampled_from(["equality", "box", "above", "below"]))
            if kind != "equality" and inequalities >= max_inequalities:
                kind = "equality"
            centre, width = rng.uniform(-2.0, 2.0), rng.uniform(0.0, 2.0)
            lo[i], hi[i] = {
                "equality": (centre, centre),
                "box": (centre - width, centre + width),
                "above": (centre, np.inf),
                "below": (-np.inf, centre),
            }[kind]
            inequalities += kind != "equality"
        levels.append((J, lo, hi))
    return Problem(levels=levels, n=n)


def scale(x: np.ndarray) -> float:
    return 1.0 + float(np.linalg.norm(x))


# --- a) the lexicographic optimum ---------------------------------------------------------


@SETTINGS
@given(problems())
def test_equals_an_independent_cascade_of_exact_qps(problem):
    reference = cascade(problem.levels, problem.n)
    result = solve_hqp(problem.levels)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))
    # The reported slacks are those of the reference (each level's optimum).
    for k, (J, lo, hi) in enumerate(problem.levels):
        v = J @ reference
        np.testing.assert_allclose(result.levels[k].slack, v - np.clip(v, lo, hi), atol=1e-6 * scale(v))


@SETTINGS
@given(problems())
def test_a_lower_level_never_degrades_a_higher_one(problem):
    """Level k's slack is the same whether the levels below it are solved or not."""
    full = solve_hqp(problem.levels)
    for k in range(len(problem.levels)):
        alone = solve_hqp(problem.levels[: k + 1])
        tolerance = 1e-9 * (1.0 + alone.levels[k].violation) * scale(alone.qdot)
        for j in range(k + 1):
            assert full.levels[j].violation <= alone.levels[j].violation + tolerance, f"level {j} below {k}"
        assert full.levels[k].violation == pytest.approx(alone.levels[k].violation, abs=tolerance)


@settings(max_examples=150, deadline=None)
@given(stacks())
def test_equalities_only_give_solve_strict_minimum_norm_solution(stack):
    """With equalities only, q̇ is solve_strict's (minimum norm, no regularisation level needed)."""
    strict = solve_strict(stack.levels).qdot
    hqp = solve_hqp(stack.levels)
    np.testing.assert_allclose(hqp.qdot, strict, rtol=0.0, atol=1e-9 * scale(strict))
    # Minimum norm: no component in the null space of the augmented Jacobian.
    C = np.vstack([J for J, _ in stack.levels])
    N = scipy.linalg.null_space(C, rcond=1e-9) if np.linalg.norm(C) > 1e-9 else np.eye(stack.n)
    np.testing.assert_allclose(N.T @ hqp.qdot, 0.0, atol=1e-9 * scale(strict))
    # The same stack written as (J, lower, upper) with lower == upper.
    triples = solve_hqp([(J, e, e.copy()) for J, e in stack.levels]).qdot
    np.testing.assert_allclose(triples, strict, rtol=0.0, atol=1e-9 * scale(strict))


#: A problem whose lexicographic optimum the reference cascade once missed, when it took squared
#: slacks within 1e-9 for equal: a point that broke level 0 by a residual of 1.4e-5 (2e-10 squared)
#: to do 6e-6 better at level 2 passed for optimal there (now within 1e-12).
_LEVEL_0_BROKEN_BY_THE_REFERENCE = Problem(
    levels=[
        (
            np.array([[0.18125958, -0.14344662, 0.09868597, -0.24131027, -0.54483067, -1.64298797]]),
            np.array([-0.96503719]),
            np.array([-0.79804349]),
        ),
        (
            np.array(
                [
                    [-0.05790268, 1.21092288, -0.98385406, 1.52291835, 0.6952981, 1.19799177],
                    [0.89051425, -0.60480277, 1.88578053, -0.3920762, -1.51183979, -0.34830572],
                ]
            ),
            np.array([-1.02869879, -0.53213075]),
            np.array([1.55356052, 1.23311941]),
        ),
        (
            np.array(
                [
                    [0.18125958, -0.14344662, 0.09868597, -0.24131027, -0.54483067, -1.64298797],
                    [0.66374016, -0.39185169, 0.34315577, -0.30498445, 0.20141328, -0.28248469],
                ]
            ),
            np.array([-0.58064702, 1.08539447]),
            np.array([np.inf, 1.08539447]),
        ),
    ],
    n=6,
)


@settings(max_examples=300, deadline=None)
@given(problems())
@example(_LEVEL_0_BROKEN_BY_THE_REFERENCE)
def test_equality_levels_solved_together_equal_the_cascade(problem):
    """Consecutive levels of equalities given as ``(J, t, t)`` (as StackOfTasks gives them) are
    solved with one QR when each has full row rank in what is left; a rank-deficient level
    (a row repeated from above) or a step a hard row blocks falls back level by level. Either
    way: the cascade's optimum."""
    levels = [(J, hi, hi) if (lo == hi).all() else (J, lo, hi) for J, lo, hi in problem.levels]
    reference = cascade(problem.levels, problem.n)
    result = solve_hqp(levels)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))
    assert result.free_dims == solve_hqp(problem.levels).free_dims


def test_equality_levels_solved_together_below_a_box_that_blocks_the_second():
    """Three equality levels below a box on q̇: the first step fits, the second is blocked by
    the box (the run hands that level to the active set), the third has no freedom left."""
    rng = np.random.default_rng(11)
    n = 6
    box = (np.eye(n), -np.full(n, 0.5), np.full(n, 0.5))
    first = (rng.normal(size=(2, n)), 0.1 * rng.normal(size=2))
    second = (rng.normal(size=(3, n)), 10.0 * rng.normal(size=3))  # far beyond the box
    third = (rng.normal(size=(2, n)), rng.normal(size=2))
    levels = [box] + [(J, t, t) for J, t in (first, second, third)]
    reference = cascade([box] + [(J, t, t.copy()) for J, t in (first, second, third)], n)
    np.testing.assert_allclose(solve_hqp(levels).qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))
    assert np.abs(reference).max() == pytest.approx(0.5)  # the box binds: the test sees the blocked path


@st.composite
def idle_problems(draw: st.DrawFn) -> Problem:
    """2-4 levels on 4-7 joints, each all equalities (Gaussian rows, so of full rank: at most
    n - 1 rows above the last equality level, which may be tall) or all inequalities (at most
    5 rows in all) whose bounds hold, 0.01-2 away, at the equality levels' own hierarchy
    solution: the inequalities change nothing."""
    n = draw(st.integers(4, 7))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    kinds = draw(st.lists(st.sampled_from(["equality", "inequality"]), min_size=2, max_size=4))
    kinds[draw(st.integers(0, len(kinds) - 1))] = "equality"
    last = max(i for i, kind in enumerate(kinds) if kind == "equality")
    upper_equalities = kinds[:last].count("equality")  # each takes 1 to what the others leave
    rows_left, inequalities, levels = n - 1, 0, []
    for i, kind in enumerate(kinds):
        if kind == "equality":
            if i == last:
                m = draw(st.integers(1, n + 2))
            else:
                upper_equalities -= 1
                m = draw(st.integers(1, rows_left - upper_equalities))
                rows_left -= m
            t = rng.normal(size=m)
            levels.append((rng.normal(size=(m, n)), t, t.copy()))
        else:
            m = draw(st.integers(1, max(1, min(3, 5 - inequalities))))
            inequalities += m
            levels.append((rng.normal(size=(m, n)), np.zeros(m), np.zeros(m)))
    equality_levels = [(J, t) for (J, t, _), kind in zip(levels, kinds, strict=True) if kind == "equality"]
    at = solve_strict(equality_levels).qdot
    for i, kind in enumerate(kinds):
        if kind == "inequality":
            value = levels[i][0] @ at
            below, above = rng.uniform(0.01, 2.0, size=value.size), rng.uniform(0.01, 2.0, size=value.size)
            side = rng.integers(0, 3, size=value.size)  # 0: both bounds, 1: lower only, 2: upper only
            levels[i] = (
                levels[i][0],
                np.where(side == 2, -np.inf, value - below),
                np.where(side == 1, np.inf, value + above),
            )
    return Problem(levels=levels, n=n)


@SETTINGS
@given(idle_problems())
def test_inequalities_that_hold_at_the_equality_solution_take_the_shortcut(problem):
    """When every inequality row holds where the equality levels alone lead, solve_hqp returns
    that point without an active set (``_inequalities_idle``): it is the cascade's optimum,
    and ``solve_strict``'s q̇ of the equality levels to rounding."""
    equality_levels = [(J, hi) for J, lo, hi in problem.levels if (lo == hi).all()]
    strict = solve_strict(equality_levels).qdot
    assert _inequalities_idle([(J, lo, hi) for J, lo, hi in problem.levels], 1e-6) is not None
    result = solve_hqp(problem.levels)
    reference = cascade(problem.levels, problem.n)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))
    np.testing.assert_allclose(result.qdot, strict, rtol=0.0, atol=1e-9 * scale(strict))
    for report, (_, lo, hi) in zip(result.levels, problem.levels, strict=True):
        if (lo < hi).all():  # an inequality level: every row holds, none at a bound
            assert report.violation == 0.0 and report.active_lower == report.active_upper == ()


def test_an_inequality_broken_at_the_equality_solution_goes_to_the_active_set():
    """The shortcut declines when a row does not hold at the equality levels' solution, and
    the active set then gives the cascade's optimum (the bound binds)."""
    rng = np.random.default_rng(4)
    n = 5
    J, t = rng.normal(size=(3, n)), rng.normal(size=3)
    free = solve_strict([(J, t)]).qdot
    box = (np.eye(n), -np.full(n, 0.5) * np.abs(free).max(), np.full(n, 0.5) * np.abs(free).max())
    levels = [box, (J, t, t)]
    assert _inequalities_idle(levels, 1e-6) is None
    reference = cascade([box, (J, t, t.copy())], n)
    np.testing.assert_allclose(solve_hqp(levels).qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))
    assert np.abs(reference).max() == pytest.approx(0.5 * np.abs(free).max())


@settings(max_examples=100, deadline=None)
@given(stacks(), st.sampled_from([0.05, 0.5]))
def test_damped_equalities_give_solve_strict_s_damped_solution(stack, damping):
    """With equalities only and every level damped, q̇ is solve_strict's with the same damping (its
    levels' steps ``σ / (σ² + μ²)`` along each kept singular value, the null spaces unchanged)."""
    strict = solve_strict(stack.levels, damping=damping).qdot
    hqp_qdot = solve_hqp(stack.levels, damping=damping).qdot
    np.testing.assert_allclose(hqp_qdot, strict, rtol=0.0, atol=1e-9 * scale(strict))


# --- b) by hand ---------------------------------------------------------------------------


def test_a_velocity_bound_on_top_caps_a_task_below():
    # Level 1: -1 <= q̇ <= 1. Level 2: q̇ = 3. The task gets 1, its slack is 2, the bound binds.
    result = solve_hqp([(np.eye(1), [-1.0], [1.0]), (np.eye(1), [3.0])], names=["limits", "task"])
    np.testing.assert_allclose(result.qdot, [1.0], atol=1e-14)
    assert result.level("limits").active_upper == (0,) and result.level("limits").active_lower == ()
    np.testing.assert_allclose(result.level("task").slack, [-2.0], atol=1e-14)
    assert result.level("limits").violation == 0.0


def test_a_damped_level_below_a_bound_is_the_damped_least_squares_that_keeps_it():
    """Level 1: q̇₀ <= 0.1. Level 2: q̇₀ + q̇₁ = 1, damped by μ: min (q̇₀ + q̇₁ - 1)² + μ² ||q̇||²
    with q̇₀ <= 0.1. Without the bound its optimum is q̇₀ = q̇₁ = 1 / (2 + μ²) > 0.1, so the bound
    binds and q̇₁ minimises (q̇₁ - 0.9)² + μ² q̇₁²: 0.9 / (1 + μ²); undamped, 0.9. The same with
    μ given to every level (the bound's level holds where it starts: nothing to damp) or by name."""
    levels = [(np.array([[1.0, 0.0]]), [-np.inf], [0.1]), (np.array([[1.0, 1.0]]), [1.0])]
    names = ["limits", "task"]
    mu = 0.5
    expected = [0.1, 0.9 / (1.0 + mu * mu)]
    for damping in (mu, {"task": mu}):
        result = solve_hqp(levels, names=names, damping=damping)
        np.testing.assert_allclose(result.qdot, expected, atol=1e-12)
        assert result.level("limits").active_upper == (0,)
    np.testing.assert_allclose(solve_hqp(levels, names=names).qdot, [0.1, 0.9], atol=1e-12)
    # Only the named level is damped: the bound's level above would not change, the task below is exact.
    np.testing.assert_allclose(
        solve_hqp(levels, names=names, damping={"limits": mu}).qdot, [0.1, 0.9], atol=1e-12
    )


def test_a_damped_step_along_a_tiny_singular_value_stays_below_one_over_two_mu():
    """J = [1e-4 0], ė = 1: the exact step is 1e4; damped by μ = 0.1, σ / (σ² + μ²) ≈ 0.01 (<= 1/(2μ))."""
    level = (np.array([[1e-4, 0.0]]), [1.0])
    np.testing.assert_allclose(solve_hqp([level]).qdot, [1e4, 0.0], rtol=1e-12)
    np.testing.assert_allclose(solve_hqp([level], damping=0.1).qdot, [1e-4 / (1e-8 + 0.01), 0.0], rtol=1e-12)


def test_an_inequality_is_met_with_the_smallest_velocity():
    # 1 <= q̇1 + q̇2 <= 2: the minimum-norm point of the strip is (0.5, 0.5) (the regularisation level).
    result = solve_hqp([(np.array([[1.0, 1.0]]), [1.0], [2.0])])
    np.testing.assert_allclose(result.qdot, [0.5, 0.5], atol=1e-14)
    assert result.levels[0].active_lower == (0,)
    # Inside the strip, no motion at all.
    np.testing.assert_allclose(solve_hqp([(np.array([[1.0, 1.0]]), [-1.0], [2.0])]).qdot, 0.0, atol=0)


def test_conflicting_inequalities_of_one_level_share_the_violation():
    # q̇ >= 2 and q̇ <= 1 on one level: min (q̇ - 1)² + (2 - q̇)² -> q̇ = 1.5, slacks (-0.5, 0.5).
    result = solve_hqp([(np.array([[1.0], [1.0]]), [2.0, -np.inf], [np.inf, 1.0])])
    np.testing.assert_allclose(result.qdot, [1.5], atol=1e-14)
    np.testing.assert_allclose(result.levels[0].slack, [-0.5, 0.5], atol=1e-14)
    assert result.levels[0].active_lower == (0,) and result.levels[0].active_upper == (1,)


def test_a_hard_row_from_above_is_released_when_a_lower_level_pulls_inward():
    # Level 1: 0 <= q̇1 <= 1 (holds at 0). Level 2: q̇1 + q̇2 = -1, pulled against q̇1 >= 0 it is
    # met with q̇2 alone. Level 3: q̇1 = 0.5 moves q̇1 inside its bounds (the row is released),
    # while level 2 is kept: q̇2 = -1.5.
    levels = [
        (np.array([[1.0, 0.0]]), [0.0], [1.0]),
        (np.array([[1.0, 1.0]]), [-1.0]),
        (np.array([[1.0, 0.0]]), [0.5]),
    ]
    result = solve_hqp(levels)
    np.testing.assert_allclose(result.qdot, [0.5, -1.5], atol=1e-14)
    assert [r.violation for r in result.levels] == pytest.approx([0.0, 0.0, 0.0], abs=1e-14)


def test_an_equality_cannot_push_a_bound_of_a_higher_level():
    # Level 1: q̇1 <= 0.2. Level 2: q̇ = (1, 1): q̇1 stops at 0.2 and q̇2 reaches 1.
    result = solve_hqp([(np.array([[1.0, 0.0]]), [-np.inf], [0.2]), (np.eye(2), [1.0, 1.0])])
    np.testing.assert_allclose(result.qdot, [0.2, 1.0], atol=1e-14)
    np.testing.assert_allclose(result.levels[1].slack, [-0.8, 0.0], atol=1e-14)


def test_parallel_bounds_at_two_levels_and_duplicated_rows():
    # Velocity limit |q̇| <= 1 on top, a tighter position-derived bound q̇ <= 0.5 below it
    # written twice (parallel rows, degenerate), then q̇ = 2: q̇ = 0.5.
    levels = [
        (np.eye(1), [-1.0], [1.0]),
        (np.array([[1.0], [2.0]]), [-np.inf, -np.inf], [0.5, 1.0]),
        (np.eye(1), [2.0]),
    ]
    result = solve_hqp(levels)
    np.testing.assert_allclose(result.qdot, [0.5], atol=1e-14)
    assert result.levels[1].active_upper == (0, 1)


def test_zero_rows_and_unbounded_rows_constrain_nothing():
    rng = np.random.default_rng(3)
    J, e = rng.normal(size=(2, 4)), rng.normal(size=2)
    reference = solve_hqp([(J, e)]).qdot
    padded = [
        (np.zeros((3, 4)), [-1.0, -np.inf, 0.0], [1.0, np.inf, 0.0]),
        (rng.normal(size=(1, 4)), [-np.inf], [np.inf]),
        (J, e),
    ]
    result = solve_hqp(padded)
    np.testing.assert_allclose(result.qdot, reference, atol=1e-14)
    np.testing.assert_allclose(result.levels[0].slack, 0.0, atol=0)


def test_no_levels():
    result = solve_hqp([])
    assert result.qdot.shape == (0,) and result.levels == () and result.free_dims == ()


def test_reports_name_levels_and_lookup_lists_them():
    result = solve_hqp([(np.eye(2), [0.0, 0.0], [1.0, 1.0]), (np.eye(2), [2.0, -1.0])], names=["jl", "task"])
    assert [r.name for r in result.levels] == ["jl", "task"]
    assert result.level("jl").active_upper == (0,) and result.level("jl").active_lower == (1,)
    assert result.free_dims == (2, 0)
    with pytest.raises(KeyError, match="no level named 'x'; levels: jl, task"):
        result.level("x")
    assert [r.name for r in solve_hqp([(np.eye(1), [0.0])]).levels] == ["0"]


def test_unvalidated_fast_path_gives_the_same_result():
    rng = np.random.default_rng(5)
    levels = [
        (rng.normal(size=(3, 6)), -np.ones(3), np.ones(3)),
        (rng.normal(size=(4, 6)), rng.normal(size=4)),
    ]
    a = solve_hqp(levels)
    b = solve_hqp([(J, *rest) for J, *rest in levels], validate=False)
    np.testing.assert_array_equal(a.qdot, b.qdot)


# --- d) degenerate problems: Bland's rule, and the guard that never raises ------------------


@st.composite
def degenerate_problems(draw: st.DrawFn) -> Problem:
    """Like :func:`problems`, made degenerate: rows of small integers, bounds through 0 (rows at
    their bound where q̇ starts, zero multipliers), rows repeated from above with the same bounds
    or scaled, and rank-deficient levels (a row the sum of two others)."""
    problem = draw(problems())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    levels: list[Level3] = []
    for J, lo, hi in problem.levels:
        J = rng.integers(-2, 3, size=J.shape).astype(float)
        if J.shape[0] >= 3 and draw(st.booleans()):
            J[2] = J[0] + J[1]
        if levels and draw(st.booleans()):
            J_src, lo_src, hi_src = levels[rng.integers(len(levels))]
            k, i = rng.integers(J_src.shape[0]), rng.integers(J.shape[0])
            factor = draw(st.sampled_from([1.0, -1.0, 2.0]))
            J[i] = factor * J_src[k]
            lo, hi = lo.copy(), hi.copy()
            if factor == 1.0 and draw(st.booleans()):
                lo[i], hi[i] = lo_src[k], hi_src[k]
        # Shift the finite bounds of inequality rows onto 0 (equalities keep their targets).
        lo, hi = lo.copy(), hi.copy()
        box = (lo < hi) & (rng.random(lo.size) < 0.6)
        lo[box & np.isfinite(lo)] = np.minimum(lo[box & np.isfinite(lo)], 0.0) * (rng.random() < 0.5)
        hi[box & np.isfinite(hi)] = np.maximum(hi[box & np.isfinite(hi)], 0.0) * (rng.random() < 0.5)
        levels.append((J, lo, hi))
    return Problem(levels=levels, n=problem.n)


@pytest.mark.parametrize("bland_after", [5, 0])
@settings(max_examples=200, deadline=None)
@given(problem=degenerate_problems())
def test_degenerate_problems_reach_the_cascade_with_and_without_blands_rule(problem, bland_after):
    """On degenerate problems the active set settles on the cascade's optimum, whether Bland's
    smallest-index rule takes over after a few iterations that do not move q̇ (the default) or
    rules every choice from the start (``BLAND_AFTER = 0``)."""
    reference = cascade(problem.levels, problem.n)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(hqp._ActiveSet, "BLAND_AFTER", bland_after)
        result = solve_hqp(problem.levels)
    assert result.unsettled == ()
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))


def test_an_active_set_stopped_by_its_guard_returns_where_it_stands(monkeypatch):
    """The last-resort guard (no iteration allowed here) does not raise: the level stops where it
    stands, is named in ``unsettled``, and q̇ keeps the level above at its optimum and the box."""
    monkeypatch.setattr(hqp._ActiveSet, "ITERATIONS_PER_ROW", 0)
    n = 3
    levels = [
        (np.array([[1.0, 0.0, 0.0]]), np.array([0.3])),  # q̇1 = 0.3, met by the first step
        (np.eye(n), -np.full(n, 0.5), np.full(n, 0.5)),  # holds at (0.3, 0, 0): hard rows
        (np.eye(n), np.full(n, 2.0)),  # blocked by the box: its active set is stopped at once
    ]
    result = solve_hqp(levels, names=["first", "box", "task"])
    assert result.unsettled == ("task",)
    np.testing.assert_allclose(result.qdot, [0.3, 0.0, 0.0], atol=1e-15)
    assert result.level("first").violation == 0.0 and result.level("box").violation == 0.0
    # Without the guard, the task gets the box's corner (0.5, 0.5, 0.5) but q̇1, fixed at 0.3.
    monkeypatch.undo()
    settled = solve_hqp(levels, names=["first", "box", "task"])
    assert settled.unsettled == ()
    np.testing.assert_allclose(settled.qdot, [0.3, 0.5, 0.5], atol=1e-12)


# --- e) large random hierarchies against daqp's cascade, polished -----------------------------


def daqp_guess(levels: list[Level3], n: int) -> np.ndarray | None:
    """A cascade of QPs solved by daqp (a dual active set, independent of solve_hqp): level k
    minimises ``||v_k||²`` over ``x = x_{k-1} + N y`` and ``l_k <= J_k x - v_k <= u_k``, with the
    rows that held at the levels above as constraints (relaxed by 1e-9 for rounding); its equality
    and violated rows then shrink the basis N (SVD, singular values > 1e-9); last, the least-norm
    x. None when daqp reports no optimum. Its answers carry daqp's own tolerances (rows of the
    levels above violated by up to ~1e-6): :func:`polished` makes them exact."""
    x, N, hard = np.zeros(n), np.eye(n), []
    for J, lo, hi in levels:
        m, k = J.shape[0], N.shape[1]
        if k:
            A = np.vstack(
                [np.hstack([J @ N, -np.eye(m)])]
                + [np.hstack([C @ N, np.zeros((C.shape[0], m))]) for C, _, _ in hard]
            )
            lower = np.concatenate([lo - J @ x] + [c_lo - C @ x - 1e-9 for C, c_lo, _ in hard])
            upper = np.concatenate([hi - J @ x] + [c_hi - C @ x + 1e-9 for C, _, c_hi in hard])
            z, _, flag, _ = daqp.solve(
                np.diag(np.r_[np.zeros(k), np.ones(m)]),
                np.zeros(k + m),
                A,
                np.minimum(upper, 1e30),
                np.maximum(lower, -1e30),
                np.zeros(lower.size, dtype=np.int32),
                eps_prox=-1.0,
                primal_tol=1e-11,
                dual_tol=1e-12,
            )
            if flag != 1:
                return None
            x = x + N @ z[:k]
        value = J @ x
        fixed = (lo == hi) | (np.abs(value - np.clip(value, lo, hi)) > 1e-7)
        if fixed.any() and k:
            _, s, Vt = scipy.linalg.svd(J[fixed] @ N)
            N = N @ Vt[int(np.sum(s > 1e-9)) :].T
        hard.append((J[~fixed], lo[~fixed], hi[~fixed]))
    if N.shape[1] and hard:
        A = np.vstack([C @ N for C, _, _ in hard])
        lower = np.concatenate([c_lo - C @ x - 1e-9 for C, c_lo, _ in hard])
        upper = np.concatenate([c_hi - C @ x + 1e-9 for C, _, c_hi in hard])
        y, _, flag, _ = daqp.solve(
            np.eye(N.shape[1]),
            N.T @ x,
            A,
            np.minimum(upper, 1e30),
            np.maximum(lower, -1e30),
            np.zeros(lower.size, dtype=np.int32),
            primal_tol=1e-11,
            dual_tol=1e-12,
        )
        if flag != 1:
            return None
        x = x + N @ y
    elif N.shape[1]:
        x = x - N @ (N.T @ x)
    return x


def polished(levels: list[Level3], x: np.ndarray, n: int) -> np.ndarray:
    """The candidate of the module docstring for the active set seen at ``x``: each inequality
    row within 1e-7 of a bound binds there, the others are dropped; exact to rounding."""
    hierarchy = []
    for J, lo, hi in levels:
        v = J @ x
        side = np.where(lo == hi, 2, np.where(v >= hi - 1e-7, 1, np.where(v <= lo + 1e-7, -1, 0)))
        rows = np.flatnonzero(side)
        hierarchy.append((J[rows], np.where(side[rows] == -1, lo[rows], hi[rows])))
    return equality_hierarchy(hierarchy, n)


@st.composite
def large_problems(draw: st.DrawFn) -> Problem:
    """6-10 levels of 2-13 rows on 38-50 joints, degenerate if drawn
    (:func:`random_hierarchies.random_hierarchy` says how; the benchmark draws the same)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    degenerate = draw(st.booleans())
    n = draw(st.integers(38, 50))
    return Problem(levels=random_hierarchy(rng, degenerate, n, draw(st.integers(6, 10))), n=n)


@pytest.mark.slow  # large hypothesis draws: on the main Python only (make test's compat runs skip slow)
@settings(max_examples=40, deadline=None)
@given(large_problems())
def test_large_hierarchies_settle_and_are_never_beaten_by_an_independent_cascade(problem):
    """Large random hierarchies, degenerate ones included: the active set settles (no level is
    unsettled), and daqp's cascade, its active set polished into an exact candidate, never
    does lexicographically better by more than 1e-6 at the first level where they differ beyond
    rounding; when it does as well, it is the same q̇ (the optimum is unique). daqp sometimes
    stops on a worse point (its own tolerances)."""
    result = solve_hqp(problem.levels)
    assert result.unsettled == ()
    guess = daqp_guess(problem.levels, problem.n)
    if guess is None:
        event("daqp found no optimum")
        return
    reference = polished(problem.levels, guess, problem.n)
    ours, theirs = slacks(problem.levels, result.qdot), slacks(problem.levels, reference)
    # The first level where the two differ beyond rounding (1e-8) decides.
    for level, (mine, other) in enumerate(zip(ours, theirs, strict=True)):
        if abs(mine - other) <= 1e-8 * (1.0 + other):
            continue
        assert mine <= other + 1e-6 * (1.0 + other), f"level {level}: {mine} > {other}"
        event("solve_hqp better than the candidate" if mine < other else "within 1e-6, beyond 1e-8")
        return  # the candidate is not the optimum, or they differ by little more than rounding
    event("the candidate is solve_hqp's q̇")
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))


# --- f) warm start ------------------------------------------------------------------------------


def moved(levels: list[Level3], rng: np.random.Generator, size: float) -> list[Level3]:
    """The same rows with every finite bound moved by up to ``size`` (a next control tick)."""
    out = []
    for J, lo, hi in levels:
        shift = rng.uniform(-size, size, lo.size)
        out.append((J, lo + shift, np.where(lo == hi, lo + shift, hi + shift)))
    return out


@settings(max_examples=150, deadline=None)
@given(problems(), st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.01, 1.0]))
def test_a_warm_start_gives_the_cold_answer(problem, seed, size):
    """Warm-started from the result of the same problem, of a nearby one (bounds moved by 0.01:
    the same rows bind, mostly) or of another (moved by 1: a wrong guess), the answer is the
    cold one, which is the cascade's."""
    previous = solve_hqp(problem.levels)
    levels = moved(problem.levels, np.random.default_rng(seed), size)
    cold = solve_hqp(levels)
    warm = solve_hqp(levels, warm_start=previous)
    reference = cascade(levels, problem.n)
    np.testing.assert_allclose(cold.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))
    np.testing.assert_allclose(warm.qdot, cold.qdot, rtol=0.0, atol=1e-9 * scale(cold.qdot))
    assert warm.free_dims == cold.free_dims and warm.unsettled == ()
    if warm.iterations < cold.iterations:
        event("the guess certified: one equality solve")


@pytest.mark.slow  # large hypothesis draws: on the main Python only (make test's compat runs skip slow)
@settings(max_examples=30, deadline=None)
@given(large_problems(), st.integers(0, 2**32 - 1))
def test_a_warm_start_gives_the_cold_answer_on_large_hierarchies(problem, seed):
    previous = solve_hqp(problem.levels)
    levels = moved(problem.levels, np.random.default_rng(seed), 0.01)
    cold = solve_hqp(levels)
    warm = solve_hqp(levels, warm_start=previous)
    np.testing.assert_allclose(warm.qdot, cold.qdot, rtol=0.0, atol=1e-9 * scale(cold.qdot))
    assert warm.free_dims == cold.free_dims


@settings(max_examples=100, deadline=None)
@given(problems(), st.integers(0, 2**32 - 1))
def test_a_warm_start_given_as_sides_by_level_name_is_the_result_s_rows_at_a_bound(problem, seed):
    """``bound_sides`` of each inequality level (a control system keeps only these): +1 on the
    report's ``active_upper`` rows, -1 on its other ``active_lower`` rows; as a warm start they give
    the cold answer, as the result they come from does."""
    previous = solve_hqp(problem.levels)
    sides = {}
    for report, (J, lo, hi) in zip(previous.levels, problem.levels, strict=True):
        side = hqp.bound_sides(J, lo, hi, previous.qdot)
        expected = np.zeros(J.shape[0])
        expected[list(report.active_lower)] = -1.0
        expected[list(report.active_upper)] = 1.0
        np.testing.assert_array_equal(side, expected)
        sides[report.name] = side
    levels = moved(problem.levels, np.random.default_rng(seed), 0.01)
    cold = solve_hqp(levels)
    warm = solve_hqp(levels, warm_start=sides)
    np.testing.assert_allclose(warm.qdot, cold.qdot, rtol=0.0, atol=1e-9 * scale(cold.qdot))
    assert warm.free_dims == cold.free_dims


def limits_and_tasks(bound_rows: int, n: int = 30) -> list[Level3]:
    """Joint-velocity limits on top, three tasks of 6 rows and a posture below: the limits are
    tightened to half the unconstrained q̇ on its ``bound_rows`` largest joints."""
    rng = np.random.default_rng(7)
    tasks = [(rng.normal(size=(6, n)), rng.normal(size=6)) for _ in range(3)]
    posture = (np.eye(n), 0.3 * rng.normal(size=n))
    free = solve_strict([*tasks, posture]).qdot
    limit = 2.0 * np.abs(free) + 1.0
    largest = np.argsort(-np.abs(free))[:bound_rows]
    limit[largest] = 0.5 * np.abs(free[largest])
    return [(np.eye(n), -limit, limit)] + [(J, t, t) for J, t in (*tasks, posture)]


@pytest.mark.parametrize("bound_rows", [1, 4, 8])
def test_a_tick_whose_rows_at_a_bound_do_not_change_is_one_equality_solve(bound_rows):
    """The rows at a bound of the last tick, still right: no active-set iteration (one per level,
    the shortcut's count), the cold answer, which is the independent cascade's. (With 16
    tightened limits, 13 bind: with the tasks' 18 rows, more than the 30 joints, not the
    shortcut's form.)"""
    levels = limits_and_tasks(bound_rows)
    previous = solve_hqp(levels)
    assert 0 < len(previous.levels[0].active_lower) + len(previous.levels[0].active_upper) <= bound_rows
    nearby = moved(levels, np.random.default_rng(1), 1e-3)
    warm = solve_hqp(nearby, warm_start=previous)
    assert warm.iterations == len(levels)
    cold = solve_hqp(nearby)
    np.testing.assert_allclose(warm.qdot, cold.qdot, rtol=0.0, atol=1e-12)
    reference = polished(nearby, daqp_guess(nearby, 30), 30)
    np.testing.assert_allclose(cold.qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))


@pytest.mark.parametrize(("bound_rows", "guessed"), [(1, True), (4, True), (6, True), (8, True), (16, False)])
def test_limits_met_for_the_first_time_are_guessed_from_the_rows_the_free_solution_crosses(
    bound_rows, guessed
):
    """Without a warm start, the rows that the equality levels' own solution crosses are tried as
    the rows at a bound, then the guesses each refused one gives: right here for 1, 4, 6 and 8
    tightened limits (equality solves, no active set; for 8, of which 7 bind, the first guess is
    wrong), not for 16 (13 bind: with the tasks' 18 rows, more than the 30 joints, not the
    shortcut's form: the active set runs). Either way the independent cascade's answer."""
    levels = limits_and_tasks(bound_rows)
    result = solve_hqp(levels)
    assert (result.iterations == len(levels)) == guessed
    reference = polished(levels, daqp_guess(levels, 30), 30)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))


@pytest.mark.parametrize(("tightened", "certified"), [(12, True), (20, False)])
def test_limits_crossed_by_more_rows_than_fit_are_guessed_one_at_a_time(tightened, certified):
    """Limits at 0.95 of the free q̇ on its ``tightened`` largest joints: the free q̇ crosses them
    all, more than fit beside the tasks' 18 rows in 30 joints, and fewer bind (9 of 12; 13 of 20).
    The guesses add the rows one at a time: for 12, certified with no active set (one iteration
    per level); for 20 the guesses run out and the active set runs. Either way the independent
    cascade's answer."""
    n = 30
    levels = limits_and_tasks(0, n)
    limit = levels[0][2].copy()
    free = solve_strict([(J, t) for J, t, _ in levels[1:]]).qdot
    largest = np.argsort(-np.abs(free))[:tightened]
    limit[largest] = 0.95 * np.abs(free[largest])
    levels[0] = (np.eye(n), -limit, limit)
    result = solve_hqp(levels)
    assert (result.iterations == len(levels)) == certified
    assert ((np.abs(free) > limit) & ~np.isclose(np.abs(result.qdot), limit, rtol=0.0, atol=1e-9)).any()
    reference = polished(levels, daqp_guess(levels, n), n)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))


def test_a_guess_whose_row_the_tall_last_level_does_not_hold_on_is_declined():
    """Six joints (a problem drawn by the warm-start test); the last level (3 rows) is tall in
    what the rows above leave once row 1 of each inequality level is guessed at its upper bound
    (the rows the equality levels' solution crosses). Its multipliers say nothing against the
    guess but one is zero: that row may leave its bound inside the last level's optimal set, where
    the least norm picks another q̇ (the same slacks, a smaller norm). The guess is declined, and
    solve_hqp gives the cascade's q̇."""
    J0 = [[0.23886608, -0.99354207, -0.24619597, 0.49059852, 0.09865879, -1.79773618],
          [1.08519888, 1.7808936, 0.15387148, -0.93639985, -1.06122414, -1.0343604],
          [0.82005546, 0.03305635, -0.67048348, -1.29101287, -1.28979652, 0.43117544]]  # fmt: skip
    J1 = [[-0.96624565, 2.01056605, 0.27910279, -0.68923228, 1.88020045, -0.21210476],
          [1.64254264, 0.22751585, -1.40172399, 0.34924981, 0.4418076, -1.2277591]]  # fmt: skip
    J2 = [[0.2287021, 0.89252649, 2.07315697, -0.16163895, 2.18236131, -0.72216214],
          [-0.0231937, 0.36639292, 1.23110768, -2.05484617, -0.62641843, 0.08691651]]  # fmt: skip
    J3 = [[0.61601752, -0.63445516, -0.14056953, -0.67257739, -0.47461416, 1.82451072],
          J1[1],  # the last level asks row 1 of level 1 for a value out of its bounds
          [1.47042402, -1.50580556, 1.20515689, 0.23388077, 0.35630153, -0.42049917]]  # fmt: skip
    t2, t3 = np.array([1.36998918, 0.05885112]), np.array([-1.7409731, 1.21777279, -0.11785095])
    levels = [
        (
            np.array(J0),
            np.array([-0.30128097, -np.inf, -2.91229613]),
            np.array([3.37087475, -0.31984178, 0.77803986]),
        ),
        (np.array(J1), np.array([-0.93543346, -1.43463374]), np.array([2.4062721, -1.11692069])),
        (np.array(J2), t2, t2.copy()),
        (np.array(J3), t3, t3.copy()),
    ]
    reference = cascade(levels, 6)
    guess = {0: (np.array([1]), np.array([1.0])), 1: (np.array([1]), np.array([1.0]))}
    certified = _inequalities_idle(levels, 1e-6, 1e-9, guess)
    assert certified is None or np.allclose(certified[0], reference, atol=1e-9)
    np.testing.assert_allclose(solve_hqp(levels).qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))


# --- c) bad input -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("levels", "kwargs", "message"),
    [
        (
            [(np.eye(2), [0.0, 0.0]), (np.eye(2), [0.0, 1.0], [1.0, 0.5])],
            {"names": ["feet", "taskJL"]},
            r"levels\[1\] \('taskJL'\): row 1: lower = 1.0, upper = 0.5 \(lower > upper\)",
        ),
        (
            [(np.eye(2), [0.0, np.nan], [1.0, 1.0])],
            {},
            r"levels\[0\] \('0'\): row 1: lower = nan, upper = 1.0 \(NaN\)",
        ),
        ([(np.eye(1), [np.inf], [np.inf])], {}, r"row 0: .*an infinite bound on the wrong side"),
        (
            [(np.eye(2), [0.0, 0.0], [1.0])],
            {},
            r"levels\[0\] \('0'\): upper must have shape \(2,\), got shape \(1,\)",
        ),
        (
            [(np.eye(2), [0.0, np.nan])],
            {},
            r"levels\[0\] \('0'\): target = .* contains NaN or Inf \(entry \[1\]\)",
        ),
        ([(np.eye(2), [0.0, np.inf])], {}, r"levels\[0\] \('0'\): target = .* contains NaN or Inf"),
        ([(np.array([[1.0, np.nan]]), [0.0])], {}, r"levels\[0\] \('0'\): J of shape \(1, 2\) contains NaN"),
        (
            [(np.eye(2), [0.0, 0.0]), (np.eye(3), np.zeros(3))],
            {},
            r"levels\[1\] \('1'\): J has shape \(3, 3\) but levels\[0\] J has shape \(2, 2\)",
        ),
        ([(np.eye(2),)], {}, r"levels\[0\] \('0'\) must be \(J, target\) or \(J, lower, upper\)"),
        ([(np.eye(1), [0.0])], {"names": ["a", "b"]}, "names has 2 entries but there are 1 levels"),
        ([(np.eye(1), [0.0])], {"names": [""]}, r"names\[0\] = '': must be a non-empty string"),
        ([(np.eye(1), [0.0])], {"tolerance": 0.0}, "tolerance = 0.0: must be finite and > 0"),
        ([(np.eye(1), [0.0])], {"rank_threshold": np.nan}, "rank_threshold = nan: must be finite"),
        ([(np.eye(1), [0.0])], {"damping": -1.0}, "damping = -1.0: must be finite and >= 0"),
        (
            [(np.eye(1), [0.0])],
            {"names": ["task"], "damping": {"task": np.nan}},
            r"damping\['task'\] = nan: must be finite and >= 0",
        ),
        (
            [(np.eye(1), [0.0])],
            {"names": ["task"], "damping": {"hand": 0.1}},
            r"damping names \['hand'\], not levels; levels: task",
        ),
    ],
)
def test_invalid_input_names_the_level_and_row(levels, kwargs, message):
    with pytest.raises(ValueError, match=message):
        solve_hqp(levels, **kwargs)
