"""Tests of the generalized projector drake_sot.generalized.generalized_projector
(Liu, Lober, Padois 2016, eq. 4, 8).

The references are computed here independently:
- the paper's construction taken literally: rows of the augmented Jacobian
  sorted by decreasing alpha (stable), Gram-Schmidt row by row (modified,
  twice) keeping the rows independent of the ones already taken, each basis
  vector weighted by the alpha of its origin row, zero-alpha rows included;
- the classical null-space projector ``N N^T`` from scipy.linalg.null_space.

Random Jacobians are rank deficient by construction: rows copied or combined
from other tasks, low-rank blocks, zero rows, more rows than joints.  Exact
dependencies leave residuals ~1e-15 and independent rows residuals far above
the 1e-9 threshold, so the rank decisions are unambiguous.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot.generalized import (
    generalized_projector,
    generalized_projectors,
    priority_matrix,
    projected_jacobians,
)

SETTINGS = settings(max_examples=120, deadline=None)
TOL = 1e-8


@dataclass(frozen=True)
class Problem:
    jacobians: list[np.ndarray]
    alpha: np.ndarray  # (n,) alpha_row of the task under study
    nv: int


@st.composite
def jacobian_sets(draw: st.DrawFn, max_nv: int = 10, max_tasks: int = 6) -> tuple[list[np.ndarray], int]:
    """1-6 tasks of 0-5 rows on 1-10 joints, with exact dependencies between and within tasks."""
    nv = draw(st.integers(1, max_nv))
    n = draw(st.integers(1, max_tasks))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    jacobians: list[np.ndarray] = []
    for _ in range(n):
        m = draw(st.integers(0, 5))
        kind = draw(st.sampled_from(["random", "low_rank", "combination", "copy_and_zero"]))
        previous = np.vstack(jacobians) if jacobians else np.zeros((0, nv))
        if kind == "random" or m == 0:
            J = rng.standard_normal((m, nv))
        elif kind == "low_rank":
            c = int(rng.integers(1, m + 1))
            J = rng.standard_normal((m, c)) @ rng.standard_normal((c, nv))
        elif kind == "combination" and previous.shape[0]:
            J = rng.standard_normal((m, previous.shape[0])) @ previous
            J[rng.random(m) < 0.3] = rng.standard_normal(nv)  # and some new rows
        else:
            J = rng.standard_normal((m, nv))
            if previous.shape[0]:
                J[0] = 3.0 * previous[rng.integers(previous.shape[0])]
            J[rng.random(m) < 0.3] = 0.0
        jacobians.append(J)
    return jacobians, nv


def alpha_values(n: int) -> st.SearchStrategy[np.ndarray]:
    """(n,) alphas, often tied (0, 1, 0.5) and sometimes arbitrary."""
    value = st.one_of(st.sampled_from([0.0, 1.0, 0.5, 0.25]), st.floats(0.0, 1.0))
    return st.lists(value, min_size=n, max_size=n).map(np.array)


@st.composite
def problems(draw: st.DrawFn, max_nv: int = 10, max_tasks: int = 6) -> Problem:
    jacobians, nv = draw(jacobian_sets(max_nv, max_tasks))
    return Problem(jacobians, draw(alpha_values(len(jacobians))), nv)


def literal_reference(jacobians: list[np.ndarray], alpha: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Eq. 8 as written: stable sort of the rows by decreasing alpha, row-by-row Gram-Schmidt,
    P = I - B^T A B."""
    nv = jacobians[0].shape[1]
    order = sorted(range(len(jacobians)), key=lambda j: -alpha[j])  # stable
    basis: list[np.ndarray] = []
    weights: list[float] = []
    for j in order:
        for row in jacobians[j]:
            norm = np.linalg.norm(row)
            if norm == 0.0:
                continue
            v = row / norm
            for _ in range(2):
                for b in basis:
                    v = v - (b @ v) * b
            residual = np.linalg.norm(v)
            if residual > tol:
                basis.append(v / residual)
                weights.append(float(alpha[j]))
    P = np.eye(nv)
    for b, a in zip(basis, weights, strict=False):
        P -= a * np.outer(b, b)
    return P


