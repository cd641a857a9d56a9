"""Smooth priority and activation transitions alpha(t) (Liu, Lober, Padois 2016, eq. 12).

A change of the task hierarchy of the generalized projector is a change of
the priority parameters ``alpha_ij`` (:func:`drake_sot.generalized.generalized_projector`).
Done abruptly it jerks the torques; Liu, Lober and Padois move each parameter along the
raised-cosine profile of eq. 12,

    alpha_ij(t) = 0.5 - 0.5 cos(pi (t - t1) / (t2 - t1)),   t in [t1, t2],

whose slope is zero at both ends, and swaps two tasks by moving ``alpha_ij``
0 -> 1 and ``alpha_ji = 1 - alpha_ij`` 1 -> 0 together.  :func:`smooth_step`
is the profile; :class:`AlphaSchedule` keeps the (n, n) matrix alpha(t) of
named tasks and the transitions scheduled on any number of its entries (each an
:class:`AlphaTransition`); :class:`Priorities` is alpha at one instant with its
task names, the value that travels on ports: its consumers look the tasks up by
name, never by position.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drake_sot.errors import UnknownNameError
from drake_sot.validation import finite, nonnegative

__all__ = ["AlphaSchedule", "AlphaTransition", "Priorities", "smooth_step"]


def smooth_step(t: float | np.ndarray, t1: float, t2: float) -> float | np.ndarray:
    """Raised-cosine step of Liu, Lober, Padois 2016, eq. 12: 0 before ``t1``, 1 after ``t2``.

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
    t1 = finite("t1", t1)
    t2 = finite("t2", t2)
    if t2 < t1:
        raise ValueError(f"smooth_step needs t2 >= t1, got t1 = {t1}, t2 = {t2}")
    if np.ndim(t) == 0:
        s = finite("t", t)
        if s >= t2:
            return 1.0
        if s <= t1:
            return 0.0
        # Halved (exactly): the differences of times near ±1.8e308 do not overflow.
        return float(0.5 - 0.5 * np.cos(np.pi * ((0.5 * s - 0.5 * t1) / (0.5 * t2 - 0.5 * t1))))
    ts = np.asarray(t, dtype=float)
    if not np.isfinite(ts).all():
        raise ValueError("smooth_step: t contains NaN or Inf")
    if t2 == t1:
        return (ts >= t1).astype(float)
    # Halved (exactly) so that the differences of times near ±1.8e308 do not overflow. A span of
    # a few ulps can overflow the quotient to ±inf outside [t1, t2]; the clip maps that to the
    # right end, so the overflow is expected, not an error.
    with np.errstate(over="ignore"):
        u = np.clip((0.5 * ts - 0.5 * t1) / (0.5 * t2 - 0.5 * t1), 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * u)


def _task_names(task_names: Sequence[str]) -> list[str]:
    """``task_names`` as a list of distinct strings, or TypeError / ValueError naming the bad one."""
    names = list(task_names)
    for k, name in enumerate(names):
        if not isinstance(name, str):
            raise TypeError(f"task_names[{k}] = {name!r} is not a string")
    if len(set(names)) != len(names):
        duplicates = sorted({name for name in names if names.count(name) > 1})
        raise ValueError(f"task names must be distinct; repeated: {', '.join(map(repr, duplicates))}")
    return names


def _alpha_matrix(what: str, names: Sequence[str], alpha: np.ndarray) -> np.ndarray:
    """``alpha`` as an (n, n) float array with every value in [0, 1] (n = len(names)), or
    ValueError naming the first bad entry by position and task names."""
    n = len(names)
    a = np.array(alpha, dtype=float)
    if a.shape != (n, n):
        raise ValueError(f"{what} has shape {a.shape} but there are {n} tasks; expected ({n}, {n})")
    ok = (a >= 0.0) & (a <= 1.0)  # NaN fails both
    if not ok.all():
        i, j = (int(x) for x in np.argwhere(~ok)[0])
        raise ValueError(
            f"{what}[{i}, {j}] (alpha of {names[i]!r} w.r.t. {names[j]!r}) = {float(a[i, j])!r} "
            "must be finite and in [0, 1]"
        )
    return a


