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
an empty stack, ``up`` of the top task, ``down`` of the bottom one) raises
:class:`StackError` naming the task and listing the known tasks or the current stack:
nothing is silently ignored. Priorities are read by name
(:meth:`Stack.priority`), never by position in some other list.

The commands also exist as data (:class:`Push`, :class:`Pop`, :class:`Rm`, :class:`Up`,
:class:`Down`, :class:`Clear`, each with its optional transition time, applied with
:meth:`Stack.apply`), so that a state machine or a script can hold them before they run.
:data:`VERBS` is the one vocabulary of their words (verb → type, number of task names,
transition time) and :func:`parse_command` the one parser: a script line, a remote line, a
state machine's entry and Python make the same command and meet the same errors.

Smooth changes. A command is instantaneous: the control law jumps from the solution of
one stack to the solution of the next. A stack can instead be *reached* from the one
before over a transition time T (:meth:`Stack.transition_from`): it then carries a
:class:`StackTransition` (the stack it comes from, the start time, T), and
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

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import ClassVar

from drake_sot import validation
from drake_sot.errors import DrakeSotError, UnknownNameError
from drake_sot.immutable import Immutable
from drake_sot.transitions import smooth_step

__all__ = [
    "COMMANDS",
    "MAX_TASK_NAME",
    "MAX_TRANSITION",
    "VERBS",
    "Clear",
    "StackCommand",
    "Down",
    "Pop",
    "Push",
    "Rm",
    "Stack",
    "StackError",
    "StackTransition",
    "UnknownTaskError",
    "Up",
    "StackVerb",
    "find_verb",
    "parse_command",
    "task_name",
    "task_names",
]


class StackError(DrakeSotError, ValueError):
    """A hierarchy that is not valid, or a command that does not apply to the stack it meets.

    The message names the task and lists the known tasks (unknown name) or the current
    stack (a task already, or not, in it).
    """


class UnknownTaskError(StackError, UnknownNameError):
    """A task name that is not one of the known tasks: a :class:`StackError` (a ValueError) and an
    :class:`~drake_sot.errors.UnknownNameError` of kind ``"task"`` (a KeyError) listing the known
    tasks."""

    def __init__(self, task: object, known: Iterable[str], *, where: str = "") -> None:
        UnknownNameError.__init__(self, "task", task, known, where=where)


#: The longest task name [characters]: a name is a word a person types (``taskRH``); it keys the
#: run's logs (``error/<task>`` in the npz, whose zip format holds a member name of at most
#: 65,535 bytes), so an absurd one is refused when the task is made rather than when the
#: artefacts of a finished run are written.
MAX_TASK_NAME = 128


def task_name(name: object) -> str:
    """``name`` as a task's name: a non-empty ``str`` of at most :data:`MAX_TASK_NAME` characters.

    Raises:
        StackError: naming the value (its first characters and its length when too long).
    """
    if not isinstance(name, str) or not name:
        raise StackError(f"task name = {validation.shown(name)[:80]}: must be a non-empty string")
    if len(name) > MAX_TASK_NAME:
        raise StackError(f"task name {name[:20]!r}... has {len(name)} characters: at most {MAX_TASK_NAME}")
    return name


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
# The commands as data, and their one vocabulary (verbs, parser)
# ---------------------------------------------------------------------------------------

#: The longest transition time of a stack command [s]. The paper's transitions last a fraction of
#: a second to a few seconds; a change blended over more than a minute is, for a controller that
#: runs at a few ms, a change that never happens (and 1e308 s one that never ends).
MAX_TRANSITION = 60.0


def _transition_time(what: str, value: object, *, positive: bool = False) -> float:
    """``value`` as a transition time [s] in [0, :data:`MAX_TRANSITION`] (> 0 if ``positive``), or
    StackError naming ``what``, the value and the bound (NaN, an infinity, a huge integer included)."""
    try:
        if positive:
            validation.positive(what, value, unit="s")
        return validation.bounded(what, value, 0.0, MAX_TRANSITION, unit="s")
    except ValueError as error:
        raise StackError(str(error)) from None


