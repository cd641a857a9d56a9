"""Re-anchoring a walking plan on the measured stance foot: planar rigid transforms. Pure numpy.

**Why the open-loop walk drifts.**  The kinematic SoT integrates its own reference
configuration q_ref, floating base included (the "device" of Mansard et al. 2009), and the
robot's joints track q_ref; nothing tells the reference where the robot's feet really are.
Write ``X^r`` for a pose in the reference's world, ``X^m`` for the measured pose of the same
frame on the robot, and ``S``, ``W`` for the stance and swing soles. While the stance foot
holds on the ground (no slip), the swing foot lands where the robot's legs put it relative
to the stance foot::

    W^m = S^m ∘ (S^r)⁻¹ ∘ W^r ∘ ε,

``ε`` the step's relative placement error (the joints' tracking error at touch-down). The
foot tasks put ``W^r`` on the footprint ``F_k``, so the landing error obeys
``e_k = e_(k-1) + ε_k``: a running sum. Without re-anchoring the landing error grows by a few
millimetres per forward step (``benchmarks/README.md`` has the measurement on ``walk_long``).

**The fix.**  Map the plan into the reference's world through the measured stance foot.
At each lift-off, with the stance foot on the ground in both worlds, the drift::

    Δ = S^r ∘ (S^m)⁻¹          (the robot's world → the reference's world, planar: x, y, yaw)

and the swing foot's target becomes ``W^r = Δ ∘ F_k``; then
``W^m = S^m ∘ (S^r)⁻¹ ∘ Δ ∘ F_k ∘ ε = F_k ∘ ε``: every landing carries one step's ε, never
the sum. The CoM and waist references go through the same Δ (they must stay consistent
with the feet in the reference's world), and a foot on the ground keeps the Δ it landed
with (changing it would drag a stance foot the robot cannot move, and its task would pull
the whole reference instead). The floating base of q_ref is left alone: the reference's
world drifts from the robot's by Δ, which the mapping absorbs.

Re-synchronising q_ref's floating base with the robot's at each landing instead does not
stop the sum by itself: the reference stance sole then sits on the measured one,
``F_(k-1) + e_(k-1)``, its task pulls it back onto ``F_(k-1)`` by moving the whole
reference (the base, not the joints, which the robot would feel), and ``e_(k-1)`` is
restored; it works only if the stance reference becomes the measured sole, which is this
mapping seen from the other world. ``S^m`` is the simulator's pose of the sole; on a robot
it would come from an estimate of the foot in the world (odometry, motion capture).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drake_sot import validation
from drake_sot.footsteps import wrap_angle


@dataclass(frozen=True)
class PlanarTransform:
    """A rigid transform of the ground plane: rotation by ``yaw`` [rad] then translation
    ``(x, y)`` [m]. As the pose of a frame, it maps the frame's coordinates to the world's."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x", "y", "yaw"):
            object.__setattr__(self, name, validation.finite(f"PlanarTransform.{name}", getattr(self, name)))

    def compose(self, other: PlanarTransform) -> PlanarTransform:
        """``self ∘ other``: apply ``other`` first."""
        x, y = self.apply_point(np.array([other.x, other.y]))
        return PlanarTransform(float(x), float(y), self.yaw + other.yaw)

    def inverse(self) -> PlanarTransform:
        """The transform that undoes this one."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return PlanarTransform(-(c * self.x + s * self.y), s * self.x - c * self.y, -self.yaw)

    def rotate(self, v: np.ndarray) -> np.ndarray:
        """(2,) the vector ``v`` rotated by ``yaw`` (a velocity, a displacement)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])

    def apply_point(self, p: np.ndarray) -> np.ndarray:
        """(2,) the point ``p`` transformed."""
        return self.rotate(p) + (self.x, self.y)


def drift(reference: PlanarTransform, measured: PlanarTransform) -> PlanarTransform:
    """``Δ = reference ∘ measured⁻¹``: maps the measured world onto the reference's, given one
    frame's pose in each (the stance sole, fixed on the ground in both)."""
    return reference.compose(measured.inverse())


def blend(a: PlanarTransform, b: PlanarTransform, s: float) -> PlanarTransform:
    """From ``a`` (s = 0) to ``b`` (s = 1), linearly in x, y and yaw (the short way round)."""
    s = validation.bounded("s", s, 0.0, 1.0)
    return PlanarTransform(
        a.x + s * (b.x - a.x), a.y + s * (b.y - a.y), a.yaw + s * wrap_angle(b.yaw - a.yaw)
    )
