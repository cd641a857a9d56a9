"""The torque family's law in drake_sot.generalized, against computations made here
independently: numpy's pinv and inverse for the task-space inertia (Λ = (J M⁻¹ Jᵀ)⁺), a
loop over the tasks for the relative shortfall, and a minimum-norm least-squares of the
base's equilibrium for the fallback's gravity compensation."""

from __future__ import annotations

import numpy as np
import pytest

from drake_sot.generalized import (
    ProjectedJacobians,
    fallback_torques,
    generalized_projector,
    inertia_weighted,
    relative_shortfall,
    task_inertia,
)


def _mass_matrix(rng: np.random.Generator, nv: int) -> np.ndarray:
    X = rng.normal(size=(nv, nv))
    return X @ X.T + nv * np.eye(nv)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("deficient", [False, True])
def test_task_inertia_is_the_pseudo_inverse_of_the_inverse_inertia_in_task_space(seed, deficient):
    rng = np.random.default_rng(seed)
    nv, m = 9, 5
    M = _mass_matrix(rng, nv)
    J = rng.normal(size=(m, nv))
    if deficient:  # rank 3 of 5: a copied row and a combination
        J[3] = J[0]
        J[4] = 0.5 * J[1] - 2.0 * J[2]
    M_inv = np.linalg.inv(M)
    expected = np.linalg.pinv(J @ M_inv @ J.T, rcond=1e-10)
    got = task_inertia(J, M_inv, 1e-8)
    np.testing.assert_allclose(got, expected, rtol=1e-8, atol=1e-10 * np.abs(expected).max())
    assert np.linalg.matrix_rank(got) == (3 if deficient else 5)


def test_task_inertia_gives_zero_to_zero_rows():
    """An inactive joint-limit row (all zero) is left out of the pseudo-inverse, not just zeroed."""
    rng = np.random.default_rng(7)
    nv = 6
    M_inv = np.linalg.inv(_mass_matrix(rng, nv))
    J = rng.normal(size=(3, nv))
    J[1] = 0.0
    got = task_inertia(J, M_inv, 1e-8)
    kept = J[[0, 2]]
    np.testing.assert_allclose(got[np.ix_([0, 2], [0, 2])], np.linalg.inv(kept @ M_inv @ kept.T), rtol=1e-9)
    assert not got[1].any() and not got[:, 1].any()
    assert not task_inertia(np.zeros((2, nv)), M_inv, 1e-8).any()


def test_inertia_weighted_is_lambda_times_a_per_task_with_dependent_rows_in_one_task():
    """The Cholesky path and the pseudo-inverse fallback agree with Λ_i a_i from numpy's pinv."""
    rng = np.random.default_rng(11)
    nv = 10
    M = _mass_matrix(rng, nv)
    M_inv = np.linalg.inv(M)
    for dependent in (False, True):
        J1, J2 = rng.normal(size=(3, nv)), rng.normal(size=(4, nv))
        if dependent:
            J2[3] = J2[0] + J2[1]
        a = rng.normal(size=7)
        blocks = np.zeros((7, 7), dtype=bool)
        blocks[:3, :3] = blocks[3:, 3:] = True
        got = inertia_weighted(np.vstack([J1, J2]), [slice(0, 3), slice(3, 7)], M, a, blocks, 1e-8)
        expected = np.concatenate(
            [np.linalg.pinv(J @ M_inv @ J.T, rcond=1e-10) @ part for J, part in ((J1, a[:3]), (J2, a[3:]))]
        )
        np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-9 * np.abs(expected).max())


def test_inertia_weighted_refuses_a_mass_matrix_that_is_not_positive_definite():
    M = np.diag([1.0, -1.0, 1.0])
    with pytest.raises(RuntimeError, match="not positive definite"):
        inertia_weighted(np.eye(3), [slice(0, 3)], M, np.ones(3), np.ones((3, 3), dtype=bool), 1e-8)


