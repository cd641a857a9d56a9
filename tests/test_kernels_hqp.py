"""The compiled strict hierarchy (``drake_sot/kernels/hqp.cpp``) against its numpy oracle
(``drake_sot.hqp._solve_numpy``), the exhaustive reference and the independent cascade of
``tests/test_hqp.py``.

Both solvers take the same decisions (the same rank floors, certificates, ratio tests and
anti-cycling rules), so where they reach the same free dimensions without a guard, their q̇ agree
to rounding: 1e-12 (1 + |q̇|). Where a rank decision falls within rounding of its floor the two
may decide differently (their SVDs and QRs are LAPACK's and Eigen's); none of the problems here
does, and the tests say so when one would (1e-6 then, the reference's tolerance).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from random_hierarchies import Level3, random_hierarchy
from test_hqp import (
    cascade,
    daqp_guess,
    degenerate_problems,
    large_problems,
    limits_and_tasks,
    moved,
    polished,
    problems,
    scale,
    slacks,
)

from drake_sot import hqp, kernels
from drake_sot.hqp import HqpResult, solve_hqp

pytestmark = pytest.mark.skipif(
    kernels.compiled is None, reason=f"the compiled kernels are not loaded: {kernels.REASON}"
)


def on_numpy(levels: list, **kwargs) -> HqpResult:
    """``solve_hqp`` on the numpy solver (the compiled kernels hidden for the call)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(kernels, "compiled", None)
        return solve_hqp(levels, **kwargs)


def assert_agree(compiled: HqpResult, numpy: HqpResult) -> None:
    """The two paths' answers: the same free dimensions and unsettled levels, and q̇ to 1e-12 (1 + |q̇|).
    Not always the same iteration count: on degenerate problems rows tie exactly (a row repeated
    blocks at the same step as its copy), and rounding, which differs between the two, picks the
    first of them; the paths differ, their end does not."""
    assert compiled.unsettled == numpy.unsettled
    assert compiled.free_dims == numpy.free_dims
    np.testing.assert_allclose(compiled.qdot, numpy.qdot, rtol=0.0, atol=1e-12 * scale(numpy.qdot))


def draw(seed: int) -> list[Level3]:
    """A large random hierarchy (6-10 levels of 2-13 rows on 38-50 joints), degenerate or not."""
    rng = np.random.default_rng(seed)
    return random_hierarchy(rng, bool(seed % 2), int(rng.integers(38, 51)), int(rng.integers(6, 11)))


@pytest.mark.parametrize("block", range(4))
def test_large_random_hierarchies_agree_with_the_numpy_solver(block):
    """Sixty large random hierarchies (half of them degenerate: repeated, opposite and doubled rows,
    rank-deficient levels, bounds through 0), cold and warm-started from their own answer moved by
    0.01: the same decisions and q̇ to rounding."""
    for seed in range(15 * block, 15 * (block + 1)):
        levels = draw(seed)
        compiled, numpy = solve_hqp(levels), on_numpy(levels)
        assert_agree(compiled, numpy)
        assert compiled.unsettled == ()
        nearby = moved(levels, np.random.default_rng(seed), 0.01)
        assert_agree(solve_hqp(nearby, warm_start=compiled), on_numpy(nearby, warm_start=numpy))


@pytest.mark.parametrize("bound_rows", [0, 1, 4, 8, 16])
def test_control_ticks_agree_cold_and_warm(bound_rows):
    """The control tick's shape (velocity limits on top, three 6-row tasks and a posture given as
    ``(J, t)``, the limits tightened on the ``bound_rows`` largest joints of the free q̇), cold,
    warm-started from the last tick (the result, or its sides by level name) with the targets
    moved by 1e-3; and its equality levels alone. The same decisions and q̇ to rounding, and the
    independent cascade's q̇ (daqp's, polished)."""
    n = 30
    levels = limits_and_tasks(bound_rows, n)
    previous_compiled, previous_numpy = solve_hqp(levels), on_numpy(levels)
    assert_agree(previous_compiled, previous_numpy)
    nearby = moved(levels, np.random.default_rng(bound_rows), 1e-3)
    nearby = [nearby[0]] + [(J, t, t) for J, t, _ in nearby[1:]]  # as StackOfTasks gives them
    warm = solve_hqp(nearby, warm_start=previous_compiled)
    assert_agree(warm, on_numpy(nearby, warm_start=previous_numpy))
    sides = {"0": hqp.bound_sides(*levels[0], previous_compiled.qdot)}
    assert_agree(solve_hqp(nearby, warm_start=sides), on_numpy(nearby, warm_start=sides))
    cold = solve_hqp(nearby)
    assert_agree(cold, on_numpy(nearby))
    reference = polished(nearby, daqp_guess(nearby, n), n)
    np.testing.assert_allclose(cold.qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))
    np.testing.assert_allclose(warm.qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))
    equalities = [(J, t) for J, t, _ in nearby[1:]]
    assert_agree(solve_hqp(equalities), on_numpy(equalities))


