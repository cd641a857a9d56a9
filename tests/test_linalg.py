"""Tests of drake_sot.linalg against numpy/scipy references and defining properties."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot.linalg import (
    SvdSplit,
    damped_pinv,
    full_rank_lstsq,
    null_space_basis,
    pinv,
    rank,
    weighted_pinv,
)

SETTINGS = settings(max_examples=150, deadline=None)
THRESHOLD = 1e-6


def orthonormal(rng: np.random.Generator, rows: int, cols: int) -> np.ndarray:
    """(rows, cols) matrix with orthonormal columns (cols <= rows), uniformly random."""
    Q, R = np.linalg.qr(rng.standard_normal((rows, rows)))
    return (Q * np.sign(np.diag(R)))[:, :cols]


def matrix_with_spectrum(rng: np.random.Generator, m: int, n: int, r: int) -> tuple[np.ndarray, np.ndarray]:
    """Random (m, n) matrix of rank r as a product of thin factors U_r diag(s) V_r^T.

    The r nonzero singular values lie in [0.1, 10], far from THRESHOLD, the
    others are exact zeros.  Returns the matrix and its nonzero singular values.
    """
    s = rng.uniform(0.1, 10.0, size=r)
    return (orthonormal(rng, m, r) * s) @ orthonormal(rng, n, r).T, s


@st.composite
def matrices(draw: st.DrawFn, max_dim: int = 12) -> tuple[np.ndarray, int, np.ndarray]:
    """(J, rank, nonzero singular values) with J of shape (m, n), full rank or rank-deficient."""
    m = draw(st.integers(1, max_dim))
    n = draw(st.integers(1, max_dim))
    r = draw(st.integers(0, min(m, n)))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    J, s = matrix_with_spectrum(rng, m, n, r)
    return J, r, s


def spd(rng: np.random.Generator, n: int) -> np.ndarray:
    """Random symmetric positive definite (n, n) matrix with eigenvalues in [0.5, 5]."""
    Q = orthonormal(rng, n, n)
    return (Q * rng.uniform(0.5, 5.0, size=n)) @ Q.T


def numpy_pinv(J: np.ndarray, s: np.ndarray) -> np.ndarray:
    """numpy's pinv with its relative cutoff chosen to equal the absolute THRESHOLD."""
    s_max = s.max(initial=1.0)
    return np.linalg.pinv(J, THRESHOLD / s_max)


# --- pinv -------------------------------------------------------------------------------


@SETTINGS
@given(matrices())
def test_pinv_matches_numpy_and_moore_penrose_conditions(case):
    J, _, s = case
    X = pinv(J)
    assert X.shape == J.T.shape
    np.testing.assert_allclose(X, numpy_pinv(J, s), atol=1e-10)
    np.testing.assert_allclose(J @ X @ J, J, atol=1e-10)
    np.testing.assert_allclose(X @ J @ X, X, atol=1e-10)
    np.testing.assert_allclose((J @ X).T, J @ X, atol=1e-10)
    np.testing.assert_allclose((X @ J).T, X @ J, atol=1e-10)


def test_pinv_drops_singular_values_at_or_below_threshold():
    J = np.diag([2.0, 1e-8, 1e-3])
    np.testing.assert_allclose(pinv(J), np.diag([0.5, 0.0, 1e3]))
    np.testing.assert_allclose(pinv(J, rank_threshold=1e-3), np.diag([0.5, 0.0, 0.0]))


# --- damped_pinv ------------------------------------------------------------------------


@SETTINGS
@given(matrices(), st.floats(1e-2, 10.0))
def test_damped_pinv_matches_closed_formula(case, damping):
    # damping >= 1e-2 keeps J J^T + damping^2 I (singular when J is rank deficient)
    # conditioned well enough for the reference solve to be accurate to 1e-10.
    J, _, _ = case
    m = J.shape[0]
    expected = J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(m), np.eye(m))
    np.testing.assert_allclose(damped_pinv(J, damping), expected, atol=1e-10)


def test_damped_pinv_is_bounded_near_singularity():
    J = np.diag([1.0, 1e-5])
    damping = 1e-2
    X = damped_pinv(J, damping)
    # s / (s^2 + l^2) by hand for s = 1e-5, l = 1e-2: 1e-5 / (1e-10 + 1e-4)
    np.testing.assert_allclose(np.diag(X), [1.0 / (1.0 + 1e-4), 1e-5 / (1e-10 + 1e-4)])
    assert np.abs(X).max() <= 1.0 / (2.0 * damping)


def test_damped_pinv_with_zero_damping_is_exact_pinv():
    J = np.array([[1.0, 1.0], [1.0, 1.0]])
    np.testing.assert_allclose(damped_pinv(J, 0.0), np.full((2, 2), 0.25))


