"""Tests of drake_sot.footsteps and drake_sot.walk_planner: footprints, bounds, segments, the offline
and online planners.

References are independent of the code under test: SE(2) products of homogeneous
matrices for the footprint composition, geometry (sole rectangles, convex hulls of the
soles), finite differences, and the preview controller run by hand over the offline plan.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from drake_sot.footsteps import (
    WALKING_BOUNDS,
    Footstep,
    StepLimits,
    StepTiming,
    alternating_steps,
    compose,
    mean_yaw,
    relative_steps,
    stance_width,
)
from drake_sot.preview import PreviewController
from drake_sot.walk_planner import (
    FOOTPRINTS_AHEAD,
    FootstepPlan,
    Segment,
    WalkPlanner,
    step_segment,
    stop_segment,
)

DT = 0.005
SOLE_LENGTH, SOLE_WIDTH = 0.23, 0.13  # the rectangle around the sole centre (HRP-2-like)
HALF_WIDTH = 0.095  # feet 0.19 m apart


@pytest.fixture(scope="module")
def controller() -> PreviewController:
    return PreviewController(dt=DT, z_c=0.814, horizon=1.6)


def se2(x: float, y: float, yaw: float) -> np.ndarray:
    """The homogeneous 3x3 matrix of a planar pose."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def pose_of(T: np.ndarray) -> tuple[float, float, float]:
    return T[0, 2], T[1, 2], math.atan2(T[1, 0], T[0, 0])


def same_footprint(step: Footstep, T: np.ndarray, side: str) -> None:
    x, y, yaw = pose_of(T)
    assert step.side == side
    np.testing.assert_allclose([step.x, step.y], [x, y], atol=1e-12)
    assert abs(math.remainder(step.yaw - yaw, 2 * math.pi)) < 1e-12


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


def test_stop_segment_without_hold_ends_on_the_midpoint():
    """A preview controller holds the last reference for ever: it must be the midpoint."""
    left, right = Footstep(1.0, 0.1, 0.0, "left"), Footstep(0.8, -0.1, 0.0, "right")
    seg = stop_segment(left, right, left.xy, StepTiming(), DT, hold=0.0)
    assert len(seg) == round(0.3 / DT) + 1
    np.testing.assert_array_equal(seg.zmp[-1], [0.9, 0.0])


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
    steps = alternating_steps(LEFT0, RIGHT0, 4, stride=0.3, first_side="left")
    assert [s.side for s in steps] == ["left", "right", "left", "right"]
    for k, s in enumerate(steps, start=1):
        assert math.isclose(s.x, 0.3 * k) and s.yaw == 0.0
        assert math.isclose(s.y, HALF_WIDTH if s.side == "left" else -HALF_WIDTH)
    with pytest.raises(ValueError, match="stride"):
        alternating_steps(LEFT0, RIGHT0, 4, stride=[0.1, 0.2])
    with pytest.raises(ValueError, match="first_side"):
        alternating_steps(LEFT0, RIGHT0, 4, first_side="middle")
    with pytest.raises(ValueError, match="width = -0.19"):  # a crossed stance has no width
        alternating_steps(Footstep(0, -HALF_WIDTH, 0, "left"), Footstep(0, HALF_WIDTH, 0, "right"), 2)
    with pytest.raises(ValueError, match="step 0.*max_stride"):
        FootstepPlan(LEFT0, RIGHT0, alternating_steps(LEFT0, RIGHT0, 4, stride=0.4))


def test_segment_arrays_are_read_only_views():
    zmp = np.zeros((2, 2))
    feet = [np.zeros((2, 4)) for _ in range(4)]  # left, right and their velocities
    seg = Segment(zmp, *feet, np.array([0, 1]))
    assert seg.phase.dtype == np.int8
    assert zmp.flags.writeable and not seg.zmp.flags.writeable
    with pytest.raises(ValueError, match="phase"):
        Segment(zmp, *feet, np.array([0, 3]))