@dataclass(frozen=True, repr=False)
class _Command:
    """What every command holds: ``transition``, the time [s] over which the change is blended
    (0: at once; at most :data:`MAX_TRANSITION`). StackError at construction for a bad one."""

    #: The command's word in scripts and remote lines (the key of :data:`VERBS`).
    verb: ClassVar[str] = ""
    transition: float = field(default=0.0, kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "transition", _transition_time(f"{self.verb}: transition", self.transition))

    def __repr__(self) -> str:
        shown = [f"{f.name}={getattr(self, f.name)!r}" for f in fields(self) if f.name != "transition"]
        if self.transition:
            shown.append(f"transition={self.transition!r}")
        return f"{type(self).__name__}({', '.join(shown)})"

    def __str__(self) -> str:
        """The command as a script line's words (``push taskLH 0.5``)."""
        words = [self.verb, *(str(getattr(self, f.name)) for f in fields(self) if f.name != "transition")]
        return " ".join(words + ([f"{self.transition:g}"] if self.transition else []))


@dataclass(frozen=True, repr=False)
class _TaskCommand(_Command):
    """A command on one task: ``task``, a non-empty string (StackError otherwise)."""

    task: str

    def __post_init__(self) -> None:
        if not isinstance(self.task, str) or not self.task:
            raise StackError(f"{self.verb}: task = {validation.shown(self.task)}: must be a non-empty string")
        super().__post_init__()


@dataclass(frozen=True, repr=False)
class Push(_TaskCommand):
    """Add ``task`` at the lowest priority (the SoT's ``sot.push``)."""

    verb: ClassVar[str] = "push"


@dataclass(frozen=True, repr=False)
class Pop(_Command):
    """Remove the lowest-priority task (the SoT's ``sot.pop``)."""

    verb: ClassVar[str] = "pop"


@dataclass(frozen=True, repr=False)
class Rm(_TaskCommand):
    """Remove ``task`` wherever it is in the stack (the SoT's ``sot.rm``)."""

    verb: ClassVar[str] = "rm"


@dataclass(frozen=True, repr=False)
class Up(_TaskCommand):
    """Raise ``task`` by one priority level (the SoT's ``sot.up``); refused at the top."""

    verb: ClassVar[str] = "up"


@dataclass(frozen=True, repr=False)
class Down(_TaskCommand):
    """Lower ``task`` by one priority level (the SoT's ``sot.down``); refused at the bottom."""

    verb: ClassVar[str] = "down"


@dataclass(frozen=True, repr=False)
class Clear(_Command):
    """Empty the stack (the SoT's ``sot.clear``)."""

    verb: ClassVar[str] = "clear"


StackCommand = Push | Pop | Rm | Up | Down | Clear
#: The command types, for ``isinstance`` checks.
COMMANDS = (Push, Pop, Rm, Up, Down, Clear)


@dataclass(frozen=True)
class StackVerb:
    """One row of the vocabulary: a command's word, its type, what it takes, what it does.

    Attributes:
        command: the command type (its ``verb`` is the word).
        tasks: how many task names it takes (0 or 1).
        timed: whether an optional transition time [s] may follow its task names.
        doc: what it does, for help texts.
    """

    command: type[StackCommand]
    tasks: int
    timed: bool
    doc: str

    @property
    def name(self) -> str:
        """The word (``push``)."""
        return self.command.verb

    @property
    def usage(self) -> str:
        """The word and its arguments (``push TASK [SECONDS]``)."""
        return f"{self.name}{' TASK' * self.tasks}{' [SECONDS]' if self.timed else ''}"


#: THE stack-command vocabulary (Mansard, Stasse, Evrard, Kheddar 2009, III-B.6): word → its row.
#: Scripts, remote lines, state machines and Python all make their commands through it
#: (:func:`parse_command`) or through the command types, which check the same way.
VERBS: Mapping[str, StackVerb] = MappingProxyType(
    {
        verb.name: verb
        for verb in (
            StackVerb(Push, 1, True, "add TASK at the lowest priority (over SECONDS)"),
            StackVerb(Pop, 0, True, "remove the lowest-priority task; writes its name"),
            StackVerb(Rm, 1, True, "remove TASK wherever it is (over SECONDS)"),
            StackVerb(Up, 1, True, "raise TASK by one priority level (over SECONDS)"),
            StackVerb(Down, 1, True, "lower TASK by one priority level (over SECONDS)"),
            StackVerb(Clear, 0, True, "empty the stack (over SECONDS)"),
        )
    }
)


