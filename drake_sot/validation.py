"""Argument checks, the one place for them (pure: numpy only).

Every check returns the value converted (a float, an int, a float array) or raises
ValueError naming the argument, the bad value and what was expected. Comparisons are
written so that NaN fails them — ``not (v > 0)``, never ``v <= 0`` — because every
comparison with NaN is False. Values are checked here, before they reach Drake: a
Drake assertion on a bad value raises ``SystemExit``, which ends the interpreter.

Conventions of the messages: ``"{name} = {value!r}: must be ..."`` (:func:`shown`: an integer
too long to quote is shown by its number of digits). An integer beyond float range (more than
308 digits) is refused like any other bad value: ValueError, never OverflowError.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

__all__ = [
    "bounded",
    "bounds",
    "finite",
    "magnitude",
    "matrix",
    "nonempty_string",
    "nonnegative",
    "per_axis",
    "positive",
    "positive_int",
    "position",
    "real_array",
    "shown",
    "vector",
    "within",
]

Sign = Literal["any", "nonnegative", "positive"]


def shown(value) -> str:
    """``repr(value)`` for a message; an integer of more than 128 bits (about 39 digits) as its
    sign and its number of digits: its ``repr`` is unreadable, and raises beyond 4300 digits."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        digits = int(value.bit_length() * math.log10(2)) + 1  # exact to within one digit
        return f"{'-' if value < 0 else ''}an integer of ~{digits} digits"
    return repr(value)


def _scalar(name: str, value) -> float:
    """``value`` as a float, or ValueError naming ``name`` (strings, arrays of size > 1, None, an
    integer beyond float range)."""
    if isinstance(value, bool | str | complex) or getattr(getattr(value, "dtype", None), "kind", "") == "c":
        raise ValueError(f"{name} = {shown(value)}: must be a number")
    try:
        return float(value)
    except OverflowError:
        raise ValueError(f"{name} = {shown(value)}: must be a number within float range (±1.8e308)") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {shown(value)}: must be a number") from None


def real_array(name: str, value) -> np.ndarray:
    """``value`` as a float array; ValueError naming ``name`` for an integer beyond float range or
    a complex entry (numpy would drop its imaginary part with a mere warning)."""
    try:
        a = np.asarray(value)
        if a.dtype.kind == "c":
            raise ValueError(f"{name}: complex entries (dtype {a.dtype}): must be real numbers")
        return np.asarray(a, dtype=float)
    except OverflowError:
        raise ValueError(f"{name}: an entry is an integer beyond float range (±1.8e308)") from None


