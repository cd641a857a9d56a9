"""Tests of the strict-priority solver drake_sot.hierarchy.solve_strict (Mansard et al. 2009, eq. 8-9).

Random stacks are built so that every projected matrix J_i Z_{i-1} has its
nonzero singular values in [0.1, 10] and the others zero up to rounding: the
Jacobians are written in the coordinates of a random orthogonal matrix Q in
which the augmented Jacobian is block lower triangular.  Level i "owns" c_i
new directions of Q (its block D_i, of full column rank c_i), may couple
to (conflict with) the directions owned by the levels above it (block X_i),
and may repeat rows of the levels above it with the same or another target.
Tolerances of 1e-9 are then meaningful; a reference lexicographic
least-squares solution is computed independently with scipy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot.hierarchy import HierarchyResult, solve_strict

SETTINGS = settings(max_examples=150, deadline=None)
RCOND = 1e-9  # relative cutoff of the scipy reference; the spectra are far from it
Level = tuple[np.ndarray, np.ndarray]


def orthonormal(rng: np.random.Generator, rows: int, cols: int) -> np.ndarray:
    """(rows, cols) matrix with orthonormal columns (cols <= rows), uniformly random."""
    Q, R = np.linalg.qr(rng.standard_normal((rows, rows)))
    return (Q * np.sign(np.diag(R)))[:, :cols]


@dataclass(frozen=True)
class Stack:
    """A generated stack and the rank each level has by construction."""

    levels: list[Level]
    n: int
    ranks: list[int]


@st.composite
def stacks(draw: st.DrawFn, min_n: int = 3, max_n: int = 20, max_levels: int = 5) -> Stack:
    """Random stacks of 1-5 levels on 3-20 joints, well conditioned but rank deficient.

    Per level: c new directions (rank of J_i Z_{i-1}), extra rows that make
    the projected matrix rank deficient, either a dense coupling X to the
    directions above (J_i full row rank, conflicts) or a thin product
    U (m, c) [X D 0] (J_i itself rank deficient), and rows duplicated from the
    levels above with the same (compatible) or a new (conflicting) target.
    """
    n = draw(st.integers(min_n, max_n))
    n_levels = draw(st.integers(1, max_levels))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    Q = orthonormal(rng, n, n)
    levels: list[Level] = []
    ranks: list[int] = []
    used = 0  # directions of Q owned by the levels so far
    for _ in range(n_levels):
        c = draw(st.integers(0, min(n - used, 6)))
        extra = draw(st.integers(0, 2))
        thin = draw(st.booleans())
        m = c + extra
        s = rng.uniform(0.1, 10.0, size=c)
        D = (orthonormal(rng, c, c) * s) @ orthonormal(rng, c, c).T  # (c, c), singular values s
        U = orthonormal(rng, m, c)
        if thin:  # rows = U [X D 0]: rank J_i = c < m when extra > 0
            rows_q = U @ np.hstack([rng.standard_normal((c, used)), D, np.zeros((c, n - used - c))])
        else:  # rows = [X  U D  0]: J_i generically full row rank, J_i Z_{i-1} of rank c
            rows_q = np.hstack([rng.standard_normal((m, used)), U @ D, np.zeros((m, n - used - c))])
        J = rows_q @ Q.T
        edot = rng.uniform(-3.0, 3.0, size=m)
        n_dup = draw(st.integers(0, 2)) if levels else 0
        for _ in range(n_dup):
            J_src, edot_src = levels[rng.integers(len(levels))]
            if J_src.shape[0] == 0:
                continue
            row = rng.integers(J_src.shape[0])
            target = edot_src[row] if draw(st.booleans()) else rng.uniform(-3.0, 3.0)
            J = np.vstack([J, J_src[row]])
            edot = np.append(edot, target)
        order = rng.permutation(J.shape[0])
        levels.append((J[order], edot[order]))
        ranks.append(c)
        used += c
    return Stack(levels=levels, n=n, ranks=ranks)


def stacked(levels: list[Level], n: int) -> np.ndarray:
    """Augmented Jacobian (J_1; ...; J_k), shape (sum m_i, n)."""
    return np.vstack([J for J, _ in levels]) if levels else np.zeros((0, n))


def negligible(A: np.ndarray) -> bool:
    """True for an empty or numerically zero matrix (entries are O(1) here, zeros O(1e-15)).

    scipy's cutoffs are relative to the largest singular value, so a matrix
    made only of rounding errors must be recognised as zero beforehand.
    """
    return A.size == 0 or np.linalg.norm(A, 2) <= 1e-9


def kernel(C: np.ndarray, n: int) -> np.ndarray:
    """Orthonormal basis (n, k) of ker C by scipy.linalg.null_space."""
    return np.eye(n) if negligible(C) else scipy.linalg.null_space(C, rcond=RCOND)


def lexicographic_reference(levels: list[Level], n: int, qdot0: np.ndarray | None = None) -> np.ndarray:
    """Lexicographic least squares closest to qdot0, computed with scipy only.

    Level i minimises ||J_i x - edot_i|| over the set where all the levels
    above keep their optimal task values, {x : C x = C x_prev} with C the
    augmented Jacobian of the levels above: a particular solution (scipy
    lstsq of C) plus the null space of C taken from scratch (scipy
    null_space of the whole augmented Jacobian, not updated recursively).
    Minimum-norm least-squares choices at every step make x - qdot0 of
    minimum norm.
    """
    x0 = np.zeros(n) if qdot0 is None else qdot0
    delta = np.zeros(n)
    for i, (J, edot) in enumerate(levels):
        C = stacked(levels[:i], n)
        particular = np.zeros(n) if negligible(C) else scipy.linalg.lstsq(C, C @ delta, cond=RCOND)[0]
        N = kernel(C, n)
        delta = particular
        if not negligible(J @ N):
            delta = particular + N @ scipy.linalg.lstsq(J @ N, edot - J @ (x0 + particular), cond=RCOND)[0]
    return x0 + delta


def scale(*vectors: np.ndarray) -> float:
    """1 + the largest of the norms: the size that tolerances are relative to."""
    return 1.0 + max((float(np.linalg.norm(v)) for v in vectors), default=0.0)


# --- a) strict priority -----------------------------------------------------------------


@SETTINGS
@given(stacks(), st.one_of(st.just(0.0), st.floats(1e-3, 1.0)))
def test_lower_levels_do_not_disturb_higher_ones(stack, damping):
    """J_j qdot equals J_j qdot^(j), qdot^(j) solved with the levels below j removed (any damping)."""
    qdot = solve_strict(stack.levels, damping=damping).qdot
    for j, (J, _) in enumerate(stack.levels):
        qdot_j = solve_strict(stack.levels[: j + 1], damping=damping).qdot
        tolerance = 1e-9 * scale(J @ qdot_j) * (1.0 + np.linalg.norm(J, 2))
        np.testing.assert_allclose(J @ qdot, J @ qdot_j, rtol=0.0, atol=tolerance, err_msg=f"level {j}")


# --- b) lexicographic optimum, minimum norm ---------------------------------------------


@SETTINGS
@given(stacks())
def test_matches_independent_lexicographic_least_squares(stack):
    result = solve_strict(stack.levels)
    reference = lexicographic_reference(stack.levels, stack.n)
    np.testing.assert_allclose(result.qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))
    # Minimum norm: qdot has no component in the null space of the augmented Jacobian.
    N = kernel(stacked(stack.levels, stack.n), stack.n)
    np.testing.assert_allclose(N.T @ result.qdot, 0.0, atol=1e-9 * scale(reference))


@SETTINGS
@given(stacks(), st.integers(0, 2**32 - 1))
def test_each_level_is_optimal_given_the_levels_above(stack, seed):
    """No velocity that keeps the levels above at their values does better on level i."""
    qdot = solve_strict(stack.levels).qdot
    rng = np.random.default_rng(seed)
    for i, (J, edot) in enumerate(stack.levels):
        N = kernel(stacked(stack.levels[:i], stack.n), stack.n)
        trial = qdot + N @ rng.standard_normal(N.shape[1]) * 1e-3
        assert np.linalg.norm(J @ trial - edot) >= np.linalg.norm(J @ qdot - edot) - 1e-9 * scale(edot)


# --- c) hand-checkable examples ---------------------------------------------------------


def test_conflicting_tasks_on_two_joints_by_hand():
    # Level 1: qdot_x + qdot_y = 2 -> minimum norm (1, 1), free direction (1, -1).
    # Level 2: qdot = (3, 0) conflicts; along (1, 1) + t (1, -1) it minimises
    # (t - 2)^2 + (1 - t)^2 -> t = 1.5, qdot = (2.5, -0.5), residual |(-0.5, -0.5)|.
    levels = [(np.array([[1.0, 1.0]]), np.array([2.0])), (np.eye(2), np.array([3.0, 0.0]))]
    result = solve_strict(levels)
    np.testing.assert_allclose(result.qdot, [2.5, -0.5], atol=1e-14)
    assert result.rank == (1, 1)
    assert result.free_dims == (1, 0)
    np.testing.assert_allclose(result.residual, [0.0, np.sqrt(0.5)], atol=1e-14)


def test_direct_conflict_and_exhausted_free_space_by_hand():
    # Level 1 sets qdot_x = 1.  Level 2 repeats its row with another target: it
    # gets nothing (rank 0, residual |1 - (-1)|).  Level 3 sets 2 qdot_y = 4 and
    # uses the last free joint, so level 4 gets nothing (residual |1 + 2 - 0|).
    levels = [
        (np.array([[1.0, 0.0]]), np.array([1.0])),
        (np.array([[1.0, 0.0]]), np.array([-1.0])),
        (np.array([[0.0, 2.0]]), np.array([4.0])),
        (np.array([[1.0, 1.0]]), np.array([0.0])),
    ]
    result = solve_strict(levels)
    np.testing.assert_allclose(result.qdot, [1.0, 2.0], atol=1e-14)
    assert result.rank == (1, 0, 1, 0)
    assert result.free_dims == (1, 1, 0, 0)
    np.testing.assert_allclose(result.residual, [0.0, 2.0, 0.0, 3.0], atol=1e-14)


def test_no_levels():
    result = solve_strict([])
    assert result.qdot.shape == (0,)
    assert result.rank == result.residual == result.free_dims == ()
    qdot0 = np.array([1.0, -2.0, 3.0])
    result = solve_strict([], qdot0=qdot0)
    np.testing.assert_array_equal(result.qdot, qdot0)
    assert result.qdot is not qdot0
    assert isinstance(result, HierarchyResult)


# --- d) ranks, free dimensions and residuals --------------------------------------------


@SETTINGS
@given(stacks())
def test_reports_projected_rank_free_dims_and_residuals(stack):
    result = solve_strict(stack.levels)
    assert result.rank == tuple(stack.ranks)
    for i, (J, edot) in enumerate(stack.levels):
        Z = kernel(stacked(stack.levels[:i], stack.n), stack.n)
        JZ = J @ Z
        assert result.rank[i] == (np.linalg.matrix_rank(JZ, tol=1e-6) if JZ.size else 0)
        augmented_rank = np.linalg.matrix_rank(stacked(stack.levels[: i + 1], stack.n), tol=1e-6)
        assert result.free_dims[i] == stack.n - augmented_rank
        residual = np.linalg.norm(J @ result.qdot - edot)
        assert result.residual[i] == pytest.approx(residual, abs=1e-9 * scale(edot))


# --- e) initial velocity qdot0 ----------------------------------------------------------


@SETTINGS
@given(stacks(), st.integers(0, 2**32 - 1))
def test_qdot0_null_space_component_is_preserved(stack, seed):
    qdot0 = np.random.default_rng(seed).uniform(-2.0, 2.0, size=stack.n)
    qdot = solve_strict(stack.levels, qdot0=qdot0).qdot
    C = stacked(stack.levels, stack.n)
    P = np.eye(stack.n) - np.linalg.pinv(C, RCOND) @ C  # projector onto ker of the augmented Jacobian
    np.testing.assert_allclose(P @ qdot, P @ qdot0, atol=1e-9 * scale(qdot0))
    reference = lexicographic_reference(stack.levels, stack.n, qdot0)
    np.testing.assert_allclose(qdot, reference, rtol=0.0, atol=1e-9 * scale(reference))


def test_qdot0_is_not_modified():
    qdot0 = np.array([1.0, 2.0, 3.0])
    solve_strict([(np.array([[1.0, 0.0, 0.0]]), np.array([0.0]))], qdot0=qdot0)
    np.testing.assert_array_equal(qdot0, [1.0, 2.0, 3.0])


# --- f) damping -------------------------------------------------------------------------


@SETTINGS
@given(
    st.integers(2, 10),
    st.integers(0, 2**32 - 1),
    st.floats(1e-5, 1e-3),
    st.floats(1e-2, 1.0),
)
def test_damping_reduces_velocity_near_singularity(n, seed, small, damping):
    """A 2-row level with one singular value in [1e-5, 1e-3] (kept by the 1e-6 threshold)."""
    rng = np.random.default_rng(seed)
    J = (orthonormal(rng, 2, 2) * [1.0, small]) @ orthonormal(rng, n, 2).T
    edot = rng.uniform(-1.0, 1.0, size=2)
    exact = solve_strict([(J, edot)]).qdot
    damped = solve_strict([(J, edot)], damping=damping).qdot
    assert np.linalg.norm(damped) < np.linalg.norm(exact)
    closed_form = J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(2), edot)
    np.testing.assert_allclose(damped, closed_form, atol=1e-10)


def test_damping_below_a_higher_level_by_hand():
    # Level 1 fixes qdot_x = 1; level 2 wants qdot_y = 1 through a gain of 1e-3:
    # undamped qdot_y = 1e3; damped, s / (s^2 + l^2) with s = 1e-3, l = 1e-2
    # times what level 1 left of the target.
    levels = [(np.array([[1.0, 0.0]]), np.array([1.0])), (np.array([[1.0, 1e-3]]), np.array([2.0]))]
    np.testing.assert_allclose(solve_strict(levels).qdot, [1.0, 1e3], rtol=1e-12)
    x = 1.0 / (1.0 + 1e-4)  # level 1 is damped too: s / (s^2 + l^2) with s = 1
    y = 1e-3 / (1e-6 + 1e-4) * (2.0 - x)
    np.testing.assert_allclose(solve_strict(levels, damping=1e-2).qdot, [x, y], rtol=1e-12)


def test_rank_threshold_drops_small_projected_directions():
    levels = [(np.array([[1.0, 0.0]]), np.array([1.0])), (np.array([[1.0, 1e-3]]), np.array([2.0]))]
    result = solve_strict(levels, rank_threshold=1e-2)
    np.testing.assert_allclose(result.qdot, [1.0, 0.0], atol=1e-14)
    assert result.rank == (1, 0)
    assert result.free_dims == (1, 1)


# --- g) validation ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("levels", "kwargs", "message"),
    [
        (
            [(np.ones((1, 3)), np.ones(1)), (np.ones((2, 4)), np.ones(2))],
            {},
            r"levels\[1\]: J has shape \(2, 4\) but levels\[0\] J has shape \(1, 3\)",
        ),
        (
            [(np.ones((1, 3)), np.ones(1)), (np.ones((2, 3)), np.ones(3))],
            {},
            r"levels\[1\]: edot has shape \(3,\) but J has shape \(2, 3\); expected edot of shape \(2,\)",
        ),
        ([(np.ones(3), np.ones(1))], {}, r"levels\[0\]: J must be a 2-D matrix, got shape \(3,\)"),
        (
            [(np.ones((1, 3)), np.ones(1))],
            {"qdot0": np.zeros(4)},
            r"levels\[0\]: J has shape \(1, 3\) but qdot0 has shape \(4,\)",
        ),
        (
            [(np.ones((1, 3)), np.ones(1)), (np.ones((1, 3)), np.ones(1)), (np.ones((1, 3)), [np.nan])],
            {},
            r"levels\[2\]: J or edot contains NaN or Inf",
        ),
        ([(np.array([[1.0, np.inf]]), np.ones(1))], {}, r"levels\[0\]: J or edot contains NaN or Inf"),
        ([(np.ones((1, 2)), np.ones(1))], {"qdot0": [0.0, np.nan]}, "qdot0 contains NaN or Inf"),
        ([(np.ones((1, 2)), np.ones(1))], {"damping": -0.1}, "damping = -0.1: must be finite and >= 0"),
        ([(np.ones((1, 2)), np.ones(1))], {"rank_threshold": -1.0}, "rank_threshold = -1.0: must be finite"),
    ],
)
def test_invalid_input_names_the_level_and_shapes(levels, kwargs, message):
    with pytest.raises(ValueError, match=message):
        solve_strict(levels, **kwargs)


def test_zero_rows_are_skipped_but_reported():
    """A level of exactly-zero rows (an inactive joint-limit task) changes nothing and uses no rank."""
    rng = np.random.default_rng(11)
    J1, e1 = rng.normal(size=(2, 5)), rng.normal(size=2)
    J2, e2 = rng.normal(size=(3, 5)), rng.normal(size=3)
    reference = solve_strict([(J1, e1), (J2, e2)])
    zero = np.zeros((4, 5))
    with_zero = solve_strict([(zero, np.ones(4)), (J1, e1), (J2, e2)])
    np.testing.assert_allclose(with_zero.qdot, reference.qdot, atol=1e-12)
    assert with_zero.rank[0] == 0 and with_zero.free_dims[0] == 5
    assert with_zero.residual[0] == pytest.approx(2.0)  # ||0 - 1|| over 4 rows
    # A level with some zero rows equals the level without them.
    mixed = np.vstack((J1[:1], np.zeros((1, 5)), J1[1:]))
    a = solve_strict([(mixed, np.array([e1[0], 0.0, e1[1]])), (J2, e2)])
    np.testing.assert_allclose(a.qdot, reference.qdot, atol=1e-12)


def test_unvalidated_fast_path_gives_the_same_result():
    rng = np.random.default_rng(12)
    levels = [(rng.normal(size=(m, 7)), rng.normal(size=m)) for m in (2, 3, 4)]
    a = solve_strict(levels)
    b = solve_strict(levels, validate=False)
    np.testing.assert_array_equal(a.qdot, b.qdot)
    assert a.rank == b.rank and a.residual == b.residual