def null_space_projector(J: np.ndarray, nv: int) -> np.ndarray:
    """N N^T with N an orthonormal basis of ker J (scipy), I for an empty or zero J."""
    if J.size == 0 or not J.any():
        return np.eye(nv)
    N = scipy.linalg.null_space(J, rcond=1e-10)
    return N @ N.T


# -------------------------------------------------------------------------------------------
# eq. 8 and the strict special cases
# -------------------------------------------------------------------------------------------


@SETTINGS
@given(problems())
def test_matches_the_papers_construction(p: Problem) -> None:
    P = generalized_projector(p.jacobians, p.alpha)
    assert P.shape == (p.nv, p.nv)
    np.testing.assert_allclose(P, literal_reference(p.jacobians, p.alpha), atol=TOL)


@SETTINGS
@given(jacobian_sets(), st.data())
def test_strict_priority_of_all_the_others_is_their_null_space_projector(
    js: tuple[list[np.ndarray], int], data: st.DataObject
) -> None:
    jacobians, nv = js
    i = data.draw(st.integers(0, len(jacobians) - 1))
    alpha = np.ones(len(jacobians))
    alpha[i] = 0.0
    others = [J for j, J in enumerate(jacobians) if j != i]
    J_others = np.vstack(others) if others else np.zeros((0, nv))
    np.testing.assert_allclose(
        generalized_projector(jacobians, alpha), null_space_projector(J_others, nv), atol=TOL
    )


@SETTINGS
@given(jacobian_sets())
def test_all_alphas_zero_give_the_identity(js: tuple[list[np.ndarray], int]) -> None:
    jacobians, nv = js
    assert np.array_equal(generalized_projector(jacobians, np.zeros(len(jacobians))), np.eye(nv))


@SETTINGS
@given(problems(), st.data())
def test_alpha_ii_one_cancels_task_i(p: Problem, data: st.DataObject) -> None:
    """alpha_ii = 1 is the largest possible alpha: task i's rows are all in the first group,
    whose span S_1 is removed completely, so the range of P is orthogonal to the rows of J_i."""
    i = data.draw(st.integers(0, len(p.jacobians) - 1))
    alpha = p.alpha.copy()
    alpha[i] = 1.0
    P = generalized_projector(p.jacobians, alpha)
    np.testing.assert_allclose(
        p.jacobians[i] @ P, 0.0, atol=TOL * (1.0 + np.abs(p.jacobians[i]).max(initial=0.0))
    )


@SETTINGS
@given(problems())
def test_tasks_at_the_largest_alpha_are_scaled_by_one_minus_it(p: Problem) -> None:
    """J_j P = (1 - a_max) J_j for every task j whose alpha is the largest one."""
    P = generalized_projector(p.jacobians, p.alpha)
    a_max = p.alpha.max()
    for j in np.flatnonzero(p.alpha == a_max):
        J = p.jacobians[j]
        np.testing.assert_allclose(J @ P, (1.0 - a_max) * J, atol=TOL * (1.0 + np.abs(J).max(initial=0.0)))


@SETTINGS
@given(problems())
def test_symmetric_with_eigenvalues_one_minus_an_alpha_or_one(p: Problem) -> None:
    P = generalized_projector(p.jacobians, p.alpha)
    np.testing.assert_allclose(P, P.T, atol=1e-12)
    eigenvalues = np.linalg.eigvalsh(P)
    assert eigenvalues.min() >= -1e-10 and eigenvalues.max() <= 1.0 + 1e-10
    allowed = np.append(1.0 - p.alpha, 1.0)
    distance = np.abs(eigenvalues[:, None] - allowed[None, :]).min(axis=1)
    assert distance.max() <= 1e-9, (eigenvalues, allowed)


