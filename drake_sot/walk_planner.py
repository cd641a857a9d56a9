"""The walking planner: footprints to ZMP reference, feet trajectories and CoM, offline or online.

Pure numpy; no Drake. The step vocabulary it plans with (footprints, timing, limits,
bounds) is :mod:`drake_sot.footsteps`; the ZMP preview control that turns the planned
ZMP reference into a CoM trajectory is :mod:`drake_sot.preview`.

**Segments.**  A walk is cut into :class:`Segment` s sampled at ``dt`` (sample ``i`` at
time ``i·dt`` from the segment start): for each step a double-support phase where the ZMP
reference moves linearly onto the stance foot, then a single-support phase where it stays
at the stance sole centre (the piecewise ZMP reference of Kajita et al. 2003) while the
swing foot travels (quintic in x, y, yaw; ``64 s³(1-s)³`` bump in z).

**Planning.**  :class:`FootstepPlan` checks a whole list of footsteps against
:class:`~drake_sot.footsteps.StepLimits` and samples it (offline: hand its ZMP reference to
:meth:`drake_sot.preview.PreviewController.plan` for the CoM).  :class:`WalkPlanner` does
the same online, as the walking planner of Evrard et al. 2009 (section III-C) runs: it
appends footprints while the walk goes (or makes them from a velocity, keeping
:data:`FOOTPRINTS_AHEAD` planned), never changes the references already in the preview
window, and takes one preview-control step per tick.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from drake_sot import validation
from drake_sot.footsteps import (
    PHASE_DOUBLE,
    PHASE_LEFT_SUPPORT,
    PHASE_RIGHT_SUPPORT,
    SIDES,
    WALKING_BOUNDS,
    Footstep,
    StepLimits,
    StepTiming,
    compose,
    mean_yaw,
    other_side,
    sample_count,
    stance_width,
    wrap_angle,
)
from drake_sot.immutable import Immutable
from drake_sot.preview import PreviewController

__all__ = [
    "FOOTPRINTS_AHEAD",
    "STOP_TRANSFER_MIN",
    "FootstepPlan",
    "Segment",
    "WalkPlanner",
    "stand_segment",
    "step_segment",
    "stop_segment",
]

#: Shortest ZMP transfer [s] of :func:`stop_segment`: the final shift of the ZMP
#: to the midpoint of the soles lasts ``max(timing.double_support, STOP_TRANSFER_MIN)``.
STOP_TRANSFER_MIN = 0.3

#: Footprints the :class:`WalkPlanner` keeps planned ahead in velocity mode
#: (Evrard et al. 2009, III-C).
FOOTPRINTS_AHEAD = 4
# Samples already executed that the online planner keeps before dropping them (also while
# walking: a walk in velocity mode never ends, and its plan must not grow without bound).
_KEEP_EXECUTED = 4000


@dataclass(frozen=True, eq=False)
class Segment:
    """Samples at ``dt`` of one stretch of a walk (sample ``i`` at time ``i·dt`` from its start).

    Attributes:
        zmp: (K, 2) ZMP reference [m].
        left, right: (K, 4) sole poses ``[x, y, z, yaw]`` [m, rad].
        left_vel, right_vel: (K, 4) their time derivatives.
        phase: (K,) int8: 0 double support, 1 left support (right foot swinging),
            2 right support (left foot swinging).

    The arrays are read-only.
    """

    zmp: np.ndarray
    left: np.ndarray
    right: np.ndarray
    left_vel: np.ndarray
    right_vel: np.ndarray
    phase: np.ndarray

    def __post_init__(self) -> None:
        K = len(self.phase)
        shapes = {"zmp": 2, "left": 4, "right": 4, "left_vel": 4, "right_vel": 4}
        for name, cols in shapes.items():
            # a read-only view: the caller's array stays writeable
            a = np.asarray(getattr(self, name), dtype=float).view()
            if a.shape != (K, cols):
                raise ValueError(f"Segment.{name} must have shape ({K}, {cols}), got {a.shape}")
            a.flags.writeable = False
            object.__setattr__(self, name, a)
        p = np.asarray(self.phase).view()
        if p.ndim != 1:
            raise ValueError(f"Segment.phase must be 1-D, got shape {p.shape}")
        if p.dtype != np.int8:
            if not np.all(np.isin(p, (0, 1, 2))):
                raise ValueError(f"Segment.phase values must be 0, 1 or 2, got {np.unique(p)}")
            p = p.astype(np.int8)
        elif np.any((p < 0) | (p > 2)):
            raise ValueError(f"Segment.phase values must be 0, 1 or 2, got {np.unique(p)}")
        p.flags.writeable = False
        object.__setattr__(self, "phase", p)

    def __len__(self) -> int:
        return len(self.phase)

    def part(self, start: int, stop: int | None = None) -> Segment:
        """Samples ``start`` to ``stop`` (exclusive; None: to the end), sharing the arrays."""
        return Segment(
            **{
                name: getattr(self, name)[start:stop]
                for name in ("zmp", "left", "right", "left_vel", "right_vel")
            },
            phase=self.phase[start:stop],
        )

    def concatenate(self, other: Segment) -> Segment:
        """This segment followed by ``other``."""
        return Segment.join([self, other])

    @staticmethod
    def join(segments: Sequence[Segment]) -> Segment:
        """The segments one after the other (one copy, unlike repeated :meth:`concatenate`)."""
        if len(segments) == 0:
            raise ValueError("Segment.join needs at least one segment")

        def cat(name: str) -> np.ndarray:
            return np.concatenate([getattr(s, name) for s in segments])

        return Segment(
            zmp=cat("zmp"),
            left=cat("left"),
            right=cat("right"),
            left_vel=cat("left_vel"),
            right_vel=cat("right_vel"),
            phase=cat("phase"),
        )


def _zmp_transfer(start: np.ndarray, end: np.ndarray, n: int) -> np.ndarray:
    """(n, 2) linear move from ``start`` (sample 0) towards ``end``, reached at sample n."""
    s = (np.arange(n) / n)[:, None]
    return (1.0 - s) * start + s * end


def _still(pose: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.broadcast_to(pose, (n, 4)).copy(), np.zeros((n, 4))


def _check_feet(left: Footstep, right: Footstep) -> None:
    if left.side != "left":
        raise ValueError(f"the left foot has side {left.side!r}")
    if right.side != "right":
        raise ValueError(f"the right foot has side {right.side!r}")


def _landing_yaw(yaw0: float, yaw1: float) -> float:
    """``yaw1`` shifted by a multiple of 2π to within π of ``yaw0`` (itself if already so)."""
    return yaw1 if abs(yaw1 - yaw0) <= math.pi else yaw0 + wrap_angle(yaw1 - yaw0)


def _swing(start: Footstep, end: Footstep, height: float, n: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, 4) poses and velocities of a swing from ``start`` (sample 0) to ``end`` (sample n-1).

    The swing lasts ``(n-1)·dt`` so that lift-off and touch-down are both samples.
    Horizontal: quintic ``10s³ - 15s⁴ + 6s⁵``; vertical ``h·64 s³(1-s)³``: zero velocity
    and acceleration at both ends.  The yaw turns the short way round.
    """
    T = (n - 1) * dt
    s = np.arange(n) / (n - 1)
    s[-1] = 1.0
    q = s**3 * (10.0 + s * (-15.0 + 6.0 * s))
    dq = 30.0 * s**2 * (1.0 - s) ** 2 / T
    yaw0, yaw1 = start.yaw, _landing_yaw(start.yaw, end.yaw)
    p0 = np.array([start.x, start.y, 0.0, yaw0])
    p1 = np.array([end.x, end.y, 0.0, yaw1])
    pose = (1.0 - q)[:, None] * p0 + q[:, None] * p1
    vel = dq[:, None] * (p1 - p0)
    pose[:, 2] = height * 64.0 * (s * (1.0 - s)) ** 3
    vel[:, 2] = height * 192.0 * (s * (1.0 - s)) ** 2 * (1.0 - 2.0 * s) / T
    return pose, vel