@pytest.mark.parametrize("damping", [0.05, 0.5])
def test_damped_levels_agree(damping):
    """Damped levels (every level, or one by name) under the limits and on large hierarchies."""
    for levels in (limits_and_tasks(8, 30), draw(3), draw(4)):
        assert_agree(solve_hqp(levels, damping=damping), on_numpy(levels, damping=damping))
        one = {"2": damping}
        assert_agree(solve_hqp(levels, damping=one), on_numpy(levels, damping=one))


@settings(max_examples=150, deadline=None)
@given(problems())
def test_small_problems_reach_the_exhaustive_reference(problem):
    """The compiled path on the small problems of the exhaustive reference: its q̇, and the numpy
    solver's decisions."""
    result = solve_hqp(problem.levels)
    reference = cascade(problem.levels, problem.n)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))
    assert_agree(result, on_numpy(problem.levels))


@pytest.mark.parametrize("bland_after", [5, 0])
@settings(max_examples=100, deadline=None)
@given(problem=degenerate_problems())
def test_degenerate_problems_reach_the_reference_with_and_without_blands_rule(problem, bland_after):
    """Degenerate small problems, Bland's rule after 5 still iterations or from the start (the class
    attribute reaches the C++): the reference's q̇, the numpy solver's decisions."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(hqp._ActiveSet, "BLAND_AFTER", bland_after)
        result = solve_hqp(problem.levels)
        numpy = on_numpy(problem.levels)
    assert result.unsettled == ()
    reference = cascade(problem.levels, problem.n)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))
    assert_agree(result, numpy)


@settings(max_examples=25, deadline=None)
@given(large_problems())
def test_large_problems_are_never_beaten_by_the_independent_cascade(problem):
    """daqp's cascade, polished, never does lexicographically better than the compiled path by more
    than 1e-6 at the first level where the two differ beyond rounding; when they are equal there,
    the same q̇ to 1e-6."""
    result = solve_hqp(problem.levels)
    assert result.unsettled == ()
    guess = daqp_guess(problem.levels, problem.n)
    if guess is None:
        return  # daqp found no optimum: nothing to compare (test_hqp.py counts these)
    reference = polished(problem.levels, guess, problem.n)
    for mine, other in zip(
        slacks(problem.levels, result.qdot), slacks(problem.levels, reference), strict=True
    ):
        if abs(mine - other) <= 1e-8 * (1.0 + other):
            continue
        assert mine <= other + 1e-6 * (1.0 + other)
        return
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-6 * scale(reference))


def test_the_guard_names_the_same_level_as_the_numpy_solver(monkeypatch):
    """No iteration allowed (the guard's class attribute reaches the C++): the level stops where it
    stands and is named, as on numpy, on a small stack and on large hierarchies."""
    monkeypatch.setattr(hqp._ActiveSet, "ITERATIONS_PER_ROW", 0)
    n = 3
    levels = [
        (np.array([[1.0, 0.0, 0.0]]), np.array([0.3])),
        (np.eye(n), -np.full(n, 0.5), np.full(n, 0.5)),
        (np.eye(n), np.full(n, 2.0)),
    ]
    names = ["first", "box", "task"]
    result = solve_hqp(levels, names=names)
    assert result.unsettled == ("task",)
    assert_agree(result, on_numpy(levels, names=names))
    for seed in range(6):
        levels = draw(seed)
        compiled = solve_hqp(levels)
        assert compiled.unsettled  # every active set stopped at once
        assert_agree(compiled, on_numpy(levels))


@st.composite
def hostile_levels(draw_: st.DrawFn) -> tuple[list, float]:
    """Valid but hostile stacks: zero rows, rows without finite bounds, levels without rows, huge and
    tiny scales, all-zero Jacobians, a tall last level, one column."""
    n = draw_(st.integers(1, 6))
    rng = np.random.default_rng(draw_(st.integers(0, 2**32 - 1)))
    scale_ = draw_(st.sampled_from([1e-150, 1e-8, 1.0, 1e8, 1e150]))
    levels = []
    for _ in range(draw_(st.integers(1, 5))):
        m = draw_(st.integers(0, 2 * n + 1))
        J = scale_ * rng.normal(size=(m, n)) * (rng.random((m, 1)) < 0.8)
        lo = scale_ * rng.normal(size=m)
        hi = lo + scale_ * rng.uniform(0.0, 2.0, size=m) * (rng.random(m) < 0.7)
        lo[rng.random(m) < 0.2], hi[rng.random(m) < 0.2] = -np.inf, np.inf
        lo = np.minimum(lo, hi)
        if draw_(st.booleans()) and (lo == hi).all():
            levels.append((J, hi))
        else:
            levels.append((J, lo, hi))
    return levels, scale_


@settings(max_examples=200, deadline=None)
@given(hostile_levels())
def test_the_compiled_path_never_raises_and_agrees_on_hostile_stacks(drawn):
    """Whatever the valid stack, the compiled path returns (no exception) a finite q̇; at unit scale it
    agrees with numpy where both decided alike (the same free dimensions and nothing unsettled: to
    1e-12 relative to q̇). Not at the other scales: at 1e8 an absolute tolerance of 1e-9 is below the
    rows' rounding (1e8 n eps), and one scaled to the rows (1e-8) swallows the multipliers of the
    regularisation, which are in q̇'s units (1e-8 of them): either way which rows stay at a bound is
    rounding's choice, and the two paths' roundings differ (measured: the same slacks, q̇ apart)."""
    levels, scale_ = drawn
    compiled, numpy = solve_hqp(levels), on_numpy(levels)
    assert np.isfinite(compiled.qdot).all()
    if scale_ != 1.0:
        return
    if compiled.free_dims == numpy.free_dims and compiled.unsettled == numpy.unsettled == ():
        np.testing.assert_allclose(compiled.qdot, numpy.qdot, rtol=0.0, atol=1e-12 * scale(numpy.qdot))


@pytest.mark.parametrize("seed", range(40))
def test_the_compiled_check_of_the_levels_accepts_and_refuses_as_the_numpy_one(seed):
    """``levels_hold`` (one compiled call) in place of ``_validate_hqp``'s numpy calls: the same
    levels pass, and a level it refuses gets ``_validate_hqp``'s message."""
    from drake_sot.hqp import _validate_hqp

    core = kernels.compiled
    rng = np.random.default_rng(7000 + seed)
    levels = random_hierarchy(rng, bool(seed % 2), int(rng.integers(3, 12)), int(rng.integers(1, 5)))
    levels = [(J, lo, hi) if rng.random() < 0.7 or not (lo == hi).all() else (J, lo) for J, lo, hi in levels]
    if seed % 4:  # one entry spoilt: NaN, an infinite bound on the wrong side, lower > upper, a shape
        k = int(rng.integers(len(levels)))
        J, *rest = (a.copy() for a in levels[k])
        spoil = seed % 4
        if spoil == 1:
            J[0, 0] = rng.choice([np.nan, np.inf])
        elif spoil == 2:
            rest[0][0] = rng.choice([np.nan, np.inf])
        else:
            J = J[:, :-1]
        levels[k] = (J, *rest)
    holds = core.levels_hold([lv[0] for lv in levels], [lv[1] for lv in levels], [lv[-1] for lv in levels])
    try:
        _validate_hqp(levels, None)
    except ValueError as error:
        assert not holds
        with pytest.raises(ValueError) as raised:
            solve_hqp(levels)
        assert str(raised.value) == str(error)
    else:
        assert holds
