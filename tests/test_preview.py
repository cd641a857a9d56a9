"""Tests of drake_sot.preview: cart-table ZMP preview control and footstep plans.

References are independent of the code under test: the cart-table formula
p = c - z_c/g c̈, Taylor expansion of a jerk held over a period, the Riccati
recursion iterated to convergence, a second Riccati equation on a
shift-register formulation of the preview, finite differences, and geometry
(sole rectangles, convex hulls of the soles).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import scipy.linalg
from scipy.spatial import ConvexHull

from drake_sot.preview import (
    Footstep,
    FootstepPlan,
    PreviewController,
    Segment,
    StepLimits,
    StepTiming,
    step_segment,
    stop_segment,
)

DT = 0.005
Z_C = 0.814
G = 9.81
SOLE_LENGTH, SOLE_WIDTH = (
    0.23,
    0.13,
)  # the rectangle around the sole centre (HRP-2-like)
HALF_WIDTH = 0.095  # feet 0.19 m apart


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


def sole_corners(pose: np.ndarray) -> np.ndarray:
    """(4, 2) corners of the sole rectangle of a pose [x, y, z, yaw]."""
    c, s = math.cos(pose[3]), math.sin(pose[3])
    local = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]]) * [
        SOLE_LENGTH / 2,
        SOLE_WIDTH / 2,
    ]
    return pose[:2] + local @ np.array([[c, s], [-s, c]])


def in_sole(point: np.ndarray, pose: np.ndarray, tol: float = 1e-9) -> bool:
    c, s = math.cos(pose[3]), math.sin(pose[3])
    d = point - pose[:2]
    return (
        abs(c * d[0] + s * d[1]) <= SOLE_LENGTH / 2 + tol
        and abs(-s * d[0] + c * d[1]) <= SOLE_WIDTH / 2 + tol
    )


def support_violations(seg: Segment, zmp: np.ndarray, tol: float = 1e-9) -> list[int]:
    """Sample indices where `zmp` is outside the support polygon given by the phase."""
    bad = []
    hulls: dict[bytes, ConvexHull] = {}
    for k, phase in enumerate(seg.phase):
        if phase == 1:
            ok = in_sole(zmp[k], seg.left[k], tol)
        elif phase == 2:
            ok = in_sole(zmp[k], seg.right[k], tol)
        else:
            key = np.concatenate([seg.left[k], seg.right[k]]).tobytes()
            if key not in hulls:
                hulls[key] = ConvexHull(np.vstack([sole_corners(seg.left[k]), sole_corners(seg.right[k])]))
            eq = hulls[key].equations
            ok = bool(np.all(eq[:, :2] @ zmp[k] + eq[:, 2] <= tol))
        if not ok:
            bad.append(k)
    return bad


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


def test_step_speed(controller):
    np.zeros((3, 2))
    s = np.zeros(2)
    window = np.random.default_rng(0).normal(size=(controller.N, 2))
    times = np.empty(5000)
    for i in range(len(times)):
        t0 = time.perf_counter()
        _x, s, _ = controller.step(np.zeros((3, 2)), s, window)
        times[i] = time.perf_counter() - t0
    print(f"PreviewController.step median {np.median(times) * 1e6:.2f} µs (N = {controller.N})")


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


# --------------------------------------------------------------------------- footsteps


LEFT0 = Footstep(0.0, HALF_WIDTH, 0.0, "left")
RIGHT0 = Footstep(0.0, -HALF_WIDTH, 0.0, "right")


def test_step_segment():
    dt = 0.001
    timing = StepTiming(single_support=0.7, double_support=0.1, step_height=0.05)
    step = Footstep(0.25, -0.12, 0.3, "right")
    start = np.array([0.0, 0.0])
    seg = step_segment(LEFT0, RIGHT0, start, step, timing, dt)
    n_ds, n_ss = 100, 700
    assert len(seg) == n_ds + n_ss
    for a, cols in (
        (seg.zmp, 2),
        (seg.left, 4),
        (seg.right, 4),
        (seg.left_vel, 4),
        (seg.right_vel, 4),
    ):
        assert a.shape == (len(seg), cols)
    assert seg.phase.dtype == np.int8
    assert np.all(seg.phase[:n_ds] == 0) and np.all(seg.phase[n_ds:] == 1)  # left support

    # Stance foot still; swing foot still in double support, exactly on the step at the end.
    np.testing.assert_array_equal(seg.left, np.tile([0.0, HALF_WIDTH, 0.0, 0.0], (len(seg), 1)))
    np.testing.assert_array_equal(seg.left_vel, 0.0)
    np.testing.assert_array_equal(seg.right[: n_ds + 1], np.tile([0.0, -HALF_WIDTH, 0.0, 0.0], (n_ds + 1, 1)))
    np.testing.assert_array_equal(seg.right[-1], [0.25, -0.12, 0.0, 0.3])

    swing = seg.right[n_ds:]
    z = swing[:, 2]
    assert z[0] == 0.0 and z[-1] == 0.0 and np.all(z >= 0.0)
    assert abs(z.max() - 0.05) < 1e-5
    assert abs(np.argmax(z) - (n_ss - 1) / 2) <= 1  # at mid-swing

    # Velocity and acceleration from finite differences vanish at lift-off and touch-down
    # (relative to their peaks over the swing), for every coordinate.
    vel = np.diff(swing, axis=0) / dt
    acc = np.diff(swing, n=2, axis=0) / dt**2
    for i in range(4):
        assert np.abs(vel[[0, -1], i]).max() < 1e-3 * np.abs(vel[:, i]).max(), i
        assert np.abs(acc[[0, -1], i]).max() < 0.05 * np.abs(acc[:, i]).max(), i
    assert np.abs(acc[:, :2]).max() < 10.0  # a smooth swing, not a jump

    # Derivatives given with the poses match finite differences.
    np.testing.assert_allclose(np.gradient(seg.right, dt, axis=0)[1:-1], seg.right_vel[1:-1], atol=1e-3)
    np.testing.assert_array_equal(seg.right_vel[[n_ds, -1]], 0.0)

    # ZMP: linear from the start to the stance sole centre, then inside the stance sole.
    np.testing.assert_array_equal(seg.zmp[0], start)
    expected = start + np.arange(n_ds)[:, None] / n_ds * (np.array([0.0, HALF_WIDTH]) - start)
    np.testing.assert_allclose(seg.zmp[:n_ds], expected, atol=1e-15)
    assert all(in_sole(seg.zmp[k], seg.left[k]) for k in range(n_ds, len(seg)))
    assert support_violations(seg, seg.zmp) == []


def test_left_step_segment_phase_and_yaw():
    seg = step_segment(
        LEFT0,
        RIGHT0,
        np.array([0.0, -HALF_WIDTH]),
        Footstep(0.2, 0.1, -0.2, "left"),
        StepTiming(),
        DT,
    )
    n_ds = 20
    assert np.all(seg.phase[n_ds:] == 2)  # right support
    np.testing.assert_array_equal(seg.right, np.tile(RIGHT0.pose, (len(seg), 1)))
    np.testing.assert_array_equal(seg.left[-1], [0.2, 0.1, 0.0, -0.2])
    assert np.all(np.diff(seg.left[n_ds:, 3]) <= 0.0)  # yaw turns monotonically
    np.testing.assert_allclose(seg.zmp[n_ds:], np.tile(RIGHT0.xy, (len(seg) - n_ds, 1)))


def test_stop_segment():
    timing = StepTiming(double_support=0.1)
    left, right = Footstep(1.0, 0.1, 0.0, "left"), Footstep(0.8, -0.1, 0.0, "right")
    seg = stop_segment(left, right, left.xy, timing, DT, hold=0.5)
    n_transfer = round(0.3 / DT)
    assert len(seg) == n_transfer + 100
    assert np.all(seg.phase == 0)
    np.testing.assert_array_equal(seg.zmp[0], left.xy)
    np.testing.assert_allclose(seg.zmp[n_transfer:], np.tile([0.9, 0.0], (100, 1)), atol=1e-15)
    np.testing.assert_array_equal(seg.left_vel, 0.0)
    assert support_violations(seg, seg.zmp) == []


def test_segment_concatenate():
    a = stop_segment(LEFT0, RIGHT0, LEFT0.xy, StepTiming(), DT, hold=0.1)
    b = step_segment(
        LEFT0,
        RIGHT0,
        a.zmp[-1],
        Footstep(0.1, -HALF_WIDTH, 0, "right"),
        StepTiming(),
        DT,
    )
    c = a.concatenate(b)
    assert len(c) == len(a) + len(b)
    np.testing.assert_array_equal(c.right[len(a) :], b.right)
    np.testing.assert_array_equal(c.phase[: len(a)], a.phase)
    with pytest.raises(ValueError, match="zmp"):
        Segment(
            np.zeros((3, 2)),
            np.zeros((3, 4)),
            np.zeros((3, 4)),
            np.zeros((3, 4)),
            np.zeros((3, 4)),
            np.zeros(4, dtype=np.int8),
        )


def test_limits_refuse_bad_steps():
    limits = StepLimits()
    with pytest.raises(ValueError, match="min_width"):  # right foot onto the left one
        limits.check(LEFT0, Footstep(0.1, 0.05, 0.0, "right"))
    with pytest.raises(ValueError, match="cross"):  # left foot to the right of the right one
        limits.check(RIGHT0, Footstep(0.1, -0.2, 0.0, "left"))
    with pytest.raises(ValueError, match="max_stride") as err:
        limits.check(LEFT0, Footstep(0.5, -HALF_WIDTH, 0.0, "right"))
    assert "0.5" in str(err.value) and "0.35" in str(err.value)
    with pytest.raises(ValueError, match="max_width"):
        limits.check(LEFT0, Footstep(0.0, -0.4, 0.0, "right"))
    with pytest.raises(ValueError, match="max_yaw"):
        limits.check(LEFT0, Footstep(0.1, -HALF_WIDTH, 0.8, "right"))
    limits.check(LEFT0, Footstep(0.3, -HALF_WIDTH, 0.4, "right"))  # reachable
    # The check is done in the stance frame: a stance foot turned by 90° (facing +y).
    stance = Footstep(0.0, 0.0, math.pi / 2, "left")
    limits.check(stance, Footstep(0.19, 0.3, math.pi / 2, "right"))  # its right is +x
    with pytest.raises(ValueError, match="max_stride"):
        limits.check(stance, Footstep(0.19, 0.4, math.pi / 2, "right"))


def test_bad_values_are_refused():
    with pytest.raises(ValueError, match="middle"):
        Footstep(0.0, 0.0, 0.0, "middle")
    with pytest.raises(ValueError, match="single_support.*0"):
        StepTiming(single_support=0.0)
    with pytest.raises(ValueError, match="step_height"):
        StepTiming(step_height=-0.1)
    with pytest.raises(ValueError, match="step 1.*max_stride"):
        FootstepPlan(
            LEFT0,
            RIGHT0,
            [
                Footstep(0.2, -HALF_WIDTH, 0, "right"),
                Footstep(0.7, HALF_WIDTH, 0, "left"),
            ],
        )
    with pytest.raises(ValueError, match="step 0.*min_width"):
        FootstepPlan(LEFT0, RIGHT0, [Footstep(0.1, 0.0, 0, "right")])
    with pytest.raises(ValueError, match="initial stance"):
        FootstepPlan(Footstep(0, -0.1, 0, "left"), Footstep(0, 0.1, 0, "right"), [])


def turning_walk_steps() -> list[Footstep]:
    """8 forward steps of 0.25 m, then 4 steps turning left by π/8 each, 0.05 m apart."""
    steps = []
    side = "right"
    ox, oy, yaw = 0.0, 0.0, 0.0  # a frame midway between the feet
    for k in range(12):
        if k < 8:
            ox += 0.25
        else:
            yaw += math.pi / 8
            ox, oy = ox + 0.05 * math.cos(yaw), oy + 0.05 * math.sin(yaw)
        lat = HALF_WIDTH if side == "left" else -HALF_WIDTH
        steps.append(Footstep(ox - lat * math.sin(yaw), oy + lat * math.cos(yaw), yaw, side))
        side = "left" if side == "right" else "right"
    return steps


def test_turning_walk_zmp_in_support_polygon():
    steps = turning_walk_steps()
    plan = FootstepPlan(LEFT0, RIGHT0, steps)  # valid with the default limits
    assert math.isclose(steps[-1].yaw, math.pi / 2)
    seg = plan.sample(DT, hold=1.0)
    timing = StepTiming()
    expected = 12 * round((timing.single_support + timing.double_support) / DT) + round(1.3 / DT)
    assert len(seg) == expected
    assert support_violations(seg, seg.zmp) == []
    # Every foot ends where its last step put it.
    np.testing.assert_array_equal(seg.right[-1], steps[-2].pose)
    np.testing.assert_array_equal(seg.left[-1], steps[-1].pose)
    np.testing.assert_allclose(seg.zmp[-1], 0.5 * (steps[-1].xy + steps[-2].xy), atol=1e-12)
    # Poses are continuous and their derivatives match finite differences.
    for pose, vel in ((seg.left, seg.left_vel), (seg.right, seg.right_vel)):
        assert np.abs(np.diff(pose, axis=0)).max() < 0.02  # no jumps
        np.testing.assert_allclose(np.gradient(pose, DT, axis=0)[1:-1], vel[1:-1], atol=0.02)
    # FootstepPlan.walk builds the same footsteps.
    built = FootstepPlan.walk(
        LEFT0,
        RIGHT0,
        12,
        stride=[0.25] * 8 + [0.05] * 4,
        turn=[0.0] * 8 + [math.pi / 8] * 4,
    )
    for a, b in zip(built.steps, steps, strict=False):
        assert a.side == b.side
        np.testing.assert_allclose([a.x, a.y, a.yaw], [b.x, b.y, b.yaw], atol=1e-12)


def test_planned_zmp_of_a_walk_stays_in_support_polygon(controller):
    """The CoM plan of a sampled walk keeps the model ZMP inside the (slightly shrunk) support."""
    seg = FootstepPlan(LEFT0, RIGHT0, turning_walk_steps()).sample(DT, hold=1.0, stand=1.0)
    plan = controller.plan(seg.zmp)
    assert np.abs(plan.zmp - seg.zmp).max() < 0.02
    assert support_violations(seg, plan.zmp) == []
    # Without the standing lead-in the CoM, at rest at t = 0, cannot shift in time for
    # the first 0.1 s transfer: the lead-in is what makes the plan feasible.
    no_lead = FootstepPlan(LEFT0, RIGHT0, turning_walk_steps()).sample(DT, hold=1.0)
    assert support_violations(no_lead, controller.plan(no_lead.zmp).zmp) != []


def test_straight_walk_footprints():
    plan = FootstepPlan.walk(LEFT0, RIGHT0, 4, stride=0.3, first_side="left")
    assert [s.side for s in plan.steps] == ["left", "right", "left", "right"]
    for k, s in enumerate(plan.steps, start=1):
        assert math.isclose(s.x, 0.3 * k) and s.yaw == 0.0
        assert math.isclose(s.y, HALF_WIDTH if s.side == "left" else -HALF_WIDTH)
    with pytest.raises(ValueError, match="stride"):
        FootstepPlan.walk(LEFT0, RIGHT0, 4, stride=[0.1, 0.2])
    with pytest.raises(ValueError, match="step 0.*max_stride"):
        FootstepPlan.walk(LEFT0, RIGHT0, 4, stride=0.4)


def test_segment_arrays_are_read_only_views():
    zmp = np.zeros((2, 2))
    seg = Segment(
        zmp,
        np.zeros((2, 4)),
        np.zeros((2, 4)),
        np.zeros((2, 4)),
        np.zeros((2, 4)),
        np.array([0, 1]),
    )
    assert seg.phase.dtype == np.int8
    assert zmp.flags.writeable and not seg.zmp.flags.writeable
    with pytest.raises(ValueError, match="phase"):
        Segment(
            zmp,
            np.zeros((2, 4)),
            np.zeros((2, 4)),
            np.zeros((2, 4)),
            np.zeros((2, 4)),
            np.array([0, 3]),
        )


def test_full_turn_keeps_yaw_continuous():
    """Footstep yaws given wrapped to [-π, π) still give a continuous sampled yaw."""
    built = FootstepPlan.walk(LEFT0, RIGHT0, 18, stride=0.0, turn=math.pi / 8, first_side="left")
    wrapped = [Footstep(s.x, s.y, (s.yaw + math.pi) % (2 * math.pi) - math.pi, s.side) for s in built.steps]
    seg = FootstepPlan(LEFT0, RIGHT0, wrapped).sample(DT, hold=0.2)
    for pose in (seg.left, seg.right):
        assert np.abs(np.diff(pose[:, 3])).max() < 0.02
    np.testing.assert_allclose(seg.left[-1, 3], 17 * math.pi / 8)
    np.testing.assert_allclose(seg.right[-1, 3], 18 * math.pi / 8)
    assert support_violations(seg, seg.zmp) == []
