"""The master site of the tele-cooperation (Evrard et al. 2009, section IV), pure numpy.

Two admittance-type haptic arms on a mobile base, and a model of the operator who holds
them.

**Haptic arms (eq. 8-9).** Each arm renders a virtual admittance on the offset x_Δ
between its desired end-effector position and the slave's hand position x_S received over
the link::

    ẍ_Δ = M⁻¹ (f_M − B ẋ_Δ − K x_Δ)            (8)
    x_d = x_Δ + (x_S − x_B)                      (9)

with f_M the force the operator applies on the handle and x_B the position of the mobile
platform relative to its start. x_d is the input of the arm's inner position loop (in the
platform's frame, translation only: the platform's rotation is left out of eq. 9 as in the
paper). The admittance is :class:`drake_sot.admittance.MassDamperSpring` (exact under a
zero-order hold of f_M). With an ideal inner loop the handle is at x_B + x_d = x_S + x_Δ
in the world: the operator's hand is the slave's hand plus the local compliance.

**Base placement.** The base maximises the smaller manipulability of the two arms: both
end-effectors on circles of radius r_opt around the shoulder joints, and the first joints
of both arms at equal angles (the symmetric posture), which puts the platform parallel to
the line from x_L to x_R with its centre on the perpendicular bisector of that line
(:func:`base_placement`; the paper's geometric solution, horizontal plane). The base moves
towards that pose with bounded speed and acceleration (:class:`BaseMotion`).

**Operator.** The operator's hands are pulled towards an intention trajectory by a
spring-damper (:func:`operator_force`) and the operator's body walks along its own path
(:func:`piecewise_linear_path`). These are a model chosen here; the paper has a human.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from drake_sot import validation
from drake_sot.footsteps import wrap_angle

__all__ = [
    "BaseLimits",
    "BaseMotion",
    "Path",
    "base_placement",
    "desired_position",
    "operator_force",
    "piecewise_linear_path",
]

#: A path: time [s] → (position (n,), velocity (n,)).
Path = Callable[[float], tuple[np.ndarray, np.ndarray]]


def desired_position(offset: np.ndarray, slave: np.ndarray, base: np.ndarray) -> np.ndarray:
    """x_d = x_Δ + (x_S − x_B) (3,): the arm's desired end-effector position, eq. 9.

    Args:
        offset: x_Δ (3,) [m], the admittance's offset (eq. 8).
        slave: x_S (3,) [m], the slave's hand position as received.
        base: x_B (3,) [m], the platform's displacement from its start.
    """
    return (
        validation.vector("offset", offset, 3)
        + validation.vector("slave", slave, 3)
        - validation.vector("base", base, 3)
    )


def base_placement(
    left: np.ndarray, right: np.ndarray, *, shoulder_half_width: float, r_opt: float
) -> np.ndarray:
    """The platform pose ``[x, y, yaw]`` that maximises the smaller manipulability of the arms.

    The shoulders are at ``±shoulder_half_width`` along the platform's lateral axis (left
    positive), about its centre. In the horizontal plane, with m the midpoint of the hands,
    2a their distance and u the unit vector from the right hand to the left one, the
    platform's lateral axis is u (parallel to the line x_R → x_L), its forward axis n is u
    turned by −90°, and its centre ``c = m − d n`` with ``d = √(r_opt² − (a − s)²)``: each
    shoulder ``c ± s u`` is then at distance r_opt from its hand and the two arms are mirror
    images (equal first-joint angles). When the hands are too far apart or too close for
    that (``|a − s| > r_opt``), d = 0: the platform sits on the line, the hands as close to
    their circles as the line allows.

    Args:
        left, right: the end-effector positions x_L, x_R (3,) [m], world; their horizontal
            distance must be > 0.
        shoulder_half_width: s [m], > 0.
        r_opt: [m] the radius of best manipulability around a shoulder, > 0.

    Returns:
        (3,) ``[x, y, yaw]`` [m, m, rad]: the platform centre and heading in the world.
    """
    pl = validation.vector("left", left, 3)[:2]
    pr = validation.vector("right", right, 3)[:2]
    s = validation.positive("shoulder_half_width", shoulder_half_width, unit="m")
    r = validation.positive("r_opt", r_opt, unit="m")
    span = pl - pr
    width = float(np.hypot(*span))
    if not (width > 1e-9):
        raise ValueError(
            f"left = {left}, right = {right}: the hands must not coincide in the horizontal plane"
        )
    u = span / width
    n = np.array([u[1], -u[0]])
    a = 0.5 * width
    d = math.sqrt(max(r * r - (a - s) ** 2, 0.0))
    c = 0.5 * (pl + pr) - d * n
    return np.array([c[0], c[1], math.atan2(n[1], n[0])])


@dataclass(frozen=True)
class BaseLimits:
    """Bounds of the platform's motion: translation speed [m/s] and acceleration [m/s²]
    (norms in the plane), yaw rate [rad/s] and yaw acceleration [rad/s²]; all > 0."""

    speed: float = 0.5
    acceleration: float = 0.5
    yaw_rate: float = 0.5
    yaw_acceleration: float = 1.0

    def __post_init__(self) -> None:
        for name in ("speed", "acceleration", "yaw_rate", "yaw_acceleration"):
            object.__setattr__(self, name, validation.positive(f"BaseLimits.{name}", getattr(self, name)))


def _clip_norm(v: np.ndarray, bound: float) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    return v if norm <= bound else v * (bound / norm)


class BaseMotion:
    """The platform moving towards a target pose with bounded speed and acceleration.

    Each step of ``dt``: the wanted velocity points at the target with magnitude
    ``min(limit speed, √(2 a_max distance), gain·distance)`` (the last two let it stop
    without overshoot), then the velocity changes towards it by at most ``a_max dt``, and
    the pose moves by ``v dt``. Translation (norm in the plane) and yaw are bounded apart.

    Args:
        limits: the bounds. dt: [s] the step, > 0. gain: [1/s] the approach rate near the
            target, > 0.
    """

    def __init__(self, limits: BaseLimits, dt: float, gain: float = 2.0) -> None:
        if not isinstance(limits, BaseLimits):
            raise TypeError(f"limits must be BaseLimits, got {type(limits).__name__}")
        self.limits = limits
        self.dt = validation.positive("dt", dt, unit="s")
        self.gain = validation.positive("gain", gain, unit="1/s")

    def _wanted(self, error: np.ndarray, speed: float, acceleration: float) -> np.ndarray:
        distance = float(np.linalg.norm(error))
        if distance == 0.0:
            return np.zeros_like(error)
        magnitude = min(speed, math.sqrt(2.0 * acceleration * distance), self.gain * distance)
        return error * (magnitude / distance)

    def step(
        self, pose: np.ndarray, velocity: np.ndarray, target: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(pose, velocity)`` (3,) ``[x, y, yaw]`` [m, rad] and [m/s, rad/s] after one step."""
        pose = validation.vector("pose", pose, 3)
        velocity = validation.vector("velocity", velocity, 3)
        target = validation.vector("target", target, 3)
        lim, dt = self.limits, self.dt
        error = target - pose
        error[2] = wrap_angle(error[2])
        new = np.empty(3)
        wanted = self._wanted(error[:2], lim.speed, lim.acceleration)
        new[:2] = velocity[:2] + _clip_norm(wanted - velocity[:2], lim.acceleration * dt)
        wanted_yaw = self._wanted(error[2:], lim.yaw_rate, lim.yaw_acceleration)
        new[2:] = velocity[2:] + _clip_norm(wanted_yaw - velocity[2:], lim.yaw_acceleration * dt)
        return pose + new * dt, new