def test_full_turn_keeps_yaw_continuous():
    """Footstep yaws given wrapped to [-π, π) still give a continuous sampled yaw."""
    built = alternating_steps(LEFT0, RIGHT0, 18, turn=math.pi / 8, first_side="left")
    wrapped = [Footstep(s.x, s.y, (s.yaw + math.pi) % (2 * math.pi) - math.pi, s.side) for s in built]
    seg = FootstepPlan(LEFT0, RIGHT0, wrapped).sample(DT, hold=0.2)
    for pose in (seg.left, seg.right):
        assert np.abs(np.diff(pose[:, 3])).max() < 0.02
    np.testing.assert_allclose(seg.left[-1, 3], 17 * math.pi / 8)
    np.testing.assert_allclose(seg.right[-1, 3], 18 * math.pi / 8)
    assert support_violations(seg, seg.zmp) == []


# --------------------------------------------------------------------------- composition


def test_compose_is_the_product_of_planar_transforms():
    rng = np.random.default_rng(1)
    for _ in range(20):
        fx, fy, fyaw, x, y, yaw = rng.uniform(-3, 3, 6)
        step = compose(Footstep(fx, fy, fyaw, "left"), x, y, yaw, "right")
        same_footprint(step, se2(fx, fy, fyaw) @ se2(x, y, yaw), "right")


def test_relative_steps_are_chained_from_the_other_foot():
    moves = [("right", 0.2, -0.19, 0.1), ("left", 0.25, 0.2, -0.05), ("left", 0.0, 0.21, 0.0)]
    steps = relative_steps(LEFT0, RIGHT0, moves)
    feet = {"left": se2(*LEFT0.pose[[0, 1, 3]]), "right": se2(*RIGHT0.pose[[0, 1, 3]])}
    for step, (side, dx, dy, dyaw) in zip(steps, moves, strict=True):
        feet[side] = feet["right" if side == "left" else "left"] @ se2(dx, dy, dyaw)
        same_footprint(step, feet[side], side)
    with pytest.raises(ValueError, match="'up'"):
        relative_steps(LEFT0, RIGHT0, [("up", 0.0, 0.0, 0.0)])


def test_alternating_steps_against_planar_products():
    """Each footprint is the other foot's last one times (stride, ±width, turn)."""
    strides = [0.25] * 8 + [0.05] * 4
    turns = [0.0] * 8 + [math.pi / 8] * 4
    steps = alternating_steps(LEFT0, RIGHT0, 12, stride=strides, turn=turns)
    feet = {"left": se2(0.0, HALF_WIDTH, 0.0), "right": se2(0.0, -HALF_WIDTH, 0.0)}
    side = "right"
    for step, stride, turn in zip(steps, strides, turns, strict=True):
        lateral = 2 * HALF_WIDTH if side == "left" else -2 * HALF_WIDTH
        feet[side] = feet["left" if side == "right" else "right"] @ se2(stride, lateral, turn)
        same_footprint(step, feet[side], side)
        side = "left" if side == "right" else "right"
    FootstepPlan(LEFT0, RIGHT0, steps)  # within the default limits