@SETTINGS
@given(problems(), st.randoms(use_true_random=False))
def test_independent_of_the_task_order(p: Problem, random) -> None:
    """Equal alphas are tied in task order, but which tied row spans a shared direction does not matter."""
    perm = list(range(len(p.jacobians)))
    random.shuffle(perm)
    P = generalized_projector(p.jacobians, p.alpha)
    P_perm = generalized_projector([p.jacobians[k] for k in perm], p.alpha[perm])
    np.testing.assert_allclose(P_perm, P, atol=TOL)


def test_zero_alpha_rows_and_zero_rows_change_nothing() -> None:
    rng = np.random.default_rng(0)
    J1, J2 = rng.standard_normal((2, 5)), rng.standard_normal((3, 5))
    P = generalized_projector([J1, J2], [0.7, 0.3])
    # a third task at alpha 0 (any rows), or a zero row in a task, or an all-zero task
    np.testing.assert_allclose(
        generalized_projector([J1, J2, rng.standard_normal((4, 5))], [0.7, 0.3, 0.0]), P
    )
    np.testing.assert_allclose(generalized_projector([np.vstack([J1, np.zeros(5)]), J2], [0.7, 0.3]), P)
    np.testing.assert_allclose(generalized_projector([J1, J2, np.zeros((2, 5))], [0.7, 0.3, 1.0]), P)
    np.testing.assert_allclose(generalized_projector([J1, J2, np.zeros((0, 5))], [0.7, 0.3, 1.0]), P)


# -------------------------------------------------------------------------------------------
# ordering: hand-checked 2-D examples
# -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("a1, a2", [(0.8, 0.3), (0.3, 0.8), (0.6, 0.6), (1.0, 0.0), (0.0, 1.0)])
def test_a_shared_direction_is_attributed_to_the_larger_alpha(a1: float, a2: float) -> None:
    """J_1 = [1 0], J_2 = [1 1] on 2 joints.

    a1 >= a2: B = (e1; e2), e1 from task 1 and e2 = [1 1] - e1 from task 2:
        P = diag(1 - a1, 1 - a2).
    a2 > a1: B = ([1 1]/√2; [1 -1]/√2), the second from task 1 ([1 0] minus its part along [1 1]):
        P = I - a2/2 [[1, 1], [1, 1]] - a1/2 [[1, -1], [-1, 1]].
    Both give diag(1 - a) at a1 = a2 = a.
    """
    P = generalized_projector([np.array([[1.0, 0.0]]), np.array([[1.0, 1.0]])], [a1, a2])
    if a1 >= a2:
        expected = np.diag([1.0 - a1, 1.0 - a2])
    else:
        expected = (
            np.eye(2)
            - a2 / 2 * np.array([[1.0, 1.0], [1.0, 1.0]])
            - a1 / 2 * np.array([[1.0, -1.0], [-1.0, 1.0]])
        )
    np.testing.assert_allclose(P, expected, atol=1e-14)


@pytest.mark.parametrize("a1, a2", [(0.8, 0.3), (0.3, 0.8), (0.5, 0.5)])
def test_a_direction_of_two_tasks_is_removed_with_the_larger_alpha(a1: float, a2: float) -> None:
    """Both tasks are the same direction (scaled): P = diag(1 - max(a1, a2), 1)."""
    P = generalized_projector([np.array([[2.0, 0.0]]), np.array([[-0.5, 0.0]])], [a1, a2])
    np.testing.assert_allclose(P, np.diag([1.0 - max(a1, a2), 1.0]), atol=1e-15)


def test_orthonormal_rows_give_i_minus_jt_a_j() -> None:
    """With orthonormal rows, B is the sorted J and eq. 8 is I - J^T A_i J with eq. 4's A_i."""
    Q = np.linalg.qr(np.random.default_rng(3).standard_normal((7, 7)))[0]
    J = Q[:6]  # 6 orthonormal rows on 7 joints
    dims = [2, 1, 3]
    jacobians = [J[:2], J[2:3], J[3:]]
    alpha = [0.4, 1.0, 0.7]
    np.testing.assert_allclose(
        generalized_projector(jacobians, alpha),
        np.eye(7) - J.T @ priority_matrix(alpha, dims) @ J,
        atol=1e-13,
    )