def test_projected_jacobians_tick_after_tick_follow_alpha_and_zero_rows():
    """The cached structure of eq. 8 is rebuilt when α changes and when a row becomes zero (a
    switched-off component), and not otherwise: every call equals J_i P_i(A_i) with each task's
    projector built from scratch."""
    rng = np.random.default_rng(2)
    dims, nv = [2, 3, 1, 4], 7
    project = ProjectedJacobians(dims)
    strict = np.array([[0, 0, 0, 0], [1, 0, 0, 0], [1, 1, 0, 0], [1, 1, 1, 0]], dtype=float)
    soft = strict.copy()
    soft[2, 1], soft[1, 2] = 0.3, 0.7  # mid-transition between tasks 1 and 2
    out = np.empty((sum(dims), nv))
    for alpha, zero_row in (
        (strict, None),
        (strict, None),
        (soft, None),
        (soft, 3),
        (soft, None),
        (strict, 3),
    ):
        stacked = rng.normal(size=(sum(dims), nv))
        if zero_row is not None:
            stacked[zero_row] = 0.0
        blocks = np.split(stacked, np.cumsum(dims)[:-1])
        got = project(stacked, alpha, out)
        assert got is out
        expected = np.vstack([J @ generalized_projector(blocks, alpha[i]) for i, J in enumerate(blocks)])
        np.testing.assert_allclose(got, expected, atol=1e-12)


def test_relative_shortfall_per_task_with_the_floor():
    desired = np.array([3.0, 4.0, 0.1, 0.0, 2.0])  # tasks: rows 0-1, row 2, rows 3-4
    achieved = np.array([3.0, 3.0, 0.0, 0.0, 1.0])
    starts = np.array([0, 2, 3])
    floor = 1.0
    expected = [
        np.linalg.norm(achieved[s] - desired[s]) / max(np.linalg.norm(desired[s]), floor)
        for s in (slice(0, 2), slice(2, 3), slice(3, 5))
    ]
    np.testing.assert_allclose(relative_shortfall(achieved, desired, starts, floor), expected, rtol=1e-15)
    np.testing.assert_allclose(expected, [0.2, 0.1, 0.5])  # by hand: 1/5, 0.1/floor, 1/2
    nan = relative_shortfall(np.full(5, np.nan), desired, starts, floor)
    assert np.isnan(nan).all()


def test_fallback_torques_hold_the_base_with_the_least_contact_forces_plus_the_posture_pd():
    """Unsaturated: the base's rows of −τ_g are carried by contact forces of least norm
    (lstsq here), the joints get the rest plus k_p e − k_d v; saturated: clipped, the cut
    is what the bound took."""
    rng = np.random.default_rng(5)
    n_base, na = 6, 8
    nv = n_base + na
    g = rng.normal(size=nv) * 10.0
    Jc = rng.normal(size=(12, nv))  # four 3-D contact points
    actuated = rng.permutation(na)
    error, velocity = rng.normal(size=na), rng.normal(size=na)
    gains = (50.0, 4.0)
    f = np.linalg.lstsq(Jc[:, :n_base].T, g[:n_base], rcond=None)[0]  # least-norm forces
    wanted = g[n_base:] - Jc[:, n_base:].T @ f
    wanted[actuated] += gains[0] * error - gains[1] * velocity
    tau, cut = fallback_torques(g, Jc, n_base, actuated, error, velocity, gains, np.full(na, np.inf))
    np.testing.assert_allclose(tau, wanted, rtol=1e-9, atol=1e-9)
    assert not cut.any()
    bound = np.abs(wanted) / 2.0 + 0.1
    bound[0] = np.inf
    tau, cut = fallback_torques(g, Jc, n_base, actuated, error, velocity, gains, bound)
    assert (np.abs(tau) <= bound).all()
    np.testing.assert_allclose(tau + cut, wanted, rtol=1e-9, atol=1e-9)
    clipped = np.abs(wanted) > bound
    assert clipped.sum() >= na - 2 and not cut[~clipped].any()
    np.testing.assert_allclose(np.abs(tau[clipped]), bound[clipped])
