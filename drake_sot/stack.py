"""The hierarchy of tasks as one named value, and its algebra (pure: no Drake).

In the Stack of Tasks (Mansard, Stasse, Evrard, Kheddar 2009, III-B.6) the solver entity
holds an ordered list of the active tasks, highest priority first, changed at run time
by the commands ``push`` (add at the lowest priority), ``pop`` (remove the lowest),
``rm`` (remove a task wherever it is), ``up`` / ``down`` (swap a task with its neighbour
above / below) and ``clear``. This module is the one place where that algebra lives:
``StackOfTasks`` (commands on a context) and ``TaskSequencer`` (entry actions of a state
machine) both apply it through :class:`Stack`.

A :class:`Stack` is a value: it holds the names of every task the solver knows (the
*universe*, fixed when the diagram is built) and the ordered active tasks; every command
returns a new value and leaves the old one alone, so a value can be kept, compared,
hashed, logged or sent across a port without copies. A command that does not apply
(an unknown task, a task pushed twice, ``rm`` of a task that is not active, ``pop`` of
an empty stack) raises :class:`StackError` naming the task and listing the known tasks
or the current stack: nothing is silently ignored. Priorities are read by name
(:meth:`Stack.priority`), never by position in some other list.

The commands also exist as data (:class:`Push`, :class:`Pop`, :class:`Rm`, :class:`Up`,
:class:`Down`, :class:`Clear`, applied with :meth:`Stack.apply`), so that a state machine
or a script can hold them before they run.

Smooth changes. A command is instantaneous: the control law jumps from the solution of
one stack to the solution of the next. A stack can instead be *reached* from the one
before over a transition time T (:meth:`Stack.transition_from`): it then carries a
:class:`Transition` (the stack it comes from, the start time, T), and
:meth:`Stack.blend` says, at any time t, which stacks the control law combines and with
which weights — the stack left with ``1 - h(t)``, the stack reached with ``h(t)``, where
``h`` is the raised-cosine profile of Liu, Lober, Padois 2016, eq. 12
(:func:`drake_sot.transitions.smooth_step`). What the solver does with them is
``StackOfTasks``'s (the continuous inverse of Mansard, Remazeilles, Chaumette 2009); this
module only keeps the names and the times.

Example::

    s = Stack(("taskTwofeet", "taskCom", "taskRH", "taskPosture"))
    s = s.push("taskTwofeet").push("taskCom").push("taskPosture").push("taskRH").up("taskRH")
    s.active                  # ('taskTwofeet', 'taskCom', 'taskRH', 'taskPosture')
    s.priority("taskRH")      # 2 (0 is the highest)
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from drake_sot import validation
from drake_sot.transitions import smooth_step

__all__ = [
    "COMMANDS",
    "Clear",
    "Command",
    "Down",
    "Pop",
    "Push",
    "Rm",
    "Stack",
    "StackError",
    "Transition",
    "UnknownTaskError",
    "Up",
    "task_names",
]


class StackError(ValueError):
    """A hierarchy that is not valid, or a command that does not apply to the stack it meets.

    The message names the task and lists the known tasks (unknown name) or the current
    stack (a task already, or not, in it).
    """


class UnknownTaskError(StackError, KeyError):
    """A task name that is not one of the known tasks.

    Both a :class:`StackError` (a ValueError) and a KeyError, like the lookup of an
    unknown key; its message lists the known tasks.
    """

    def __str__(self) -> str:
        return BaseException.__str__(self)  # the message, not KeyError's quoted repr of it


def task_names(value: Iterable[str], *, what: str) -> tuple[str, ...]:
    """``value`` as a tuple of distinct, non-empty task names.

    Raises:
        StackError: naming ``what``, when ``value`` is a string (a common slip for a
            one-task tuple), is not iterable, holds something else than a non-empty
            ``str``, or lists a name twice.
    """
    if isinstance(value, str):
        raise StackError(f"{what} must be a sequence of task names, got the string {value!r}")
    try:
        names = tuple(value)
    except TypeError:
        raise StackError(f"{what} must be a sequence of task names, got {value!r}") from None
    bad = [n for n in names if not isinstance(n, str) or not n]
    if bad:
        raise StackError(
            f"{what} {names} holds {', '.join(map(repr, bad))}: a task name is a non-empty string"
        )
    twice = _twice(names)
    if twice:
        raise StackError(f"{what} {names} lists {', '.join(map(repr, twice))} twice")
    return names


def _tasks(names: list[str]) -> str:
    """``task 'a'`` or ``tasks 'a', 'b'``."""
    return f"task{'s' if len(names) > 1 else ''} {', '.join(map(repr, names))}"


def _twice(names: tuple[str, ...]) -> list[str]:
    """The names listed more than once, in order of first appearance."""
    seen: set[str] = set()
    twice: list[str] = []
    for n in names:
        if n in seen and n not in twice:
            twice.append(n)
        seen.add(n)
    return twice


# ---------------------------------------------------------------------------------------
# The commands as data
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Push:
    """Add ``task`` at the lowest priority (the SoT's ``sot.push``)."""

    task: str

    def __post_init__(self) -> None:
        validation.nonempty_string("Push.task", self.task)


@dataclass(frozen=True)
class Pop:
    """Remove the lowest-priority task (the SoT's ``sot.pop``)."""


@dataclass(frozen=True)
class Rm:
    """Remove ``task`` wherever it is in the stack (the SoT's ``sot.rm``)."""

    task: str

    def __post_init__(self) -> None:
        validation.nonempty_string("Rm.task", self.task)


@dataclass(frozen=True)
class Up:
    """Raise ``task`` by one priority level; no-op at the top (the SoT's ``sot.up``)."""

    task: str

    def __post_init__(self) -> None:
        validation.nonempty_string("Up.task", self.task)


@dataclass(frozen=True)
class Down:
    """Lower ``task`` by one priority level; no-op at the bottom (the SoT's ``sot.down``)."""

    task: str

    def __post_init__(self) -> None:
        validation.nonempty_string("Down.task", self.task)


@dataclass(frozen=True)
class Clear:
    """Empty the stack (the SoT's ``sot.clear``)."""


Command = Push | Pop | Rm | Up | Down | Clear
#: The command types, for ``isinstance`` checks.
COMMANDS = (Push, Pop, Rm, Up, Down, Clear)


# ---------------------------------------------------------------------------------------
# The value
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Transition:
    """A change of the stack in progress: the control law moves from the solution of
    ``origin`` to that of the stack holding this transition over
    ``[start, start + duration]``.

    Attributes:
        origin: the stack the change started from (it may itself be in a transition:
            changes that overlap in time nest).
        start: when the change started [s], finite.
        duration: how long it lasts [s], finite and > 0.

    Raises:
        ValueError: ``start`` not finite or ``duration`` not finite and > 0 (named).
        TypeError: ``origin`` is not a :class:`Stack`.
    """

    origin: Stack
    start: float
    duration: float

    def __post_init__(self) -> None:
        if not isinstance(self.origin, Stack):
            raise TypeError(f"Transition.origin must be a Stack, got {type(self.origin).__name__}")
        object.__setattr__(self, "start", validation.finite("Transition.start", self.start))
        object.__setattr__(
            self, "duration", validation.positive("Transition.duration", self.duration, unit="s")
        )

    def progress(self, t: float) -> float:
        """``h(t)`` in [0, 1]: 0 until ``start``, 1 from ``start + duration`` (eq. 12's profile)."""
        return smooth_step(t, self.start, self.start + self.duration)


@dataclass(frozen=True)
class Stack:
    """The hierarchy: the known tasks and the active ones in priority order.

    Attributes:
        tasks: every task name a command may use (e.g. ``StackOfTasks.task_names``),
            distinct, non-empty strings.
        active: the active tasks, highest priority first (index 0); distinct, each
            one of ``tasks``.
        transition: None for a stack in force, or the change in progress that leads to
            it from another stack of the same known tasks (see :meth:`transition_from`).
            The commands return stacks without one: a command is instantaneous.

    Iterating over a stack, ``len`` and ``in`` see the active tasks. Instances are
    immutable and hashable; two stacks are equal when both fields are.

    Raises:
        StackError: at construction, when ``tasks`` or ``active`` is not a tuple of
            distinct names; :class:`UnknownTaskError` when ``active`` names an unknown
            task (the message lists the culprits and the known tasks). A command raises
            UnknownTaskError for an unknown name and StackError when it does not apply.
    """

    tasks: tuple[str, ...]
    active: tuple[str, ...] = ()
    transition: Transition | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "tasks", task_names(self.tasks, what="tasks"))
        object.__setattr__(self, "active", self._checked_active(self.active))
        if self.transition is not None:
            if not isinstance(self.transition, Transition):
                raise StackError(f"transition must be a Transition or None, got {self.transition!r}")
            if self.transition.origin.tasks != self.tasks:
                raise StackError(
                    f"the transition comes from a stack of other known tasks "
                    f"({self.transition.origin._known()}); known tasks: {self._known()}"
                )

    # --- construction without re-validating what the algebra guarantees ---------------
    def _with(self, active: tuple[str, ...], transition: Transition | None = None) -> Stack:
        stack = object.__new__(Stack)
        object.__setattr__(stack, "tasks", self.tasks)
        object.__setattr__(stack, "active", active)
        object.__setattr__(stack, "transition", transition)
        return stack

    def _checked_active(self, value: Iterable[str]) -> tuple[str, ...]:
        if isinstance(value, str) or not isinstance(value, Iterable):
            raise StackError(f"the stack must be a sequence of task names, got {value!r}")
        active = tuple(value)
        if not all(isinstance(n, str) for n in active):
            raise StackError(f"the stack must be a sequence of task names, got {active!r}")
        unknown = [n for n in active if n not in self.tasks]
        twice = _twice(active)
        if unknown or twice:
            problems = []
            if unknown:
                problems.append(f"unknown {_tasks(unknown)}")
            if twice:
                problems.append(f"{_tasks(twice)} listed twice")
            error = UnknownTaskError if unknown else StackError
            raise error(f"the stack {active} has {' and '.join(problems)}; known tasks: {self._known()}")
        return active

    def with_active(self, active: Iterable[str]) -> Stack:
        """The same known tasks with ``active`` as the stack (validated: StackError as at construction).

        The receiver of a stack sent as a tuple of names (a ``stack`` input port)
        checks it with this.
        """
        return self._with(self._checked_active(active))

    def over(self, tasks: Iterable[str]) -> Stack:
        """The same stack, and the change in progress that leads to it, over the known ``tasks``
        (e.g. a solver's, for a stack made by a sequencer that knows fewer tasks): itself when
        they are its own. StackError (UnknownTaskError) when an active task of it or of a stack
        it comes from is not one of ``tasks``."""
        tasks = task_names(tasks, what="tasks")
        if tasks == self.tasks:
            return self
        base = Stack(tasks)
        transition = self.transition
        if transition is not None:
            transition = Transition(transition.origin.over(tasks), transition.start, transition.duration)
        return base._with(base._checked_active(self.active), transition)

    # --- the value ---------------------------------------------------------------------
    def __iter__(self) -> Iterator[str]:
        return iter(self.active)

    def __len__(self) -> int:
        return len(self.active)

    def __contains__(self, task: object) -> bool:
        return task in self.active

    def __copy__(self) -> Stack:
        return self

    def __deepcopy__(self, memo: dict) -> Stack:
        return self  # immutable: Drake copies abstract state at every update

    def _known(self) -> str:
        return ", ".join(self.tasks) or "(none)"

    def check_known(self, task: str) -> str:
        """``task`` if it is one of the known tasks, else UnknownTaskError listing them."""
        if task not in self.tasks:
            raise UnknownTaskError(f"unknown task {task!r}; known tasks: {self._known()}")
        return task

    def priority(self, task: str) -> int:
        """The priority level of an active task: 0 for the highest, ``len - 1`` for the lowest.

        Raises:
            UnknownTaskError: ``task`` is unknown (lists the known tasks).
            StackError: ``task`` is not active (shows the stack).
        """
        return self._position(task)

    def _position(self, task: str) -> int:
        if self.check_known(task) not in self.active:
            raise StackError(f"task {task!r} is not in the stack {self.active}")
        return self.active.index(task)

    # --- the commands (each returns a new value) ------------------------------------
    def push(self, task: str) -> Stack:
        """``task`` added at the lowest priority; StackError if unknown or already in the stack."""
        if self.check_known(task) in self.active:
            raise StackError(f"task {task!r} is already in the stack {self.active}")
        return self._with(self.active + (task,))

    def pop(self) -> Stack:
        """The lowest-priority task removed (it is ``self.active[-1]``); StackError if empty."""
        if not self.active:
            raise StackError("pop from an empty stack")
        return self._with(self.active[:-1])

    def rm(self, task: str) -> Stack:
        """``task`` removed wherever it is; StackError if unknown or not in the stack."""
        i = self._position(task)
        return self._with(self.active[:i] + self.active[i + 1 :])

    def up(self, task: str) -> Stack:
        """``task`` swapped with the task above it (unchanged at the top)."""
        i = self._position(task)
        if i == 0:
            return self
        a = self.active
        return self._with(a[: i - 1] + (a[i], a[i - 1]) + a[i + 1 :])

    def down(self, task: str) -> Stack:
        """``task`` swapped with the task below it (unchanged at the bottom)."""
        i = self._position(task)
        if i == len(self.active) - 1:
            return self
        a = self.active
        return self._with(a[:i] + (a[i + 1], a[i]) + a[i + 2 :])

    def clear(self) -> Stack:
        """No active task."""
        return self._with(())

    def apply(self, command: Command) -> Stack:
        """The stack after ``command`` (one of :data:`COMMANDS`); StackError as the method."""
        match command:
            case Push(task):
                return self.push(task)
            case Pop():
                return self.pop()
            case Rm(task):
                return self.rm(task)
            case Up(task):
                return self.up(task)
            case Down(task):
                return self.down(task)
            case Clear():
                return self.clear()
        raise TypeError(f"{command!r} is not a stack command ({', '.join(c.__name__ for c in COMMANDS)})")

    # --- smooth changes ------------------------------------------------------------------
    def transition_from(self, before: Stack, *, start: float, duration: float) -> Stack:
        """This stack, reached from ``before`` over ``[start, start + duration]``.

        ``duration = 0`` returns the stack as it is (an instantaneous change). Otherwise
        the result carries a :class:`Transition` from ``before`` as it stands at ``start``:
        its transitions finished by then are dropped, and one that has not progressed
        yet (it starts at ``start`` or later: e.g. ``push`` then ``up`` given at the same
        instant) is composed with this one, which then leads from that transition's
        origin. A change back to the stack it starts from (``up`` of the top task, a
        ``push`` then ``rm`` at the same instant) is no change: no transition.

        Raises:
            StackError: ``before`` has other known tasks.
            ValueError: ``start`` not finite, ``duration`` not finite or negative (named).
        """
        start = validation.finite("start", start)
        duration = validation.nonnegative("transition", duration, unit="s")
        if not isinstance(before, Stack) or before.tasks != self.tasks:
            known = before._known() if isinstance(before, Stack) else repr(before)
            raise StackError(f"cannot reach a stack of tasks {self._known()} from one of tasks {known}")
        if duration == 0.0:
            return self._with(self.active)
        origin = before.settled(start)
        if origin.transition is not None and origin.transition.progress(start) == 0.0:
            origin = origin.transition.origin
        if origin.transition is None and origin.active == self.active:
            return self._with(self.active)
        return self._with(self.active, Transition(origin, start, duration))

    def settled(self, t: float) -> Stack:
        """The same stack without the transitions (its own and nested ones) finished at time ``t``."""
        t = validation.finite("t", t)
        if self.transition is None:
            return self
        if self.transition.progress(t) >= 1.0:
            return self._with(self.active)
        origin = self.transition.origin.settled(t)
        if origin is self.transition.origin:
            return self
        return self._with(self.active, Transition(origin, self.transition.start, self.transition.duration))

    def blend(self, t: float) -> tuple[tuple[tuple[str, ...], float], ...]:
        """The stacks the control law combines at time ``t`` and their weights.

        ``((active, weight), ...)`` with positive weights summing to 1, the stack reached
        first, one entry per distinct ``active``. Without a transition (or once it is
        over): ``((self.active, 1.0),)``. During one, with ``h = transition.progress(t)``:
        ``self.active`` with ``h`` and the origin's own blend scaled by ``1 - h``.
        """
        t = validation.finite("t", t)
        weights: dict[tuple[str, ...], float] = {}
        self._blend_into(weights, t, 1.0)
        return tuple(weights.items())

    def _blend_into(self, weights: dict[tuple[str, ...], float], t: float, scale: float) -> None:
        h = 1.0 if self.transition is None else self.transition.progress(t)
        if h > 0.0:
            weights[self.active] = weights.get(self.active, 0.0) + scale * h
        if h < 1.0:
            self.transition.origin._blend_into(weights, t, scale * (1.0 - h))