def test_stance_width_is_lateral_across_the_mean_heading():
    rng = np.random.default_rng(2)
    for _ in range(20):
        x, y, yaw, ahead, width = *rng.uniform(-2, 2, 3), rng.uniform(-0.3, 0.3), rng.uniform(0.1, 0.4)
        right = Footstep(x, y, yaw, "right")
        # The left sole `width` to the left and `ahead` forward, same yaw: the fore-aft
        # offset does not count.
        lx, ly, _ = pose_of(se2(x, y, yaw) @ se2(ahead, width, 0.0))
        assert stance_width(Footstep(lx, ly, yaw, "left"), right) == pytest.approx(width, abs=1e-12)
        # Feet crossed: negative.
        lx, ly, _ = pose_of(se2(x, y, yaw) @ se2(0.0, -width, 0.0))
        assert stance_width(Footstep(lx, ly, yaw, "left"), right) == pytest.approx(-width, abs=1e-12)
    # Feet turned apart by ±0.2 rad around a heading of 3 rad (across the ±π seam): the
    # width is measured across the heading of 3 rad.
    heading = 3.0
    centre = se2(1.0, -2.0, heading)
    lx, ly, _ = pose_of(centre @ se2(0.0, 0.1, 0.0))
    rx, ry, _ = pose_of(centre @ se2(0.0, -0.1, 0.0))
    left = Footstep(lx, ly, heading + 0.2, "left")
    right = Footstep(rx, ry, math.remainder(heading - 0.2, 2 * math.pi), "right")
    assert stance_width(left, right) == pytest.approx(0.2, abs=1e-12)


def test_mean_yaw_takes_the_short_way_round():
    assert mean_yaw(0.4, 0.2) == pytest.approx(0.3)
    # 170° and -170° are 20° apart across ±180°: their mean is 180°, not 0°.
    m = mean_yaw(math.radians(170), math.radians(-170))
    assert abs(math.remainder(m - math.pi, 2 * math.pi)) < 1e-12


# --------------------------------------------------------------------------- bounds


def _bound_text(bound) -> str:
    return rf"\[{bound.low:g}, {bound.high:g}\] {bound.unit}"


@pytest.mark.parametrize("name", ["single_support", "double_support", "step_height"])
def test_step_timing_is_bounded(name):
    bound = getattr(WALKING_BOUNDS, name)
    eps = 1e-6 * bound.high
    for value in (math.nan, math.inf, -math.inf, bound.low - eps, bound.high + eps, -bound.low):
        with pytest.raises(ValueError, match=rf"StepTiming.{name} = .*{_bound_text(bound)}"):
            StepTiming(**{name: value})
    for value in (bound.low, bound.high):
        assert getattr(StepTiming(**{name: value}), name) == value


def test_walking_bounds_hold_their_physical_claims(controller):
    b = WALKING_BOUNDS
    # The shortest single support swings the longest default stride with a peak
    # acceleration (quintic: 10/sqrt(3) D / T^2) below 6 g.
    assert 10 / math.sqrt(3) * StepLimits().max_stride / b.single_support.low**2 < 6 * 9.81
    # The shortest double support still gives the ZMP transfer 10 ticks at 5 ms.
    assert StepTiming(double_support=b.double_support.low).samples(DT)[0] == 10
    # The shortest preview time keeps the planned model ZMP of a walk in its support
    # polygon (with the default 0.8 s steps, HRP-2's CoM height).
    short = PreviewController(dt=DT, z_c=0.814, horizon=b.preview_time.low)
    seg = FootstepPlan(LEFT0, RIGHT0, alternating_steps(LEFT0, RIGHT0, 8, stride=0.2)).sample(DT, stand=1.0)
    assert support_violations(seg, short.plan(seg.zmp).zmp) == []


def test_timing_samples_refuse_a_period_too_long():
    timing = StepTiming(single_support=0.7, double_support=0.1)
    assert timing.samples(0.005) == (20, 140)
    with pytest.raises(ValueError, match=r"double_support = 0.1 s gives 0 samples at dt = 0.25 s"):
        timing.samples(0.25)
    with pytest.raises(ValueError, match=r"single_support = 0.7 s gives 1 samples at dt = 0.5 s; at least 2"):
        StepTiming(double_support=1.0, single_support=0.7).samples(0.5)
    with pytest.raises(ValueError, match="dt = nan"):
        timing.samples(math.nan)


# --------------------------------------------------------------------------- online planner


def _start(**kwargs) -> WalkPlanner:
    return WalkPlanner.start(LEFT0, RIGHT0, com_height=0.814, dt=DT, horizon=1.6, **kwargs)


