"""The pure side of the inequality tasks (drake_sot.inequalities): velocity-damper bounds,
the quantities' Jacobians against finite differences, support polygons by hand."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot import inequalities as ineq
from drake_sot import so3

EPS = 1e-6


# --- velocity bounds ----------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-5, 5),
    st.floats(-3, 3),
    st.floats(0, 3),
    st.floats(0.1, 200),
    st.floats(0, 10),
    st.booleans(),
)
def test_bounds_are_ordered_and_an_euler_step_stays_inside(s, s_min, width, gain, rate, with_rates):
    """lower <= upper always; with λ = 1/dt and no rate bound, s + dt·ṡ lands inside [s_min, s_max]
    for every ṡ in the bounds (exactly on a bound at the bound's value)."""
    s_max = s_min + width
    rates = (-rate, rate) if with_rates else (-np.inf, np.inf)
    lower, upper = ineq.velocity_bounds(np.array([s]), s_min, s_max, gain, *rates)
    assert lower[0] <= upper[0]
    assert rates[0] <= lower[0] and upper[0] <= rates[1]
    if not with_rates:
        dt = 1.0 / gain
        assert s + dt * lower[0] == pytest.approx(s_min, abs=1e-9)
        assert s + dt * upper[0] == pytest.approx(s_max, abs=1e-9)


def test_bounds_by_hand():
    # s = 1 in [0, 3], λ = 2: -2 <= ṡ <= 4; with rates ±3: -2 <= ṡ <= 3.
    np.testing.assert_allclose(ineq.velocity_bounds([1.0], 0.0, 3.0, 2.0), [[-2.0], [4.0]])
    np.testing.assert_allclose(ineq.velocity_bounds([1.0], 0.0, 3.0, 2.0, -3.0, 3.0), [[-2.0], [3.0]])
    # Far below the set, both bounds ask to rise, capped at the rate: 3 <= ṡ <= 3.
    np.testing.assert_allclose(ineq.velocity_bounds([-10.0], 0.0, 3.0, 2.0, -3.0, 3.0), [[3.0], [3.0]])
    # One-sided: s >= 0.5 only.
    np.testing.assert_allclose(ineq.velocity_bounds([1.0], 0.5, np.inf, 2.0), [[-1.0], [np.inf]])
    np.testing.assert_allclose(ineq.outside([-1.0, 1.0, 4.0], 0.0, 3.0), [-1.0, 0.0, 1.0])


# --- Jacobians against finite differences ---------------------------------------------------


def moving_frame(rng, nv=7):
    """A frame (R, p) with a random Jacobian J (6, nv), and its pose after moving at J q̇ for t."""
    R, p, J = so3.exp(rng.normal(size=3)), rng.normal(size=3), rng.normal(size=(6, nv))
    qdot = rng.normal(size=nv)

    def at(t):
        return so3.exp(t * (J[:3] @ qdot)) @ R, p + t * (J[3:] @ qdot)

    return R, p, J, qdot, at


def test_point_in_frame_jacobian():
    rng = np.random.default_rng(0)
    for _ in range(5):
        R, p, J, qdot, at = moving_frame(rng)
        offset = rng.normal(size=3)
        point, Jp = ineq.point_in_frame(R, p, J, offset)
        np.testing.assert_allclose(point, p + R @ offset, atol=1e-15)
        fd = (ineq.point_in_frame(*at(EPS), J, offset)[0] - ineq.point_in_frame(*at(-EPS), J, offset)[0]) / (
            2 * EPS
        )
        np.testing.assert_allclose(Jp @ qdot, fd, atol=1e-7 * (1 + np.linalg.norm(fd)))


def test_clearance_and_distance_jacobians():
    """Two frames moving with the same q̇ (Jacobians J_a, J_b): a point of a above a plane,
    and its distance to a point of b."""
    rng = np.random.default_rng(1)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    origin = rng.normal(size=3)
    nv = 7
    for _ in range(5):
        qdot = rng.normal(size=nv)
        frames = [(so3.exp(rng.normal(size=3)), rng.normal(size=3), rng.normal(size=(6, nv))) for _ in "ab"]
        offsets = rng.normal(size=(2, 3))

        def quantities(t, frames=frames, offsets=offsets, qdot=qdot):
            points = [
                ineq.point_in_frame(so3.exp(t * (J[:3] @ qdot)) @ R, p + t * (J[3:] @ qdot), J, off)
                for (R, p, J), off in zip(frames, offsets, strict=True)
            ]
            (pa, Ja), (pb, Jb) = points
            plane = ineq.clearance_above_plane(pa, Ja, normal, origin)
            distance = ineq.point_distance(pa, Ja, pb, Jb)
            return plane, distance, pa, pb

        (s_plane, J_plane), (s_dist, J_dist), pa, pb = quantities(0.0)
        assert s_plane[0] == pytest.approx(float(normal @ (pa - origin)), abs=1e-15)
        assert s_dist[0] == pytest.approx(float(np.linalg.norm(pa - pb)), abs=1e-15)
        plus, minus = quantities(EPS), quantities(-EPS)
        np.testing.assert_allclose(J_plane @ qdot, (plus[0][0] - minus[0][0]) / (2 * EPS), atol=1e-7)
        np.testing.assert_allclose(J_dist @ qdot, (plus[1][0] - minus[1][0]) / (2 * EPS), atol=1e-7)


def test_coincident_points_give_a_zero_row():
    s, J = ineq.point_distance(np.ones(3), np.eye(3), np.ones(3), np.zeros((3, 3)))
    assert s[0] == 0.0 and not J.any()


# --- distances between bodies (self-collision) --------------------------------------------


def test_distance_rows_by_hand():
    """Two pairs in four rows: ``J_d = nᵀ (J_A - J_B)`` and the bound of Kanoun et al. 2011,
    ``ḋ >= -ξ (d - d_s) / (d_i - d_s)``, written out; the rows beyond the pairs are free."""
    d_s, d_i, xi = 0.01, 0.05, 0.2
    gain = ineq.distance_damper_gain("test", d_s, d_i, xi)
    assert gain == pytest.approx(5.0)
    distances = np.array([0.03, 0.005])  # the second already inside the margin
    normals = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
    J_a = np.zeros((2, 3, 3))
    J_b = np.zeros((2, 3, 3))
    J_a[0, 2] = [1.0, 2.0, 3.0]  # pair 0: A's witness point rises with q̇
    J_b[0, 2] = [0.0, 0.0, 1.0]
    J_b[1, 0] = [1.0, 0.0, 0.0]  # pair 1: B's point moves along x, A's stands
    error, J, lower, upper = ineq.distance_rows(distances, normals, J_a, J_b, d_s, gain, 4)
    np.testing.assert_allclose(J, [[1.0, 2.0, 2.0], [-0.6, 0.0, 0.0], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(lower[:2], [-0.2 * 0.02 / 0.04, -0.2 * -0.005 / 0.04])
    assert np.isneginf(lower[2:]).all() and np.isposinf(upper).all()
    np.testing.assert_allclose(error, [0.0, -0.005, 0.0, 0.0])
    with pytest.raises(ValueError, match="3 pairs of bodies: more than the 2 rows"):
        ineq.distance_rows(
            np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3, 1)), np.zeros((3, 3, 1)), d_s, gain, 2
        )
    # With a recovery gain, only the pair inside the margin changes: 200/s × the 5 mm lost.
    _, J_r, lower_r, upper_r = ineq.distance_rows(distances, normals, J_a, J_b, d_s, gain, 4, 200.0)
    np.testing.assert_allclose(lower_r[:2], [-0.2 * 0.02 / 0.04, 200.0 * 0.005])
    np.testing.assert_array_equal(J_r, J)
    assert np.isneginf(lower_r[2:]).all() and np.isposinf(upper_r).all()


@pytest.mark.parametrize(
    ("d_s", "d_i", "xi", "message"),
    [
        (float("nan"), 0.05, 0.2, "safety margin d_s = nan m: must be finite and >= 0"),
        (-0.01, 0.05, 0.2, "safety margin d_s = -0.01 m: must be finite and >= 0"),
        (0.01, float("nan"), 0.2, "activation distance d_i = nan: must be a finite number"),
        (0.01, 0.01, 0.2, "activation distance d_i = 0.01 m: must be > the safety margin d_s = 0.01 m"),
        (0.05, 0.02, 0.2, "activation distance d_i = 0.02 m: must be > the safety margin d_s = 0.05 m"),
        (0.01, float("inf"), 0.2, "activation distance d_i = inf: must be a finite number"),
        (0.01, 0.05, float("nan"), "ξ = nan m/s: must be finite and > 0"),
        (0.01, 0.05, 0.0, "ξ = 0.0 m/s: must be finite and > 0"),
        (0.01, 0.05, -1.0, "ξ = -1.0 m/s: must be finite and > 0"),
    ],
)
def test_bad_distance_damper_parameters_are_refused_by_name(d_s, d_i, xi, message):
    with pytest.raises(ValueError, match=f"^arms: {message}"):
        ineq.distance_damper_gain("arms", d_s, d_i, xi)


# --- polygons -----------------------------------------------------------------------------


def test_polygon_edges_of_a_square_by_hand():
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    normals, offsets = ineq.polygon_edges(square)
    # (0.5, 0.25) is 0.25 above the bottom edge, 1.5 left of the right one, 0.75 below the top
    # and 0.5 right of the left one.
    np.testing.assert_allclose(normals @ [0.5, 0.25] - offsets, [0.25, 1.5, 0.75, 0.5], atol=1e-15)
    np.testing.assert_allclose(normals, [[0, 1], [-1, 0], [0, -1], [1, 0]], atol=1e-15)


@pytest.mark.parametrize(
    ("vertices", "message"),
    [
        ([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]], "counter-clockwise and convex"),
        ([[0, 0], [2, 0], [1, 0.2], [2, 1], [0, 1]], "counter-clockwise and convex"),
        ([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], "edge 0 has zero length"),
        ([[0.0, 0.0], [1.0, 0.0]], "needs >= 3 vertices, got 2"),
        ([[0.0, 0.0, 0.0]], r"must be a matrix of shape \(n, 2\)"),
        ([[0.0, 0.0], [np.nan, 0.0], [0.0, 1.0]], "contains NaN"),
    ],
)
def test_bad_polygons_are_refused(vertices, message):
    with pytest.raises(ValueError, match=message):
        ineq.polygon_edges(np.array(vertices, dtype=float))


