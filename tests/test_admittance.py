"""The admittance dynamics against closed forms and an independent ODE solver.

Every reference value is written here from the equations (or integrated with
scipy's solve_ivp at tight tolerance), never taken from the code under test.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from drake_sot.admittance import MassDamperSpring, apparent_inertia, coupled_step, joint_acceleration

DT = 0.005


def run(mds, x0, v0, f, steps, rest=None):
    """States at t = 0, dt, ..., steps*dt under a constant force: arrays (steps + 1, n)."""
    xs, vs = [np.array(x0, dtype=float)], [np.array(v0, dtype=float)]
    for _ in range(steps):
        x, v = mds.step(xs[-1], vs[-1], f, rest)
        xs.append(x)
        vs.append(v)
    return np.array(xs), np.array(vs)


def test_mass_damper_matches_the_closed_form_under_a_constant_force():
    # Six axes with different masses, dampings, forces and initial velocities.
    M = np.array([1.0, 2.0, 5.0, 0.1, 0.05, 0.5])
    B = np.array([10.0, 40.0, 20.0, 1.0, 2.0, 0.5])
    f = np.array([20.0, -5.0, 3.0, 0.7, -0.2, 0.05])
    x0 = np.array([0.1, -0.2, 0.3, 0.0, 0.5, -1.0])
    v0 = np.array([0.0, 0.3, -0.1, 0.2, 0.0, 0.4])
    mds = MassDamperSpring(M, B, 0.0, DT)
    steps = 400  # 2 s
    xs, vs = run(mds, x0, v0, f, steps)
    t = DT * np.arange(steps + 1)[:, None]
    decay = np.exp(-B * t / M)
    v_ref = f / B + (v0 - f / B) * decay
    x_ref = x0 + f / B * t + (M / B) * (v0 - f / B) * (1.0 - decay)
    np.testing.assert_allclose(vs, v_ref, rtol=1e-6, atol=1e-6 * np.abs(v_ref).max())
    np.testing.assert_allclose(xs, x_ref, rtol=1e-6, atol=1e-6 * np.abs(x_ref).max())
    # Pure mass-damper from rest: x0 + f/B t - (M f / B^2)(1 - e^{-Bt/M}), as written in paper terms.
    xs, vs = run(mds, np.zeros(6), np.zeros(6), f, steps)
    T = steps * DT
    np.testing.assert_allclose(xs[-1], f / B * T - M * f / B**2 * (1 - np.exp(-B * T / M)), rtol=1e-6)
    np.testing.assert_allclose(vs[-1], f / B * (1 - np.exp(-B * T / M)), rtol=1e-6)
    # Steady velocity f/B, reached after the transient (the slowest time constant is 1 s here).
    _, vs = run(mds, np.zeros(6), np.zeros(6), f, 5000)
    np.testing.assert_allclose(vs[-1], f / B, rtol=1e-9)


def spring_closed_form(M, B, K, f, y0, v0, t):
    """(y, v) of M y'' + B y' + K y = f by cases of the damping ratio (y = x - rest)."""
    if K == 0.0 and B == 0.0:  # a free mass
        return y0 + v0 * t + f / (2 * M) * t**2, v0 + f / M * t
    w = np.sqrt(K / M)
    zeta = B / (2 * np.sqrt(K * M))
    z0 = y0 - f / K  # deviation from the equilibrium f/K
    if np.isclose(zeta, 1.0, rtol=0, atol=1e-12):
        a, b = z0, v0 + w * z0
        z = (a + b * t) * np.exp(-w * t)
        dz = (b - w * (a + b * t)) * np.exp(-w * t)
    elif zeta < 1.0:
        wd = w * np.sqrt(1 - zeta**2)
        a, b = z0, (v0 + zeta * w * z0) / wd
        e = np.exp(-zeta * w * t)
        z = e * (a * np.cos(wd * t) + b * np.sin(wd * t))
        dz = -zeta * w * z + e * wd * (-a * np.sin(wd * t) + b * np.cos(wd * t))
    else:
        r1 = -zeta * w + w * np.sqrt(zeta**2 - 1)
        r2 = -zeta * w - w * np.sqrt(zeta**2 - 1)
        c1 = (v0 - r2 * z0) / (r1 - r2)
        c2 = z0 - c1
        z = c1 * np.exp(r1 * t) + c2 * np.exp(r2 * t)
        dz = r1 * c1 * np.exp(r1 * t) + r2 * c2 * np.exp(r2 * t)
    return f / K + z, dz


