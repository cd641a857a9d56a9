"""Task gains λ: constant, or the original SoT's adaptive gain ``λ(e) = a·exp(-b‖e‖) + c``."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class AdaptiveGain:
    """``λ(‖e‖) = a·exp(-b‖e‖) + c`` [1/s]: high near the goal, bounded far from it.

    Attributes:
        a, b, c: non-negative coefficients; ``λ(0) = a + c``, ``λ(∞) = c``.
    """

    a: float
    b: float
    c: float

    def __post_init__(self) -> None:
        for key in ("a", "b", "c"):
            value = getattr(self, key)
            if not math.isfinite(value) or value < 0.0:
                raise ValueError(f"AdaptiveGain.{key} = {value} must be finite and >= 0")
        if self.a + self.c <= 0.0:
            raise ValueError("AdaptiveGain gives λ = 0 everywhere (a + c = 0)")

    @classmethod
    def from_limits(cls, at_zero: float, at_infinity: float, slope_at_zero: float) -> AdaptiveGain:
        """The SoT parametrisation: λ(0), λ(∞) and ``-dλ/d‖e‖`` at 0."""
        a = at_zero - at_infinity
        if a <= 0.0:
            raise ValueError(f"at_zero ({at_zero}) must exceed at_infinity ({at_infinity})")
        return cls(a=a, b=slope_at_zero / a, c=at_infinity)

    def __call__(self, error_norm: float) -> float:
        return self.a * math.exp(-self.b * error_norm) + self.c


Gain = float | AdaptiveGain


def validate_gain(gain: Gain, *, name: str) -> Gain:
    """Return ``gain`` if usable, else raise ValueError naming the task ``name``."""
    if isinstance(gain, AdaptiveGain):
        return gain
    value = float(gain)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"task {name!r}: gain {gain} must be a finite number > 0 or an AdaptiveGain")
    return value


def evaluate_gain(gain: Gain, error_norm: float) -> float:
    """λ for the current error norm."""
    return gain(error_norm) if isinstance(gain, AdaptiveGain) else gain
