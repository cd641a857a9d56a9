"""DCM stabilization: the desired ZMP makes the DCM error decay at k_ξ (Englsberger et al. 2015),
the CoM offset returns to zero on a robot that tracks it, limits are reported."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drake_sot.stabilization import (
    GRAVITY,
    HandLoad,
    StabilizerGains,
    divergent_component,
    natural_frequency,
    project_into_polygon,
    stabilizer_step,
)

OMEGA = math.sqrt(9.81 / 0.8)
BIG = np.array([[-10.0, -10.0], [10.0, -10.0], [10.0, 10.0], [-10.0, 10.0]])  # no saturation
SOLE = np.array([[-0.115, -0.065], [0.115, -0.065], [0.115, 0.065], [-0.115, 0.065]])


def test_natural_frequency_and_dcm_by_hand():
    assert natural_frequency(0.8) == pytest.approx(3.5017, abs=1e-4)  # sqrt(9.81 / 0.8)
    np.testing.assert_allclose(divergent_component([0.1, 0.0], [0.35, -0.7], 3.5), [0.2, -0.2])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"dcm": 0.0}, "dcm = 0.0 1/s: must be finite and > 0"),
        ({"zmp": float("nan")}, r"zmp = nan"),
        ({"max_offset": -0.1}, r"max_offset = -0.1"),
        ({"damping": -1.0}, r"damping = -1.0"),
        ({"zmp_filter": float("inf")}, r"zmp_filter = inf"),
        ({"margin": float("nan")}, r"margin = nan"),
    ],
)
def test_gains_refuse_bad_values_by_name(kwargs, message):
    with pytest.raises(ValueError, match=message):
        StabilizerGains(**kwargs)


def test_projection_into_a_rectangle_is_clipping_its_coordinates():
    """For an axis-aligned rectangle shrunk by m, the nearest point is the clipped one."""
    rng = np.random.default_rng(0)
    margin = 0.01
    for point in rng.uniform(-0.3, 0.3, size=(200, 2)):
        expected = np.clip(point, [-0.115 + margin, -0.065 + margin], [0.115 - margin, 0.065 - margin])
        np.testing.assert_allclose(project_into_polygon(SOLE, point, margin), expected, atol=1e-12)


def test_projection_into_a_turned_polygon_lands_on_its_shrunk_boundary():
    c, s = math.cos(0.4), math.sin(0.4)
    turned = SOLE @ np.array([[c, s], [-s, c]])
    point = np.array([0.0, 0.3])
    projected = project_into_polygon(turned, point, 0.01)
    a, b = turned, np.roll(turned, -1, axis=0)
    edge = b - a
    inward = np.stack((-edge[:, 1], edge[:, 0]), axis=1) / np.linalg.norm(edge, axis=1, keepdims=True)
    distances = np.einsum("ij,ij->i", projected - a, inward)
    assert distances.min() == pytest.approx(0.01, abs=1e-12)  # on the shrunk boundary
    # and no point of the shrunk polygon is nearer: sample it
    grid = np.stack(np.meshgrid(np.linspace(-0.2, 0.2, 201), np.linspace(-0.2, 0.2, 201)), -1).reshape(-1, 2)
    inside = grid[(np.einsum("kj,ij->ki", grid, inward) - np.einsum("ij,ij->i", a, inward)).min(1) >= 0.01]
    assert np.linalg.norm(point - projected) <= np.linalg.norm(inside - point, axis=1).min() + 1e-12


def test_projection_refuses_a_margin_wider_than_the_polygon():
    with pytest.raises(ValueError, match="margin = 0.07 m: larger than the support polygon's inradius"):
        project_into_polygon(SOLE, np.array([1.0, 0.0]), 0.07)


def _step(offset=None, rate=None, filtered=None, gains=StabilizerGains(), **kw):
    zero = np.zeros(2)
    args = {
        "com_ref": np.zeros(2),
        "com_vel_ref": np.zeros(2),
        "zmp_ref": np.zeros(2),
        "com": np.zeros(2),
        "com_vel": np.zeros(2),
        "zmp": np.zeros(2),
        "polygon": BIG,
        "omega": OMEGA,
        "dt": 0.005,
        "gains": gains,
    } | kw
    return stabilizer_step(
        zero if offset is None else offset,
        zero if rate is None else rate,
        zero if filtered is None else filtered,
        **args,
    )


def test_at_the_reference_nothing_moves():
    step = _step()
    np.testing.assert_array_equal(step.offset, 0.0)
    np.testing.assert_array_equal(step.offset_rate, 0.0)
    np.testing.assert_array_equal(step.zmp_desired, 0.0)
    assert not step.zmp_saturated and not step.offset_saturated


def test_the_desired_zmp_makes_the_dcm_error_decay_at_k():
    """A linear inverted pendulum whose ZMP is the desired one: its DCM error decays as exp(-k t)."""
    gains = StabilizerGains(dcm=2.0)
    dt, c, cd = 1e-4, np.array([0.0, 0.02]), np.array([0.1, 0.05])  # reference at rest at 0
    e0 = divergent_component(c, cd, OMEGA)
    for _ in range(int(1.0 / dt)):
        p = _step(com=c, com_vel=cd, gains=gains).zmp_desired
        c, cd = c + cd * dt, cd + OMEGA**2 * (c - p) * dt  # LIPM, explicit Euler
    np.testing.assert_allclose(divergent_component(c, cd, OMEGA), e0 * math.exp(-2.0), rtol=2e-3)


def test_on_a_robot_that_tracks_its_reference_the_offset_returns_to_zero():
    """c = c_r + Δc, p = c − c̈/ω² (the LIPM of the tracked reference): from a pushed state
    (a CoM velocity), the offset goes out and comes back, without leaving its bounds."""
    dt = 0.005
    offset, rate, filtered = np.zeros(2), np.zeros(2), np.zeros(2)
    push = np.array([0.0, 0.3])  # [m/s] the CoM velocity a push leaves
    previous_rate, p = rate, np.zeros(2)
    peak = 0.0
    for k in range(int(8.0 / dt)):
        com_vel = rate + (push * math.exp(-5.0 * k * dt))  # the push's velocity, damped by the robot
        step = _step(offset, rate, filtered, com=offset, com_vel=com_vel, zmp=p)
        offset, rate, filtered = step.offset, step.offset_rate, step.zmp_filtered
        p = offset - (rate - previous_rate) / dt / OMEGA**2
        previous_rate = rate
        peak = max(peak, np.abs(offset).max())
        assert not step.offset_saturated
    assert peak > 0.005  # it did move
    assert np.abs(offset).max() < 0.02 * peak and np.abs(rate).max() < 1e-3


def test_a_desired_zmp_outside_the_support_is_projected_and_reported():
    com_vel = np.array([0.0, 0.5])  # DCM 0.14 m to the left: beyond the sole
    step = _step(com_vel=com_vel, polygon=SOLE)
    assert step.zmp_saturated
    np.testing.assert_allclose(step.zmp_desired, [0.0, 0.065 - StabilizerGains().margin])


def test_an_offset_at_its_bound_is_held_and_reported():
    gains = StabilizerGains(max_offset=0.05)
    step = _step(offset=np.array([0.0499, 0.0]), rate=np.array([0.1, 0.0]), gains=gains)
    assert step.offset_saturated
    np.testing.assert_array_equal(step.offset, [0.05, 0.0])
    assert step.offset_rate[0] == 0.0


def test_a_missing_zmp_keeps_the_last_measurement():
    first = _step(filtered=np.full(2, np.nan), zmp=np.array([0.03, 0.01]))
    np.testing.assert_array_equal(first.zmp_filtered, [0.03, 0.01])  # the first is taken as it is
    lost = _step(filtered=first.zmp_filtered, zmp=np.full(2, np.nan))
    np.testing.assert_array_equal(lost.zmp_filtered, [0.03, 0.01])
    never = _step(filtered=np.full(2, np.nan), zmp=np.full(2, np.nan))
    np.testing.assert_array_equal(never.offset_rate, 0.0)


# --- external wrenches at the hands (eq. 4-6, 2') ---------------------------------------------
MASS = 57.8  # [kg]
HAND_POINTS = np.array([[0.34, -0.2, 0.84], [0.36, 0.21, 0.83]])  # right, left [m]
#: [τ; f] on the robot at each hand: a forward pull of 14 N, some sideways and a board's weight,
#: torques from the grasp.
HAND_WRENCHES = np.array([[0.4, -0.8, 0.1, 7.0, 1.5, -6.0], [-0.3, 0.5, 0.0, 7.5, -0.5, -4.0]])


def _cop_by_equilibrium(com, com_acc, points, wrenches, mass=MASS):
    """(2,) centre of pressure of the ground's wrench on a point mass at ``com`` (3,) accelerating
    at ``com_acc`` (3,), with the wrenches [τ; f] at ``points``: Newton-Euler about the world
    origin gives the ground's force and moment; the CoP is where that moment is vertical."""
    gravity = np.array([0.0, 0.0, -GRAVITY])
    force = mass * (com_acc - gravity) - wrenches[:, 3:].sum(axis=0)
    moment = np.cross(com, mass * (com_acc - gravity)) - sum(
        np.cross(h, w[3:]) + w[:3] for h, w in zip(points, wrenches, strict=True)
    )
    return np.array([-moment[1], moment[0]]) / force[2]