def is_number(text: str) -> bool:
    """True when ``text`` reads as a float (``"1e3"``, ``"nan"``): a command-line value that is a
    number, so that a refusal can say why the number is refused rather than that it is not one."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def finite(name: str, value) -> float:
    """``value`` as a finite float (not NaN, not ±inf)."""
    v = _scalar(name, value)
    if not math.isfinite(v):
        raise ValueError(f"{name} = {shown(value)}: must be a finite number")
    return v


def positive(name: str, value, *, unit: str = "") -> float:
    """``value`` as a finite float > 0."""
    v = _scalar(name, value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} = {shown(value)}{_unit(unit)}: must be finite and > 0")
    return v


def nonnegative(name: str, value, *, unit: str = "") -> float:
    """``value`` as a finite float >= 0."""
    v = _scalar(name, value)
    if not (math.isfinite(v) and v >= 0.0):
        raise ValueError(f"{name} = {shown(value)}{_unit(unit)}: must be finite and >= 0")
    return v


def bounded(name: str, value, low: float, high: float, *, unit: str = "") -> float:
    """``value`` as a finite float in [``low``, ``high``]; the message names the bound."""
    v = _scalar(name, value)
    if not (low <= v <= high):
        raise ValueError(f"{name} = {shown(value)}{_unit(unit)}: must be in [{low:g}, {high:g}]{_unit(unit)}")
    return v


def positive_int(name: str, value, *, minimum: int = 1) -> int:
    """``value`` as an int >= ``minimum`` (a float with an integer value is accepted, a bool is not)."""
    if isinstance(value, bool):
        raise ValueError(f"{name} = {shown(value)}: must be an integer >= {minimum}")
    try:
        v = int(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} = {shown(value)}: must be an integer >= {minimum}") from None
    if v != value or not (v >= minimum):
        raise ValueError(f"{name} = {shown(value)}: must be an integer >= {minimum}")
    return v


def vector(name: str, value, size: int | None = None) -> np.ndarray:
    """``value`` as a finite 1-D float array, of length ``size`` when given."""
    a = real_array(name, value)
    if a.ndim != 1 or (size is not None and a.shape[0] != size):
        raise ValueError(f"{name} must have shape {_shape((size,))}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} = {a}: contains NaN or Inf (entry {_first_bad(a)})")
    return a


def matrix(name: str, value, shape: Sequence[int | None] | None = None) -> np.ndarray:
    """``value`` as a finite 2-D float array; ``shape`` may fix either dimension (None: any)."""
    a = real_array(name, value)
    want = tuple(shape) if shape is not None else (None, None)
    if a.ndim != 2 or any(w is not None and w != s for w, s in zip(want, a.shape, strict=False)):
        raise ValueError(f"{name} must be a matrix of shape {_shape(want)}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} of shape {a.shape} contains NaN or Inf (entry {_first_bad(a)})")
    return a


def per_axis(name: str, value, n: int, *, sign: Sign = "any", allow_inf: bool = False) -> np.ndarray:
    """A per-axis parameter as a float array (n,).

    Accepted: a scalar (the same on every axis), ``n`` values, or — when ``n == 6``, a
    spatial quantity ordered [3 translation, 3 rotation] or [3 rotation, 3 translation]
    as the caller documents — a pair (first three axes, last three). ``sign`` asks every
    value to be > 0 (``"positive"``) or >= 0 (``"nonnegative"``); ``allow_inf`` lets
    ``+inf`` through (e.g. "no saturation"); NaN never passes.
    """
    a = real_array(name, value).reshape(-1)
    if a.size == 1:
        a = np.full(n, a[0])
    elif a.size == 2 and n == 6:
        a = np.repeat(a, 3)
    elif a.size != n:
        pair = ", a pair (3 + 3 axes)" if n == 6 else ""
        raise ValueError(f"{name} must be a scalar{pair} or {n} values, got {a.size} values")
    ok = np.isfinite(a) | (allow_inf & (a == np.inf))
    if sign == "positive":
        ok &= a > 0.0
    elif sign == "nonnegative":
        ok &= a >= 0.0
    if not ok.all():
        what = {"any": "finite", "nonnegative": "finite and >= 0", "positive": "finite and > 0"}[sign]
        if allow_inf:
            what += " (or +inf)"
        raise ValueError(f"{name} = {a}: every value must be {what}; entry {int(np.argmin(ok))} is not")
    return a


def bounds(name: str, lower, upper, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` as float arrays (``size``,) with ``lower <= upper`` row by row.

    Infinite bounds are allowed on their own side (``lower = -inf``: no lower bound;
    ``upper = +inf``: no upper bound); NaN, ``lower = +inf`` and ``upper = -inf`` are
    not. The message names the row.
    """
    lo = real_array(f"{name}: lower", lower)
    hi = real_array(f"{name}: upper", upper)
    for side, a in (("lower", lo), ("upper", hi)):
        if a.shape != (size,):
            raise ValueError(f"{name}: {side} must have shape ({size},), got shape {a.shape}")
    ok = (lo < np.inf) & (hi > -np.inf) & (lo <= hi)  # NaN fails every comparison
    if not ok.all():
        row = int(np.argmin(ok))
        what = "NaN" if math.isnan(lo[row]) or math.isnan(hi[row]) else "lower > upper"
        if what != "NaN" and (lo[row] == np.inf or hi[row] == -np.inf):
            what = "an infinite bound on the wrong side"
        raise ValueError(
            f"{name}: row {row}: lower = {float(lo[row])!r}, upper = {float(hi[row])!r} ({what}): "
            "bounds must satisfy lower <= upper, -inf <= lower < inf, -inf < upper <= inf"
        )
    return lo, hi


