"""Free-flyer integration on SE(3) against scipy rotations and its inverse."""

import numpy as np
from scipy.spatial.transform import Rotation

from drake_sot.configuration import difference, integrate, quaternion_to_rotation


def _random_q(rng, n_joints=4):
    quat_xyzw = Rotation.random(random_state=rng).as_quat()
    wxyz = np.roll(quat_xyzw, 1)
    return np.concatenate((wxyz, rng.normal(size=3), rng.normal(size=n_joints)))


def test_quaternion_to_rotation_matches_scipy():
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = _random_q(rng)
        R = Rotation.from_quat(np.roll(q[:4], -1)).as_matrix()
        np.testing.assert_allclose(quaternion_to_rotation(q[:4]), R, atol=1e-12)


def test_integrate_rotates_with_world_angular_velocity():
    rng = np.random.default_rng(1)
    q = _random_q(rng)
    v = rng.normal(size=10)
    dt = 0.37
    q1 = integrate(q, v, dt)
    R0 = quaternion_to_rotation(q[:4])
    expected_R = Rotation.from_rotvec(v[:3] * dt).as_matrix() @ R0
    np.testing.assert_allclose(quaternion_to_rotation(q1[:4]), expected_R, atol=1e-12)
    np.testing.assert_allclose(q1[4:7], q[4:7] + dt * v[3:6], atol=1e-12)
    np.testing.assert_allclose(q1[7:], q[7:] + dt * v[6:], atol=1e-12)
    assert abs(np.linalg.norm(q1[:4]) - 1.0) < 1e-14


def test_difference_inverts_integrate():
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = _random_q(rng)
        v = rng.normal(size=10)
        np.testing.assert_allclose(difference(q, integrate(q, v, 1.0)), v, atol=1e-9)


def test_fixed_base_is_linear():
    q = np.array([0.1, 0.2])
    np.testing.assert_allclose(integrate(q, np.array([1.0, -1.0]), 0.5, floating_base=False), [0.6, -0.3])