def operator_force(
    stiffness: float, damping: float, intention: np.ndarray, intention_rate: np.ndarray, hand, hand_rate
) -> np.ndarray:
    """The force [N] the operator applies on a handle: ``K (x_i − x) + B (ẋ_i − ẋ)``.

    The operator model of this library (not in the paper): the hand is pulled towards the
    intention ``x_i`` by a spring ``stiffness`` [N/m] (> 0) and a damper ``damping`` [N s/m]
    (>= 0) relative to the intention's velocity. All vectors (3,) [m, m/s], world.
    """
    k = validation.positive("stiffness", stiffness, unit="N/m")
    b = validation.nonnegative("damping", damping, unit="N s/m")
    return k * (validation.vector("intention", intention, 3) - validation.vector("hand", hand, 3)) + b * (
        validation.vector("intention_rate", intention_rate, 3) - validation.vector("hand_rate", hand_rate, 3)
    )


def piecewise_linear_path(
    start: Sequence[float], waypoints: Sequence[Sequence[float]], speed: float, *, t0: float = 0.0
) -> Path:
    """A path from ``start`` through ``waypoints`` at constant ``speed``, starting at ``t0``.

    Before ``t0`` it rests at ``start``, after the last waypoint at that waypoint. Each leg
    is travelled at ``speed`` [m/s] (> 0) in a straight line; the velocity is that of the
    current leg (it jumps at the corners, as a walk's intention does).

    Args:
        start: (n,) the initial position. waypoints: each (n,). speed: [m/s]. t0: [s].
    """
    p0 = validation.vector("start", start)
    points = [p0] + [validation.vector(f"waypoints[{i}]", w, p0.size) for i, w in enumerate(waypoints)]
    v = validation.positive("speed", speed, unit="m/s")
    t0 = validation.finite("t0", t0)
    legs = []
    t = t0
    for a, b in zip(points[:-1], points[1:], strict=True):
        length = float(np.linalg.norm(b - a))
        if length > 0.0:
            legs.append((t, t + length / v, a, (b - a) / length * v))
            t += length / v
    end = points[-1]

    def path(time: float) -> tuple[np.ndarray, np.ndarray]:
        for t_start, t_end, a, rate in legs:
            if t_start <= time < t_end:
                return a + rate * (time - t_start), rate.copy()
        if time < t0:
            return p0.copy(), np.zeros(p0.size)
        return end.copy(), np.zeros(p0.size)

    return path