def test_online_planner_given_a_whole_walk_reproduces_the_offline_plan(controller):
    """Steps given at t = 0: the planner stands one preview time (the frozen window), then
    walks exactly the samples of FootstepPlan with that lead-in, and its CoM is the
    preview controller's offline plan of them."""
    steps = alternating_steps(LEFT0, RIGHT0, 6, stride=0.2, turn=[0.0, 0.0, 0.1, 0.1, 0.1, 0.0])
    planner = _start().add_steps(steps)
    offline = FootstepPlan(LEFT0, RIGHT0, steps).sample(DT, hold=0.0, stand=controller.N * DT)
    for name in ("zmp", "left", "right", "left_vel", "right_vel", "phase"):
        np.testing.assert_array_equal(getattr(planner.samples, name), getattr(offline, name), err_msg=name)
    landings = [i for i, _ in planner.landings]
    ends = np.flatnonzero((offline.phase[:-1] != 0) & (offline.phase[1:] == 0))  # last single-support samples
    assert landings == list(ends)
    com = controller.plan(offline.zmp).com
    for k in range(len(offline)):
        np.testing.assert_allclose(planner.com[:2], com[k], atol=1e-12, err_msg=f"sample {k}")
        assert planner.in_process == (k < planner.walk_end)
        planner = planner.advance()


def test_steps_given_during_a_walk_never_change_the_previewed_samples():
    planner = _start().add_steps(alternating_steps(LEFT0, RIGHT0, 2, stride=0.2))
    for _ in range(100):
        planner = planner.advance()
    seen = planner.samples.part(0, planner.k + planner.controller.N)
    later = planner.add_steps([compose(planner.feet["left"], 0.2, -2 * HALF_WIDTH, 0.0, "right")])
    for name in ("zmp", "left", "right", "phase"):
        np.testing.assert_array_equal(getattr(later.samples, name)[: len(seen)], getattr(seen, name))
    # The new step starts where the old plan's stop segment started.
    assert later.landings[-1][0] > planner.stop_start
    assert later.landings[:2] == planner.landings


def test_a_planner_stands_indefinitely_after_its_plan_and_walks_what_it_is_given_then():
    """Standing, then a two-step walk, then standing again, each for longer than the executed
    samples the planner keeps: the references stay those of standing (the CoM at rest over the
    feet' midpoint, both feet down), and steps given after an hour-long wait are walked as the
    same steps given at once are (the same samples from the moment they are given)."""
    standing = _start()
    midpoint = 0.5 * (LEFT0.xy + RIGHT0.xy)
    for _ in range(3 * round(20.0 / DT)):  # 60 s standing: three times the samples kept
        standing = standing.advance()
    np.testing.assert_allclose(standing.com[:2], midpoint, atol=1e-9)
    np.testing.assert_allclose(standing.com_vel[:2], 0.0, atol=1e-9)
    assert not standing.in_process and standing.contacts.tolist() == [1.0, 1.0]
    steps = alternating_steps(LEFT0, RIGHT0, 2, stride=0.2)
    fresh = _start().add_steps(steps)
    late = standing.add_steps(steps)
    assert [i - late.k for i, _ in late.landings] == [i - fresh.k for i, _ in fresh.landings]
    for _ in range(round(25.0 / DT)):  # the walk, then standing past the samples kept again
        np.testing.assert_allclose(late.com, fresh.com, atol=1e-9)
        np.testing.assert_array_equal(late.sole("left"), fresh.sole("left"))
        late, fresh = late.advance(), fresh.advance()
    assert not late.in_process
    np.testing.assert_allclose(
        late.feet["left"].xy, steps[-1].xy if steps[-1].side == "left" else steps[-2].xy
    )


