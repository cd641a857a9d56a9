"""Tests of drake_sot.preview: cart-table ZMP preview control.

References are independent of the code under test: the cart-table formula
p = c - z_c/g c̈, Taylor expansion of a jerk held over a period, the Riccati
recursion iterated to convergence, a second Riccati equation on a
shift-register formulation of the preview, and finite differences.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from drake_sot.preview import PreviewController

DT = 0.005
Z_C = 0.814
G = 9.81


# --------------------------------------------------------------------------- helpers


def walk_reference(
    stand: float,
    n_steps: int = 8,
    period: float = 0.8,
    stride: float = 0.3,
    lateral: float = 0.1,
    after: float = 2.0,
    dt: float = DT,
):
    """Kajita's test reference: piecewise constant, x += stride every period, y = ±lateral.

    Returns (reference (K, 2), jump sample indices).  Built from sample counts so
    that the jumps fall on exact samples.
    """
    n_stand, n_step, n_after = (round(v / dt) for v in (stand, period, after))
    K = n_stand + n_steps * n_step + n_after
    k = np.arange(K)
    j = np.floor_divide(k - n_stand, n_step)  # step index, -1 before the walk
    ref = np.zeros((K, 2))
    ref[:, 0] = stride * np.clip(j, 0, n_steps)
    walking = (j >= 0) & (j < n_steps)
    ref[walking, 1] = np.where(j[walking] % 2 == 0, lateral, -lateral)
    jumps = n_stand + n_step * np.arange(n_steps + 1)
    assert np.all(np.abs(np.diff(ref, axis=0)).sum(axis=1)[jumps - 1] > 0)
    return ref, jumps


def error_away_from_jumps(zmp: np.ndarray, ref: np.ndarray, jumps: np.ndarray, window: float) -> float:
    """Max |zmp - ref| (per axis) over the samples farther than `window` seconds from every jump."""
    k = np.arange(len(ref))
    far = np.min(np.abs(k[:, None] - jumps[None, :]), axis=1) * DT > window
    return float(np.abs(zmp - ref)[far].max())


def augmented(dt: float, z_c: float, g: float):
    """Kajita's integral-augmented matrices, written out from the paper."""
    A = np.array([[1, dt, dt**2 / 2], [0, 1, dt], [0, 0, 1]])
    B = np.array([[dt**3 / 6], [dt**2 / 2], [dt]])
    C = np.array([[1, 0, -z_c / g]])
    At = np.block([[np.eye(1), C @ A], [np.zeros((3, 1)), A]])
    Bt = np.vstack([C @ B, B])
    return A, B, C, At, Bt


@pytest.fixture(scope="module")
def controller() -> PreviewController:
    return PreviewController(dt=DT, z_c=Z_C, horizon=1.6, q=1.0, r=1e-6, g=G)


@pytest.fixture(scope="module")
def walk(controller):
    # 1.6 s standing = the horizon: at t = 0 the window is constant, so the CoM starts
    # from rest with nothing to anticipate yet (with 1 s, the first jump is already in
    # the window and the ZMP must move ~6 mm the wrong way right at the start).
    ref, jumps = walk_reference(stand=1.6)
    return ref, jumps, controller.plan(ref)


# --------------------------------------------------------------------------- preview control


def test_tracking_stability_and_final_rest(controller, walk):
    ref, jumps, plan = walk
    assert plan.zmp.shape == plan.com.shape == plan.com_vel.shape == plan.com_acc.shape == ref.shape
    assert error_away_from_jumps(plan.zmp, ref, jumps, 0.1) < 3e-3
    rho = np.max(np.abs(np.linalg.eigvals(controller.closed_loop)))
    assert rho < 1.0
    np.testing.assert_allclose(plan.com[-1], ref[-1], atol=1e-3)
    assert np.all(np.abs(plan.com_vel[-1]) < 1e-3)
    assert np.all(np.abs(plan.com_acc[-1]) < 1e-2)
    # The CoM swings less than the ZMP laterally (the inverted pendulum smooths).
    assert np.abs(plan.com[:, 1]).max() < 0.1


def test_horizon_matters(walk):
    ref, jumps, plan = walk
    long_error = error_away_from_jumps(plan.zmp, ref, jumps, 0.1)
    short = PreviewController(dt=DT, z_c=Z_C, horizon=0.4, q=1.0, r=1e-6, g=G).plan(ref)
    short_error = error_away_from_jumps(short.zmp, ref, jumps, 0.1)
    assert short_error > 3 * long_error
    assert short_error > 0.02  # centimetres off: a 0.4 s preview cannot anticipate a 0.8 s step


