"""Task gains λ: constant, or the original SoT's adaptive gain ``λ(e) = a·exp(-b‖e‖) + c``."""

from __future__ import annotations

import math
from dataclasses import dataclass

from drake_sot.validation import finite, nonnegative, positive


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
            nonnegative(f"AdaptiveGain.{key}", getattr(self, key), unit="1/s" if key != "b" else "1/m")
        if not (self.a + self.c > 0.0):
            raise ValueError("AdaptiveGain gives λ = 0 everywhere (a + c = 0)")

    @classmethod
    def from_limits(cls, at_zero: float, at_infinity: float, slope_at_zero: float) -> AdaptiveGain:
        """The SoT parametrisation: λ(0), λ(∞) and ``-dλ/d‖e‖`` at 0.

        Example: ``AdaptiveGain.from_limits(at_zero=4.0, at_infinity=1.0, slope_at_zero=6.0)``
        converges fast near the goal (λ = 4/s) without a violent start far from it (λ → 1/s).
        """
        at_zero = finite("at_zero", at_zero)
        at_infinity = nonnegative("at_infinity", at_infinity, unit="1/s")
        slope_at_zero = nonnegative("slope_at_zero", slope_at_zero)
        a = at_zero - at_infinity
        if not (a > 0.0):
            raise ValueError(f"at_zero = {at_zero}: must exceed at_infinity = {at_infinity}")
        return cls(a=a, b=slope_at_zero / a, c=at_infinity)

    def __call__(self, error_norm: float) -> float:
        return self.a * math.exp(-self.b * error_norm) + self.c


Gain = float | AdaptiveGain


def validate_gain(gain: Gain, *, name: str) -> Gain:
    """Return ``gain`` if usable, else raise ValueError naming the task ``name``."""
    if isinstance(gain, AdaptiveGain):
        return gain
    try:
        return positive(f"task {name!r}: gain", gain, unit="1/s")
    except ValueError as error:
        raise ValueError(f"{error} (or an AdaptiveGain)") from None