def step_segment(
    left: Footstep,
    right: Footstep,
    zmp_start: np.ndarray,
    step: Footstep,
    timing: StepTiming,
    dt: float,
) -> Segment:
    """One step of the foot ``step.side`` from its current pose to ``step``.

    Double support (``round(double_support/dt)`` samples): both feet still, the ZMP
    reference moves linearly from ``zmp_start`` towards the stance sole centre (the foot
    that is not ``step.side``), reaching it at the first single-support sample.
    Single support (``round(single_support/dt)`` samples, at least 2): the ZMP stays at
    the stance sole centre; the swing foot lifts off at the first sample and touches
    down exactly on ``step`` at the last (x, y, yaw quintic, the yaw turning the short
    way round, so it may land on ``step.yaw ± 2π``; z ``= step_height·64 s³(1-s)³``;
    zero velocity and acceleration at both ends).  Feet are at z = 0 on the ground.
    Limits are not checked here (see :class:`StepLimits`).
    """
    _check_feet(left, right)
    z0 = validation.vector("zmp_start", zmp_start, 2)
    n_ds, n_ss = timing.samples(dt)
    swing_left = step.side == "left"
    stance = right if swing_left else left
    swing_from = left if swing_left else right

    zmp = np.concatenate([_zmp_transfer(z0, stance.xy, n_ds), np.broadcast_to(stance.xy, (n_ss, 2))])
    stance_pose, stance_vel = _still(stance.pose, n_ds + n_ss)
    ds_pose, ds_vel = _still(swing_from.pose, n_ds)
    sw_pose, sw_vel = _swing(swing_from, step, timing.step_height, n_ss, dt)
    swing_pose = np.concatenate([ds_pose, sw_pose])
    swing_vel = np.concatenate([ds_vel, sw_vel])
    phase = np.empty(n_ds + n_ss, dtype=np.int8)
    phase[:n_ds] = PHASE_DOUBLE
    phase[n_ds:] = PHASE_RIGHT_SUPPORT if swing_left else PHASE_LEFT_SUPPORT
    if swing_left:
        return Segment(zmp, swing_pose, stance_pose, swing_vel, stance_vel, phase)
    return Segment(zmp, stance_pose, swing_pose, stance_vel, swing_vel, phase)