def test_cart_table_model(walk):
    _, _, plan = walk
    c, v, a, p = plan.com, plan.com_vel, plan.com_acc, plan.zmp
    np.testing.assert_allclose(p, c - Z_C / G * a, atol=1e-12)
    # Jerk held over each period: exact Taylor expansion between samples.
    jerk = np.diff(a, axis=0) / DT
    np.testing.assert_allclose(np.diff(v, axis=0), DT * a[:-1] + DT**2 / 2 * jerk, atol=1e-12)
    np.testing.assert_allclose(
        np.diff(c, axis=0),
        DT * v[:-1] + DT**2 / 2 * a[:-1] + DT**3 / 6 * jerk,
        atol=1e-12,
    )
    # And plain finite differences agree to O(dt²).
    np.testing.assert_allclose(np.gradient(c, DT, axis=0)[1:-1], v[1:-1], atol=2e-3)
    np.testing.assert_allclose(np.gradient(v, DT, axis=0)[1:-1], a[1:-1], atol=0.1)  # jerk up to ~1e2 m/s³


def test_gains_against_riccati_iteration(controller):
    _, _, _, At, Bt = augmented(DT, Z_C, G)
    Q = np.diag([1.0, 0, 0, 0])
    R = 1e-6
    P = Q.copy()
    for _ in range(200000):
        S = R + (Bt.T @ P @ Bt).item()
        P_next = Q + At.T @ P @ At - (At.T @ P @ Bt) @ (Bt.T @ P @ At) / S
        if np.max(np.abs(P_next - P)) < 1e-12 * np.max(np.abs(P)):
            P = P_next
            break
        P = P_next
    else:
        pytest.fail("Riccati recursion did not converge")
    K = (Bt.T @ P @ At)[0] / (R + (Bt.T @ P @ Bt).item())
    np.testing.assert_allclose(controller.Gi, K[0], rtol=1e-6)
    np.testing.assert_allclose(controller.Gx, K[1:], rtol=1e-6)
    np.testing.assert_allclose(controller.closed_loop, At - Bt @ K[None, :], rtol=1e-6, atol=1e-9)
    print(f"Gi = {controller.Gi:.6g}, Gx = {controller.Gx}, Gp[0] = {controller.Gp[0]:.6g}")


def test_preview_gains_against_shift_register_riccati(controller):
    """The preview gains are the optimal gains on the future reference increments.

    Append L future increments d(k+j) = p_ref(k+j) - p_ref(k+j-1) to the augmented
    state as a shift register and solve that Riccati equation: its gains on d(k+j)
    are the (horizon-independent) Katayama gains G(j) = Gp[j].
    """
    _, _, _, At, Bt = augmented(DT, Z_C, G)
    L = 40
    n = 4 + L
    Az = np.zeros((n, n))
    Az[:4, :4] = At
    Az[0, 4] = -1.0  # e(k+1) = ... - d(k+1)
    Az[4:-1, 5:] = np.eye(L - 1)  # shift
    Bz = np.zeros((n, 1))
    Bz[:4] = Bt
    Qz = np.zeros((n, n))
    Qz[0, 0] = 1.0
    Pz = scipy.linalg.solve_discrete_are(Az, Bz, Qz, np.array([[1e-6]]))
    Kz = np.linalg.solve(1e-6 + Bz.T @ Pz @ Bz, Bz.T @ Pz @ Az)[0]
    scale = np.abs(Kz[4:]).max()
    np.testing.assert_allclose(controller.Gp[1 : L + 1], Kz[4:], atol=1e-8 * scale)
    np.testing.assert_allclose(controller.Gp[0], -controller.Gi)


def test_preview_gains_decay(controller):
    Gp = controller.Gp
    assert Gp.shape == (controller.N,) == (320,)
    # With Kajita's parameters the slowest closed-loop pole is |λ| ≈ 0.983 per 5 ms, so
    # over 1.6 s the gain falls to ~0.8 % of Gp[0] (not below 1e-3).
    assert abs(Gp[-1]) < 1e-2 * abs(Gp[0])
    quarter = controller.N // 4
    assert np.abs(Gp[-quarter:]).max() < 0.05 * np.abs(Gp).max()
    # Standing still over a displaced reference needs no jerk: in the infinite-preview
    # limit the preview gains cancel the position gain; 1.6 s gets within 1 %.
    assert abs(controller.Gx[0] + Gp[1:].sum()) < 1e-2 * controller.Gx[0]