def find_verb(word: object) -> StackVerb:
    """The row of :data:`VERBS` for ``word``, or StackError listing the words."""
    found = VERBS.get(word) if isinstance(word, str) else None
    if found is None:
        raise StackError(f"{validation.shown(word)}: not a stack command ({', '.join(VERBS)})")
    return found


def parse_command(word: object, args: Sequence[object]) -> StackCommand:
    """The command ``word ARG…``: its task names (``str``), then, if the verb is timed, an optional
    transition time [s] (a number; none: 0, at once).

    The one parser of stack commands: a script line (``sot.push taskLH 0.5``), a remote line and a
    state machine's entry action give their words and values to it.

    Raises:
        StackError: an unknown ``word`` (listing the words), a wrong number of values (naming the
            usage), a task name that is not a non-empty string, a time that is not a number in
            [0, :data:`MAX_TRANSITION`] s (naming the value and the bound).
    """
    row = find_verb(word)
    args = tuple(args)
    extra_name = len(args) > row.tasks and isinstance(args[row.tasks], str)
    if not (row.tasks <= len(args) <= row.tasks + row.timed) or extra_name:
        time = " and an optional time" if row.timed else ""
        raise StackError(f"{row.usage}: takes {row.tasks} task name(s){time}, got {len(args)} value(s)")
    if len(args) > row.tasks:
        return row.command(*args[: row.tasks], transition=args[row.tasks])
    return row.command(*args)


# ---------------------------------------------------------------------------------------
# The value
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StackTransition:
    """A change of the stack in progress: the control law moves from the solution of
    ``origin`` to that of the stack holding this transition over
    ``[start, start + duration]``.

    Attributes:
        origin: the stack the change started from (it may itself be in a transition:
            changes that overlap in time nest).
        start: when the change started [s], finite.
        duration: how long it lasts [s], finite, > 0 and at most :data:`MAX_TRANSITION`.

    Raises:
        ValueError: ``start`` not finite (named); StackError (a ValueError): ``duration`` not
            finite, > 0 and at most :data:`MAX_TRANSITION` (named, with the bound).
        TypeError: ``origin`` is not a :class:`Stack`.
    """

    origin: Stack
    start: float
    duration: float

    def __post_init__(self) -> None:
        if not isinstance(self.origin, Stack):
            raise TypeError(f"StackTransition.origin must be a Stack, got {type(self.origin).__name__}")
        object.__setattr__(self, "start", validation.finite("StackTransition.start", self.start))
        duration = _transition_time("StackTransition.duration", self.duration, positive=True)
        object.__setattr__(self, "duration", duration)

    def progress(self, t: float) -> float:
        """``h(t)`` in [0, 1]: 0 until ``start``, 1 from ``start + duration`` (eq. 12's profile)."""
        return smooth_step(t, self.start, self.start + self.duration)


