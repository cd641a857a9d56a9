"""The visual point's interaction matrix (Chaumette & Hutchinson 2006) against finite differences
of a moving camera, without Drake: the camera pose is moved by a twist in its own frame."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from drake_sot.features import MIN_DEPTH, interaction_matrix, visual_point


def _image(R_WC, p_WC, p_WP):
    X, Y, Z = R_WC.T @ (p_WP - p_WC)
    return np.array([X / Z, Y / Z])


@pytest.mark.parametrize("seed", range(5))
def test_interaction_matrix_is_the_image_rate_of_a_camera_twist(seed):
    rng = np.random.default_rng(seed)
    R_WC = Rotation.random(random_state=seed).as_matrix()
    p_WC = rng.normal(size=3)
    p_WP = p_WC + R_WC @ (np.array([*rng.uniform(-1, 1, 2), 1.0]) * rng.uniform(0.3, 3.0))
    twist = rng.normal(size=6)  # [v; ω] of the camera, in the camera frame

    def moved(h):  # the camera after h seconds at that twist (body-frame velocities)
        return R_WC @ Rotation.from_rotvec(twist[3:] * h).as_matrix(), p_WC + R_WC @ twist[:3] * h

    h = 1e-6
    rate = (_image(*moved(h), p_WP) - _image(*moved(-h), p_WP)) / (2 * h)
    x, y = _image(R_WC, p_WC, p_WP)
    depth = (R_WC.T @ (p_WP - p_WC))[2]
    np.testing.assert_allclose(interaction_matrix(x, y, depth) @ twist, rate, rtol=1e-7, atol=1e-8)


def test_visual_point_error_jacobian_and_feedforward_by_finite_differences():
    """A camera carried by a random linear 'robot': p_WC(q) = p0 + A q, R_WC(q) = R0 exp(B q),
    whose Jacobian [ω; v] in world is [R0 B; A] at q = 0."""
    rng = np.random.default_rng(9)
    nv = 7
    R0 = Rotation.random(random_state=3).as_matrix()
    p0 = rng.normal(size=3)
    A, B = rng.normal(size=(3, nv)), rng.normal(size=(3, nv))
    J_C = np.vstack((R0 @ B, A))  # ω in world = R0 (B q̇) for a body-frame rotation vector
    p_WP = p0 + R0 @ np.array([0.3, -0.2, 1.5])
    s_des = np.array([0.02, -0.04])

    def error(q, p=p_WP):
        return visual_point(R0 @ Rotation.from_rotvec(B @ q).as_matrix(), p0 + A @ q, J_C, p, s_des)[0]

    e, J_e, feedforward = visual_point(R0, p0, J_C, p_WP, s_des)
    np.testing.assert_allclose(e, _image(R0, p0, p_WP) - s_des, atol=1e-15)
    np.testing.assert_array_equal(feedforward, 0.0)
    h = 1e-6
    for k in range(nv):
        dq = np.zeros(nv)
        dq[k] = h
        np.testing.assert_allclose(J_e[:, k], (error(dq) - error(-dq)) / (2 * h), rtol=1e-6, atol=1e-8)
    velocity = rng.normal(size=3)
    _, _, feedforward = visual_point(R0, p0, J_C, p_WP, s_des, velocity)
    de_dt = (error(np.zeros(nv), p_WP + velocity * h) - error(np.zeros(nv), p_WP - velocity * h)) / (2 * h)
    np.testing.assert_allclose(feedforward, -de_dt, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("depth", [0.0, -1.0, MIN_DEPTH, float("nan"), float("inf")])
def test_a_point_not_in_front_of_the_camera_is_refused_naming_its_depth(depth):
    with pytest.raises(ValueError, match=f"depth Z = {depth!r} m: the point must be in front of the camera"):
        interaction_matrix(0.1, 0.2, depth)
    if np.isfinite(depth):
        with pytest.raises(ValueError, match="depth Z = .* m: the point must be in front"):
            visual_point(np.eye(3), np.zeros(3), np.zeros((6, 2)), np.array([0.0, 0.0, depth]), np.zeros(2))