def test_plan_is_repeated_steps_of_kajitas_law(controller):
    rng = np.random.default_rng(3)
    ref, _ = walk_reference(stand=0.5, n_steps=3, after=0.5)
    ref = ref + rng.normal(scale=0.01, size=ref.shape)  # arbitrary reference
    x0 = np.array([[0.02, -0.01], [0.1, 0.05], [0.3, -0.2]])
    plan = controller.plan(ref, x0=x0)
    N = controller.N
    padded = np.vstack([ref, np.repeat(ref[-1:], N, axis=0)])
    # Kajita's summed law, written here: u = -Gi Σ_{i≤k} e(i) - Gx x(k) - Σ_{j≥1} G(j) p_ref(k+j).
    A, B, C, _, _ = augmented(DT, Z_C, G)
    x = x0.copy()
    e_sum = controller.initial_error_sum(x0, padded[:N])
    steps_x, steps_s = x0.copy(), e_sum.copy()
    for k in range(len(ref)):
        np.testing.assert_allclose(plan.com[k], x[0], atol=1e-9)
        np.testing.assert_allclose(plan.com_acc[k], x[2], atol=1e-7)
        e_sum = e_sum + (C @ x)[0] - padded[k]
        u = -controller.Gi * e_sum - controller.Gx @ x - controller.Gp[1:] @ padded[k + 1 : k + N]
        x = A @ x + B @ u[None, :]
        # and plan() is step() repeated, bit for bit
        steps_x, steps_s, z = controller.step(steps_x, steps_s, padded[k : k + N])
        assert np.array_equal(z, plan.zmp[k])


def test_bumpless_start_and_translation_invariance(controller):
    p0 = np.array([5.0, -3.0])
    plan = controller.plan(np.tile(p0, (400, 1)))
    np.testing.assert_allclose(plan.com, np.tile(p0, (400, 1)), atol=1e-9)
    np.testing.assert_allclose(plan.com_acc, 0.0, atol=1e-7)
    ref, _ = walk_reference(stand=1.0, n_steps=2, after=1.0)
    a = controller.plan(ref)
    b = controller.plan(ref + p0)
    np.testing.assert_allclose(b.com, a.com + p0, atol=1e-7)
    np.testing.assert_allclose(b.com_acc, a.com_acc, atol=1e-6)
    # At rest with a jump 1 s ahead in the window: the jerk starts from zero and the ZMP
    # barely moves; a zero error sum would instead start with the jerk of a controller
    # that had already been running (a kick of centimetres).
    first = slice(0, round(0.2 / DT))
    bumpless = np.abs(a.zmp[first] - ref[first]).max()
    kicked = np.abs(controller.plan(ref, error_sum=np.zeros(2)).zmp[first] - ref[first]).max()
    assert bumpless < 0.01
    assert kicked > 5 * bumpless


def test_window_holds_the_last_reference_past_the_end(controller):
    N = controller.N
    ref = np.arange(2.0 * (N + 5)).reshape(N + 5, 2)
    np.testing.assert_array_equal(controller.window(ref, 3), ref[3 : 3 + N])
    tail = controller.window(ref, N)
    np.testing.assert_array_equal(tail[:5], ref[N:])
    np.testing.assert_array_equal(tail[5:], np.tile(ref[-1], (N - 5, 1)))
    np.testing.assert_array_equal(controller.window(ref, len(ref) + 7), np.tile(ref[-1], (N, 1)))


def test_controller_validation():
    with pytest.raises(ValueError, match="z_c"):
        PreviewController(z_c=0.0)
    with pytest.raises(ValueError, match="horizon"):
        PreviewController(horizon=0.004)
    pc = PreviewController(horizon=0.1)
    with pytest.raises(ValueError, match="shape"):
        pc.plan(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="NaN"):
        pc.plan(np.full((10, 2), np.nan))
    with pytest.raises(ValueError, match="x0"):
        pc.plan(np.zeros((10, 2)), x0=np.zeros(3))
    with pytest.raises(ValueError, match="x0 .*NaN"):
        pc.plan(np.zeros((10, 2)), x0=np.full((3, 2), np.nan))
    with pytest.raises(ValueError, match="error_sum .*NaN"):
        pc.plan(np.zeros((10, 2)), error_sum=[0.0, np.nan])
    with pytest.raises(ValueError, match="at least one sample"):
        pc.plan(np.zeros((0, 2)))
    for name in ("dt", "z_c", "horizon", "q", "r", "g"):
        for bad in (np.nan, np.inf, -1.0, 0.0):
            with pytest.raises(ValueError, match=f"^{name} = "):
                PreviewController(**{name: bad})
