"""Push recovery beyond the ankle: the hip strategy, and why not a capture step. Pure numpy.

Notation as in :mod:`drake_sot.stabilization` (ground-plane quantities (2,) [m], world
frame; ξ the divergent component of motion (DCM), ω the LIPM's natural frequency).

**When the ZMP is not enough.** The DCM obeys ξ̇ = ω (ξ − p) (Englsberger et al. 2015): once
ξ has left the support polygon, no ZMP p inside it can bring ξ back. Two things can: a step
that puts a new sole beyond ξ, or angular momentum about the CoM. With the centroidal
angular momentum L (about the CoM, x axis for the lateral direction), the moment balance
about the CoM of the ground reaction at the ZMP gives

    c̈_y = ω² (c_y − p_y) + L̇_x / (m z_c),                                     (1)

so accelerating the upper body's roll with its top moving towards the fall (L̇_x < 0 for a
fall towards +y) acts as a ZMP moved beyond the sole edge by |L̇_x| / (m g) (the centroidal
moment pivot): the hip strategy.

**Why not a capture step (numbers of the embedded humanoid).** A 350 N, 0.1 s lateral push on
the torso leaves ξ ≈ 0.17 m from the feet's midpoint (measured: 0.164 m at 0.15 s after the
push began), the left sole's outer edge at 0.16 m. The capturing step must be taken by the
left foot, which carries the robot; once it lifts, the ZMP can be at best at the right
sole's inner edge (p = −0.03 m, −0.04 m with the stabilizer's 1 cm margin), and ξ runs away
from it during the single support T as ξ(T) = p + (ξ₀ − p) e^{ωT}. The widest step the
pattern generator accepts (``StepLimits.max_width`` = 0.35 m from the right foot) puts the
left sole's outer edge at 0.32 m: :func:`longest_capturing_swing` gives
T = ln((0.31 + 0.04) / (0.17 + 0.04)) / 3.49 ≈ 0.15 s, below the 0.2 s shortest single
support that ``footsteps.WALKING_BOUNDS`` allows (a 50 m/s² foot). Tried in physics with a
0.2 s and a 0.3 s swing, the loaded sole does not even lift: the robot rolls over its edge
(benchmarks/README.md). The trunk, in contrast,
can lean by 0.3 rad in 0.2 s with both feet on the ground: the hip strategy below. Its
measured push limits, with and without the lean, are in ``benchmarks/README.md``.

**The lean.** When ξ leaves the support polygon (by more than a threshold), the trunk's
orientation reference tilts its vertical axis towards the side ξ left by, by ``angle`` over
``rise`` (a quintic ``10s³ − 15s⁴ + 6s⁵``: zero velocity and acceleration at both ends), the
CoM task keeping the CoM: the hips move the other way and the trunk's angular momentum does
(1). It is held for ``hold`` and then brought back upright over ``back``, slowly enough that
the opposite L̇ stays within what the ZMP, now well inside, absorbs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drake_sot import validation
from drake_sot.stabilization import project_into_polygon


def dcm_excess(polygon: np.ndarray, dcm: np.ndarray) -> np.ndarray:
    """ξ minus its nearest point of the support polygon (2,) [m]: zero inside, else how far and
    which way ξ has left it."""
    dcm = validation.vector("dcm", dcm, 2)
    return dcm - project_into_polygon(polygon, dcm)


def longest_capturing_swing(dcm: float, stance_zmp: float, reach: float, omega: float) -> float:
    """The longest single support [s] after which a step still captures the DCM, on one axis.

    During the swing the DCM runs away from the stance ZMP ``stance_zmp`` as
    ξ(T) = p + (ξ₀ − p) e^{ωT}; the step captures it while ξ(T) stays within ``reach``, the
    farthest ZMP the landed sole offers on the side ξ runs to [m]. ``omega`` [1/s] > 0.
    Zero when ξ₀ is already at or beyond ``reach`` (or ``reach`` is on the other side).

    Raises:
        ValueError: ``dcm`` equal to ``stance_zmp`` (the DCM does not run away: any swing
            captures it), or a non-finite value, named.
    """
    omega = validation.positive("omega", omega, unit="1/s")
    dcm, stance_zmp, reach = (
        validation.finite(n, v) for n, v in (("dcm", dcm), ("stance_zmp", stance_zmp), ("reach", reach))
    )
    if dcm == stance_zmp:
        raise ValueError(f"dcm = {dcm!r} m: equal to stance_zmp, it does not run away")
    ratio = (reach - stance_zmp) / (dcm - stance_zmp)
    return math.log(ratio) / omega if ratio > 1.0 else 0.0


@dataclass(frozen=True)
class LeanProfile:
    """The hip strategy's trunk lean.

    Attributes:
        angle: [rad] tilt of the trunk's vertical axis, in (0, π/2).
        rise: [s] time to reach it, > 0.
        hold: [s] time it is held after reaching it, >= 0.
        back: [s] time to come back upright, > 0.
        threshold: [m] the lean starts when ξ is farther than this outside the support
            polygon, >= 0.

    Raises:
        ValueError: a value out of its range, named.
    """

    angle: float = 0.3
    rise: float = 0.2
    hold: float = 1.0
    back: float = 1.0
    threshold: float = 0.005

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "angle", validation.bounded("angle", self.angle, 0.0, math.pi / 2, unit="rad")
        )
        if not self.angle > 0.0:
            raise ValueError(f"angle = {self.angle!r} rad: must be > 0")
        for name in ("rise", "back"):
            object.__setattr__(self, name, validation.positive(name, getattr(self, name), unit="s"))
        for name, unit in (("hold", "s"), ("threshold", "m")):
            object.__setattr__(self, name, validation.nonnegative(name, getattr(self, name), unit=unit))

    @property
    def duration(self) -> float:
        """[s] from the start of the lean to upright again."""
        return self.rise + self.hold + self.back

    def at(self, elapsed: float) -> tuple[float, float]:
        """``(angle [rad], rate [rad/s])`` of the lean ``elapsed`` [s] after it started."""
        if elapsed < self.rise:
            s, span, sign = max(elapsed, 0.0) / self.rise, self.rise, 1.0
        elif elapsed < self.rise + self.hold:
            return self.angle, 0.0
        elif elapsed < self.duration:
            s, span, sign = (elapsed - self.rise - self.hold) / self.back, self.back, -1.0
        else:
            return 0.0, 0.0
        q = s**3 * (10.0 + s * (-15.0 + 6.0 * s))
        dq = 30.0 * s**2 * (1.0 - s) ** 2 / span
        angle = self.angle * (q if sign > 0 else 1.0 - q)
        return angle, sign * self.angle * dq


def lean_axis(direction: np.ndarray) -> np.ndarray:
    """Unit rotation axis (3,) that tilts the vertical towards the ground ``direction`` (2,)
    (z × d): a positive rotation about it moves the trunk's top along ``direction``."""
    direction = validation.vector("direction", direction, 2)
    norm = float(np.hypot(*direction))
    if not norm > 0.0:
        raise ValueError(f"direction = {direction.tolist()}: must be non-zero")
    return np.array([-direction[1], direction[0], 0.0]) / norm