# -------------------------------------------------------------------------------------------
# continuity and monotonicity in alpha
# -------------------------------------------------------------------------------------------


@SETTINGS
@given(problems(), st.data())
def test_lipschitz_and_monotone_in_each_alpha(p: Problem, data: st.DataObject) -> None:
    """||P(a') - P(a)||_2 <= |a'_j - a_j| and P(a) - P(a') is positive semidefinite for a' >= a,
    even when the change of alpha_j reorders the tasks (ties included)."""
    j = data.draw(st.integers(0, len(p.jacobians) - 1))
    new = data.draw(st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1.0, 0.5])))
    changed = p.alpha.copy()
    changed[j] = new
    P, P_changed = generalized_projector(p.jacobians, p.alpha), generalized_projector(p.jacobians, changed)
    assert np.linalg.norm(P_changed - P, 2) <= abs(new - p.alpha[j]) + 1e-9
    low, high = (P_changed, P) if new >= p.alpha[j] else (P, P_changed)  # alpha up -> P down
    assert np.linalg.eigvalsh(low - high).max() <= 1e-9


def test_finite_difference_is_the_projector_of_the_new_directions() -> None:
    """With the ordering fixed (distinct alphas), dP/d alpha_j = -(projector onto the directions
    task j adds)."""
    rng = np.random.default_rng(7)
    jacobians = [rng.standard_normal((2, 6)), rng.standard_normal((2, 6)), rng.standard_normal((1, 6))]
    jacobians[2] = jacobians[0][:1] + jacobians[1][:1] + rng.standard_normal((1, 6))
    alpha = np.array([0.9, 0.5, 0.2])
    h = 1e-6
    for j in range(3):
        step = np.zeros(3)
        step[j] = h
        derivative = (
            generalized_projector(jacobians, alpha + step) - generalized_projector(jacobians, alpha - step)
        ) / (2 * h)
        above = np.vstack([jacobians[k] for k in range(3) if alpha[k] > alpha[j]] or [np.zeros((0, 6))])
        with_j = np.vstack([above, jacobians[j]])
        expected = -(null_space_projector(above, 6) - null_space_projector(with_j, 6))
        np.testing.assert_allclose(derivative, expected, atol=1e-8)


# -------------------------------------------------------------------------------------------
# threshold, realistic size, batch
# -------------------------------------------------------------------------------------------


def test_rank_threshold_is_relative_to_the_row_norm() -> None:
    """[1, 1e-12] is within 1e-12 of the span of [1, 0]: dependent at the default 1e-9 whatever its scale."""
    for scale in (1e-6, 1.0, 1e6):
        jacobians = [np.array([[1.0, 0.0]]), scale * np.array([[1.0, 1e-12]])]
        np.testing.assert_allclose(
            generalized_projector(jacobians, [1.0, 0.5]), np.diag([0.0, 1.0]), atol=1e-15
        )
    near = [np.array([[1.0, 0.0]]), np.array([[1.0, 1e-6]])]
    np.testing.assert_allclose(generalized_projector(near, [1.0, 0.5]), np.diag([0.0, 0.5]), atol=1e-9)
    np.testing.assert_allclose(
        generalized_projector(near, [1.0, 0.5], rank_threshold=1e-5), np.diag([0.0, 1.0]), atol=1e-15
    )