@pytest.mark.parametrize(
    "M, B, K",
    [
        (2.0, 4.0, 200.0),  # underdamped, zeta = 0.1
        (2.0, 80.0, 200.0),  # overdamped, zeta = 2
        (2.0, 40.0, 200.0),  # critically damped
        (0.5, 0.0, 50.0),  # undamped oscillator
        (1.5, 0.0, 0.0),  # free mass (damping and stiffness may both be zero)
    ],
)
def test_mass_damper_spring_matches_the_closed_form(M, B, K):
    rest = np.array([0.3, -0.1])
    f = np.array([12.0, -3.0])
    x0 = np.array([0.0, 0.2])
    v0 = np.array([0.5, -0.4])
    mds = MassDamperSpring(M, B, K, DT, n=2)
    steps = 400
    xs, vs = run(mds, x0, v0, f, steps, rest)
    t = DT * np.arange(steps + 1)
    for i in range(2):
        y, v = spring_closed_form(M, B, K, f[i], x0[i] - rest[i], v0[i], t)
        scale = max(np.abs(y).max(), 1e-3)
        np.testing.assert_allclose(xs[:, i] - rest[i], y, rtol=1e-6, atol=1e-6 * scale)
        np.testing.assert_allclose(vs[:, i], v, rtol=1e-6, atol=1e-6 * max(np.abs(v).max(), 1e-3))


def test_spring_settles_at_rest_plus_f_over_k():
    M, B, K = np.array([1.0, 3.0, 0.2]), np.array([20.0, 50.0, 3.0]), np.array([100.0, 400.0, 10.0])
    mds = MassDamperSpring(M, B, K, DT)
    rest, f = np.array([1.0, -2.0, 0.5]), np.array([30.0, -8.0, 1.0])
    xs, vs = run(mds, np.zeros(3), np.zeros(3), f, 2000, rest)  # 10 s, much longer than every time constant
    np.testing.assert_allclose(xs[-1], rest + f / K, rtol=1e-9)
    np.testing.assert_allclose(vs[-1], 0.0, atol=1e-9)


