"""Smooth priority and activation transitions alpha(t) (paper 004, eq. 12).

A change of the task hierarchy of the generalized projector is a change of
the priority parameters ``alpha_ij`` (:func:`drake_sot.hierarchy.generalized_projector`).
Done abruptly it jerks the torques; paper 004 moves each parameter along the
raised-cosine profile of eq. 12,

    alpha_ij(t) = 0.5 - 0.5 cos(pi (t - t1) / (t2 - t1)),   t in [t1, t2],

whose slope is zero at both ends, and swaps two tasks by moving ``alpha_ij``
0 -> 1 and ``alpha_ji = 1 - alpha_ij`` 1 -> 0 together.  :func:`smooth_step`
is the profile; :class:`AlphaSchedule` keeps the (n, n) matrix alpha(t) of
named tasks and the transitions scheduled on any number of its entries.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["AlphaSchedule", "Transition", "smooth_step"]


def _finite(name: str, value: float) -> float:
    """Return ``value`` as a float or raise ValueError if it is not a finite number."""
    v = float(value)
    if not np.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v


def smooth_step(t: float | np.ndarray, t1: float, t2: float) -> float | np.ndarray:
    """Raised-cosine step of paper 004, eq. 12: 0 before ``t1``, 1 after ``t2``.

    ``0.5 - 0.5 cos(pi (t - t1) / (t2 - t1))`` on [t1, t2]: continuous with a
    continuous first derivative (zero at ``t1`` and ``t2``; the largest slope,
    ``pi / (2 (t2 - t1))``, is at mid-time).

    ``t2 == t1`` is allowed and means an instantaneous switch: 0 for
    ``t < t1`` and 1 for ``t >= t1``.

    Args:
        t: time(s) [s], a scalar or an array of any shape, finite.
        t1, t2: start and end of the transition [s], finite, ``t2 >= t1``.

    Returns:
        A float for a scalar ``t``, else an array of the shape of ``t``, in [0, 1].

    Raises:
        ValueError: ``t2 < t1``, or a non-finite ``t``, ``t1`` or ``t2``.
    """
    t1 = _finite("t1", t1)
    t2 = _finite("t2", t2)
    if t2 < t1:
        raise ValueError(f"smooth_step needs t2 >= t1, got t1 = {t1}, t2 = {t2}")
    if np.ndim(t) == 0:
        s = _finite("t", t)
        if s >= t2:
            return 1.0
        if s <= t1:
            return 0.0
        return float(0.5 - 0.5 * np.cos(np.pi * (s - t1) / (t2 - t1)))
    ts = np.asarray(t, dtype=float)
    if not np.isfinite(ts).all():
        raise ValueError("smooth_step: t contains NaN or Inf")
    if t2 == t1:
        return (ts >= t1).astype(float)
    u = np.clip((ts - t1) / (t2 - t1), 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * u)


@dataclass(frozen=True)
class Transition:
    """One scheduled move of ``alpha[i, j]`` from ``start_value`` to ``value`` over [start, end].

    ``start_value`` is the value the schedule had at ``start`` when the
    transition was added.  The transition governs ``alpha[i, j]`` from
    ``start`` until the next transition of the same pair starts (holding
    ``value`` after ``end``).
    """

    i: int
    j: int
    start: float
    end: float
    start_value: float
    value: float

    def at(self, t: float) -> float:
        """Value of the profile at time ``t`` (``start_value`` before ``start``, ``value`` after ``end``)."""
        return self.start_value + (self.value - self.start_value) * smooth_step(t, self.start, self.end)


class AlphaSchedule:
    """The (n, n) priority matrix alpha(t) of named tasks and its scheduled transitions.

    ``alpha[i, j]`` is the priority of task j with respect to task i (paper
    004, eq. 4): 1 when j is strictly above i, 0 when i is not restricted by
    j; the diagonal ``alpha[i, i]`` is the deactivation of task i (1 = off).

    Each entry starts at ``initial[i, j]`` and follows the transitions
    scheduled on it (:meth:`set`, :meth:`switch`), each along eq. 12's
    profile.  A transition starts from the value the schedule has at its
    start, so chained transitions are continuous; one that starts after the
    previous one has ended also keeps the derivative continuous (zero at the
    junction), one that starts during the previous one interrupts it (the
    value stays continuous, its slope does not).  Transitions of a pair must
    be scheduled in chronological order of their starts.

    Tasks are referred to by name or by index.

    Args:
        task_names: the n distinct task names, in the order of alpha's rows.
        initial: (n, n) alpha at the beginning, every value in [0, 1].

    Raises:
        TypeError: a name that is not a string.
        ValueError: duplicate names, ``initial`` not (n, n), or a value
            outside [0, 1] or not finite (with its position).
    """

    def __init__(self, task_names: Sequence[str], initial: np.ndarray) -> None:
        names = list(task_names)
        for k, name in enumerate(names):
            if not isinstance(name, str):
                raise TypeError(f"task_names[{k}] = {name!r} is not a string")
        duplicates = sorted({name for name in names if names.count(name) > 1})
        if duplicates:
            raise ValueError(f"task names must be distinct; repeated: {', '.join(map(repr, duplicates))}")
        n = len(names)
        base = np.array(initial, dtype=float)
        if base.shape != (n, n):
            raise ValueError(f"initial has shape {base.shape} but there are {n} tasks; expected ({n}, {n})")
        bad = np.argwhere(~((base >= 0.0) & (base <= 1.0)))
        if bad.size:
            i, j = (int(x) for x in bad[0])
            raise ValueError(
                f"initial[{i}, {j}] (alpha of {names[i]!r} w.r.t. {names[j]!r}) = {float(base[i, j])!r} "
                "must be finite and in [0, 1]"
            )
        self._names = names
        self._index = {name: k for k, name in enumerate(names)}
        self._base = base
        self._pairs: dict[tuple[int, int], list[Transition]] = {}
        self._arrays: tuple[np.ndarray, ...] | None = None  # flat arrays of all transitions, built lazily

    # -- names -------------------------------------------------------------------------------

    @property
    def task_names(self) -> tuple[str, ...]:
        """The task names, in the order of alpha's rows and columns."""
        return tuple(self._names)

    @property
    def initial(self) -> np.ndarray:
        """(n, n) copy of alpha before any transition."""
        return self._base.copy()

    @property
    def transitions(self) -> tuple[Transition, ...]:
        """All the scheduled transitions, by pair then start."""
        return tuple(tr for pair in sorted(self._pairs) for tr in self._pairs[pair])

    @property
    def end_time(self) -> float:
        """When the last scheduled transition ends (-inf if none): alpha is constant after it."""
        return max((tr.end for trs in self._pairs.values() for tr in trs), default=-np.inf)

    def index(self, task: str | int) -> int:
        """Row/column of ``task`` (a name or an index), or raise ValueError listing the known names."""
        if isinstance(task, str):
            try:
                return self._index[task]
            except KeyError:
                raise ValueError(f"unknown task {task!r}; known tasks: {', '.join(self._names)}") from None
        if isinstance(task, (int, np.integer)) and not isinstance(task, bool):
            k = int(task)
            if not 0 <= k < len(self._names):
                raise ValueError(
                    f"task index {k} out of range for {len(self._names)} tasks ({', '.join(self._names)})"
                )
            return k
        raise ValueError(f"a task is a name or an index, got {task!r}")

    # -- scheduling ----------------------------------------------------------------------------

    def set(self, i: str | int, j: str | int, value: float, *, start: float, duration: float) -> Transition:
        """Move ``alpha[i, j]`` from its value at ``start`` to ``value`` over [start, start + duration].

        ``duration = 0`` switches at ``start`` (``value`` from ``start`` on).

        Returns:
            The scheduled transition.

        Raises:
            ValueError: unknown task, ``value`` outside [0, 1], non-finite
                ``start``, negative or non-finite ``duration``, or ``start``
                earlier than the start of a transition already scheduled on
                this pair (schedule in chronological order).
        """
        a, b = self.index(i), self.index(j)
        value = _finite("value", value)
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"alpha[{self._names[a]!r}, {self._names[b]!r}] = {value} must be in [0, 1]")
        start = _finite("start", start)
        duration = _finite("duration", duration)
        if duration < 0.0:
            raise ValueError(f"duration must be >= 0, got {duration}")
        trs = self._pairs.get((a, b), [])
        if trs and start < trs[-1].start:
            raise ValueError(
                f"alpha[{self._names[a]!r}, {self._names[b]!r}] has a transition starting at "
                f"t = {trs[-1].start}; a new one starting at t = {start} would precede it "
                "(schedule the transitions of a pair in chronological order)"
            )
        tr = Transition(a, b, start, start + duration, self.alpha(start, a, b), value)
        self._pairs.setdefault((a, b), []).append(tr)
        self._arrays = None
        return tr

    def switch(
        self, i: str | int, j: str | int, *, start: float, duration: float
    ) -> tuple[Transition, Transition]:
        """Swap the priorities of tasks i and j: paper 004's priority switch, eq. 12.

        ``alpha[i, j]`` and ``alpha[j, i]`` exchange the values they have at
        ``start``: with (0, 1) (j is not above i, i is strictly above j), i
        comes under j: ``alpha[i, j]`` 0 -> 1 and ``alpha[j, i]`` 1 -> 0 along
        the same profile, and switching again reverses it.  The sum
        ``alpha[i, j] + alpha[j, i]`` stays constant during the switch (1 in
        the strict case).

        Returns:
            The transitions of ``alpha[i, j]`` and ``alpha[j, i]``.

        Raises:
            ValueError: as :meth:`set`, ``i`` and ``j`` the same task, or the
                two values equal at ``start`` (the switch would change nothing).
        """
        a, b = self.index(i), self.index(j)
        if a == b:
            raise ValueError(f"switch needs two different tasks, got {self._names[a]!r} twice")
        start = _finite("start", start)
        ab, ba = self.alpha(start, a, b), self.alpha(start, b, a)
        if ab == ba:
            raise ValueError(
                f"switch({self._names[a]!r}, {self._names[b]!r}) at t = {start}: "
                f"alpha[i, j] = alpha[j, i] = {ab}, "
                "swapping them changes nothing; use set() to change them"
            )
        # validate the second pair's ordering before scheduling the first one
        for p, q in ((a, b), (b, a)):
            trs = self._pairs.get((p, q), [])
            if trs and start < trs[-1].start:
                raise ValueError(
                    f"alpha[{self._names[p]!r}, {self._names[q]!r}] has a transition starting at "
                    f"t = {trs[-1].start}; a switch starting at t = {start} would precede it"
                )
        return (
            self.set(a, b, ba, start=start, duration=duration),
            self.set(b, a, ab, start=start, duration=duration),
        )

    # -- evaluation ----------------------------------------------------------------------------

    def alpha(self, t: float, i: str | int, j: str | int) -> float:
        """``alpha[i, j]`` at time ``t`` (scalar evaluation of the pair's own transitions)."""
        a, b = self.index(i), self.index(j)
        t = _finite("t", t)
        value = float(self._base[a, b])
        for tr in self._pairs.get((a, b), ()):
            if tr.start > t:
                break
            value = tr.at(t)  # the last transition started by t governs
        return value

    def _flat(self) -> tuple[np.ndarray, ...]:
        """Arrays over all transitions: flat index, start, end, start value, value, next start of the pair."""
        if self._arrays is None:
            n = len(self._names)
            rows = [
                (
                    a * n + b,
                    tr.start,
                    tr.end,
                    tr.start_value,
                    tr.value,
                    trs[k + 1].start if k + 1 < len(trs) else np.inf,
                )
                for (a, b), trs in self._pairs.items()
                for k, tr in enumerate(trs)
            ]
            cols = list(zip(*rows, strict=False)) if rows else [()] * 6
            self._arrays = (np.array(cols[0], dtype=int),) + tuple(np.array(c, dtype=float) for c in cols[1:])
        return self._arrays

    def at(self, t: float) -> np.ndarray:
        """(n, n) alpha at time ``t``, all the scheduled pairs evaluated at once.

        Raises:
            ValueError: ``t`` not finite.
        """
        t = _finite("t", t)
        out = self._base.copy()
        if not self._pairs:
            return out
        flat, t1, t2, v0, v1, next_start = self._flat()
        live = (t1 <= t) & (t < next_start)  # at most one transition per pair governs at t
        if live.any():
            t1, t2, v0, v1 = t1[live], t2[live], v0[live], v1[live]
            span = t2 - t1
            u = np.divide(t - t1, span, out=np.ones_like(span), where=span > 0.0)
            s = 0.5 - 0.5 * np.cos(np.pi * np.minimum(u, 1.0))
            out.flat[flat[live]] = v0 + (v1 - v0) * s
        return out
