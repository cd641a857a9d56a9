"""The compiled 6D pose features against their numpy versions (the oracle), to 1e-12, on random
poses and Jacobians, the angles near 0 and near π included (the branches of the SO(3) log)."""

import numpy as np
import pytest
from kernel_paths import compiled_kernels

from drake_sot import features, so3


def _rotation(rng: np.random.Generator, angle: float | None = None) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return so3.exp(axis * (rng.uniform(0.0, np.pi) if angle is None else angle))


ANGLES = [None, None, None, 0.0, 1e-9, 1e-5, np.pi - 1e-3, np.pi - 1e-6, np.pi]


def _close(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape
    assert np.abs(a - b).max() <= 1e-12 * (1.0 + np.abs(b).max())


@pytest.mark.parametrize("seed", range(40))
def test_point6d_matches_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(seed)
    angle = ANGLES[seed % len(ANGLES)]
    R_des = _rotation(rng)
    R = so3.exp(so3.log(_rotation(rng, angle))) @ R_des  # R R*ᵀ at the chosen angle
    nv = int(rng.integers(1, 50))
    J = rng.normal(size=(6, nv))
    if seed % 2:
        J = np.asfortranarray(J)  # a Jacobian as Drake may give it
    p, p_des, velocity = rng.normal(size=3), rng.normal(size=3), rng.normal(size=6)
    for v in (None, velocity):
        got = core.point6d(R, p, J, R_des, p_des, v)
        expected = features.point6d_numpy(R, p, J, R_des, p_des, v)
        for a, b in zip(got, expected, strict=True):
            _close(a, b)


@pytest.mark.parametrize("seed", range(40))
def test_point6d_relative_matches_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(1000 + seed)
    R_a, R_b, R_des = _rotation(rng), _rotation(rng), _rotation(rng)
    angle = ANGLES[seed % len(ANGLES)]
    if angle is not None:
        R_a = R_b @ _rotation(rng, angle) @ R_des  # R_ba R*ᵀ at the chosen angle
    nv = int(rng.integers(1, 50))
    args = (R_a, rng.normal(size=3), rng.normal(size=(6, nv)), R_b, rng.normal(size=3))
    args += (rng.normal(size=(6, nv)), R_des, rng.normal(size=3))
    got = core.point6d_relative(*args)
    expected = features.point6d_relative_numpy(*args)
    for a, b in zip(got, expected, strict=True):
        _close(a, b)