def test_exact_under_a_piecewise_constant_force_against_solve_ivp():
    """Zero-order hold: each step is exact for the force held over it, whatever the force does."""
    rng = np.random.default_rng(3)
    M, B, K = np.array([2.0, 0.3]), np.array([15.0, 0.1]), np.array([60.0, 0.0])
    mds = MassDamperSpring(M, B, K, 0.02)
    rest = np.array([0.1, 0.0])
    x, v = np.array([0.0, 0.4]), np.array([0.2, -1.0])
    for _ in range(30):
        f = rng.normal(scale=10.0, size=2)
        sol = solve_ivp(
            lambda t, s, f=f: np.concatenate((s[2:], (f - B * s[2:] - K * (s[:2] - rest)) / M)),
            (0.0, 0.02),
            np.concatenate((x, v)),
            method="DOP853",
            rtol=1e-12,
            atol=1e-14,
        )
        x, v = mds.step(x, v, f, rest)
        np.testing.assert_allclose(x, sol.y[:2, -1], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(v, sol.y[2:, -1], rtol=1e-9, atol=1e-12)


def random_spd(rng, n):
    X = rng.normal(size=(n, n))
    return X @ X.T + n * np.eye(n)


def test_eq14_with_the_apparent_inertia_the_robot_behaves_as_a_compliant_body():
    """Paper 000 eq. 13 with W = A and M = Λ gives A q̈ = Jᵀ f − Jᵀ B J q̇ (eq. 14)."""
    rng = np.random.default_rng(0)
    for n, m in ((10, 6), (7, 3), (6, 6)):
        A = random_spd(rng, n)
        J = rng.normal(size=(m, n))
        B = random_spd(rng, m)
        f = rng.normal(size=m)
        qdot = rng.normal(size=n)
        Lam = apparent_inertia(J, A)
        np.testing.assert_allclose(Lam, np.linalg.inv(J @ np.linalg.inv(A) @ J.T), rtol=1e-9)
        qddot = joint_acceleration(J, A, Lam, B, f, J @ qdot)
        np.testing.assert_allclose(A @ qddot, J.T @ f - J.T @ B @ J @ qdot, rtol=1e-9, atol=1e-9)
        # Any virtual mass: the task point accelerates as the admittance says, J q̈ = M⁻¹(f − B ṙ),
        # with the least A-weighted joint acceleration (q̈ lies in the range of A⁻¹ Jᵀ).
        Mv = random_spd(rng, m)
        rdot = rng.normal(size=m)
        b = rng.uniform(1.0, 5.0, m)  # a diagonal damping, given as its diagonal
        qddot = joint_acceleration(J, A, Mv, b, f, rdot)
        np.testing.assert_allclose(J @ qddot, np.linalg.solve(Mv, f - b * rdot), rtol=1e-9, atol=1e-10)
        Ainv_Jt = np.linalg.solve(A, J.T)
        coeffs = np.linalg.lstsq(Ainv_Jt, qddot, rcond=None)[0]
        np.testing.assert_allclose(Ainv_Jt @ coeffs, qddot, atol=1e-10)


def test_validation_errors_name_the_value():
    with pytest.raises(ValueError, match=r"mass = \[1. 0.\]: every value must be finite and > 0; entry 1"):
        MassDamperSpring([1.0, 0.0], [1.0, 1.0], 0.0, DT)
    with pytest.raises(ValueError, match="damping = .*: every value must be finite and >= 0"):
        MassDamperSpring(1.0, -1.0, 0.0, DT, n=3)
    with pytest.raises(ValueError, match="stiffness = .*: every value must be finite and >= 0; entry 1"):
        MassDamperSpring(1.0, 1.0, [0.0, -2.0], DT)
    with pytest.raises(ValueError, match="dt = 0.0 s: must be finite and > 0"):
        MassDamperSpring(1.0, 1.0, 0.0, 0.0, n=1)
    with pytest.raises(ValueError, match="dt .* is required"):
        MassDamperSpring(1.0, 1.0, n=1)
    with pytest.raises(ValueError, match="different lengths"):
        MassDamperSpring([1.0, 1.0], [1.0, 1.0, 1.0], 0.0, DT)
    with pytest.raises(ValueError, match="give the number of axes n"):
        MassDamperSpring(1.0, 1.0, 0.0, DT)
    with pytest.raises(ValueError, match="mass = .*: every value must be finite and > 0"):
        MassDamperSpring([1.0, np.nan], 1.0, 0.0, DT)
    with pytest.raises(
        ValueError, match=r"damping must be a scalar, a pair \(3 \+ 3 axes\) or 6 values, got 3"
    ):
        MassDamperSpring(1.0, [1.0, 2.0, 3.0], 0.0, DT, n=6)
    mds = MassDamperSpring(1.0, 1.0, 0.0, DT, n=6)
    assert mds.n == 6
    with pytest.raises(ValueError, match=r"f must have shape \(6,\)"):
        mds.step(np.zeros(6), np.zeros(6), np.zeros(3))
    rng = np.random.default_rng(1)
    A = random_spd(rng, 5)
    J = rng.normal(size=(3, 5))
    with pytest.raises(ValueError, match="full row rank"):
        apparent_inertia(np.vstack((J[:2], J[:1])), A)
    with pytest.raises(ValueError, match="positive definite"):
        apparent_inertia(J, -A)
    with pytest.raises(ValueError, match="shape"):
        joint_acceleration(J, A, np.eye(2), np.eye(3), np.zeros(3), np.zeros(3))


def test_coupled_step_is_the_per_axis_one_when_the_mass_is_diagonal_and_in_its_eigenbasis_otherwise():
    """A second algorithm: MassDamperSpring per axis, on the diagonal, and in the eigenbasis of
    M (with B and K multiples of the identity, the coupled system separates there)."""
    rng = np.random.default_rng(4)
    y, v, f = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    m, b, k = np.array([1.0, 3.0, 0.5]), np.array([20.0, 5.0, 0.0]), np.array([0.0, 50.0, 300.0])
    ref = MassDamperSpring(m, b, k, DT).step(y, v, f)
    got = coupled_step(np.diag(m), b, np.diag(k), y, v, f, DT)
    for r, g in zip(ref, got, strict=True):
        np.testing.assert_allclose(g, r, rtol=1e-10, atol=1e-14)
    M = random_spd(rng, 3)
    lam, U = np.linalg.eigh(M)
    y_e, v_e = MassDamperSpring(lam, 40.0, 100.0, DT).step(U.T @ y, U.T @ v, U.T @ f)
    y_c, v_c = coupled_step(M, 40.0 * np.eye(3), 100.0 * np.eye(3), y, v, f, DT)
    np.testing.assert_allclose(y_c, U @ y_e, rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(v_c, U @ v_e, rtol=1e-9, atol=1e-13)


def test_coupled_step_names_bad_values():
    with pytest.raises(ValueError, match="M = .*positive definite"):
        coupled_step(-np.eye(2), np.ones(2), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), DT)
    with pytest.raises(ValueError, match=r"B must be finite with shape \(2, 2\)"):
        coupled_step(np.eye(2), np.ones(3), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), DT)
    with pytest.raises(ValueError, match="f = .*NaN"):
        coupled_step(np.eye(2), np.ones(2), np.zeros(2), np.zeros(2), np.zeros(2), [np.nan, 0.0], DT)
    with pytest.raises(ValueError, match="dt = nan s"):
        coupled_step(np.eye(2), np.ones(2), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), np.nan)
