"""The compiled kernels of the torque family (Liu, Lober, Padois 2016) against their numpy oracles,
on random inputs shaped like a controller's: the projected Jacobians ``J_i P_i(A_i)`` of eq. 8
(:class:`drake_sot.generalized.ProjectedJacobians`) and the task-space inertia weighting of eq. 2
(:func:`drake_sot.generalized.inertia_weighted`). Both must agree to 1e-12, relative to the size of
what they are given; where the compiled kernel declines (a mass matrix that is not positive
definite, dependent rows), the numpy version runs and its answer or error is the public one."""

from __future__ import annotations

import numpy as np
import pytest

from drake_sot import kernels
from drake_sot.generalized import ProjectedJacobians, inertia_weighted, inertia_weighted_numpy

pytestmark = pytest.mark.skipif(
    kernels.compiled is None, reason=f"the compiled kernels are not loaded: {kernels.REASON}"
)

#: Agreement of the compiled and numpy kernels, relative to the size of the input.
AGREEMENT = 1e-12


def _alpha(rng: np.random.Generator, n: int) -> np.ndarray:
    """α (n, n) as a scheduler makes it: mostly 0 and 1, some transitions, rows shared by tasks."""
    alpha = rng.choice([0.0, 1.0], size=(n, n), p=[0.5, 0.5])
    soft = rng.random((n, n)) < 0.2
    alpha[soft] = rng.choice([0.25, 0.5, rng.random()], size=int(soft.sum()))
    for i in range(n):
        if rng.random() < 0.3:  # the same α row as another task (both hands' orientation tasks)
            alpha[i] = alpha[rng.integers(n)]
    return alpha


def _stacked(rng: np.random.Generator, dims: list[int], nv: int) -> np.ndarray:
    """Task Jacobians stacked: random rows, some zero (switched off), some copied or combined from
    others (dependent), then some scaled to 1e-170 or 1e200 (squared norms out of range; a row's
    scale does not change its direction, so the rows stay as far from dependent as they were:
    the agreement tested is the kernels', not the conditioning of nearly dependent rows)."""
    J = rng.normal(size=(sum(dims), nv))
    J[:, rng.random(nv) < 0.2] = 0.0  # joints outside a chain
    for k in range(J.shape[0]):
        u = rng.random()
        if u < 0.08:
            J[k] = 0.0
        elif u < 0.16 and k:
            J[k] = rng.normal() * J[rng.integers(k)]
        elif u < 0.22 and k > 1:
            J[k] = J[rng.integers(k)] - 2.0 * J[rng.integers(k)]
    scaled = rng.random(J.shape[0]) < 0.1
    J[scaled] *= rng.choice([1e-170, 1e200, 1e-9, 1e6], size=(int(scaled.sum()), 1))
    return J


@pytest.mark.parametrize("seed", range(6))
def test_projected_jacobians_compiled_agree_with_numpy(seed):
    """Tick after tick (α changing now and then, as in a transition), the compiled J_i P_i(A_i)
    equals numpy's, each row within 1e-12 of its own Jacobian row's size."""
    rng = np.random.default_rng(seed)
    cases = 0
    while cases < 60:
        n = int(rng.integers(1, 13))
        dims = [int(m) for m in rng.integers(0, 7, size=n)]
        if not sum(dims):
            continue
        nv = int(rng.integers(2, 40))
        project = ProjectedJacobians(dims)
        alpha = _alpha(rng, n)
        for _ in range(4):
            if rng.random() < 0.5:
                alpha = _alpha(rng, n)
            stacked = _stacked(rng, dims, nv)
            compiled = project(stacked, alpha, np.empty_like(stacked))
            oracle = project.numpy(stacked, alpha, np.empty_like(stacked))
            size = np.abs(stacked).max(axis=1, keepdims=True)
            assert np.all(np.abs(compiled - oracle) <= AGREEMENT * size), (
                f"dims {dims}, nv {nv}: largest relative gap "
                f"{np.max(np.abs(compiled - oracle) / np.where(size > 0, size, 1.0)):.3g}"
            )
        cases += 1


def test_projected_jacobians_compiled_refuse_shapes_that_do_not_match():
    project = ProjectedJacobians([2, 3])
    stacked = np.ones((5, 4))
    with pytest.raises(ValueError, match="do not describe the 5 stacked rows"):
        project(stacked, np.zeros((3, 3)), np.empty((5, 4)))
    with pytest.raises(ValueError, match="out must have the shape of stacked"):
        project(stacked, np.zeros((2, 2)), np.empty((4, 4)))
    with pytest.raises(TypeError):  # out is written in place: a strided view is not taken
        project(stacked, np.zeros((2, 2)), np.empty((4, 5)).T)