@dataclass(frozen=True)
class Stack(Immutable):
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
            task (the message names the first and lists the known tasks). A command raises
            UnknownTaskError for an unknown name and StackError when it does not apply.
    """

    tasks: tuple[str, ...]
    active: tuple[str, ...] = ()
    transition: StackTransition | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "tasks", task_names(self.tasks, what="tasks"))
        object.__setattr__(self, "active", self._checked_active(self.active))
        if self.transition is not None:
            if not isinstance(self.transition, StackTransition):
                raise StackError(f"transition must be a StackTransition or None, got {self.transition!r}")
            if self.transition.origin.tasks != self.tasks:
                raise StackError(
                    f"the transition comes from a stack of other known tasks "
                    f"({self.transition.origin._known()}); known tasks: {self._known()}"
                )

    # --- construction without re-validating what the algebra guarantees ---------------
    def _with(self, active: tuple[str, ...], transition: StackTransition | None = None) -> Stack:
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
        if unknown:
            raise UnknownTaskError(unknown[0], self.tasks, where=f"the stack {active}")
        if twice:
            raise StackError(f"the stack {active} has {_tasks(twice)} listed twice")
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
            transition = StackTransition(transition.origin.over(tasks), transition.start, transition.duration)
        return base._with(base._checked_active(self.active), transition)

    # --- the value ---------------------------------------------------------------------
    def __iter__(self) -> Iterator[str]:
        return iter(self.active)

    def __len__(self) -> int:
        return len(self.active)

    def __contains__(self, task: object) -> bool:
        return task in self.active

    def _known(self) -> str:
        return ", ".join(self.tasks) or "(none)"

    def check_known(self, task: str) -> str:
        """``task`` if it is one of the known tasks, else UnknownTaskError listing them."""
        if task not in self.tasks:
            raise UnknownTaskError(task, self.tasks)
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
        """``task`` swapped with the task above it; StackError if unknown, not in the stack or at
        its top (nothing would change: a command that does not apply is refused, not ignored)."""
        i = self._position(task)
        if i == 0:
            raise StackError(f"up {task}: already at the top of the stack ({', '.join(self.active)})")
        a = self.active
        return self._with(a[: i - 1] + (a[i], a[i - 1]) + a[i + 1 :])

    def down(self, task: str) -> Stack:
        """``task`` swapped with the task below it; StackError if unknown, not in the stack or at
        its bottom (nothing would change)."""
        i = self._position(task)
        if i == len(self.active) - 1:
            raise StackError(f"down {task}: already at the bottom of the stack ({', '.join(self.active)})")
        a = self.active
        return self._with(a[:i] + (a[i + 1], a[i]) + a[i + 2 :])

    def clear(self) -> Stack:
        """No active task."""
        return self._with(())

    def apply(self, command: StackCommand, *, at: float | None = None) -> Stack:
        """The stack after ``command`` (one of :data:`COMMANDS`): the one way a command acts.

        A command with a ``transition`` T > 0 gives the stack reached from this one over
        ``[at, at + T]`` (:meth:`transition_from`); ``at`` [s] is then required.

        Raises:
            UnknownTaskError: the command names an unknown task (lists the known tasks).
            StackError: it does not apply (a push of a task in the stack, an rm, up or down of
                one that is not, up of the top task, down of the bottom one, pop of an empty
                stack: the message shows the stack); a transition without ``at``.
            TypeError: ``command`` is not a stack command.
        """
        match command:
            case Push(task):
                after = self.push(task)
            case Pop():
                after = self.pop()
            case Rm(task):
                after = self.rm(task)
            case Up(task):
                after = self.up(task)
            case Down(task):
                after = self.down(task)
            case Clear():
                after = self.clear()
            case _:
                raise TypeError(
                    f"{command!r} is not a stack command ({', '.join(c.__name__ for c in COMMANDS)})"
                )
        if not command.transition:
            return after
        if at is None:
            raise StackError(f"{command}: a transition needs the time it starts at (at=)")
        return after.transition_from(self, start=at, duration=command.transition)

    # --- smooth changes ------------------------------------------------------------------
    def transition_from(self, before: Stack, *, start: float, duration: float) -> Stack:
        """This stack, reached from ``before`` over ``[start, start + duration]``.

        ``duration = 0`` returns the stack as it is (an instantaneous change). Otherwise
        the result carries a :class:`StackTransition` from ``before`` as it stands at ``start``:
        its transitions finished by then are dropped, and one that has not progressed
        yet (it starts at ``start`` or later: e.g. ``push`` then ``up`` given at the same
        instant) is composed with this one, which then leads from that transition's
        origin. A change back to the stack it starts from (a ``push`` then ``rm`` at the
        same instant) is no change: no transition.

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
        return self._with(self.active, StackTransition(origin, start, duration))

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
        return self._with(
            self.active, StackTransition(origin, self.transition.start, self.transition.duration)
        )

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