def test_the_zmp_under_hand_wrenches_is_the_centre_of_pressure_of_the_statics():
    """A point mass at rest and one accelerating horizontally: eq. 4's ZMP is the centre of
    pressure the Newton-Euler balance with the hands' wrenches gives."""
    com = np.array([0.02, -0.01, 0.8])
    load = HandLoad(MASS, HAND_POINTS, HAND_WRENCHES)
    omega = math.sqrt(GRAVITY / com[2])
    for acc in (np.zeros(3), np.array([0.6, -0.3, 0.0])):
        expected = _cop_by_equilibrium(com, acc, HAND_POINTS, HAND_WRENCHES)
        np.testing.assert_allclose(load.zmp(com[:2] - acc[:2] / omega**2), expected, atol=1e-12)
    # the forward pull moves the ZMP forward, by about z_h f_x / (m g) (2.1 cm) and the load in front
    at_rest = load.zmp(com[:2])
    assert 0.02 < at_rest[0] - com[0] < 0.04
    no_hands = HandLoad(MASS, np.zeros((0, 3)), np.zeros((0, 6)))
    np.testing.assert_array_equal(no_hands.zmp(com[:2]), com[:2])
    assert no_hands.feedback_scale() == 1.0


def test_the_desired_zmp_with_hand_wrenches_makes_the_dcm_error_decay_at_k():
    """A point mass with the hands' wrenches whose ZMP is the desired one (its acceleration
    solved from the Newton-Euler balance): its DCM error decays as exp(-k t), as without them."""
    gains = StabilizerGains(dcm=2.0)
    load = HandLoad(MASS, HAND_POINTS, HAND_WRENCHES)
    z = GRAVITY / OMEGA**2
    dt, c, cd = 1e-4, np.array([0.0, 0.02]), np.array([0.1, 0.05])  # reference at rest at 0
    e0 = divergent_component(c, cd, OMEGA)

    def acceleration(c, p):
        """c̈ (2,) for which the centre of pressure is p (affine in c̈: two evaluations)."""
        com = np.append(c, z)
        base = _cop_by_equilibrium(com, np.zeros(3), HAND_POINTS, HAND_WRENCHES)
        J = np.column_stack(
            [_cop_by_equilibrium(com, np.eye(3)[i], HAND_POINTS, HAND_WRENCHES) - base for i in range(2)]
        )
        return np.linalg.solve(J, p - base)

    # the reference at rest under the wrenches: ZMP at the planned place with the load's shift
    for _ in range(int(1.0 / dt)):
        p = _step(com=c, com_vel=cd, gains=gains, hands=load).zmp_desired
        c, cd = c + cd * dt, cd + acceleration(c, p) * dt
    np.testing.assert_allclose(divergent_component(c, cd, OMEGA), e0 * math.exp(-2.0), rtol=2e-3)