def _mass_matrix(rng: np.random.Generator, nv: int) -> np.ndarray:
    """A mass matrix with the spread of a humanoid's (light hands, heavy base)."""
    X = rng.normal(size=(nv, nv)) * np.logspace(0, -1, nv)
    return X @ X.T + np.diag(np.logspace(1, -1, nv))


def _tasks(dims: list[int]) -> tuple[list[slice], np.ndarray]:
    ends = np.cumsum(dims)
    tasks = [slice(int(e - m), int(e)) for e, m in zip(ends, dims, strict=True)]
    blocks = np.zeros((sum(dims), sum(dims)), dtype=bool)
    for rows in tasks:
        blocks[rows, rows] = True
    return tasks, blocks


@pytest.mark.parametrize("seed", range(4))
def test_inertia_weighted_compiled_agree_with_numpy(seed):
    """Λ_i a_i of the compiled Cholesky path equals numpy's within 1e-12 of its largest entry,
    zero rows (inactive joint limits) included. Tasks of at most nv/2 rows keep J_i M⁻¹ J_iᵀ as
    well conditioned as a humanoid's tasks away from singularities (condition numbers up to a few
    hundred): two correct Cholesky solves differ by rounding times that condition."""
    rng = np.random.default_rng(100 + seed)
    for _ in range(100):
        nv = int(rng.integers(6, 40))
        dims = [int(m) for m in rng.integers(1, min(nv // 2, 7), size=int(rng.integers(1, 9)))]
        tasks, blocks = _tasks(dims)
        J = rng.normal(size=(sum(dims), nv))
        J[rng.random(J.shape[0]) < 0.1] = 0.0
        M = _mass_matrix(rng, nv)
        a = rng.normal(size=J.shape[0]) * 10.0
        compiled = kernels.compiled.inertia_weighted(J, [t.start for t in tasks] + [J.shape[0]], M, a, 1e-10)
        oracle = inertia_weighted_numpy(J, tasks, M, a, blocks, 1e-8)
        assert compiled is not None, f"dims {dims}, nv {nv}: independent rows declined"
        assert np.abs(compiled - oracle).max() <= AGREEMENT * np.abs(oracle).max(), (
            f"dims {dims}, nv {nv}: gap {np.abs(compiled - oracle).max() / np.abs(oracle).max():.3g}"
        )
        assert np.array_equal(inertia_weighted(J, tasks, M, a, blocks, 1e-8), compiled)


def test_inertia_weighted_compiled_declines_where_numpy_takes_the_pseudo_inverse():
    """Dependent rows in a task, or a mass matrix that is not positive definite: the kernel gives
    None and the public function answers as numpy does (pseudo-inverses, or the named error)."""
    rng = np.random.default_rng(7)
    nv = 9
    M = _mass_matrix(rng, nv)
    J = rng.normal(size=(5, nv))
    J[4] = J[2] - 0.5 * J[3]  # the second task (rows 2-4) has rank 2
    tasks, blocks = _tasks([2, 3])
    a = rng.normal(size=5)
    assert kernels.compiled.inertia_weighted(J, [0, 2, 5], M, a, 1e-10) is None
    np.testing.assert_array_equal(
        inertia_weighted(J, tasks, M, a, blocks, 1e-8), inertia_weighted_numpy(J, tasks, M, a, blocks, 1e-8)
    )
    indefinite = np.diag([1.0, -1.0, 1.0])
    assert kernels.compiled.inertia_weighted(np.eye(3), [0, 3], indefinite, np.ones(3), 1e-10) is None
    with pytest.raises(RuntimeError, match="not positive definite"):
        inertia_weighted(np.eye(3), [slice(0, 3)], indefinite, np.ones(3), np.ones((3, 3), dtype=bool), 1e-8)


def test_inertia_weighted_compiled_refuse_shapes_that_do_not_match():
    with pytest.raises(ValueError, match=r"J \(3, 4\), M \(3, 3\)"):
        kernels.compiled.inertia_weighted(np.ones((3, 4)), [0, 3], np.eye(3), np.ones(3), 1e-10)
    with pytest.raises(ValueError, match="task starts"):
        kernels.compiled.inertia_weighted(np.ones((3, 3)), [0, 2], np.eye(3), np.ones(3), 1e-10)