def test_feet_polygon_by_hand():
    size = (0.2, 0.1)
    left = (np.eye(3), np.array([0.0, 0.1, 0.0]))
    right = (np.eye(3), np.array([0.0, -0.1, 0.0]))
    both = ineq.feet_polygon([left, right], [1.0, 1.0], size)
    # Two 0.2 x 0.1 soles 0.2 apart: the hull is the rectangle x in [-0.1, 0.1], y in [-0.15, 0.15].
    np.testing.assert_allclose(
        np.sort(both, axis=0), [[-0.1, -0.15], [-0.1, -0.15], [0.1, 0.15], [0.1, 0.15]]
    )
    normals, offsets = ineq.polygon_edges(both)  # counter-clockwise, convex
    assert normals.shape == (4, 2)
    only_left = ineq.feet_polygon([left, right], [1.0, 0.0], size)
    np.testing.assert_allclose(
        np.sort(only_left, axis=0), [[-0.1, 0.05], [-0.1, 0.05], [0.1, 0.15], [0.1, 0.15]]
    )
    # A sole turned by 90°: its long side along y.
    turned = (so3.exp(np.array([0.0, 0.0, np.pi / 2])), np.zeros(3))
    np.testing.assert_allclose(
        np.ptp(ineq.feet_polygon([turned], [1.0], size), axis=0), [0.1, 0.2], atol=1e-12
    )
    with pytest.raises(ValueError, match="no foot in contact"):
        ineq.feet_polygon([left, right], [0.0, 0.0], size)