def _step_segments(
    left: Footstep,
    right: Footstep,
    zmp_start: np.ndarray,
    steps: Sequence[Footstep],
    timing: StepTiming,
    dt: float,
) -> tuple[list[Segment], dict[str, Footstep]]:
    """One :func:`step_segment` per step, each from where the previous one left the feet
    and the ZMP; and the last footprint of each foot, its yaw within π of the foot's
    previous one (so that the sampled yaw stays continuous when footprint yaws wrap round)."""
    feet = {"left": left, "right": right}
    zmp = zmp_start
    segments = []
    for step in steps:
        segment = step_segment(feet["left"], feet["right"], zmp, step, timing, dt)
        segments.append(segment)
        zmp = segment.zmp[-1]
        feet[step.side] = replace(step, yaw=_landing_yaw(feet[step.side].yaw, step.yaw))
    return segments, feet


def stop_segment(
    left: Footstep,
    right: Footstep,
    zmp_start: np.ndarray,
    timing: StepTiming,
    dt: float,
    hold: float,
) -> Segment:
    """End of a walk, both feet still (phase 0).

    The ZMP reference moves linearly from ``zmp_start`` to the midpoint of the two sole
    centres over ``max(timing.double_support, STOP_TRANSFER_MIN)`` seconds, then stays
    there for ``hold`` seconds (``hold >= 0``; at least one sample, so that the reference
    ends on the midpoint: a preview controller holds the last sample for ever).
    """
    _check_feet(left, right)
    dt = validation.positive("dt", dt, unit="s")
    z0 = validation.vector("zmp_start", zmp_start, 2)
    hold = validation.nonnegative("hold", hold, unit="s")
    n_tr = sample_count("stop transfer", max(timing.double_support, STOP_TRANSFER_MIN), dt, 1)
    n_hold = max(round(hold / dt), 1)
    mid = 0.5 * (left.xy + right.xy)
    zmp = np.concatenate([_zmp_transfer(z0, mid, n_tr), np.broadcast_to(mid, (n_hold, 2))])
    n = n_tr + n_hold
    lp, lv = _still(left.pose, n)
    rp, rv = _still(right.pose, n)
    return Segment(zmp, lp, rp, lv, rv, np.zeros(n, dtype=np.int8))


