"""The compiled distance-damper rows (self-collision avoidance) against their numpy version, to
1e-12, on random pairs: inside and outside the margin, with and without a recovery gain, fewer pairs
than rows, and Jacobians given as views (the witness points' rows are every other one)."""

import numpy as np
import pytest
from kernel_paths import compiled_kernels

from drake_sot.inequalities import distance_rows_numpy


@pytest.mark.parametrize("seed", range(30))
def test_distance_rows_match_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(seed)
    rows, nv = int(rng.integers(1, 9)), int(rng.integers(1, 45))
    k = int(rng.integers(0, rows + 1))
    margin = float(rng.uniform(0.001, 0.05))
    distances = rng.uniform(-0.02, 0.1, size=k)
    normals = rng.normal(size=(k, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True) if k else 1.0
    both = rng.normal(size=(2 * k, 3, nv))
    J_a, J_b = both[0::2], both[1::2]  # views, as the self-collision system gives them
    gain = float(rng.uniform(1.0, 100.0))
    recovery = None if seed % 2 else gain * float(rng.uniform(1.0, 5.0))
    got = core.distance_rows(distances, normals, J_a, J_b, margin, gain, rows, recovery)
    expected = distance_rows_numpy(distances, normals, J_a, J_b, margin, gain, rows, recovery)
    for a, b in zip(got, expected, strict=True):
        assert a.shape == b.shape
        assert np.array_equal(np.isinf(a), np.isinf(b))
        finite = np.isfinite(b)
        assert np.abs(a[finite] - b[finite]).max(initial=0.0) <= 1e-12 * (
            1.0 + np.abs(b[finite]).max(initial=0)
        )


def test_more_pairs_than_rows_is_refused_as_by_numpy():
    core = compiled_kernels()
    J = np.zeros((3, 3, 4))
    with pytest.raises(ValueError, match="3 pairs of bodies: more than the 2 rows"):
        core.distance_rows(np.zeros(3), np.zeros((3, 3)), J, J, 0.01, 10.0, 2, None)
    with pytest.raises(ValueError, match="3 pairs of bodies: more than the 2 rows"):
        distance_rows_numpy(np.zeros(3), np.zeros((3, 3)), J, J, 0.01, 10.0, 2, None)