#: How far from the origin of its frame a desired position may be [m]: a humanoid controlled by a
#: stack of tasks works within a few metres of where it stands (the longest scenario walks ~2 m);
#: a target farther than this is a typo or an attack, never a goal (its task would ask the robot
#: for q̇ = -λ e of that size).
WORKSPACE_RADIUS = 10.0

#: The largest coordinate of a target position a remote client may write [m, world frame]: a
#: humanoid's hand or foot target, in a scenario that walks a few metres from the origin, lies well
#: within 10 m; a target beyond is no target (1e300 m reached Drake and ended the run).
REACH_BOUND = 10.0


def position(
    name: str, value, *, size: int = 3, radius: float = WORKSPACE_RADIUS, origin: str = "the world origin"
) -> np.ndarray:
    """``value`` as a finite position (``size``,) [m] at most ``radius`` [m] from ``origin``
    (the message names the distance and the bound)."""
    a = vector(name, value, size)
    distance = math.hypot(*a)  # scaled: no overflow of the squares of 1e300 entries
    if not (distance <= radius):
        raise ValueError(
            f"{name} = {_values(a)} m: {distance:g} m from {origin}; must be within {radius:g} m of it"
        )
    return a


def magnitude(name: str, value, limit: float, size: int | None = None, *, unit: str = "") -> np.ndarray:
    """``value`` as a finite 1-D float array (of length ``size``) whose entries are all within
    ``±limit``; the message names the first entry beyond it."""
    a = vector(name, value, size)
    ok = np.abs(a) <= limit
    if not ok.all():
        k = int(np.argmin(ok))
        raise ValueError(
            f"{name} = {_values(a)}: entry [{k}] = {float(a[k]):g}{_unit(unit)}: every entry must be within "
            f"±{limit:g}{_unit(unit)}"
        )
    return a


def within(
    name: str, value, lower, upper, *, labels: Sequence[str] | None = None, unit: str = ""
) -> np.ndarray:
    """``value`` as a finite float array with ``lower[i] <= value[i] <= upper[i]`` (its length
    that of ``lower``); the message names the first entry out of its range, by ``labels[i]``
    when given."""
    lo, hi = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    a = vector(name, value, lo.size)
    ok = (lo <= a) & (a <= hi)
    if not ok.all():
        k = int(np.argmin(ok))
        label = labels[k] if labels is not None else f"entry [{k}]"
        raise ValueError(
            f"{name}: {label} = {float(a[k]):g}{_unit(unit)}: must be in "
            f"[{float(lo[k]):g}, {float(hi[k]):g}]{_unit(unit)}"
        )
    return a


def nonempty_string(name: str, value) -> str:
    """``value`` as a non-empty ``str`` (a task, state or port name; a bytes or None is refused)."""
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} = {shown(value)}: must be a non-empty string")
    return value


def _values(a: np.ndarray) -> str:
    """A short vector as ``[1000, 0, 0.8]`` (``%g`` per entry), for messages."""
    return "[" + ", ".join(f"{float(x):g}" for x in a) + "]"


def _unit(unit: str) -> str:
    return f" {unit}" if unit else ""


def _shape(shape: tuple) -> str:
    dims = ", ".join("n" if d is None else str(d) for d in shape)
    return f"({dims},)" if len(shape) == 1 else f"({dims})"


def _first_bad(a: np.ndarray) -> str:
    index = np.unravel_index(int(np.argmin(np.isfinite(a))), a.shape)
    return "".join(f"[{int(k)}]" for k in index)
