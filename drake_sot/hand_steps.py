"""The next footprint from the hands' error in the waist frame (Evrard et al. 2009, III-D), pure numpy.

The robot walks so as to keep its hands at a reference position in its waist frame: "we
considered the distance of the current position to a reference position of the hands given
in the waist coordinate system. Steps are planned to regulate this error to zero". The paper
says no more; the choices made here:

- The hands' position is the midpoint of the two hands, on the ground plane (x, y); the
  reference is that midpoint's wanted position ``(forward, lateral)`` [m] in the waist frame.
- The pattern generator is a planner with footprints queued ahead (III-C), so the error is
  taken in the waist frame *where the planned footprints leave it*: at the midpoint of the
  last planned footprint of each foot, heading midway between their yaws (the waist of a
  standing robot). Measured from the current waist, the footprints already queued would
  correct the same error again and the robot would overshoot by the queue's length.
- Below ``threshold`` [m] (the error's norm) no step is decided.
- Otherwise a foot steps so that the stance midpoint moves by the error: its footprint is
  ``2 c' − s`` with ``c'`` the wanted midpoint and ``s`` the stance foot, clipped in the
  stance foot's frame to the stride and width limits (:class:`drake_sot.footsteps.StepLimits`),
  without turning. The feet alternate (the first step on the side of the lateral error), except
  when the alternating foot's step would not reduce the error by ``_PROGRESS`` (1 mm; e.g. it
  is clipped at a width limit): then the other foot steps again. Each decided step reduces the
  error; when neither foot's would, no step is decided.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drake_sot import validation
from drake_sot.footsteps import Footstep, StepLimits, compose, mean_yaw, other_side

__all__ = ["HandStepRule", "hand_error", "stance_frame"]

#: [m] the least reduction of the error's norm that makes a step worth taking.
_PROGRESS = 1e-3
#: [m] clipped steps stay this far inside the limits (the limit check recomputes them in floats).
_INSIDE = 1e-9


def stance_frame(left: Footstep, right: Footstep) -> tuple[np.ndarray, float]:
    """``(centre (2,) [m], yaw [rad])``: the waist frame over a stance (midpoint, mean yaw)."""
    return 0.5 * (left.xy + right.xy), mean_yaw(left.yaw, right.yaw)


def hand_error(hands: np.ndarray, left: Footstep, right: Footstep, reference: np.ndarray) -> np.ndarray:
    """(2,) [m] the hands' midpoint in the waist frame over ``(left, right)``, minus ``reference``.

    Args:
        hands: (6,) ``[right (3,); left (3,)]`` hand positions in the world [m].
        left, right: the stance (footprints).
        reference: (2,) ``(forward, lateral)`` wanted position of the midpoint [m].
    """
    h = validation.vector("hands", hands, 6)
    ref = validation.vector("reference", reference, 2)
    centre, yaw = stance_frame(left, right)
    d = 0.5 * (h[:2] + h[3:5]) - centre
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]) - ref


@dataclass(frozen=True)
class HandStepRule:
    """Decides the next footprint from the hand error (see the module's docstring).

    Attributes:
        reference: (forward, lateral) [m] the hands' wanted midpoint in the waist frame.
        threshold: [m] no step while the error's norm is below it, > 0.
        limits: the step limits the footprints respect.
    """

    reference: tuple[float, float] = (0.35, 0.0)
    threshold: float = 0.05
    limits: StepLimits = StepLimits()

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "reference", tuple(validation.vector("HandStepRule.reference", self.reference, 2))
        )
        object.__setattr__(
            self, "threshold", validation.positive("HandStepRule.threshold", self.threshold, unit="m")
        )
        if not isinstance(self.limits, StepLimits):
            raise TypeError(f"HandStepRule.limits must be StepLimits, got {type(self.limits).__name__}")

    def error(self, hands: np.ndarray, left: Footstep, right: Footstep) -> np.ndarray:
        """(2,) [m] the error in the waist frame over the stance ``(left, right)``."""
        return hand_error(hands, left, right, np.array(self.reference))

    def next_footprint(
        self, hands: np.ndarray, left: Footstep, right: Footstep, last_side: str | None
    ) -> Footstep | None:
        """The next footprint after the stance ``(left, right)`` (the last planned ones), or
        None while the error is below the threshold.

        ``last_side`` is the side of the last planned step (None before the first: then the
        foot on the side of the lateral error steps first, the left one when it is zero).
        """
        e = self.error(hands, left, right)
        if not (float(np.linalg.norm(e)) >= self.threshold):
            return None
        preferred = ("left" if e[1] >= 0.0 else "right") if last_side is None else other_side(last_side)
        norm = float(np.linalg.norm(e))
        for side in (preferred, other_side(preferred)):
            step = self._step(e, left, right, side)
            stance = {"left": left, "right": right, side: step}
            if float(np.linalg.norm(self.error(hands, stance["left"], stance["right"]))) < norm - _PROGRESS:
                return step
        return None

    def _step(self, e: np.ndarray, left: Footstep, right: Footstep, side: str) -> Footstep:
        """The ``side`` footprint that moves the stance midpoint by ``e`` (waist frame), clipped."""
        stance = right if side == "left" else left
        centre, yaw = stance_frame(left, right)
        c, s = math.cos(yaw), math.sin(yaw)
        wanted_centre = centre + np.array([c * e[0] - s * e[1], s * e[0] + c * e[1]])
        d = 2.0 * wanted_centre - stance.xy - stance.xy
        # In the stance foot's frame, clipped to the limits; the swing foot keeps the stance yaw.
        cs, ss = math.cos(stance.yaw), math.sin(stance.yaw)
        dx, dy = cs * d[0] + ss * d[1], -ss * d[0] + cs * d[1]
        sign = 1.0 if side == "left" else -1.0
        lim = self.limits
        dx = float(np.clip(dx, -lim.max_stride + _INSIDE, lim.max_stride - _INSIDE))
        lateral = float(np.clip(sign * dy, lim.min_width + _INSIDE, lim.max_width - _INSIDE))
        return compose(stance, dx, sign * lateral, 0.0, side)