def stand_segment(left: Footstep, right: Footstep, duration: float, dt: float) -> Segment:
    """``duration`` [s] standing still (phase 0), the ZMP reference at the midpoint of the soles."""
    _check_feet(left, right)
    dt = validation.positive("dt", dt, unit="s")
    duration = validation.nonnegative("stand duration", duration, unit="s")
    n = round(duration / dt)
    mid = 0.5 * (left.xy + right.xy)
    lp, lv = _still(left.pose, n)
    rp, rv = _still(right.pose, n)
    return Segment(np.broadcast_to(mid, (n, 2)).copy(), lp, rp, lv, rv, np.zeros(n, dtype=np.int8))


# --------------------------------------------------------------------------- offline plan


class FootstepPlan:
    """A walk from an initial stance through a list of footsteps, checked against :class:`StepLimits`.

    The offline counterpart of :class:`WalkPlanner`: the whole walk is known in advance,
    :meth:`sample` gives its ZMP reference and feet trajectories, and
    :meth:`drake_sot.preview.PreviewController.plan` of ``sample(dt).zmp`` its CoM
    (tutorials/02_walking_pattern.py). Each step is checked against the pose the other
    foot has at that moment (the initial pose, or its last step); steps may come in any
    side order. The initial stance itself must be a valid placement of the right foot
    relative to the left.

    Raises:
        ValueError: naming the step index and the violated limit.
    """

    def __init__(
        self,
        left: Footstep,
        right: Footstep,
        steps: Sequence[Footstep],
        timing: StepTiming = StepTiming(),
        limits: StepLimits = StepLimits(),
    ) -> None:
        _check_initial_stance(left, right, limits)
        limits.check_steps(left, right, steps)
        self.left = left
        self.right = right
        self.steps = tuple(steps)
        self.timing = timing
        self.limits = limits

    def __len__(self) -> int:
        return len(self.steps)

    def sample(self, dt: float, hold: float = 1.0, stand: float = 0.0) -> Segment:
        """The whole walk sampled at ``dt`` [s].

        ``stand`` seconds standing with the ZMP at the midpoint of the feet (a lead-in that
        lets a preview controller start moving the CoM before the first transfer), then
        for each step a :func:`step_segment` (the first one transfers the ZMP from the
        midpoint to the first stance foot), then :func:`stop_segment` with ``hold`` [s].

        A CoM plan that starts at rest at the first sample needs the lead-in: with
        ``stand = 0`` the preview controller cannot shift the CoM in time for the first
        transfer (0.1 s by default) and its ZMP leaves the support polygon by centimetres;
        ``stand >= 1 s`` keeps it inside (see tests/test_footsteps.py).
        """
        stand = validation.nonnegative("stand", stand, unit="s")
        lead_in = [stand_segment(self.left, self.right, stand, dt)] if stand > 0.0 else []
        zmp = 0.5 * (self.left.xy + self.right.xy)
        steps, feet = _step_segments(self.left, self.right, zmp, self.steps, self.timing, dt)
        if steps:
            zmp = steps[-1].zmp[-1]
        stop = stop_segment(feet["left"], feet["right"], zmp, self.timing, dt, hold)
        return Segment.join([*lead_in, *steps, stop])


def _check_initial_stance(left: Footstep, right: Footstep, limits: StepLimits) -> None:
    _check_feet(left, right)
    try:
        limits.check(left, right)
    except ValueError as err:
        raise ValueError(f"initial stance: {err}") from None


# --------------------------------------------------------------------------- online planner


def _preview(dt: float, com_height: float, horizon: float, q: float, r: float) -> PreviewController:
    """The preview controller of a walk, its height and preview time within :data:`WALKING_BOUNDS`."""
    return PreviewController(
        dt=dt,
        z_c=WALKING_BOUNDS.com_height.check("com_height", com_height),
        horizon=WALKING_BOUNDS.preview_time.check("preview_time", horizon),
        q=q,
        r=r,
    )