def test_the_zmp_the_hands_cause_does_not_move_the_offset():
    """The robot on its plan (at rest, the reference at rest), its ZMP where the hands' wrenches
    put it (the statics above): with the hands in the model the offset does not move; without,
    it drives the CoM forward, towards the pull (the measured fault of the tele-cooperation walk)."""
    com = np.array([0.02, -0.01, 0.8])
    measured = _cop_by_equilibrium(com, np.zeros(3), HAND_POINTS, HAND_WRENCHES)
    at_plan = {"com_ref": com[:2], "zmp_ref": com[:2], "com": com[:2], "zmp": measured}
    load = HandLoad(MASS, HAND_POINTS, HAND_WRENCHES)
    step = _step(filtered=measured, hands=load, **at_plan)
    np.testing.assert_allclose(step.zmp_desired, measured, atol=1e-12)
    np.testing.assert_allclose(step.offset_rate, 0.0, atol=1e-12)
    blind = _step(filtered=measured, **at_plan)
    assert blind.offset_rate[0] > 0.0


def test_hand_loads_refuse_bad_values_by_name():
    with pytest.raises(ValueError, match="mass = 0.0 kg"):
        HandLoad(0.0, HAND_POINTS, HAND_WRENCHES)
    with pytest.raises(ValueError, match="wrenches must be a matrix of shape"):
        HandLoad(MASS, HAND_POINTS, HAND_WRENCHES[:1])
    with pytest.raises(ValueError, match="wrenches of shape .* contains NaN"):
        HandLoad(MASS, HAND_POINTS, np.full((2, 6), np.nan))
    lifting = np.zeros((2, 6))
    lifting[:, 5] = 0.5 * MASS * GRAVITY
    with pytest.raises(ValueError, match="carries the robot's weight"):
        HandLoad(MASS, HAND_POINTS, lifting)