@dataclass(frozen=True, eq=False)
class Priorities:
    """The priority matrix alpha of named tasks at one instant (Liu, Lober, Padois 2016, eq. 4):
    what a ``priorities`` port carries (``PrioritySchedule`` → ``GeneralizedHierarchyController``).

    ``alpha[i, j]`` is the priority of task ``task_names[j]`` with respect to task
    ``task_names[i]`` (1: j strictly above i; 0: i not restricted by j; ``alpha[i, i] = 1``:
    i deactivated). A consumer never relies on the order: :meth:`in_order` gives alpha in
    its own task order and refuses names it does not know or misses.

    Attributes:
        task_names: the n distinct task names, in the order of alpha's rows and columns.
        alpha: (n, n) values in [0, 1]; stored as a read-only copy.

    Raises:
        TypeError: a name that is not a string.
        ValueError: duplicate names, alpha not (n, n), or a value outside [0, 1] or NaN.
    """

    task_names: tuple[str, ...]
    alpha: np.ndarray

    def __post_init__(self) -> None:
        names = tuple(_task_names(self.task_names))
        alpha = _alpha_matrix("alpha", names, self.alpha)
        alpha.flags.writeable = False
        object.__setattr__(self, "task_names", names)
        object.__setattr__(self, "alpha", alpha)

    def in_order(self, task_names: Sequence[str]) -> np.ndarray:
        """alpha with rows and columns in the order of ``task_names`` (a new (n, n) array).

        Raises:
            ValueError: ``task_names`` names a task this value does not hold, or omits one
                it holds; the message lists both sets of names.
        """
        wanted = tuple(task_names)
        if wanted == self.task_names:
            return self.alpha.copy()
        index = {name: k for k, name in enumerate(self.task_names)}
        known = set(wanted)
        if (
            len(known) != len(wanted)
            or any(name not in index for name in wanted)
            or len(index) != len(wanted)
        ):
            unknown = [name for name in self.task_names if name not in known]
            missing = [name for name in wanted if name not in index]
            problems = [f"priorities name unknown task(s) {unknown}"] if unknown else []
            problems += [f"no priority for task(s) {missing}"] if missing else []
            raise ValueError(
                f"{'; '.join(problems) or 'repeated task names'}; known tasks: {', '.join(wanted)} "
                f"(the priorities are over {', '.join(self.task_names)})"
            )
        order = np.array([index[name] for name in wanted])
        return self.alpha[np.ix_(order, order)]


@dataclass(frozen=True)
class AlphaTransition:
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

    ``alpha[i, j]`` is the priority of task j with respect to task i (Liu,
    Lober, Padois 2016, eq. 4): 1 when j is strictly above i, 0 when i is not restricted by
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
        names = _task_names(task_names)
        base = _alpha_matrix("initial", names, initial)
        self._names = names
        self._index = {name: k for k, name in enumerate(names)}
        self._base = base
        self._pairs: dict[tuple[int, int], list[AlphaTransition]] = {}
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
    def transitions(self) -> tuple[AlphaTransition, ...]:
        """All the scheduled transitions, by pair then start."""
        return tuple(tr for pair in sorted(self._pairs) for tr in self._pairs[pair])

    @property
    def end_time(self) -> float:
        """When the last scheduled transition ends (-inf if none): alpha is constant after it."""
        return max((tr.end for trs in self._pairs.values() for tr in trs), default=-np.inf)

    def index(self, task: str | int) -> int:
        """Row/column of ``task`` (a name or an index); an unknown name raises
        :class:`~drake_sot.errors.UnknownNameError` (a ValueError) listing the known ones."""
        if isinstance(task, str):
            try:
                return self._index[task]
            except KeyError:
                raise UnknownNameError("task", task, self._names) from None
        if isinstance(task, (int, np.integer)) and not isinstance(task, bool):
            k = int(task)
            if not 0 <= k < len(self._names):
                raise ValueError(
                    f"task index {k} out of range for {len(self._names)} tasks ({', '.join(self._names)})"
                )
            return k
        raise ValueError(f"a task is a name or an index, got {task!r}")

    # -- scheduling ----------------------------------------------------------------------------

    def set(
        self, i: str | int, j: str | int, value: float, *, start: float, duration: float
    ) -> AlphaTransition:
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
        value = finite("value", value)
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"alpha[{self._names[a]!r}, {self._names[b]!r}] = {value} must be in [0, 1]")
        start = finite("start", start)
        duration = nonnegative("duration", duration, unit="s")
        trs = self._pairs.get((a, b), [])
        if trs and start < trs[-1].start:
            raise ValueError(
                f"alpha[{self._names[a]!r}, {self._names[b]!r}] has a transition starting at "
                f"t = {trs[-1].start}; a new one starting at t = {start} would precede it "
                "(schedule the transitions of a pair in chronological order)"
            )
        tr = AlphaTransition(a, b, start, start + duration, self.alpha(start, a, b), value)
        self._pairs.setdefault((a, b), []).append(tr)
        self._arrays = None
        return tr

    def switch(
        self, i: str | int, j: str | int, *, start: float, duration: float
    ) -> tuple[AlphaTransition, AlphaTransition]:
        """Swap the priorities of tasks i and j: the priority switch of Liu, Lober, Padois 2016, eq. 12.

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
        start = finite("start", start)
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
        t = finite("t", t)
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

    def priorities(self, t: float) -> Priorities:
        """alpha at time ``t`` with the task names: the value of a ``priorities`` port."""
        return Priorities(self.task_names, self.at(t))

    def at(self, t: float) -> np.ndarray:
        """(n, n) alpha at time ``t``, all the scheduled pairs evaluated at once.

        Raises:
            ValueError: ``t`` not finite.
        """
        t = finite("t", t)
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
