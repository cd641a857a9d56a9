"""Task gains λ: constant, or the original SoT's adaptive gain ``λ(e) = a·exp(-b‖e‖) + c``.

The range of a gain. The solver integrates the task law ``ė* = -λ e`` once per control period
``dt`` (the device integrates q̇ over the period), so the error of a task that the solver can
follow obeys explicit Euler's recursion

    e_{k+1} = (1 - λ dt) e_k,

which converges for ``0 < λ dt < 2``, without changing sign (no overshoot of the goal) for
``λ dt <= 1``, and reaches the goal in one period at ``λ dt = 1``. A gain with
``λ dt > MAX_GAIN_PERIOD = 1`` makes the robot overshoot every goal at every tick (and diverge
from ``λ dt = 2`` on): it is refused wherever the period is known (:func:`validate_gain` with
``period``; a ``Task`` learns it from the ``StackOfTasks`` it feeds). For an
:class:`AdaptiveGain` the bound is on its largest value, ``λ(0) = a + c``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from drake_sot.validation import finite, nonnegative, positive

#: The largest ``λ·dt`` a task gain may have at the control period ``dt``: beyond it, explicit
#: Euler's ``e_{k+1} = (1 - λ dt) e_k`` overshoots the goal at every tick (module docstring).
MAX_GAIN_PERIOD = 1.0


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

    @property
    def peak(self) -> float:
        """The largest value of λ, ``λ(0) = a + c`` [1/s] (λ decreases with ‖e‖)."""
        return self.a + self.c

    def __call__(self, error_norm: float) -> float:
        return self.a * math.exp(-self.b * error_norm) + self.c


Gain = float | AdaptiveGain


def validate_gain(gain: Gain, *, name: str, period: float | None = None) -> Gain:
    """Return ``gain`` if usable, else raise ValueError naming the task ``name``.

    A gain is a finite float > 0 [1/s] or an :class:`AdaptiveGain`; with ``period`` (the control
    period ``dt`` [s] at which the task's law is integrated), its largest value λ must also
    satisfy ``λ·dt <= MAX_GAIN_PERIOD`` (the message names the gain, the period and the product).
    """
    if not isinstance(gain, AdaptiveGain):
        try:
            gain = positive(f"task {name!r}: gain", gain, unit="1/s")
        except ValueError as error:
            raise ValueError(f"{error} (or an AdaptiveGain)") from None
    if period is not None:
        check_gain_period(gain, period, name=name)
    return gain


def check_gain_period(gain: Gain, period: float, *, name: str) -> None:
    """Raise ValueError naming the task ``name`` unless ``λ·period <= MAX_GAIN_PERIOD`` for the
    largest value λ of ``gain`` (a checked gain) at the control period ``period`` [s]."""
    period = positive(f"task {name!r}: control period", period, unit="s")
    peak = gain.peak if isinstance(gain, AdaptiveGain) else gain
    product = peak * period  # +inf when it overflows: refused below
    if not (product <= MAX_GAIN_PERIOD):
        which = "gain λ" if not isinstance(gain, AdaptiveGain) else "adaptive gain's λ(0)"
        raise ValueError(
            f"task {name!r}: {which} = {peak:g} 1/s at the control period {period:g} s: "
            f"λ·period = {product:g} must be <= {MAX_GAIN_PERIOD:g} (explicit Euler of ė = -λ e, "
            f"e_(k+1) = (1 - λ·period) e_k, overshoots the goal beyond 1 and diverges from 2); "
            f"at this period λ <= {MAX_GAIN_PERIOD / period:g} 1/s"
        )
