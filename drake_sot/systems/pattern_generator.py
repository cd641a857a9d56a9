"""``PatternGenerator``: the SoT's walking pattern-generator entity ("pg"), ZMP preview control.

Footprints go in (a step sequence, or a velocity from which footprints are made as the
walk goes); CoM, feet and ZMP references come out, one sample per control tick. As in
the tele-cooperation paper, the generator is a *planner*: it keeps at least four
footprints ahead of the robot, and a new footprint can be accepted each time a step is
executed, so a walk can be steered while it runs; footprints already planned are not
changed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, LeafSystem, State

from drake_sot.preview import (
    Footstep,
    PreviewController,
    Segment,
    StepLimits,
    StepTiming,
    stand_segment,
    step_segment,
    stop_segment,
)
from drake_sot.systems._context import own_context

#: Footprints kept planned ahead of the robot in velocity mode (paper 001, III-C).
FOOTPRINTS_AHEAD = 4
_SIDES = ("left", "right")


@dataclass(frozen=True)
class _Walk:
    """The generator's state. Never mutated: every change builds a new record that
    shares the (large) sample arrays, so Drake's state copy per tick is O(1)."""

    samples: Segment  # planned samples; index k is the current tick
    k: int
    x: np.ndarray  # (3, 2) cart-table state [c, ċ, c̈] per axis
    error_sum: np.ndarray  # (2,)
    feet: dict  # side -> last planned Footstep
    last_side: str | None  # side of the last planned step
    stop_start: int  # index where the final stop segment begins
    walk_end: int  # index where the ZMP has settled between the feet
    landings: tuple[tuple[int, Footstep], ...]  # (sample index, footprint) of each planned landing
    velocity: tuple[float, float, float] | None
    timing: StepTiming
    controller: PreviewController
    com_height: float

    def __deepcopy__(self, memo) -> _Walk:
        return self


