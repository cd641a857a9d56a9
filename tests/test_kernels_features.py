"""The compiled 6D pose feature (Mansard et al. 2009, FeaturePoint6d) against its numpy oracle,
:func:`drake_sot.features.point6d_numpy`, on random poses: generic rotation errors, errors near the
identity (angle < 1e-6) and near π (within 1e-4 of it), where ``log`` takes its other branches.
Both must agree to 1e-12, relative to the size of what they return."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drake_sot import kernels, so3
from drake_sot.features import point6d, point6d_numpy

pytestmark = pytest.mark.skipif(
    kernels.compiled is None, reason=f"the compiled kernels are not loaded: {kernels.REASON}"
)


def _axis(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("angle", ["generic", "near identity", "near pi"])
def test_point6d_compiled_agree_with_numpy(angle):
    rng = np.random.default_rng(["generic", "near identity", "near pi"].index(angle))
    for _ in range(300):
        R_des = so3.exp(rng.normal(size=3))
        theta = {
            "generic": rng.uniform(0.0, math.pi),
            "near identity": rng.uniform(0.0, 1e-6),
            "near pi": math.pi - rng.uniform(0.0, 1e-4),
        }[angle]
        R = so3.exp(theta * _axis(rng)) @ R_des
        nv = int(rng.integers(1, 40))
        J = rng.normal(size=(6, nv))
        if rng.random() < 0.5:
            J = np.asfortranarray(J)  # as Drake's Jacobians arrive
        p, p_des = rng.normal(size=3), rng.normal(size=3)
        e, J_e = kernels.compiled.point6d(R, p, J, R_des, p_des)
        e_ref, J_ref = point6d_numpy(R, p, J, R_des, p_des)
        assert np.abs(e - e_ref).max() <= 1e-12 * max(np.abs(e_ref).max(), 1.0)
        assert np.abs(J_e - J_ref).max() <= 1e-12 * np.abs(J_ref).max()
        ff = rng.normal(size=6)
        assert np.array_equal(point6d(R, p, J, R_des, p_des, ff)[:2][1], J_e)


def test_point6d_compiled_refuses_a_jacobian_without_six_rows():
    with pytest.raises(ValueError, match="6 rows"):
        kernels.compiled.point6d(np.eye(3), np.zeros(3), np.zeros((3, 4)), np.eye(3), np.zeros(3))
