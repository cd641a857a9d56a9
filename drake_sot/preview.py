"""ZMP preview control on the cart-table model, and footstep → ZMP / feet plans.

Pure numpy/scipy; no Drake.

**Cart-table model** (Kajita et al., ICRA 2003).  Per horizontal axis the centre
of mass (CoM) at constant height ``z_c`` has state ``x = [c, ċ, c̈]`` and the
jerk ``u`` as input; the zero-moment point (ZMP) of the model is
``p = c - z_c/g · c̈``.  Discretised exactly at the period ``dt`` (jerk held
over a period)::

    x[k+1] = A x[k] + B u[k],   p[k] = C x[k]
    A = [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]],  B = [dt³/6, dt²/2, dt],  C = [1, 0, -z_c/g]

The same one-axis model drives x and y independently: every array below has
one column per axis.

**Preview servo** (Katayama's optimal preview servo, as used by Kajita).  The
augmented state ``[e[k], Δx[k]]`` with ``e = p - p_ref`` and ``Δx[k] = x[k] -
x[k-1]`` evolves with ``Ã = [[1, C A], [0, A]]``, ``B̃ = [C B, B]``; the cost
``Σ q e² + r Δu²`` gives the Riccati solution ``P̃`` (``scipy.linalg.
solve_discrete_are``) and the gains ``[Gi, Gx] = (r + B̃ᵀP̃B̃)⁻¹ B̃ᵀ P̃ Ã``.
Summed over time the optimal increment becomes the control law::

    u[k] = -Gi Σ_{i≤k} e[i] - Gx x[k] - Σ_{j=1}^{N-1} G(j) p_ref[k+j]
    G(1) = -Gi,   G(j) = (r + B̃ᵀP̃B̃)⁻¹ B̃ᵀ X̃(j-1),   X̃(1) = -Ãcᵀ P̃ Ĩ,   X̃(j) = Ãcᵀ X̃(j-1)

with ``Ãc = Ã - B̃ [Gi, Gx]`` (:attr:`PreviewController.closed_loop`) and ``Ĩ =
[1, 0, 0, 0]``.  The preview window handed to :meth:`PreviewController.step`
holds the ``N = round(horizon/dt)`` references ``p_ref[k], ..., p_ref[k+N-1]``;
``Gp[j]`` is the gain on ``p_ref[k+j]``: ``Gp[0] = -Gi`` is the current
sample's reference as it enters through the error integral, and ``Gp[j] =
G(j)`` for ``j ≥ 1``.  With this bookkeeping the law reads
``u = -Gi s - Gx x - Gi C x - Gp · window``, ``s`` the error sum of the past samples.

The error sum also carries the history of the jerk (the law is the sum of optimal
*increments*), and the truncated preview sum is not translation invariant
(``Gx[0] + Σ_{j≥1} Gp[j]`` is small but not zero: 292 m/s³ per metre against
``Gx[0] ≈ 7.3e4`` with the defaults).  A start from ``s = 0`` therefore kicks the
jerk unless the CoM is at rest at the origin under a constant window;
:meth:`PreviewController.initial_error_sum` gives the bumpless starting value
(zero jerk on the sample before the start), and :meth:`PreviewController.plan`
uses it by default.

**Footsteps.**  A walk is cut into :class:`Segment` s sampled at ``dt``
(sample ``i`` at time ``i·dt`` from the segment start): for each step a
double-support phase where the ZMP reference moves linearly onto the stance
foot, then a single-support phase where it stays at the stance sole centre
while the swing foot travels (quintic in x, y, yaw; ``64 s³(1-s)³`` bump in z).
The paper of the collaborative-task experiment (Evrard et al.) runs this as a
*planner*: four footprints ahead, a new footprint each time a step has been
executed (:class:`FootstepPlan` samples a given list; an online generator
re-plans with :meth:`PreviewController.plan` from the current state).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

__all__ = [
    "STOP_TRANSFER_MIN",
    "Footstep",
    "FootstepPlan",
    "PreviewController",
    "PreviewPlan",
    "Segment",
    "StepLimits",
    "StepTiming",
    "stand_segment",
    "step_segment",
    "stop_segment",
]

#: Shortest ZMP transfer [s] of :func:`stop_segment`: the final shift of the ZMP
#: to the midpoint of the soles lasts ``max(timing.double_support, STOP_TRANSFER_MIN)``.
STOP_TRANSFER_MIN = 0.3

PHASE_DOUBLE = 0
PHASE_LEFT_SUPPORT = 1  # right foot swinging
PHASE_RIGHT_SUPPORT = 2  # left foot swinging

_SIDES = ("left", "right")


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be a finite value > 0, got {value!r}")
    return v


def _finite(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def _wrap(angle: float) -> float:
    """``angle`` wrapped to [-π, π)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