def test_velocity_mode_spaces_footprints_by_the_velocity_at_a_constant_width():
    """Turning while walking: each footprint is the stance foot's times (v T, ±w + vy T, wz T)
    with the initial stance width w, however long the walk (no drift of the width), and
    the executed samples are dropped without a jump in the references."""
    vx, vy, wz = 0.15, 0.02, 0.2
    planner = _start().with_velocity(vx, vy, wz)
    T = planner.timing.period
    w = 2 * HALF_WIDTH
    previous_com = planner.com
    landings = {}
    for _ in range(round(40.0 / DT)):  # 40 s: beyond the 4000 executed samples kept
        planner = planner.advance()
        assert np.linalg.norm(planner.com - previous_com) < 0.01
        previous_com = planner.com
        assert len(planner.landings_ahead()) >= FOOTPRINTS_AHEAD - 1
        for _, step in planner.landings_ahead():
            landings[(step.x, step.y, step.yaw, step.side)] = step
    assert len(planner.samples) < 4000 + 10 * round(T / DT)  # executed samples were dropped
    steps = list(landings.values())
    assert len(steps) > 40
    for stance, step in zip(steps, steps[1:], strict=False):
        lateral = w if step.side == "left" else -w
        expected = se2(stance.x, stance.y, stance.yaw) @ se2(vx * T, lateral + vy * T, wz * T)
        same_footprint(step, expected, step.side)


def test_velocity_beyond_a_limit_is_refused_and_zero_velocity_stops_side_by_side():
    planner = _start()
    with pytest.raises(ValueError, match="max_stride"):
        planner.with_velocity(1.0)
    with pytest.raises(ValueError, match="vx = nan"):
        planner.with_velocity(math.nan)
    assert planner.with_velocity(0.0) is planner  # standing: nothing to stop
    walking = planner.with_velocity(0.2)
    for _ in range(200):
        walking = walking.advance()
    stopped = walking.with_velocity(0.0, 0.0, 0.0)
    left, right = stopped.feet["left"], stopped.feet["right"]
    assert left.yaw == right.yaw and stance_width(left, right) == pytest.approx(2 * HALF_WIDTH)
    assert stopped.velocity is None and stopped.in_process


def test_planner_refuses_bad_model_changes():
    planner = _start()
    with pytest.raises(ValueError, match=r"com_height = 3.0 m: must be in \[0.1, 2\] m"):
        planner.with_model(com_height=3.0)
    with pytest.raises(ValueError, match=r"preview_time = 0.5 s: must be in \[1, 4\] s"):
        planner.with_model(horizon=0.5)
    walking = planner.add_steps(alternating_steps(LEFT0, RIGHT0, 1, stride=0.1))
    with pytest.raises(ValueError, match="com_height can change only while standing"):
        walking.with_model(com_height=0.8)
    changed = planner.with_model(com_height=0.7, horizon=1.2)
    assert changed.controller.z_c == 0.7 and changed.controller.N == 240
    # Standing over the same point with new gains: no kick (bumpless restart).
    for _ in range(100):
        changed = changed.advance()
    np.testing.assert_allclose(changed.com[:2], [0.0, 0.0], atol=1e-9)


def test_readme_states_the_walking_bounds():
    """The README's table of bounds says what WALKING_BOUNDS enforces."""
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    verbs = {
        "single_support": ":singlesupporttime",
        "double_support": ":doublesupporttime",
        "step_height": ":stepheight",
        "com_height": ":comheight",
        "preview_time": ":previewcontroltime",
    }
    for name, verb in verbs.items():
        bound = getattr(WALKING_BOUNDS, name)
        assert f"| `{verb}` | {bound.low:g} to {bound.high:g} {bound.unit}" in readme, name


def test_the_step_vocabulary_and_the_planner_import_no_drake():
    """The step vocabulary (what robot descriptions need) and the planner are pure, and the
    vocabulary does not pull the planner in."""
    code = (
        "import sys, drake_sot.footsteps; planner = 'drake_sot.walk_planner' in sys.modules; "
        "import drake_sot.walk_planner; sys.exit(2 * planner + ('pydrake' in sys.modules))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, (result.returncode, result.stderr)
