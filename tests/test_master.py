"""The master site (Evrard et al. 2009, IV): eq. 9, base placement, bounded base motion, operator."""

import math

import numpy as np
import pytest

from drake_sot.master import (
    BaseLimits,
    BaseMotion,
    base_placement,
    desired_position,
    operator_force,
    piecewise_linear_path,
)

S, R_OPT = 0.25, 0.45  # shoulder half-width, radius of best manipulability [m]


def test_eq9_the_desired_position_is_offset_plus_slave_minus_base():
    x_delta, x_s, x_b = np.array([0.01, -0.02, 0.0]), np.array([0.5, -0.2, 1.0]), np.array([0.3, 0.1, 0.0])
    np.testing.assert_allclose(desired_position(x_delta, x_s, x_b), [0.21, -0.32, 1.0])


def _shoulders(pose):
    x, y, yaw = pose
    lateral = np.array([-math.sin(yaw), math.cos(yaw)])
    c = np.array([x, y])
    return c + S * lateral, c - S * lateral, np.array([math.cos(yaw), math.sin(yaw)]), lateral


@pytest.mark.parametrize("seed", range(5))
def test_base_placement_puts_both_hands_on_their_circles_symmetrically(seed):
    rng = np.random.default_rng(seed)
    mid = rng.uniform(-2, 2, 2)
    heading = rng.uniform(-math.pi, math.pi)
    half = rng.uniform(0.15, 0.4)  # half the hands' distance, reachable
    lateral = np.array([-math.sin(heading), math.cos(heading)])
    left = np.r_[mid + half * lateral, rng.uniform(0.8, 1.2)]
    right = np.r_[mid - half * lateral, rng.uniform(0.8, 1.2)]
    pose = base_placement(left, right, shoulder_half_width=S, r_opt=R_OPT)
    sl, sr, forward, lat = _shoulders(pose)
    # Both end-effectors on circles of radius r_opt around the shoulders (horizontal plane).
    assert np.linalg.norm(left[:2] - sl) == pytest.approx(R_OPT)
    assert np.linalg.norm(right[:2] - sr) == pytest.approx(R_OPT)
    # The platform parallel to the line x_R -> x_L, the hands in front of it.
    assert abs(lat[0] * (left - right)[1] - lat[1] * (left - right)[0]) < 1e-9
    assert forward @ (left[:2] - sl) > 0 and forward @ (right[:2] - sr) > 0
    # Equal first-joint angles: the arms are mirror images about the forward axis.
    a_l, a_r = left[:2] - sl, right[:2] - sr
    assert forward @ a_l == pytest.approx(forward @ a_r)
    assert lat @ a_l == pytest.approx(-(lat @ a_r))


def test_the_placement_maximises_the_smaller_manipulability_over_a_grid():
    """A brute-force search over platform poses (distance to the circles as the manipulability
    loss of each arm, Yoshikawa's measure peaking on the circle) finds no better pose."""
    left, right = np.array([0.6, 0.35, 1.0]), np.array([0.7, -0.3, 1.0])

    def worst_loss(pose):
        sl, sr, _, _ = _shoulders(pose)
        return max(abs(np.linalg.norm(left[:2] - sl) - R_OPT), abs(np.linalg.norm(right[:2] - sr) - R_OPT))

    best = base_placement(left, right, shoulder_half_width=S, r_opt=R_OPT)
    grid = [
        (x, y, yaw)
        for x in np.linspace(-0.5, 1.0, 31)
        for y in np.linspace(-0.6, 0.6, 25)
        for yaw in np.linspace(-0.6, 0.6, 13)
    ]
    assert worst_loss(best) < 1e-9
    assert min(worst_loss(p) for p in grid) >= worst_loss(best)


def test_the_placement_refuses_coincident_hands_by_name():
    with pytest.raises(ValueError, match="must not coincide"):
        base_placement([1, 0, 1], [1, 0, 0.5], shoulder_half_width=S, r_opt=R_OPT)
    with pytest.raises(ValueError, match="r_opt"):
        base_placement([1, 0, 1], [1, -0.5, 1], shoulder_half_width=S, r_opt=float("nan"))


def test_the_base_moves_within_its_speed_and_acceleration_bounds_and_arrives():
    limits = BaseLimits(speed=0.4, acceleration=0.3, yaw_rate=0.3, yaw_acceleration=0.6)
    dt = 0.005
    motion = BaseMotion(limits, dt)
    pose, velocity = np.zeros(3), np.zeros(3)
    target = np.array([2.0, 0.5, 0.4])
    poses, velocities = [pose], [velocity]
    for _ in range(int(15 / dt)):
        pose, velocity = motion.step(pose, velocity, target)
        poses.append(pose)
        velocities.append(velocity)
    v = np.array(velocities)
    a = np.diff(v, axis=0) / dt
    assert np.linalg.norm(v[:, :2], axis=1).max() <= limits.speed + 1e-12
    assert np.abs(v[:, 2]).max() <= limits.yaw_rate + 1e-12
    assert np.linalg.norm(a[:, :2], axis=1).max() <= limits.acceleration + 1e-9
    assert np.abs(a[:, 2]).max() <= limits.yaw_acceleration + 1e-9
    np.testing.assert_allclose(pose, target, atol=1e-3)
    # No overshoot past the target along the way.
    assert np.max(np.array(poses)[:, 0]) <= target[0] + 1e-3


def test_the_operator_pulls_the_hand_towards_the_intention_like_a_spring_damper():
    f = operator_force(200.0, 20.0, [1.0, 0.0, 1.0], [0.1, 0.0, 0.0], [0.9, 0.05, 1.0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(f, [200 * 0.1 + 20 * 0.1, -200 * 0.05, 0.0])
    with pytest.raises(ValueError, match="stiffness"):
        operator_force(0.0, 1.0, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))


def test_a_piecewise_linear_path_walks_2m_forward_then_half_a_metre_sideways():
    path = piecewise_linear_path([0, 0, 0], [[2, 0, 0], [2, -0.5, 0]], 0.2, t0=1.0)
    np.testing.assert_allclose(path(0.5)[0], [0, 0, 0])
    p, v = path(6.0)
    np.testing.assert_allclose(p, [1.0, 0, 0])
    np.testing.assert_allclose(v, [0.2, 0, 0])
    p, v = path(1.0 + 10.0 + 1.0)
    np.testing.assert_allclose(p, [2.0, -0.2, 0])
    np.testing.assert_allclose(v, [0, -0.2, 0])
    np.testing.assert_allclose(path(100.0)[0], [2.0, -0.5, 0])
    np.testing.assert_allclose(path(100.0)[1], 0.0)