def penrose_residuals(A: np.ndarray, X: np.ndarray) -> list[float]:
    """The four Moore-Penrose conditions' residuals, relative to ||A|| and ||X||."""
    a, x = np.linalg.norm(A, 2), np.linalg.norm(X, 2)
    return [
        np.linalg.norm(A @ X @ A - A) / a,
        np.linalg.norm(X @ A @ X - X) / x,
        np.linalg.norm((A @ X).T - A @ X),
        np.linalg.norm((X @ A).T - X @ A),
    ]


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("function", [lambda A: damped_pinv(A, 0.0), lambda A: pinv(A, 0.0)])
def test_zero_threshold_drops_rounding_noise_of_a_rank_deficient_matrix(function, seed):
    """A 6x36 matrix of rank 3 built as a product: its singular values 4-6 are rounding
    noise (~1e-15, their exact value depends on the BLAS). Comparing them to exactly zero
    inverted them (entries of 6e14, ||A A+ A - A|| = 2); the relative floor drops them, on
    any BLAS."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((6, 3)) @ rng.standard_normal((3, 36))
    X = function(A)
    assert max(penrose_residuals(A, X)) < 1e-12
    np.testing.assert_allclose(X, np.linalg.pinv(A), atol=1e-12 * np.abs(X).max())
    assert rank(A, 0.0) == 3
    assert null_space_basis(A, 0.0).shape == (36, 33)


# --- weighted_pinv ----------------------------------------------------------------------


def kkt_min_weighted_norm(J: np.ndarray, W: np.ndarray, y: np.ndarray) -> np.ndarray:
    """argmin x^T W x over the least-squares solutions of J x = y, by a KKT solve.

    y is first projected on range(J) (numpy lstsq) so that the constraint is
    consistent; the KKT matrix may then be singular (dependent rows) but the
    x part of any of its solutions is unique.
    """
    m, n = J.shape
    y_reachable = J @ np.linalg.lstsq(J, y, rcond=None)[0]
    K = np.block([[2.0 * W, J.T], [J, np.zeros((m, m))]])
    sol = np.linalg.lstsq(K, np.concatenate([np.zeros(n), y_reachable]), rcond=None)[0]
    return sol[:n]


@SETTINGS
@given(matrices(), st.integers(0, 2**32 - 1))
def test_weighted_pinv_matches_formula_and_minimises_weighted_norm(case, seed):
    J, _, s = case
    m, n = J.shape
    rng = np.random.default_rng(seed)
    W = spd(rng, n)
    X = weighted_pinv(J, W)

    W_inv = np.linalg.inv(W)
    M = J @ W_inv @ J.T
    formula = W_inv @ J.T @ np.linalg.pinv(M, 1e-8, hermitian=True)
    np.testing.assert_allclose(X, formula, atol=1e-9)

    y = rng.standard_normal(m)
    np.testing.assert_allclose(X @ y, kkt_min_weighted_norm(J, W, y), atol=1e-8)


def test_weighted_pinv_identity_weight_is_pinv():
    J = np.array([[1.0, 2.0, 0.0], [0.0, 1.0, 1.0]])
    np.testing.assert_allclose(weighted_pinv(J, np.eye(3)), np.linalg.pinv(J), atol=1e-12)


def test_weighted_pinv_moves_heavy_joints_less():
    # One task on two joints; joint 1 weighs 100x joint 0.  By hand:
    # x = W^-1 J^T / (J W^-1 J^T) = [1, 0.01] / 1.01.
    J = np.array([[1.0, 1.0]])
    W = np.diag([1.0, 100.0])
    np.testing.assert_allclose(weighted_pinv(J, W) @ [1.0], np.array([1.0, 0.01]) / 1.01)


@pytest.mark.parametrize(
    ("W", "message"),
    [
        (np.eye(2), r"W must have shape \(3, 3\).*\(2, 2\)"),
        (np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "not symmetric"),
        (np.diag([1.0, -1.0, 1.0]), "positive definite"),
        (np.diag([1.0, np.nan, 1.0]), "W .*NaN"),
    ],
)
def test_weighted_pinv_rejects_bad_weights(W, message):
    with pytest.raises(ValueError, match=message):
        weighted_pinv(np.ones((2, 3)), W)


# --- null_space_basis, rank, SvdSplit ---------------------------------------------------


@SETTINGS
@given(matrices())
def test_null_space_basis_is_orthonormal_kernel_matching_scipy(case):
    J, r, _ = case
    n = J.shape[1]
    Z = null_space_basis(J)
    assert Z.shape == (n, n - r)
    np.testing.assert_allclose(J @ Z, 0.0, atol=1e-10)
    np.testing.assert_allclose(Z.T @ Z, np.eye(n - r), atol=1e-10)
    reference = scipy.linalg.null_space(J, rcond=1e-9)
    np.testing.assert_allclose(Z @ Z.T, reference @ reference.T, atol=1e-10)


@SETTINGS
@given(matrices())
def test_rank_matches_construction_and_numpy(case):
    J, r, _ = case
    assert rank(J) == r
    assert rank(J) == np.linalg.matrix_rank(J, tol=THRESHOLD)


@SETTINGS
@given(matrices(), st.integers(0, 2**32 - 1), st.one_of(st.just(0.0), st.floats(1e-2, 1.0)))
def test_svd_split_gives_one_consistent_decomposition(case, seed, damping):
    J, r, _ = case
    m, n = J.shape
    split = SvdSplit.of(J, THRESHOLD)
    assert split.rank == r
    assert split.Vt.shape == (n, n)
    b = np.random.default_rng(seed).standard_normal(m)
    if damping > 0:
        expected = J.T @ np.linalg.solve(J @ J.T + damping**2 * np.eye(m), b)
    else:
        expected = np.linalg.pinv(J, 1e-8) @ b
    np.testing.assert_allclose(split.solve(b, damping), expected, atol=1e-9)
    np.testing.assert_allclose(split.pinv(damping) @ b, expected, atol=1e-9)


@SETTINGS
@given(matrices(), st.integers(0, 2**32 - 1))
def test_full_rank_lstsq_is_the_pseudo_inverse_solution_or_declines(case, seed):
    """The QR shortcut answers only for tall matrices of full column rank, and then with numpy's
    pseudo-inverse solution; otherwise it declines (None) and the SVD decides."""
    J, r, s = case
    m, n = J.shape
    b = np.random.default_rng(seed).standard_normal(m)
    y = full_rank_lstsq(J, b, THRESHOLD)
    if m < n or r < n:
        assert y is None
    else:
        assert y is not None  # singular values >= 0.1 here: far above the floor
        np.testing.assert_allclose(y, numpy_pinv(J, s) @ b, atol=1e-9)


@pytest.mark.parametrize("smallest", [1e-3, 1e-5, 2e-6, 1e-6, 5e-7, 1e-9, 0.0])
def test_full_rank_lstsq_never_answers_where_the_svd_drops_a_singular_value(smallest):
    """Near the threshold the shortcut may decline a full-rank matrix, but it never answers for
    one whose SVD keeps fewer than all of its singular values (they are set here exactly)."""
    rng = np.random.default_rng(7)
    s = np.array([3.0, 1.0, 0.5, smallest])
    J = (orthonormal(rng, 9, 4) * s) @ orthonormal(rng, 4, 4).T
    y = full_rank_lstsq(J, rng.standard_normal(9), THRESHOLD)
    if SvdSplit.of(J, THRESHOLD).rank < 4:
        assert y is None
    if smallest >= 1e-5:  # sqrt(4) times the threshold and more: certain
        assert y is not None


def test_empty_matrices():
    assert pinv(np.zeros((0, 3))).shape == (3, 0)
    Z = null_space_basis(np.zeros((0, 3)))
    np.testing.assert_array_equal(Z @ Z.T, np.eye(3))
    assert rank(np.zeros((2, 0))) == 0


# --- input validation -------------------------------------------------------------------


@pytest.mark.parametrize("function", [pinv, null_space_basis, rank, lambda J: damped_pinv(J, 0.1)])
def test_non_finite_or_non_matrix_input_is_rejected(function):
    with pytest.raises(ValueError, match=r"J of shape \(2, 2\) contains NaN or Inf"):
        function(np.array([[1.0, np.nan], [0.0, 1.0]]))
    with pytest.raises(ValueError, match=r"J of shape \(1, 2\) contains NaN or Inf"):
        function(np.array([[np.inf, 0.0]]))
    with pytest.raises(ValueError, match=r"J must be a matrix of shape \(n, n\), got shape \(3,\)"):
        function(np.ones(3))


def test_negative_threshold_and_damping_are_rejected():
    J = np.eye(2)
    with pytest.raises(ValueError, match=r"rank_threshold = -0.1: must be finite and >= 0"):
        pinv(J, rank_threshold=-0.1)
    with pytest.raises(ValueError, match=r"rank_threshold = -1e-06"):
        null_space_basis(J, rank_threshold=-1e-6)
    with pytest.raises(ValueError, match=r"rank_threshold = nan"):
        rank(J, rank_threshold=float("nan"))
    with pytest.raises(ValueError, match=r"rank_threshold = -1"):
        weighted_pinv(J, np.eye(2), rank_threshold=-1)
    with pytest.raises(ValueError, match=r"damping = -0.5: must be finite and >= 0"):
        damped_pinv(J, -0.5)
