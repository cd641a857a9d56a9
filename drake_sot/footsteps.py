"""The step vocabulary: footprints, step timing and limits, the walking bounds, the support phases.

Pure numpy; no Drake. The planner that turns footprints into ZMP, CoM and feet references
is :mod:`drake_sot.walk_planner`.

**Footprints.**  A :class:`Footstep` is a sole centre ``(x, y)`` [m] and ``yaw`` [rad] on
the ground, and which foot.  A step is given, as in the original pattern generator's
``:stepseq``, *relative to the other foot*: the footprint at ``(dx, dy, dyaw)`` in the
frame of the other foot's last footprint (:func:`compose`, the one composition rule of
the library).  A stance's width is :func:`stance_width` (the lateral distance of the
soles across the heading midway between their yaws).  :class:`StepTiming` says how long a
step lasts and how high the swing foot lifts, :class:`StepLimits` where a step may land.

**Bounds.**  :data:`WALKING_BOUNDS` is the one place that says which step timing, step
height, CoM height and preview time are refused.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from drake_sot import validation

__all__ = [
    "PHASE_DOUBLE",
    "PHASE_LEFT_SUPPORT",
    "PHASE_RIGHT_SUPPORT",
    "SIDES",
    "WALKING_BOUNDS",
    "Bound",
    "Footstep",
    "StepLimits",
    "StepTiming",
    "WalkingBounds",
    "alternating_steps",
    "compose",
    "mean_yaw",
    "other_side",
    "relative_steps",
    "sample_count",
    "stance_width",
    "wrap_angle",
]

SIDES = ("left", "right")
PHASE_DOUBLE = 0
PHASE_LEFT_SUPPORT = 1  # right foot swinging
PHASE_RIGHT_SUPPORT = 2  # left foot swinging


class Bound(NamedTuple):
    """A closed interval ``[low, high]`` in ``unit``."""

    low: float
    high: float
    unit: str

    def check(self, name: str, value: float) -> float:
        """``value`` as a float, or ValueError naming ``name``, the value and this bound (NaN fails)."""
        return validation.bounded(name, value, self.low, self.high, unit=self.unit)


@dataclass(frozen=True)
class WalkingBounds:
    """The walking parameters outside which a walk is refused (both ends included).

    The envelope of humanoid walking, from a 30 cm toy robot to an adult-size one; a
    robot's own, tighter limits are its choice of :class:`StepTiming`. Every path that sets
    one of these refuses a value outside it, naming the bound: :class:`StepTiming`, the
    :class:`~drake_sot.walk_planner.WalkPlanner` (and so ``PatternGenerator``'s arguments and
    its ``parsecmd`` verbs ``:singlesupporttime``, ``:doublesupporttime``, ``:stepheight``,
    ``:comheight``, ``:previewcontroltime``).

    Attributes:
        single_support: [0.2, 5] s. Below 0.2 s a 0.35 m quintic swing accelerates the
            foot at 10/√3 · 0.35 m / (0.2 s)² ≈ 50 m/s² (5 g; a fast human step lasts
            0.3 s); above 5 s a step is no longer walking.
        double_support: [0.05, 2] s. The ZMP reference moves from one foot to the other
            in this time; below 0.05 s it jumps (at a 5 ms period, fewer than 10 samples).
        step_height: [0.01, 0.3] m. The swing foot must clear the ground (1 cm) and stay
            below about half an adult-size humanoid's leg (0.3 m); 2 m would send the foot
            reference over the robot's head.
        com_height: [0.1, 2] m. The cart-table height z_c, from a toy robot to a tall one.
        preview_time: [1, 4] s. Shorter, the preview cannot anticipate the next step:
            with Kajita et al. 2003's 0.8 s steps and z_c = 0.814 m the model ZMP misses its
            reference by 2 cm at 1 s, 3 cm at 0.8 s, 12 cm at 0.5 s (2.4 mm at 1.6 s); the
            preview gains at 3 s are 6e-5 of the first, and every new step waits one preview
            time before it starts, so more than 4 s only delays the walk.
    """

    single_support: Bound = Bound(0.2, 5.0, "s")
    double_support: Bound = Bound(0.05, 2.0, "s")
    step_height: Bound = Bound(0.01, 0.3, "m")
    com_height: Bound = Bound(0.1, 2.0, "m")
    preview_time: Bound = Bound(1.0, 4.0, "s")


#: The one instance of :class:`WalkingBounds` the library checks against.
WALKING_BOUNDS = WalkingBounds()


def other_side(side: str) -> str:
    """``"right"`` for ``"left"`` and ``"left"`` for ``"right"``."""
    return "right" if side == "left" else "left"


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped to [-π, π)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def mean_yaw(a: float, b: float) -> float:
    """The yaw [rad] midway between ``a`` and ``b``, the short way round from ``b``."""
    return b + 0.5 * wrap_angle(a - b)


# --------------------------------------------------------------------------- footprints


@dataclass(frozen=True)
class Footstep:
    """A footprint: sole centre ``(x, y)`` [m] and ``yaw`` [rad] in the world, and which foot.

    ``side`` is ``"left"`` or ``"right"``.
    """

    x: float
    y: float
    yaw: float
    side: str

    def __post_init__(self) -> None:
        if self.side not in SIDES:
            raise ValueError(f"Footstep side must be 'left' or 'right', got {self.side!r}")
        for name in ("x", "y", "yaw"):
            object.__setattr__(self, name, validation.finite(f"Footstep.{name}", getattr(self, name)))

    @property
    def pose(self) -> np.ndarray:
        """(4,) ``[x, y, z=0, yaw]``, the sole pose on the ground."""
        return np.array([self.x, self.y, 0.0, self.yaw])

    @property
    def xy(self) -> np.ndarray:
        """(2,) sole centre, which is also the ZMP reference of this foot."""
        return np.array([self.x, self.y])


def compose(frame: Footstep, x: float, y: float, yaw: float, side: str) -> Footstep:
    """The ``side`` footprint at ``(x, y)`` [m] and relative yaw ``yaw`` [rad] in the frame of ``frame``."""
    c, s = math.cos(frame.yaw), math.sin(frame.yaw)
    return Footstep(frame.x + c * x - s * y, frame.y + s * x + c * y, frame.yaw + yaw, side)


def stance_width(left: Footstep, right: Footstep) -> float:
    """Width [m] of a stance: the distance of the left sole centre from the right one across
    the heading midway between their yaws (:func:`mean_yaw`); negative when the feet cross.

    Feet side by side and parallel: their distance. A fore-aft offset does not count.
    """
    heading = mean_yaw(left.yaw, right.yaw)
    return -math.sin(heading) * (left.x - right.x) + math.cos(heading) * (left.y - right.y)


def relative_steps(
    left: Footstep, right: Footstep, moves: Iterable[tuple[str, float, float, float]]
) -> list[Footstep]:
    """Footprints from moves ``(side, dx, dy, dyaw)``, each relative to the other foot.

    Each move puts the foot ``side`` at ``(dx, dy)`` [m], turned by ``dyaw`` [rad], in the
    frame of the other foot's last footprint (the initial one, or its last move). This is
    the convention of the original pattern generator's ``:stepseq``.
    """
    feet = {"left": left, "right": right}
    steps = []
    for side, dx, dy, dyaw in moves:
        if side not in SIDES:
            raise ValueError(f"a move's side must be 'left' or 'right', got {side!r}")
        feet[side] = compose(feet[other_side(side)], dx, dy, dyaw, side)
        steps.append(feet[side])
    return steps


def alternating_steps(
    left: Footstep,
    right: Footstep,
    n_steps: int,
    stride: float | Sequence[float] = 0.0,
    turn: float | Sequence[float] = 0.0,
    first_side: str = "right",
    width: float | None = None,
) -> list[Footstep]:
    """``n_steps`` steps with alternating feet, starting with ``first_side``.

    Step ``k`` lands ``stride[k]`` [m] ahead of the other foot's last footprint, ``width``
    [m] to its side, turned by ``turn[k]`` [rad] from it (:func:`relative_steps`). Straight
    (``turn = 0``) from a stance side by side, footprint ``k`` (from 1) is ``k·stride``
    ahead of the start line. ``stride`` and ``turn`` are scalars or one value per step;
    ``width`` defaults to the :func:`stance_width` of ``left`` and ``right``.
    """
    if first_side not in SIDES:
        raise ValueError(f"first_side must be 'left' or 'right', got {first_side!r}")
    n = validation.positive_int("n_steps", n_steps, minimum=0)
    width = validation.positive("width", stance_width(left, right) if width is None else width, unit="m")
    per_step = {}
    for name, value in (("stride", stride), ("turn", turn)):
        a = np.asarray(value, dtype=float)
        if a.ndim > 1 or (a.ndim == 1 and len(a) != n):
            raise ValueError(
                f"{name} must be a scalar or have {n} values (one per step), got shape {a.shape}"
            )
        per_step[name] = validation.vector(name, np.broadcast_to(a, (n,)))
    sides = [first_side if k % 2 == 0 else other_side(first_side) for k in range(n)]
    moves = [
        (side, float(dx), width if side == "left" else -width, float(dyaw))
        for side, dx, dyaw in zip(sides, per_step["stride"], per_step["turn"], strict=True)
    ]
    return relative_steps(left, right, moves)


@dataclass(frozen=True)
class StepTiming:
    """Durations of a step and the swing-foot lift, each within :data:`WALKING_BOUNDS`.

    Attributes:
        single_support: [s] one foot on the ground, the other swinging.
        double_support: [s] both feet on the ground, ZMP moving to the next stance foot.
        step_height: [m] swing-foot lift at mid-swing.
    """

    single_support: float = 0.7
    double_support: float = 0.1
    step_height: float = 0.05

    def __post_init__(self) -> None:
        for name in ("single_support", "double_support", "step_height"):
            bound = getattr(WALKING_BOUNDS, name)
            object.__setattr__(self, name, bound.check(f"StepTiming.{name}", getattr(self, name)))

    @property
    def period(self) -> float:
        """[s] one step: double support then single support."""
        return self.single_support + self.double_support

    def samples(self, dt: float) -> tuple[int, int]:
        """``(double support, single support)`` sample counts at the period ``dt`` [s].

        Raises ValueError when the period leaves double support no sample or the swing
        fewer than 2 (lift-off and touch-down are both samples).
        """
        dt = validation.positive("dt", dt, unit="s")
        return (
            sample_count("StepTiming.double_support", self.double_support, dt, 1),
            sample_count("StepTiming.single_support", self.single_support, dt, 2),
        )


@dataclass(frozen=True)
class StepLimits:
    """Reachability of a step, checked in the frame of the stance foot (the other foot).

    Attributes:
        max_stride: [m] bound on the forward/backward offset ``|dx|``.
        min_width: [m] least lateral distance of the swing foot from the stance foot,
            on its own side (below it the feet would cross / collide).
        max_width: [m] largest lateral distance.
        max_yaw: [rad] bound on the relative yaw (wrapped to [-π, π)).
    """

    max_stride: float = 0.35
    min_width: float = 0.15
    max_width: float = 0.35
    max_yaw: float = 0.5

    def __post_init__(self) -> None:
        for name in ("max_stride", "min_width", "max_width", "max_yaw"):
            object.__setattr__(self, name, validation.positive(f"StepLimits.{name}", getattr(self, name)))
        if self.min_width > self.max_width:
            raise ValueError(f"StepLimits.min_width {self.min_width} m exceeds max_width {self.max_width} m")

    def check(self, stance: Footstep, step: Footstep) -> None:
        """Raise ValueError naming the violated limit and the values; return None if reachable.

        A left step must lie to the left (+y in the stance frame) of a right stance
        foot, and a right step to the right of a left one.
        """
        if stance.side == step.side:
            raise ValueError(
                f"a {step.side} step needs a {other_side(step.side)} stance foot, got a {stance.side} one"
            )
        c, s = math.cos(stance.yaw), math.sin(stance.yaw)
        wx, wy = step.x - stance.x, step.y - stance.y
        dx = c * wx + s * wy
        dy = -s * wx + c * wy
        where = f"{step.side} step to ({step.x:.3g}, {step.y:.3g})"
        if abs(dx) > self.max_stride:
            raise ValueError(f"{where} exceeds max_stride {self.max_stride:.2f} m (stride {abs(dx):.2f} m)")
        lateral = dy if step.side == "left" else -dy
        if lateral < self.min_width:
            raise ValueError(
                f"{where} would cross the other foot: lateral distance {lateral:.2f} m "
                f"< min_width {self.min_width:.2f} m"
            )
        if lateral > self.max_width:
            raise ValueError(
                f"{where} exceeds max_width {self.max_width:.2f} m (lateral distance {lateral:.2f} m)"
            )
        dyaw = wrap_angle(step.yaw - stance.yaw)
        if abs(dyaw) > self.max_yaw:
            raise ValueError(f"{where} exceeds max_yaw {self.max_yaw:.2f} rad (relative yaw {dyaw:.2f} rad)")

    def check_steps(self, left: Footstep, right: Footstep, steps: Sequence[Footstep]) -> None:
        """Check each step against the footprint the other foot has at that moment (the
        initial one, or its last step); steps may come in any side order.

        Raises:
            TypeError: a step that is not a :class:`Footstep`.
            ValueError: ``"step i: ..."``, the first step beyond a limit and the limit's name.
        """
        feet = {"left": left, "right": right}
        for i, step in enumerate(steps):
            if not isinstance(step, Footstep):
                raise TypeError(f"step {i} must be a Footstep, got {type(step).__name__}")
            try:
                self.check(feet[other_side(step.side)], step)
            except ValueError as err:
                raise ValueError(f"step {i}: {err}") from None
            feet[step.side] = step


# --------------------------------------------------------------------------- sampled segments


def sample_count(name: str, duration: float, dt: float, minimum: int) -> int:
    """Samples of ``duration`` [s] at the period ``dt`` [s]; ValueError naming ``name`` if fewer
    than ``minimum``."""
    n = round(duration / dt)
    if n < minimum:
        raise ValueError(
            f"{name} = {duration!r} s gives {n} samples at dt = {dt!r} s; at least {minimum} needed"
        )
    return n