@pytest.mark.parametrize("scale", [1e300, 1e-170, 1e-300])
def test_rows_of_extreme_scale_count_as_the_same_rows_scaled_to_one(scale: float) -> None:
    """Rows of 1e300 (squared norm overflows) or 1e-170 (underflows) are neither dropped nor
    distorted: the projector equals the one of the same rows of entries ~1."""
    rng = np.random.default_rng(5)
    unit = [rng.standard_normal((2, 5)), rng.standard_normal((1, 5)), rng.standard_normal((2, 5))]
    unit[2][1] = 0.0  # a switched-off row: still skipped
    alpha = np.array([[0.0, 1.0, 0.5], [0.3, 0.0, 1.0], [1.0, 0.7, 0.2]])
    tiny_or_huge = 2.0 ** np.round(np.log2(scale))  # a power of two: the scaling is exact
    for k in range(3):  # one task at a time at the extreme scale, then all of them
        for scaled_tasks in ({k}, {0, 1, 2}):
            jacobians = [tiny_or_huge * J if j in scaled_tasks else J for j, J in enumerate(unit)]
            expected = generalized_projectors(unit, alpha)
            np.testing.assert_allclose(generalized_projectors(jacobians, alpha), expected, atol=1e-12)
            for i in range(3):
                np.testing.assert_allclose(
                    generalized_projector(jacobians, alpha[i]), expected[i], atol=1e-12
                )
    # Independently of the code: the strict null-space projector of the first task's rows.
    big = [1e300 * unit[0], unit[1]]
    np.testing.assert_allclose(
        generalized_projector(big, [1.0, 0.0]), null_space_projector(unit[0], 5), atol=1e-12
    )


def test_humanoid_sized_stack_matches_the_papers_construction() -> None:
    """10 tasks of dimensions 2,3,3,3,3,1,1,1,30,5 on 36 joints, with dependent force/back/posture rows."""
    rng = np.random.default_rng(11)
    nv, dims = 36, [2, 3, 3, 3, 3, 1, 1, 1, 30, 5]
    jacobians = [rng.standard_normal((m, nv)) for m in dims]
    jacobians[5] = 0.5 * jacobians[1][:1] + jacobians[1][1:2]  # a force along a hand direction
    jacobians[6] = jacobians[2][:1].copy()
    jacobians[8] = np.eye(nv)[6:]  # posture: the 30 actuated joints
    jacobians[9] = np.eye(nv)[6:11]  # back: 5 of them
    for alpha in (
        [1, 1, 1, 0, 0, 1, 0, 0, 0, 0],
        [1, 0.5, 0.3, 0.3, 0, 1, 0.7, 0.2, 0.1, 0],
        rng.random(10),
        [1, 1, 1, 1, 1, 1, 1, 1, 0, 1],
        np.ones(10),
    ):
        alpha = np.array(alpha, dtype=float)
        np.testing.assert_allclose(
            generalized_projector(jacobians, alpha), literal_reference(jacobians, alpha), atol=TOL
        )


@SETTINGS
@given(jacobian_sets(max_tasks=4), st.data())
def test_batch_equals_one_by_one(js: tuple[list[np.ndarray], int], data: st.DataObject) -> None:
    jacobians, nv = js
    n = len(jacobians)
    alpha = np.vstack([data.draw(alpha_values(n)) for _ in range(n)])
    batch = generalized_projectors(jacobians, alpha)
    assert batch.shape == (n, nv, nv)
    # Checked input: skipping the checks changes nothing.
    np.testing.assert_array_equal(generalized_projectors(jacobians, alpha, validate=False), batch)
    for i in range(n):
        np.testing.assert_allclose(batch[i], generalized_projector(jacobians, alpha[i]), atol=1e-12)


@SETTINGS
@given(jacobian_sets(max_tasks=5), st.data())
def test_projected_jacobians_are_each_jacobian_times_its_projector(
    js: tuple[list[np.ndarray], int], data: st.DataObject
) -> None:
    """J_i P_i without forming P_i, against eq. 8 as written; tasks sharing an α row included."""
    jacobians, nv = js
    n = len(jacobians)
    rows = [data.draw(alpha_values(n)) for _ in range(n)]
    alpha = np.vstack([rows[data.draw(st.integers(0, i))] for i in range(n)])  # repeated rows
    projected = projected_jacobians(jacobians, alpha)
    assert len(projected) == n
    for i, (J, JP) in enumerate(zip(jacobians, projected, strict=True)):
        assert JP.shape == J.shape
        np.testing.assert_allclose(JP, J @ literal_reference(jacobians, alpha[i]), atol=TOL)
    for JP, again in zip(projected, projected_jacobians(jacobians, alpha, validate=False), strict=True):
        np.testing.assert_array_equal(again, JP)  # checked input: skipping the checks changes nothing