@dataclass(frozen=True, eq=False)
class WalkPlanner(Immutable):
    """The online walking planner: footprints in, one sample of references per tick out.

    Never mutated: every command and :meth:`advance` return a new planner that shares the
    (large) sample arrays with this one, so a Drake state that holds it is copied in O(1).
    Make one with :meth:`start`.

    Attributes:
        controller: the cart-table preview controller (its ``dt`` is the tick).
        timing: the timing of the steps planned from now on.
        limits: reachability of a step.
        width: [m] stance width of the footprints made from a velocity (the initial
            stance's :func:`stance_width`).
        samples: the planned samples; index ``k`` is the current tick.
        k: the current tick.
        x: (3, 2) cart-table state ``[c, ċ, c̈]`` per axis (x, y).
        error_sum: (2,) the preview servo's error sum.
        feet: side -> the last planned footprint of that foot.
        last_side: side of the last planned step (None before the first).
        stop_start: index where the final stop segment begins.
        walk_end: index where the ZMP has settled between the feet.
        landings: ``(sample index, footprint)`` of each planned landing, in order.
        velocity: ``(vx, vy, wz)`` [m/s, m/s, rad/s] in velocity mode, else None.
    """

    controller: PreviewController
    timing: StepTiming
    limits: StepLimits
    width: float
    samples: Segment
    k: int
    x: np.ndarray
    error_sum: np.ndarray
    feet: Mapping[str, Footstep]
    last_side: str | None
    stop_start: int
    walk_end: int
    landings: tuple[tuple[int, Footstep], ...]
    velocity: tuple[float, float, float] | None

    @classmethod
    def start(
        cls,
        left: Footstep,
        right: Footstep,
        *,
        com_height: float,
        dt: float = 0.005,
        horizon: float = 1.6,
        q: float = 1.0,
        r: float = 1e-6,
        timing: StepTiming = StepTiming(),
        limits: StepLimits = StepLimits(),
        com: np.ndarray | None = None,
    ) -> WalkPlanner:
        """A planner standing on ``left`` and ``right``, the CoM at rest over ``com``.

        Args:
            left, right: initial footprints; the right one must be a valid step from the left
                one under ``limits``.
            com_height: cart-table height z_c [m], within ``WALKING_BOUNDS.com_height``.
            dt: tick [s]. horizon: preview time [s], within ``WALKING_BOUNDS.preview_time``.
            q, r: weights of the squared ZMP error and jerk increment.
            timing: step timing. limits: reachability of a step.
            com: (2,) initial CoM ground position [m]; default the midpoint of the soles (else
                the ZMP reference moves there as the walk's first stop segment).
        """
        _check_initial_stance(left, right, limits)
        controller = _preview(dt, com_height, horizon, q, r)
        timing.samples(controller.dt)
        com0 = 0.5 * (left.xy + right.xy) if com is None else validation.vector("com", com, 2)
        standing = stop_segment(left, right, com0, timing, controller.dt, hold=0.0)
        x0 = np.zeros((3, 2))
        x0[0] = com0
        return cls(
            controller=controller,
            timing=timing,
            limits=limits,
            width=stance_width(left, right),
            samples=standing,
            k=0,
            x=x0,
            error_sum=controller.initial_error_sum(x0, controller.window(standing.zmp, 0)),
            feet={"left": left, "right": right},
            last_side=None,
            stop_start=0,
            walk_end=0,
            landings=(),
            velocity=None,
        )

    # --- the references of the current tick ---------------------------------------------
    @property
    def dt(self) -> float:
        """[s] the tick."""
        return self.controller.dt

    @property
    def now(self) -> int:
        """Index of the current sample (the last one once the plan has been executed)."""
        return min(self.k, len(self.samples) - 1)

    @property
    def com(self) -> np.ndarray:
        """(3,) CoM reference [m]; z is the cart-table height."""
        return np.array([self.x[0, 0], self.x[0, 1], self.controller.z_c])

    @property
    def com_vel(self) -> np.ndarray:
        """(3,) CoM velocity reference [m/s]."""
        return np.array([self.x[1, 0], self.x[1, 1], 0.0])

    @property
    def zmp(self) -> np.ndarray:
        """(2,) ZMP of the cart-table model at this sample, ``c - z_c/g c̈`` [m]."""
        return self.x[0] - self.controller.z_c / self.controller.g * self.x[2]

    @property
    def zmp_ref(self) -> np.ndarray:
        """(2,) ZMP reference [m]."""
        return self.samples.zmp[self.now]

    @property
    def phase(self) -> int:
        """``PHASE_DOUBLE``, ``PHASE_LEFT_SUPPORT`` or ``PHASE_RIGHT_SUPPORT``."""
        return int(self.samples.phase[self.now])

    @property
    def contacts(self) -> np.ndarray:
        """(2,) [left, right]: 1 when the foot is on the ground."""
        phase = self.phase
        return np.array([float(phase != PHASE_RIGHT_SUPPORT), float(phase != PHASE_LEFT_SUPPORT)])

    @property
    def load(self) -> np.ndarray:
        """(2,) [left, right] share of the weight each foot carries: 1/0 in single support,
        in double support from where the ZMP reference lies between the sole centres."""
        if self.phase != PHASE_DOUBLE:
            return self.contacts
        i = self.now
        left, right = self.samples.left[i, :2], self.samples.right[i, :2]
        d = left - right
        share = float(np.clip((self.samples.zmp[i] - right) @ d / (d @ d), 0.0, 1.0))
        return np.array([share, 1.0 - share])

    def sole(self, side: str) -> np.ndarray:
        """(4,) sole pose reference ``[x, y, z, yaw]`` [m, rad] of ``side``."""
        return getattr(self.samples, side)[self.now]

    def sole_velocity(self, side: str) -> np.ndarray:
        """(4,) its time derivative [m/s, rad/s]."""
        return getattr(self.samples, f"{side}_vel")[self.now]

    @property
    def waist_yaw(self) -> float:
        """[rad] the waist's yaw reference: midway between the soles' yaws."""
        return mean_yaw(self.sole("left")[3], self.sole("right")[3])

    @property
    def in_process(self) -> bool:
        """True while a walk is under way (velocity mode, or the ZMP not settled yet)."""
        return self.velocity is not None or self.k < self.walk_end

    def landings_ahead(self) -> list[tuple[int, Footstep]]:
        """``(ticks from now, footprint)`` of every landing still ahead, in order."""
        return [(i - self.k, step) for i, step in self.landings if i > self.k]

    # --- commands -----------------------------------------------------------------------
    def add_steps(self, steps: Sequence[Footstep]) -> WalkPlanner:
        """``steps`` (absolute footprints) planned after those already planned.

        Each is checked against the foot it steps from (the last planned footprint of the
        other foot); a step beyond a limit is refused with the limit's name, and then none
        of ``steps`` is added. The preview window is frozen (Evrard et al. 2009, III-C):
        the new footprints start where the final stop segment starts, and never before one
        preview time from now; what the preview has already seen is kept, extended by
        standing still if the plan ends sooner.
        """
        steps = list(steps)
        self.limits.check_steps(self.feet["left"], self.feet["right"], steps)
        if not steps:
            return self
        dt = self.dt
        cut = max(self.stop_start, self.k + self.controller.N)
        kept = [self.samples.part(0, cut)]
        if len(kept[0]) < cut:
            kept.append(stand_segment(self.feet["left"], self.feet["right"], (cut - len(kept[0])) * dt, dt))
        zmp = kept[-1].zmp[-1]
        segments, feet = _step_segments(self.feet["left"], self.feet["right"], zmp, steps, self.timing, dt)
        landings = [landing for landing in self.landings if landing[0] < cut]
        end = cut
        for segment, step in zip(segments, steps, strict=True):
            end += len(segment)
            landings.append((end - 1, step))  # the touch-down sample
        stop = stop_segment(feet["left"], feet["right"], segments[-1].zmp[-1], self.timing, dt, hold=0.0)
        settled = int(np.argmax(np.all(stop.zmp == stop.zmp[-1], axis=1)))
        return replace(
            self,
            samples=Segment.join([*kept, *segments, stop]),
            feet=feet,
            last_side=steps[-1].side,
            landings=tuple(landings),
            stop_start=end,
            walk_end=end + settled,
        )

    def with_velocity(self, vx: float, vy: float = 0.0, wz: float = 0.0) -> WalkPlanner:
        """Walk at ``(vx, vy)`` [m/s] in the robot frame and turn at ``wz`` [rad/s].

        Footprints are made from the velocity as the walk goes (one step per
        ``timing.period``, at the stance width ``width``), keeping :data:`FOOTPRINTS_AHEAD`
        planned; those already planned are kept. ``(0, 0, 0)`` stops: one last step brings
        the feet side by side. A velocity whose steps would exceed a limit is refused,
        naming it.
        """
        velocity = (
            validation.finite("vx", vx),
            validation.finite("vy", vy),
            validation.finite("wz", wz),
        )
        if velocity == (0.0, 0.0, 0.0):
            if self.velocity is None:
                return self
            return replace(self, velocity=None).add_steps([self._next_footprint(velocity)])
        # Check the steps this velocity makes, from both feet, before accepting it.
        for side in SIDES:
            trial = replace(self, last_side=other_side(side))
            self.limits.check(self.feet[other_side(side)], trial._next_footprint(velocity))
        return replace(self, velocity=velocity)._fill_ahead()

    def with_timing(self, **changes: float) -> WalkPlanner:
        """The timing of the steps planned from now on changed (fields of :class:`StepTiming`),
        refused outside :data:`WALKING_BOUNDS` or when it leaves a phase too few ticks."""
        timing = replace(self.timing, **changes)
        timing.samples(self.dt)
        return replace(self, timing=timing)

    def with_model(self, *, com_height: float | None = None, horizon: float | None = None) -> WalkPlanner:
        """A new cart-table height [m] or preview time [s], only while standing (the
        preview gains depend on them); refused outside :data:`WALKING_BOUNDS`."""
        if self.in_process:
            name = "com_height" if com_height is not None else "preview_time"
            raise ValueError(f"{name} can change only while standing (the preview gains depend on it)")
        c = self.controller
        controller = _preview(
            c.dt,
            c.z_c if com_height is None else com_height,
            c.horizon if horizon is None else horizon,
            c.q,
            c.r,
        )
        # New gains: restart the integral action without a kick from the current state.
        error_sum = controller.initial_error_sum(self.x, controller.window(self.samples.zmp, self.k))
        return replace(self, controller=controller, error_sum=error_sum)

    def advance(self) -> WalkPlanner:
        """The planner one tick later: one preview-control step; in velocity mode, new
        footprints when a step has landed."""
        c = self.controller
        x, error_sum, _ = c.step_at(self.x, self.error_sum, self.samples.zmp, self.k)
        planner = self._ticked(x, error_sum)
        if planner.velocity is not None and any(
            i == planner.k for i, _ in planner.landings[-FOOTPRINTS_AHEAD - 1 :]
        ):
            planner = planner._fill_ahead()
        if planner.k > _KEEP_EXECUTED:
            planner = planner._drop_executed()
        return planner

    # --- internals ----------------------------------------------------------------------
    def _ticked(self, x: np.ndarray, error_sum: np.ndarray) -> WalkPlanner:
        """This planner one tick later with the new preview state: a field-for-field copy
        (``dataclasses.replace`` re-runs ``__init__`` and costs about a third of a tick;
        nothing here needs checking: the tick count and the controller's own outputs)."""
        planner = object.__new__(WalkPlanner)
        planner.__dict__.update(self.__dict__, k=self.k + 1, x=x, error_sum=error_sum)
        return planner

    def _next_footprint(self, velocity: tuple[float, float, float]) -> Footstep:
        side = "left" if self.last_side in (None, "right") else "right"
        vx, vy, wz = velocity
        period = self.timing.period
        lateral = self.width if side == "left" else -self.width
        return compose(self.feet[other_side(side)], vx * period, lateral + vy * period, wz * period, side)

    def _fill_ahead(self) -> WalkPlanner:
        """In velocity mode, footprints planned until FOOTPRINTS_AHEAD landings lie ahead."""
        if self.velocity is None:
            return self
        steps = []
        trial = self
        for _ in range(FOOTPRINTS_AHEAD - len(self.landings_ahead())):
            step = trial._next_footprint(self.velocity)
            steps.append(step)
            trial = replace(trial, feet={**trial.feet, step.side: step}, last_side=step.side)
        return self.add_steps(steps) if steps else self

    def _drop_executed(self) -> WalkPlanner:
        """The samples before the current one dropped (the indices shift to start at 0). Past
        the plan's end the current sample is its last one (every later sample would repeat it:
        the plan ends standing still), which is kept."""
        k = min(self.k, len(self.samples) - 1)
        return replace(
            self,
            samples=self.samples.part(k),
            k=0,
            stop_start=max(self.stop_start - k, 0),
            walk_end=max(self.walk_end - k, 0),
            landings=tuple((i - k, step) for i, step in self.landings if i > k),
        )