def test_projection_is_the_nearest_point_of_the_shrunk_polygon_by_a_qp():
    # Random support polygons of one or two soles: the projection equals the solution of
    # min |x - p|² s.t. n_i · x >= n_i · v_i + margin (scipy's SLSQP, another algorithm).
    from scipy.optimize import minimize

    from drake_sot.support import sole_corners, support_polygon

    rng = np.random.default_rng(7)
    for _ in range(40):
        soles = [
            sole_corners(*rng.normal(0.0, 0.1, 2), rng.uniform(-1.0, 1.0), (0.23, 0.13))
            for _ in range(rng.integers(1, 3))
        ]
        polygon = support_polygon(soles)
        point, margin = rng.normal(0.0, 0.3, 2), 0.01
        edge = np.roll(polygon, -1, axis=0) - polygon
        normal = np.stack((-edge[:, 1], edge[:, 0]), axis=1) / np.linalg.norm(edge, axis=1)[:, None]
        offset = np.sum(normal * polygon, axis=1) + margin
        qp = minimize(
            lambda x, p=point: float((x - p) @ (x - p)),
            polygon.mean(axis=0),
            jac=lambda x, p=point: 2.0 * (x - p),
            constraints=[
                {"type": "ineq", "fun": lambda x, n=normal, o=offset: n @ x - o, "jac": lambda x, n=normal: n}
            ],
            method="SLSQP",
            options={"ftol": 1e-14, "maxiter": 200},
        )
        assert qp.success, qp.message
        np.testing.assert_allclose(project_into_polygon(polygon, point, margin), qp.x, atol=1e-6)