class PatternGenerator(LeafSystem):
    """Walking references from footprints by ZMP preview control (Kajita et al. 2003).

    Output ports (one sample per control tick, held between ticks):
        com: CoM reference (3,) [m]; z is the constant CoM height of the cart-table model.
        com_vel: CoM velocity reference (3,) [m/s].
        left_foot, right_foot: abstract ``RigidTransform``, sole pose references in world.
        left_foot_vel, right_foot_vel: sole velocity references ``[v; ω]`` (6,) [m/s, rad/s],
            world frame (plug into ``FeaturePoint6d.velocity_des``).
        waist: abstract ``RigidTransform``, waist orientation reference (yaw midway
            between the feet; position = CoM reference).
        zmp_ref: ZMP reference (2,) [m].
        zmp: ZMP of the cart-table model at this sample (2,) [m].
        phase: (1,) 0 double support, 1 left support (right foot swinging), 2 right support.
        contacts: (2,) [left, right] 1 when the foot is on the ground.
        load: (2,) [left, right] share of the weight each foot carries, from where the
            ZMP reference lies between the soles (1/0 in single support, moving with the
            ZMP during double support).
        in_process: (1,) 1 while a walk is under way, 0 once standing.

    Commands (act on a context, like the paper's ``pg.parsecmd``): :meth:`add_steps`,
    :meth:`set_velocity`, :meth:`parsecmd`.

    Args:
        left, right: initial sole footprints.
        com_height: cart-table height z_c [m] (the CoM height of the robot).
        dt: control period [s]. horizon: preview time [s]. q, r: LQ weights.
        timing: step timing. limits: reachability of a step.
        com: initial CoM ground position (2,); default the midpoint of the soles.
    """

    def __init__(
        self,
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
        name: str = "pg",
    ) -> None:
        super().__init__()
        self.set_name(name)
        if left.side != "left" or right.side != "right":
            raise ValueError(
                f"initial footprints must be a left and a right one, got {left.side!r}, {right.side!r}"
            )
        self._dt = dt
        self._q, self._r = q, r
        self._limits = limits
        controller = PreviewController(dt=dt, z_c=com_height, horizon=horizon, q=q, r=r)
        com0 = _midpoint(left, right) if com is None else np.asarray(com, dtype=float)
        standing = stop_segment(left, right, com0, timing, dt, hold=0.0)
        x0 = np.zeros((3, 2))
        x0[0] = com0
        self._walk = self.DeclareAbstractState(
            Value[object](
                _Walk(
                    samples=standing,
                    k=0,
                    x=x0,
                    error_sum=controller.initial_error_sum(x0, _window(standing.zmp, 0, controller.N)),
                    feet={"left": left, "right": right},
                    last_side=None,
                    stop_start=0,
                    walk_end=0,
                    landings=(),
                    velocity=None,
                    timing=timing,
                    controller=controller,
                    com_height=com_height,
                )
            )
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(dt, 0.0, self._tick)
        ticket = {self.abstract_state_ticket(self._walk)}

        def vector(name, size, fn):
            self.DeclareVectorOutputPort(
                name, size, lambda c, out: out.SetFromVector(fn(self._state(c))), prerequisites_of_calc=ticket
            )

        def pose(name, fn):
            self.DeclareAbstractOutputPort(
                name,
                lambda: AbstractValue.Make(RigidTransform()),
                lambda c, value: value.set_value(fn(self._state(c))),
                prerequisites_of_calc=ticket,
            )

        vector("com", 3, lambda w: np.array([w.x[0, 0], w.x[0, 1], w.com_height]))
        vector("com_vel", 3, lambda w: np.array([w.x[1, 0], w.x[1, 1], 0.0]))
        pose("left_foot", lambda w: _sole_pose(w.samples.left[_now(w)]))
        pose("right_foot", lambda w: _sole_pose(w.samples.right[_now(w)]))
        vector("left_foot_vel", 6, lambda w: _sole_velocity(w, w.samples.left_vel))
        vector("right_foot_vel", 6, lambda w: _sole_velocity(w, w.samples.right_vel))
        pose("waist", _waist_pose)
        vector("zmp_ref", 2, lambda w: w.samples.zmp[_now(w)])
        vector("zmp", 2, lambda w: w.x[0] - w.controller.z_c / w.controller.g * w.x[2])
        vector("phase", 1, lambda w: np.array([float(w.samples.phase[_now(w)])]))
        vector("contacts", 2, lambda w: _contacts(w.samples.phase[_now(w)]))
        vector("load", 2, _load)
        vector("in_process", 1, lambda w: np.array([1.0 if w.velocity or w.k < w.walk_end else 0.0]))

    # --- reading the state ------------------------------------------------------------
    def _state(self, context: Context) -> _Walk:
        return context.get_abstract_state(self._walk).get_value()

    def _set(self, context: Context, walk: _Walk) -> None:
        context.get_mutable_abstract_state(self._walk).set_value(walk)

    def footprints(self, context: Context) -> dict[str, Footstep]:
        """The last planned footprint of each foot (own or root context)."""
        return dict(self._state(own_context(self, context)).feet)

    def planned_landings(self, context: Context) -> list[tuple[float, Footstep]]:
        """``(time [s], footprint)`` of every landing still ahead, in order (own or root context)."""
        context = own_context(self, context)
        walk = self._state(context)
        now = context.get_time()
        return [(now + (i - walk.k) * self._dt, step) for i, step in walk.landings if i > walk.k]

    # --- commands -----------------------------------------------------------------------
    def add_steps(self, context: Context, steps: Sequence[Footstep]) -> None:
        """Append footprints (absolute, world frame) after those already planned.

        Each is checked against the foot it steps from (the last planned footprint of
        the other foot); a step beyond a limit is refused with the limit's name, and
        then none of ``steps`` is added.
        """
        context = own_context(self, context)
        self._set(context, self._append(self._state(context), list(steps)))

    def set_velocity(self, context: Context, vx: float, vy: float = 0.0, wz: float = 0.0) -> None:
        """Walk at ``(vx, vy)`` [m/s] in the robot frame and turn at ``wz`` [rad/s].

        Footprints are made from the velocity as the walk goes, keeping
        ``FOOTPRINTS_AHEAD`` planned; those already planned are kept. ``(0, 0, 0)``
        stops: one last step brings the feet side by side. A velocity whose steps
        would exceed a limit is refused, naming it.
        """
        context = own_context(self, context)
        walk = self._state(context)
        velocity = (float(vx), float(vy), float(wz))
        if not all(math.isfinite(v) for v in velocity):
            raise ValueError(f"velocity {velocity} must be finite")
        if velocity == (0.0, 0.0, 0.0):
            if walk.velocity is not None:
                walk = self._append(
                    replace(walk, velocity=None), [self._next_footprint(walk, (0.0, 0.0, 0.0))]
                )
            self._set(context, walk)
            return
        # Check the steps this velocity makes, from both feet, before accepting it.
        for side in _SIDES:
            trial = replace(walk, last_side="right" if side == "left" else "left")
            self._limits.check(trial.feet[_other(side)], self._next_footprint(trial, velocity))
        walk = replace(walk, velocity=velocity)
        self._set(context, self._fill_ahead(walk))

    def parsecmd(self, context: Context, command: str) -> None:
        """The original generator's command interface, e.g. ``":stepseq 0.2 -0.19 0 0.2 0.19 0"``.

        Verbs: ``:stepseq x y yaw ...`` (each triple is a footprint in the frame of the
        other foot's last footprint; y > 0 steps with the left foot, y < 0 with the
        right), ``:singlesupporttime T``, ``:doublesupporttime T``, ``:stepheight h``,
        ``:comheight z`` and ``:previewcontroltime T`` (these two only while standing).
        Timing changes apply to the steps planned afterwards.
        """
        context = own_context(self, context)
        words = command.split()
        if not words:
            raise ValueError("empty command")
        verb, args = words[0], words[1:]
        handlers = {
            ":stepseq": self._cmd_stepseq,
            ":singlesupporttime": lambda c, a: self._cmd_timing(c, "single_support", a),
            ":doublesupporttime": lambda c, a: self._cmd_timing(c, "double_support", a),
            ":stepheight": lambda c, a: self._cmd_timing(c, "step_height", a),
            ":comheight": lambda c, a: self._cmd_model(c, "z_c", a),
            ":previewcontroltime": lambda c, a: self._cmd_model(c, "horizon", a),
        }
        if verb not in handlers:
            raise ValueError(f"unknown command {verb!r}; known: {', '.join(handlers)}")
        try:
            values = [float(a) for a in args]
        except ValueError:
            raise ValueError(f"{verb}: arguments must be numbers, got {' '.join(args)!r}") from None
        handlers[verb](context, values)

    def _cmd_stepseq(self, context: Context, values: list[float]) -> None:
        if not values or len(values) % 3:
            raise ValueError(f":stepseq takes x y yaw triples, got {len(values)} numbers")
        walk = self._state(context)
        feet = dict(walk.feet)
        steps = []
        for x, y, yaw in zip(values[0::3], values[1::3], values[2::3], strict=True):
            if y == 0.0:
                raise ValueError(f":stepseq triple ({x}, {y}, {yaw}): y = 0 says neither left nor right")
            side = "left" if y > 0 else "right"
            step = _compose(feet[_other(side)], x, y, yaw, side)
            feet[side] = step
            steps.append(step)
        self._set(context, self._append(walk, steps))

    def _cmd_timing(self, context: Context, field: str, values: list[float]) -> None:
        if len(values) != 1:
            raise ValueError(f"{field} takes one number, got {values}")
        walk = self._state(context)
        self._set(context, replace(walk, timing=replace(walk.timing, **{field: values[0]})))

    def _cmd_model(self, context: Context, field: str, values: list[float]) -> None:
        if len(values) != 1:
            raise ValueError(f"{field} takes one number, got {values}")
        walk = self._state(context)
        if walk.k < walk.walk_end or walk.velocity is not None:
            raise ValueError(f"{field} can change only while standing (the preview gains depend on it)")
        c = walk.controller
        params = {
            "dt": c.dt,
            "z_c": c.z_c,
            "horizon": c.horizon,
            "q": self._q,
            "r": self._r,
            field: values[0],
        }
        controller = PreviewController(**params)
        height = values[0] if field == "z_c" else walk.com_height
        # New gains: restart the integral action without a kick from the current state.
        error_sum = controller.initial_error_sum(walk.x, _window(walk.samples.zmp, walk.k, controller.N))
        self._set(context, replace(walk, controller=controller, com_height=height, error_sum=error_sum))

    # --- planning -----------------------------------------------------------------------
    def _append(self, walk: _Walk, steps: list[Footstep]) -> _Walk:
        """Plan ``steps`` after the current plan; the stop segment is redone after them."""
        feet = dict(walk.feet)
        for i, step in enumerate(steps):
            try:
                self._limits.check(feet[_other(step.side)], step)
            except ValueError as error:
                raise ValueError(f"step {i} ({step}): {error}") from None
            feet[step.side] = step
        if not steps:
            return walk
        # The preview window is frozen (paper 001, III-C): new footprints start where the
        # stop segment starts, and never before one horizon from now; what the preview has
        # already seen is kept, extended by standing still if the plan ends sooner.
        cut = max(walk.stop_start, walk.k + walk.controller.N)
        samples = _head(walk.samples, cut)
        feet = dict(walk.feet)
        if len(samples) < cut:
            samples = samples.concatenate(
                stand_segment(feet["left"], feet["right"], (cut - len(samples)) * self._dt, self._dt)
            )
        zmp = samples.zmp[-1]
        landings = [landing for landing in walk.landings if landing[0] < cut]
        dt = self._dt
        for step in steps:
            segment = step_segment(feet["left"], feet["right"], zmp, step, walk.timing, dt)
            samples = samples.concatenate(segment)
            landings.append((len(samples) - 1, step))  # the touch-down sample
            feet[step.side] = step
            zmp = segment.zmp[-1]
        return self._close(
            replace(walk, feet=feet, last_side=steps[-1].side, landings=tuple(landings)), samples, zmp
        )

    def _close(self, walk: _Walk, samples: Segment, zmp: np.ndarray) -> _Walk:
        stop = stop_segment(walk.feet["left"], walk.feet["right"], zmp, walk.timing, self._dt, hold=0.0)
        stop_start = len(samples)
        settled = stop_start + int(np.argmax(np.all(stop.zmp == stop.zmp[-1], axis=1)))
        return replace(walk, samples=samples.concatenate(stop), stop_start=stop_start, walk_end=settled)

    def _next_footprint(self, walk: _Walk, velocity: tuple[float, float, float]) -> Footstep:
        side = "left" if walk.last_side in (None, "right") else "right"
        vx, vy, wz = velocity
        period = walk.timing.single_support + walk.timing.double_support
        stance = walk.feet[_other(side)]
        width = self._stance_width(walk)
        lateral = width if side == "left" else -width
        return _compose(stance, vx * period, lateral + vy * period, wz * period, side)

    @staticmethod
    def _stance_width(walk: _Walk) -> float:
        left, right = walk.feet["left"], walk.feet["right"]
        c, s = math.cos(right.yaw), math.sin(right.yaw)
        return abs(-s * (left.x - right.x) + c * (left.y - right.y))

    def _fill_ahead(self, walk: _Walk) -> _Walk:
        """In velocity mode, plan footprints until FOOTPRINTS_AHEAD landings lie ahead."""
        if walk.velocity is None:
            return walk
        ahead = sum(1 for i, _ in walk.landings if i > walk.k)
        steps = []
        trial = walk
        for _ in range(FOOTPRINTS_AHEAD - ahead):
            step = self._next_footprint(trial, walk.velocity)
            steps.append(step)
            trial = replace(trial, feet={**trial.feet, step.side: step}, last_side=step.side)
        return self._append(walk, steps) if steps else walk

    # --- the control tick -----------------------------------------------------------------
    def _tick(self, context: Context, state: State) -> None:
        walk = self._state(context)
        c = walk.controller
        x, error_sum, _ = c.step(walk.x, walk.error_sum, _window(walk.samples.zmp, walk.k, c.N))
        walk = replace(walk, k=walk.k + 1, x=x, error_sum=error_sum)
        if walk.velocity is not None and any(i == walk.k for i, _ in walk.landings[-FOOTPRINTS_AHEAD - 1 :]):
            walk = self._fill_ahead(walk)
        if walk.k > 4000 and walk.k >= walk.stop_start:  # drop what was executed long ago
            walk = _drop_before(walk, walk.k)
        state.get_mutable_abstract_state(self._walk).set_value(walk)


# --- helpers -------------------------------------------------------------------------
def _other(side: str) -> str:
    return "right" if side == "left" else "left"


def _midpoint(left: Footstep, right: Footstep) -> np.ndarray:
    return 0.5 * np.array([left.x + right.x, left.y + right.y])


def _compose(frame: Footstep, x: float, y: float, yaw: float, side: str) -> Footstep:
    """The footprint at (x, y, yaw) in the frame of ``frame``."""
    c, s = math.cos(frame.yaw), math.sin(frame.yaw)
    return Footstep(frame.x + c * x - s * y, frame.y + s * x + c * y, frame.yaw + yaw, side)


def _window(zmp: np.ndarray, k: int, n: int) -> np.ndarray:
    """The n ZMP references from sample k on, the last one held past the end of the plan."""
    window = zmp[k : k + n]
    if len(window) < n:
        window = np.vstack((window, np.repeat(zmp[-1:], n - len(window), axis=0)))
    return window


def _now(walk: _Walk) -> int:
    return min(walk.k, len(walk.samples) - 1)


def _sole_pose(sample: np.ndarray) -> RigidTransform:
    return RigidTransform(RotationMatrix.MakeZRotation(sample[3]), sample[:3])


def _sole_velocity(walk: _Walk, velocities: np.ndarray) -> np.ndarray:
    v = velocities[_now(walk)]
    return np.array([v[0], v[1], v[2], 0.0, 0.0, v[3]])


def _waist_pose(walk: _Walk) -> RigidTransform:
    left, right = walk.samples.left[_now(walk)], walk.samples.right[_now(walk)]
    yaw = right[3] + 0.5 * math.remainder(left[3] - right[3], 2 * math.pi)
    return RigidTransform(RotationMatrix.MakeZRotation(yaw), [walk.x[0, 0], walk.x[0, 1], walk.com_height])


def _contacts(phase: int) -> np.ndarray:
    return np.array([float(phase != 2), float(phase != 1)])


def _load(walk: _Walk) -> np.ndarray:
    i = _now(walk)
    phase = walk.samples.phase[i]
    if phase != 0:
        return _contacts(phase)
    left, right = walk.samples.left[i, :2], walk.samples.right[i, :2]
    d = left - right
    share = float(np.clip((walk.samples.zmp[i] - right) @ d / (d @ d), 0.0, 1.0))
    return np.array([share, 1.0 - share])


def _head(samples: Segment, n: int) -> Segment:
    return Segment(**{f: getattr(samples, f)[:n] for f in samples.__dataclass_fields__})


def _drop_before(walk: _Walk, k: int) -> _Walk:
    samples = Segment(**{f: getattr(walk.samples, f)[k:] for f in walk.samples.__dataclass_fields__})
    return replace(
        walk,
        samples=samples,
        k=0,
        stop_start=walk.stop_start - k,
        walk_end=max(walk.walk_end - k, 0),
        landings=tuple((i - k, step) for i, step in walk.landings if i > k),
    )