# --------------------------------------------------------------------------- preview control


@dataclass(frozen=True, eq=False)
class PreviewPlan:
    """Result of :meth:`PreviewController.plan`: per sample ``k`` (time ``k·dt``) and axis (x, y).

    Attributes:
        com: (K, 2) CoM position [m].
        com_vel: (K, 2) CoM velocity [m/s].
        com_acc: (K, 2) CoM acceleration [m/s²].
        zmp: (K, 2) the model's ZMP ``C x = com - z_c/g · com_acc`` [m].
    """

    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray

    def __len__(self) -> int:
        return len(self.com)


class PreviewController:
    """Cart-table ZMP preview control, discretised at ``dt``, one axis model applied to x and y.

    Args:
        dt: sampling period [s].
        z_c: CoM height of the cart-table model [m].
        horizon: preview time [s]; ``N = round(horizon/dt)`` references are previewed
            (the current one and the ``N - 1`` next ones).
        q: weight of the squared ZMP error.
        r: weight of the squared jerk increment.
        g: gravity [m/s²].

    Attributes:
        dt, z_c, horizon, q, r, g: the arguments.
        N: number of previewed samples.
        A: (3, 3), B: (3,), C: (3,) the discrete cart-table model.
        Gi: integral gain (scalar).
        Gx: (3,) state gain.
        Gp: (N,) preview gains, ``Gp[j]`` on the reference ``j`` samples ahead (``Gp[0] = -Gi``;
            see the module docstring).
        P: (4, 4) Riccati solution of the integral-augmented system.
        closed_loop: (4, 4) ``Ã - B̃ [Gi, Gx]``, the closed loop of the augmented system.
    """

    def __init__(
        self,
        dt: float = 0.005,
        z_c: float = 0.814,
        horizon: float = 1.6,
        q: float = 1.0,
        r: float = 1e-6,
        g: float = 9.81,
    ) -> None:
        self.dt = _positive("dt", dt)
        self.z_c = _positive("z_c", z_c)
        self.horizon = _positive("horizon", horizon)
        self.q = _positive("q", q)
        self.r = _positive("r", r)
        self.g = _positive("g", g)
        self.N = round(self.horizon / self.dt)
        if self.N < 2:
            raise ValueError(
                f"horizon {horizon!r} s must cover at least 2 samples of dt {dt!r} s (N = {self.N})"
            )
        T = self.dt
        self.A = np.array([[1.0, T, T * T / 2.0], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
        self.B = np.array([T**3 / 6.0, T * T / 2.0, T])
        self.C = np.array([1.0, 0.0, -self.z_c / self.g])

        # Integral-augmented system [e, Δx].
        At = np.zeros((4, 4))
        At[0, 0] = 1.0
        At[0, 1:] = self.C @ self.A
        At[1:, 1:] = self.A
        Bt = np.concatenate([[self.C @ self.B], self.B])[:, None]
        Qt = np.zeros((4, 4))
        Qt[0, 0] = self.q
        Rt = np.array([[self.r]])
        P = scipy.linalg.solve_discrete_are(At, Bt, Qt, Rt)
        denom = float(self.r + Bt[:, 0] @ P @ Bt[:, 0])
        K = (Bt[:, 0] @ P @ At) / denom  # [Gi, Gx]
        self.P = P
        self.Gi = float(K[0])
        self.Gx = K[1:].copy()
        self.closed_loop = At - Bt @ K[None, :]

        # Preview gains: Gp[0] = -Gi (current reference, via the integral), then G(1..N-1).
        Gp = np.empty(self.N)
        Gp[0] = -self.Gi
        Gp[1] = -self.Gi
        Act = self.closed_loop.T
        X = -Act @ P[:, 0]
        for j in range(2, self.N):
            Gp[j] = (Bt[:, 0] @ X) / denom
            X = Act @ X
        self.Gp = Gp
        # step(): u = -(Gi s + Kx x + Gp·window) with Kx = Gx + Gi C.  One (5, 4+N) matrix
        # maps [x; s; window] to [x_next; s_next; zmp] (the whole tick is one product).
        Kx = self.Gx + self.Gi * self.C
        tick = np.zeros((5, 4 + self.N))
        tick[:3, :3] = self.A - np.outer(self.B, Kx)
        tick[:3, 3] = -self.Gi * self.B
        tick[:3, 4:] = -np.outer(self.B, self.Gp)
        tick[3, :3] = self.C
        tick[3, 3] = 1.0
        tick[3, 4] = -1.0
        tick[4, :3] = self.C
        self._tick = tick
        self._Ainv = np.linalg.inv(self.A)

    def step(
        self, x: np.ndarray, error_sum: np.ndarray, preview: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One online tick, for both axes at once.

        Inputs are not checked (this runs every control period); :meth:`plan` checks them.

        Args:
            x: (3, 2) current state ``[c, ċ, c̈]`` per axis.
            error_sum: (2,) sum of ``zmp - zmp_ref`` over the past samples, starting from
                :meth:`initial_error_sum` (not from zeros: see the module docstring).
            preview: (N, 2) ZMP references of the current sample and the ``N - 1`` next ones.

        Returns:
            ``(x_next (3, 2), error_sum_next (2,), zmp (2,))`` where ``zmp = C x`` is the
            model ZMP of the current state and ``error_sum_next = error_sum + zmp - preview[0]``.
        """
        out = self._tick @ np.concatenate((x, error_sum[None], preview))
        return out[:3], out[3], out[4]

    def initial_error_sum(self, x0: np.ndarray, preview: np.ndarray) -> np.ndarray:
        """(2,) error sum that starts :meth:`step` without a kick (a bumpless start).

        The summed control law carries the history of the jerk in the error sum.  This
        value makes the jerk of the sample before the start zero, as if the state ``x0``
        (3, 2) had been reached from ``A⁻¹ x0`` with no jerk while the window, shifted back
        one sample, was ``[preview[0], preview[0], ..., preview[N-2]]``.  At rest over a
        constant reference ``p0`` it is ``-(Gx[0] + Σ_{j≥1} Gp[j]) p0 / Gi``, the integral
        action that cancels the truncation of the preview sum, and the CoM stays put.

        Args:
            x0: (3, 2) state at the start.
            preview: (N, 2) the window of the first sample.
        """
        x_prev = self._Ainv @ x0
        return -(self.Gx @ x_prev + self.Gp[1:] @ preview[:-1]) / self.Gi

    def extend_reference(self, zmp_reference: np.ndarray) -> np.ndarray:
        """(K + N - 1, 2): the reference with its last value held for the preview tail."""
        ref = np.asarray(zmp_reference, dtype=float)
        return np.concatenate([ref, np.repeat(ref[-1:], self.N - 1, axis=0)])

    def plan(
        self,
        zmp_reference: np.ndarray,
        x0: np.ndarray | None = None,
        error_sum: np.ndarray | None = None,
    ) -> PreviewPlan:
        """Run :meth:`step` over a whole ZMP reference.

        Args:
            zmp_reference: (K, 2) reference sampled at ``dt``; its last value is held
                for the preview beyond the end.
            x0: (3, 2) initial ``[c, ċ, c̈]`` per axis; default at rest over ``zmp_reference[0]``.
            error_sum: (2,) initial error sum; default :meth:`initial_error_sum` (bumpless).

        Returns:
            A :class:`PreviewPlan` of K samples, sample ``k`` being the state at time ``k·dt``.
        """
        ref = np.asarray(zmp_reference, dtype=float)
        if ref.ndim != 2 or ref.shape[1] != 2 or ref.shape[0] < 1:
            raise ValueError(f"zmp_reference must have shape (K>=1, 2), got {ref.shape}")
        if not np.isfinite(ref).all():
            raise ValueError("zmp_reference contains NaN or Inf")
        if x0 is None:
            x = np.zeros((3, 2))
            x[0] = ref[0]
        else:
            x = np.array(x0, dtype=float)
            if x.shape != (3, 2):
                raise ValueError(f"x0 must have shape (3, 2), got {x.shape}")
            if not np.isfinite(x).all():
                raise ValueError("x0 contains NaN or Inf")
        K = ref.shape[0]
        N = self.N
        padded = self.extend_reference(ref)
        states = np.empty((K, 3, 2))
        zmp = np.empty((K, 2))
        if error_sum is None:
            s = self.initial_error_sum(x, padded[:N])
        else:
            s = np.array(error_sum, dtype=float)
            if s.shape != (2,) or not np.isfinite(s).all():
                raise ValueError(f"error_sum must be a finite (2,) vector, got {error_sum!r}")
        step = self.step
        for k in range(K):
            states[k] = x
            x, s, zmp[k] = step(x, s, padded[k : k + N])
        return PreviewPlan(
            com=states[:, 0].copy(),
            com_vel=states[:, 1].copy(),
            com_acc=states[:, 2].copy(),
            zmp=zmp,
        )


# --------------------------------------------------------------------------- footsteps


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
        if self.side not in _SIDES:
            raise ValueError(f"Footstep side must be 'left' or 'right', got {self.side!r}")
        for name in ("x", "y", "yaw"):
            object.__setattr__(self, name, _finite(f"Footstep.{name}", getattr(self, name)))

    @property
    def pose(self) -> np.ndarray:
        """(4,) ``[x, y, z=0, yaw]``, the sole pose on the ground."""
        return np.array([self.x, self.y, 0.0, self.yaw])

    @property
    def xy(self) -> np.ndarray:
        """(2,) sole centre, which is also the ZMP reference of this foot."""
        return np.array([self.x, self.y])


@dataclass(frozen=True)
class StepTiming:
    """Durations of a step and the swing-foot lift.

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
            object.__setattr__(self, name, _positive(f"StepTiming.{name}", getattr(self, name)))


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
            object.__setattr__(self, name, _positive(f"StepLimits.{name}", getattr(self, name)))
        if self.min_width > self.max_width:
            raise ValueError(f"StepLimits.min_width {self.min_width} m exceeds max_width {self.max_width} m")

    def check(self, stance: Footstep, step: Footstep) -> None:
        """Raise ValueError naming the violated limit and the values; return None if reachable.

        A left step must lie to the left (+y in the stance frame) of a right stance
        foot, and a right step to the right of a left one.
        """
        if stance.side == step.side:
            raise ValueError(
                f"a {step.side} step needs a {_other(step.side)} stance foot, got a {stance.side} one"
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
        dyaw = _wrap(step.yaw - stance.yaw)
        if abs(dyaw) > self.max_yaw:
            raise ValueError(f"{where} exceeds max_yaw {self.max_yaw:.2f} rad (relative yaw {dyaw:.2f} rad)")


def _other(side: str) -> str:
    return "right" if side == "left" else "left"


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


def _samples(name: str, duration: float, dt: float, minimum: int) -> int:
    n = round(duration / dt)
    if n < minimum:
        raise ValueError(f"{name} {duration!r} s gives {n} samples at dt {dt!r} s; at least {minimum} needed")
    return n


def _zmp_transfer(start: np.ndarray, end: np.ndarray, n: int) -> np.ndarray:
    """(n, 2) linear move from ``start`` (sample 0) towards ``end``, reached at sample n."""
    s = (np.arange(n) / n)[:, None]
    return (1.0 - s) * start + s * end


def _still(pose: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.broadcast_to(pose, (n, 4)).copy(), np.zeros((n, 4))


def _zmp_start(zmp_start: np.ndarray) -> np.ndarray:
    z = np.asarray(zmp_start, dtype=float)
    if z.shape != (2,) or not np.isfinite(z).all():
        raise ValueError(f"zmp_start must be a finite (2,) vector, got {z!r}")
    return z


def _check_feet(left: Footstep, right: Footstep) -> None:
    if left.side != "left":
        raise ValueError(f"the left foot has side {left.side!r}")
    if right.side != "right":
        raise ValueError(f"the right foot has side {right.side!r}")


def _landing_yaw(yaw0: float, yaw1: float) -> float:
    """``yaw1`` shifted by a multiple of 2π to within π of ``yaw0`` (itself if already so)."""
    return yaw1 if abs(yaw1 - yaw0) <= math.pi else yaw0 + _wrap(yaw1 - yaw0)


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
    Limits are not checked here (see :class:`FootstepPlan`).
    """
    _check_feet(left, right)
    dt = _positive("dt", dt)
    z0 = _zmp_start(zmp_start)
    n_ds = _samples("double_support", timing.double_support, dt, 1)
    n_ss = _samples("single_support", timing.single_support, dt, 2)
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
    there for ``hold`` seconds (``hold >= 0``).
    """
    _check_feet(left, right)
    dt = _positive("dt", dt)
    z0 = _zmp_start(zmp_start)
    hold = float(hold)
    if not (math.isfinite(hold) and hold >= 0.0):
        raise ValueError(f"hold must be a finite value >= 0, got {hold!r}")
    n_tr = _samples("stop transfer", max(timing.double_support, STOP_TRANSFER_MIN), dt, 1)
    n_hold = round(hold / dt)
    mid = 0.5 * (left.xy + right.xy)
    zmp = np.concatenate([_zmp_transfer(z0, mid, n_tr), np.broadcast_to(mid, (n_hold, 2))])
    n = n_tr + n_hold
    lp, lv = _still(left.pose, n)
    rp, rv = _still(right.pose, n)
    return Segment(zmp, lp, rp, lv, rv, np.zeros(n, dtype=np.int8))


def stand_segment(left: Footstep, right: Footstep, duration: float, dt: float) -> Segment:
    """``duration`` [s] standing still (phase 0), the ZMP reference at the midpoint of the soles."""
    _check_feet(left, right)
    dt = _positive("dt", dt)
    duration = float(duration)
    if not (math.isfinite(duration) and duration >= 0.0):
        raise ValueError(f"stand duration must be a finite value >= 0, got {duration!r}")
    n = round(duration / dt)
    mid = 0.5 * (left.xy + right.xy)
    lp, lv = _still(left.pose, n)
    rp, rv = _still(right.pose, n)
    return Segment(np.broadcast_to(mid, (n, 2)).copy(), lp, rp, lv, rv, np.zeros(n, dtype=np.int8))


class FootstepPlan:
    """A walk from an initial stance through a list of footsteps, checked against :class:`StepLimits`.

    Each step is checked against the pose the other foot has at that moment (the
    initial pose, or its last step); steps may come in any side order.  The initial
    stance itself must be a valid placement of the right foot relative to the left.

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
        _check_feet(left, right)
        try:
            limits.check(left, right)
        except ValueError as err:
            raise ValueError(f"initial stance: {err}") from None
        feet = {"left": left, "right": right}
        for i, step in enumerate(steps):
            if not isinstance(step, Footstep):
                raise TypeError(f"step {i} must be a Footstep, got {type(step).__name__}")
            try:
                limits.check(feet[_other(step.side)], step)
            except ValueError as err:
                raise ValueError(f"step {i}: {err}") from None
            feet[step.side] = step
        self.left = left
        self.right = right
        self.steps = tuple(steps)
        self.timing = timing
        self.limits = limits

    def __len__(self) -> int:
        return len(self.steps)

    def sample(self, dt: float, hold: float = 1.0, stand: float = 0.0) -> Segment:
        """The whole walk sampled at ``dt``.

        ``stand`` seconds standing with the ZMP at the midpoint of the feet (a lead-in that
        lets a preview controller start moving the CoM before the first transfer), then
        for each step a :func:`step_segment` (the first one transfers the ZMP from the
        midpoint to the first stance foot), then :func:`stop_segment` with ``hold``.

        A CoM plan that starts at rest at the first sample needs the lead-in: with
        ``stand = 0`` the preview controller cannot shift the CoM in time for the first
        transfer (0.1 s by default) and its ZMP leaves the support polygon by centimetres;
        ``stand >= 1 s`` keeps it inside (see tests/test_preview.py).
        """
        feet = {"left": self.left, "right": self.right}
        zmp = 0.5 * (self.left.xy + self.right.xy)
        segments = []
        if stand > 0.0:
            segments.append(stand_segment(self.left, self.right, stand, dt))
        for step in self.steps:
            segments.append(step_segment(feet["left"], feet["right"], zmp, step, self.timing, dt))
            zmp = feet[_other(step.side)].xy
            # keep the sampled yaw continuous when the footsteps' yaws wrap round
            yaw = _landing_yaw(feet[step.side].yaw, step.yaw)
            feet[step.side] = Footstep(step.x, step.y, yaw, step.side)
        segments.append(stop_segment(feet["left"], feet["right"], zmp, self.timing, dt, hold))
        return Segment.join(segments)

    @classmethod
    def walk(
        cls,
        left: Footstep,
        right: Footstep,
        n_steps: int,
        stride: float | Sequence[float] = 0.0,
        turn: float | Sequence[float] = 0.0,
        first_side: str = "right",
        timing: StepTiming = StepTiming(),
        limits: StepLimits = StepLimits(),
    ) -> FootstepPlan:
        """Alternating steps along a path.

        A walking frame starts midway between the soles with the left foot's yaw; for
        step k it turns by ``turn[k]`` and then advances by ``stride[k]`` along its new
        heading, and the footprint lands on it at the initial half-width of the stance,
        on its own side, with the frame's yaw.  Straight (``turn = 0``) the k-th footprint
        (k = 1..n) is ``k·stride`` ahead of the start line.  ``stride`` and ``turn`` are
        scalars or one value per step.
        """
        if first_side not in _SIDES:
            raise ValueError(f"first_side must be 'left' or 'right', got {first_side!r}")
        n = int(n_steps)
        per_step = {}
        for name, value in (("stride", stride), ("turn", turn)):
            a = np.asarray(value, dtype=float)
            if a.ndim > 1 or (a.ndim == 1 and len(a) != n):
                raise ValueError(
                    f"{name} must be a scalar or have {n} values (one per step), got shape {a.shape}"
                )
            per_step[name] = np.broadcast_to(a, (n,))
        strides, turns = per_step["stride"], per_step["turn"]
        yaw = left.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy = 0.5 * (left.x + right.x), 0.5 * (left.y + right.y)
        half = 0.5 * abs(-s * (left.x - right.x) + c * (left.y - right.y))
        side = first_side
        steps = []
        for k in range(n):
            yaw += turns[k]
            c, s = math.cos(yaw), math.sin(yaw)
            ox, oy = ox + strides[k] * c, oy + strides[k] * s
            lat = half if side == "left" else -half
            steps.append(Footstep(ox - s * lat, oy + c * lat, yaw, side))
            side = _other(side)
        return cls(left, right, steps, timing, limits)