def test_projected_jacobians_validation() -> None:
    with pytest.raises(ValueError, match=r"alpha\[1\]\[0\] = 2.0"):
        projected_jacobians([J2, J3], np.array([[0.0, 0.0], [2.0, 0.0]]))
    with pytest.raises(ValueError, match=r"jacobians\[1\] of shape \(3, 4\) contains NaN"):
        projected_jacobians([J2, np.full((3, 4), np.nan)], np.zeros((2, 2)))


# -------------------------------------------------------------------------------------------
# priority matrix and validation
# -------------------------------------------------------------------------------------------


def test_priority_matrix_is_block_diagonal_alpha_times_identity() -> None:
    A = priority_matrix([0.0, 1.0, 0.25], [2, 1, 3])
    np.testing.assert_array_equal(A, np.diag([0.0, 0.0, 1.0, 0.25, 0.25, 0.25]))
    assert priority_matrix([0.5], [0]).shape == (0, 0)


@pytest.mark.parametrize(
    "alpha, dims, match",
    [
        ([0.5, 1.2], [1, 1], r"alpha_row\[1\] = 1.2"),
        ([np.nan], [1], r"alpha_row\[0\] = nan"),
        ([0.5], [1, 2], r"dims has shape \(2,\) but alpha_row has shape \(1,\)"),
        ([0.5, 0.5], [1, -1], r"dims\[1\] \(a task dimension\) = -1: must be an integer >= 0"),
        ([0.5, 0.5], [1, 1.5], r"dims\[1\] \(a task dimension\) = 1.5"),
        ([0.5, 0.5], [1, np.nan], r"dims\[1\] \(a task dimension\) = nan"),
    ],
)
def test_priority_matrix_validation(alpha, dims, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        priority_matrix(alpha, dims)


J2 = np.ones((2, 4))
J3 = np.ones((3, 4))


@pytest.mark.parametrize(
    "jacobians, alpha, kwargs, match",
    [
        ([J2, J3], [0.5, -0.1], {}, r"alpha_row\[1\] = -0.1"),
        ([J2, J3], [1.0 + 1e-12, 0.0], {}, r"alpha_row\[0\] = 1.000"),
        ([J2, J3], [np.inf, 0.0], {}, r"alpha_row\[0\] = inf"),
        ([J2, J3], [np.nan, 0.0], {}, r"alpha_row\[0\] = nan"),
        ([J2, J3], [0.5], {}, r"alpha_row has 1 values but there are 2 Jacobians"),
        ([J2, J3], [[0.5, 0.5]], {}, r"alpha_row must be a vector"),
        (
            [J2, np.ones((3, 5))],
            [0.5, 0.5],
            {},
            r"jacobians\[1\] has shape \(3, 5\) but jacobians\[0\] has shape \(2, 4\)",
        ),
        ([J2, np.ones(4)], [0.5, 0.5], {}, r"jacobians\[1\] must be a 2-D matrix .* got shape \(4,\)"),
        ([J2, np.full((3, 4), np.nan)], [0.5, 0.0], {}, r"jacobians\[1\] of shape \(3, 4\) contains NaN"),
        ([], [], {}, r"jacobians is empty"),
        ([J2], [0.5], {"rank_threshold": -1.0}, r"rank_threshold"),
    ],
)
def test_validation(jacobians, alpha, kwargs, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        generalized_projector(jacobians, alpha, **kwargs)


def test_batch_validation() -> None:
    with pytest.raises(
        ValueError, match=r"alpha has shape \(2,\) but there are 2 Jacobians; expected \(2, 2\)"
    ):
        generalized_projectors([J2, J3], np.zeros(2))
    with pytest.raises(ValueError, match=r"alpha\[1\]\[0\] = 2.0"):
        generalized_projectors([J2, J3], np.array([[0.0, 0.0], [2.0, 0.0]]))
