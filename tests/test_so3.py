"""SO(3) exp/log and the log's Jacobian, checked against scipy and finite differences."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from drake_sot import so3

vectors = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)


@given(vectors)
def test_exp_matches_scipy(w):
    np.testing.assert_allclose(so3.exp(w), Rotation.from_rotvec(w).as_matrix(), atol=1e-12)


@given(vectors)
def test_log_inverts_exp(w):
    R = Rotation.from_rotvec(w).as_matrix()
    np.testing.assert_allclose(so3.exp(so3.log(R)), R, atol=1e-9)
    if np.linalg.norm(w) < np.pi - 1e-3:
        np.testing.assert_allclose(so3.log(R), w, atol=1e-9)


def test_log_near_pi_and_identity():
    for axis in (np.array([1.0, 0, 0]), np.array([0, 1.0, 1.0]) / np.sqrt(2), np.array([0.3, -0.5, 0.8])):
        axis = axis / np.linalg.norm(axis)
        for angle in (np.pi, np.pi - 1e-7, 1e-9, 0.0):
            R = Rotation.from_rotvec(angle * axis).as_matrix()
            w = so3.log(R)
            np.testing.assert_allclose(so3.exp(w), R, atol=1e-8)
            assert abs(np.linalg.norm(w) - angle) < 1e-7


@settings(max_examples=50)
@given(vectors, vectors)
def test_left_jacobian_inverse_is_derivative_of_log(w, omega):
    """d/dt log(exp(ε ω) X) at ε = 0 equals J_l⁻¹(log X) ω (central differences)."""
    if np.linalg.norm(w) > np.pi - 0.05:
        w = w * (np.pi - 0.1) / np.linalg.norm(w)
    X = so3.exp(w)
    h = 1e-6
    fd = (so3.log(so3.exp(h * omega) @ X) - so3.log(so3.exp(-h * omega) @ X)) / (2 * h)
    np.testing.assert_allclose(so3.left_jacobian_inverse(w) @ omega, fd, atol=1e-6)
    fd_right = (so3.log(X @ so3.exp(h * omega)) - so3.log(X @ so3.exp(-h * omega))) / (2 * h)
    np.testing.assert_allclose(so3.right_jacobian_inverse(w) @ omega, fd_right, atol=1e-6)


@given(vectors, vectors)
def test_cross_is_the_cross_product(a, b):
    # Against numpy's, and against the skew matrix [a]_x b.
    np.testing.assert_allclose(so3.cross(a, b), np.cross(a, b), atol=1e-12)
    np.testing.assert_allclose(so3.cross(a, b), so3.hat(a) @ b, atol=1e-12)
