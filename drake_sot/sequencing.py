"""The task-sequencing state machine as data (pure: no Drake).

Mansard, Stasse, Evrard, Kheddar 2009 (IV-B) drive the stack of tasks with a
*DecisionServer* that watches the robot while it walks ("tests every 1s ... if the
entity pg is still providing reference values. Once this is not the case, the server
removes the task taskLegs and pushes taskForce and taskForceLH"). Here such a server is
declared as data: :class:`State` values whose *entry actions* are the SoT's stack
commands (:class:`~drake_sot.stack.Push`, ``Pop``, ``Rm``, ``Up``, ``Down``, ``Clear``,
re-exported here from :mod:`drake_sot.stack`, which applies them) or a :class:`SetValue`
of an output (a task's reference or gain), and :class:`Transition` values guarded by
input signals (:class:`Flag`, :class:`Below`, :class:`Above`) or by time
(:class:`Timeout`).

:class:`StateMachine` checks a definition once (every name, every kind and size, and
optionally every path of the state graph) and then runs it without a Drake context:
:meth:`StateMachine.step` takes the current :class:`Status`, the time and a function
that reads a guard's input signal. The Drake system that runs it at a period is
:class:`drake_sot.systems.sequencer.TaskSequencer`::

    from drake_sot.sequencing import Below, Push, Rm, State, Transition
    from drake_sot.systems.sequencer import TaskSequencer

    server = builder.AddSystem(TaskSequencer(
        [
            State("walk", entry=(Push("taskLegs"),),
                  transitions=(Transition(Below("in_process", 0.5), "manipulate"),)),
            State("manipulate", entry=(Rm("taskLegs"), Push("taskForce"), Push("taskForceLH"))),
        ],
        initial="walk", tasks=sot.task_names, stack=("taskTwofeet", "taskCom"), period=1.0,
    ))
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from drake_sot import validation
from drake_sot.errors import UnknownNameError, prefixed
from drake_sot.immutable import Immutable
from drake_sot.stack import COMMANDS, Clear, Down, Pop, Push, Rm, Stack, StackCommand, StackError, Up

__all__ = [
    "ACTIONS",
    "GUARDS",
    "Above",
    "Action",
    "Below",
    "Clear",
    "Down",
    "Guard",
    "Pop",
    "Push",
    "Rm",
    "SetValue",
    "Flag",
    "State",
    "StateMachine",
    "Status",
    "Timeout",
    "Transition",
    "Up",
]

# ---------------------------------------------------------------------------------------
# Actions
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SetValue:
    """Set the sequencer's output ``output`` to ``value``.

    A number or a 1-D numeric sequence is a vector (the output is a vector port of
    that size, e.g. wired to a feature's vector desired value or to ``Task.gain``);
    anything else (a ``RigidTransform``, ...) is carried on an abstract port of that
    value's type. The output's initial value is given to ``StateMachine(values=...)``
    and fixes the output's kind and size; every ``SetValue`` to it must match.
    """

    output: str
    value: object

    def __post_init__(self) -> None:
        validation.nonempty_string("SetValue.output", self.output)


Action = StackCommand | SetValue
#: The action types, for ``isinstance`` checks: the stack commands and SetValue.
ACTIONS = (*COMMANDS, SetValue)


# ---------------------------------------------------------------------------------------
# Guards
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Flag:
    """Holds when the (1,) input ``port`` is > 0.5: a flag raised by a boolean signal (the
    script's guard ``signal PORT``)."""

    port: str

    def __post_init__(self) -> None:
        validation.nonempty_string("Flag.port", self.port)

    @property
    def size(self) -> int:
        return 1


@dataclass(frozen=True)
class Below:
    """Holds when the 2-norm of the (size,) input ``port`` is < ``threshold`` (> 0).

    E.g. a task's error has converged (``Below("error_com", 1e-3, size=3)``), or the
    pattern generator's ``in_process`` flag has dropped (``Below("in_process", 0.5)``).
    """

    port: str
    threshold: float
    size: int = 1

    def __post_init__(self) -> None:
        validation.nonempty_string("Below.port", self.port)
        object.__setattr__(self, "size", validation.positive_int(f"Below({self.port!r}).size", self.size))
        # A norm is >= 0: "below 0" would never hold.
        threshold = validation.positive(f"Below({self.port!r}).threshold", self.threshold)
        object.__setattr__(self, "threshold", threshold)


@dataclass(frozen=True)
class Above:
    """Holds when the 2-norm of the (size,) input ``port`` is > ``threshold`` (>= 0)."""

    port: str
    threshold: float
    size: int = 1

    def __post_init__(self) -> None:
        validation.nonempty_string("Above.port", self.port)
        object.__setattr__(self, "size", validation.positive_int(f"Above({self.port!r}).size", self.size))
        threshold = validation.nonnegative(f"Above({self.port!r}).threshold", self.threshold)
        object.__setattr__(self, "threshold", threshold)


@dataclass(frozen=True)
class Timeout:
    """Holds once ``seconds`` have passed since the current state was entered.

    It holds at the first check at or after that time (a 1 ns tolerance absorbs the
    rounding of periodic event times).
    """

    seconds: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "seconds", validation.nonnegative("Timeout.seconds", self.seconds, unit="s"))


Guard = Flag | Below | Above | Timeout
#: The guard types, for ``isinstance`` checks.
GUARDS = (Flag, Below, Above, Timeout)
_TIME_TOLERANCE = 1e-9  # [s]


# ---------------------------------------------------------------------------------------
# States
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Transition:
    """Go to state ``target`` when ``guard`` holds."""

    guard: Guard
    target: str

    def __post_init__(self) -> None:
        if not isinstance(self.guard, GUARDS):
            raise TypeError(
                f"Transition guard must be one of {', '.join(g.__name__ for g in GUARDS)}, got {self.guard!r}"
            )
        validation.nonempty_string("Transition.target", self.target)


@dataclass(frozen=True)
class State:
    """A state: its entry actions (run in order on entering it) and its transitions.

    The transitions are tested in order at each check; the first whose guard holds
    fires. A state without transitions is final. A single action or transition may be
    given without a tuple.

    ``transition_time`` [s] (finite, >= 0), when given, is the time over which the change of
    the stack made by entering this state is blended (:meth:`drake_sot.stack.Stack.transition_from`:
    q̇ moves continuously from the solution of the stack before to that of the stack after,
    Liu, Lober, Padois 2016, eq. 12's profile); None takes the machine's
    (:class:`StateMachine`'s ``transition_time``), 0 changes the stack at once.
    """

    name: str
    entry: tuple[Action, ...] = ()
    transitions: tuple[Transition, ...] = field(default=())
    transition_time: float | None = None

    def __post_init__(self) -> None:
        validation.nonempty_string("State.name", self.name)
        if self.transition_time is not None:
            object.__setattr__(
                self,
                "transition_time",
                validation.nonnegative(
                    f"state {self.name!r}: transition_time", self.transition_time, unit="s"
                ),
            )
        entry = (self.entry,) if isinstance(self.entry, ACTIONS) else tuple(self.entry)
        transitions = (
            (self.transitions,) if isinstance(self.transitions, Transition) else tuple(self.transitions)
        )
        for action in entry:
            if not isinstance(action, ACTIONS):
                raise TypeError(
                    f"state {self.name!r}: entry action {action!r} is not one of "
                    f"{', '.join(a.__name__ for a in ACTIONS)}"
                )
        for transition in transitions:
            if not isinstance(transition, Transition):
                raise TypeError(f"state {self.name!r}: {transition!r} is not a Transition")
        object.__setattr__(self, "entry", entry)
        object.__setattr__(self, "transitions", transitions)


# ---------------------------------------------------------------------------------------
# The running machine
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Status(Immutable):
    """Where a machine is: never mutated (a Drake state holding it is copied in O(1)).

    Attributes:
        state: the current state's name.
        entered: the time the current state was entered [s].
        stack: the hierarchy the machine outputs, with the change in progress that leads to it
            when the state was entered with a transition time (:class:`State`).
        values: output name → current value (read-only mapping).
        count: transitions fired so far.
    """

    state: str
    entered: float
    stack: Stack
    values: Mapping[str, object]
    count: int


def _is_vector(value: object) -> bool:
    """A number or a non-empty 1-D numeric sequence (not a bool)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float, np.integer, np.floating)):
        return True
    if isinstance(value, (list, tuple, np.ndarray)):
        try:
            array = np.asarray(value)
        except (ValueError, TypeError):
            return False
        return array.ndim == 1 and array.size >= 1 and array.dtype.kind in "iuf"
    return False


class StateMachine:
    """A validated sequencing machine over a stack of tasks and named output values.

    Semantics: :meth:`step` tests the transitions of the current state in their
    declared order and the first whose guard holds fires: at most one transition per
    step. Entering a state runs its entry actions in order on the stack and values
    (all or nothing: the status is a new value). The initial state's entry actions are
    applied to the initial ``stack`` and ``values`` at construction
    (:attr:`initial_status`); :meth:`start` returns that status entered at a given time.

    Args:
        states: the states (unique names).
        initial: name of the initial state.
        tasks: the task names stack commands may use (e.g. ``StackOfTasks.task_names``).
        stack: the initial stack, highest priority first, before the initial state's
            entry actions.
        values: the initial value of every ``SetValue`` output: a number or 1-D
            numeric sequence makes a vector output of that size, anything else an
            output of that type.
        transition_time: the time [s] over which entering a state blends the change of the
            stack it makes (finite, >= 0; 0: at once), for the states that do not give their
            own (:class:`State`'s ``transition_time``). The initial state's entry at the start
            is always at once.
        check_paths: also run the stack commands along every path of the state graph
            at construction, so that, e.g., an ``Rm`` of a task that is not in the
            stack when its state can be reached is refused then (the message gives the
            path). Guards are not evaluated: every transition is assumed possible. The
            search covers at most 10 000 (state, stack) pairs; beyond that (and with
            ``check_paths=False``) such a command raises a RuntimeError when it runs,
            naming the state, the action and the stack.
        name: the name used in messages (the sequencer system's).

    Raises:
        ValueError: for any inconsistent name or value, naming it and listing the known
            ones: an action naming an unknown task or with a transition time of its own (the
            state's ``transition_time`` blends its change), a transition to an unknown state,
            duplicate state names, an unknown initial state, an invalid initial stack,
            a ``SetValue`` to an output without an initial value (or of another
            kind/size/type, or non-finite), an initial value no ``SetValue`` sets, a
            guard port read with two sizes, a path on which a stack command fails.
        TypeError: ``states`` holds something else than :class:`State`.
    """

    _PATH_LIMIT = 10_000

    def __init__(
        self,
        states: Sequence[State],
        initial: str,
        *,
        tasks: Sequence[str],
        stack: Sequence[str] = (),
        values: Mapping[str, object] | None = None,
        check_paths: bool = True,
        transition_time: float = 0.0,
        name: str = "sequencer",
    ) -> None:
        self._name = name
        where = f"sequencer {name!r}"
        self._transition_time = validation.nonnegative(f"{where}: transition_time", transition_time, unit="s")
        try:
            empty = Stack(tasks)
        except StackError as error:
            raise prefixed(error, where) from None
        try:
            stack = empty.with_active(stack)
        except StackError as error:
            raise prefixed(error, f"{where}: initial stack") from None

        # --- states
        states = list(states)
        if not states:
            raise ValueError(f"{where} needs at least one state")
        self._states: dict[str, State] = {}
        for state in states:
            if not isinstance(state, State):
                raise TypeError(f"{where}: {state!r} is not a State")
            if state.name in self._states:
                raise ValueError(f"{where}: two states are named {state.name!r}")
            self._states[state.name] = state
        if initial not in self._states:
            raise UnknownNameError("state", initial, self._states, where=f"{where}: initial state")
        self._initial = initial

        # --- outputs set by SetValue: kinds and sizes from the initial values
        self._vector_sizes: dict[str, int] = {}
        initial_values: dict[str, object] = {}
        for key, value in (values or {}).items():
            validation.nonempty_string(f"{where}: a key of values", key)
            if _is_vector(value):
                initial_values[key] = self._checked_vector(key, value, None, "initial value")
                self._vector_sizes[key] = initial_values[key].size
            else:
                initial_values[key] = value
        set_outputs: set[str] = set()
        guard_sizes: dict[str, tuple[int, str]] = {}

        self._entries: dict[str, tuple[Action, ...]] = {}  # entry actions, SetValue values validated
        for state in states:
            at = f"{where}, state {state.name!r}"
            entry = []
            for action in state.entry:
                if isinstance(action, COMMANDS) and action.transition:
                    raise ValueError(
                        f"{at}: entry action {action!r} has its own transition time: entering a state "
                        f"blends its whole change over the state's transition_time"
                    )
                if isinstance(action, (Push, Rm, Up, Down)):
                    try:
                        stack.check_known(action.task)
                    except StackError as error:
                        raise prefixed(error, f"{at}: entry action {action!r}") from None
                if isinstance(action, SetValue):
                    action = self._checked_set_value(at, action, initial_values)
                    set_outputs.add(action.output)
                entry.append(action)
            self._entries[state.name] = tuple(entry)
            for transition in state.transitions:
                if transition.target not in self._states:
                    raise UnknownNameError(
                        "state", transition.target, self._states, where=f"{at}: transition"
                    )
                guard = transition.guard
                if isinstance(guard, Timeout):
                    continue
                previous = guard_sizes.setdefault(
                    guard.port, (guard.size, f"{guard!r} in state {state.name!r}")
                )
                if previous[0] != guard.size:
                    raise ValueError(
                        f"{at}: guard {guard!r} reads input port {guard.port!r} of size {guard.size}, "
                        f"but {previous[1]} reads it with size {previous[0]}"
                    )
        unused = [key for key in initial_values if key not in set_outputs]
        if unused:
            raise ValueError(
                f"{where}: values {', '.join(map(repr, unused))} are set by no SetValue action "
                f"(outputs set by SetValue: {', '.join(sorted(set_outputs)) or 'none'})"
            )
        self._guard_ports = {port: size for port, (size, _) in guard_sizes.items()}
        self._initial_values = MappingProxyType(initial_values)

        # --- the initial status, and the static check of every path
        try:
            entered_stack, entered_values = self._run_entry(initial, stack, self._initial_values)
        except StackError as error:
            raise prefixed(error, f"{where}, entering state {initial!r}") from None
        self._initial_status = Status(initial, 0.0, entered_stack, entered_values, 0)
        if check_paths:
            self._check_paths(self._initial_status)

    # --- the definition ------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The name used in messages."""
        return self._name

    @property
    def states(self) -> Mapping[str, State]:
        """Name → state, in declaration order (read-only)."""
        return MappingProxyType(self._states)

    @property
    def initial(self) -> str:
        """The initial state's name."""
        return self._initial

    @property
    def tasks(self) -> tuple[str, ...]:
        """The task names stack commands may use."""
        return self._initial_status.stack.tasks

    @property
    def guard_ports(self) -> dict[str, int]:
        """Name → size of every input read by a guard, in order of first appearance."""
        return dict(self._guard_ports)

    @property
    def initial_values(self) -> Mapping[str, object]:
        """Output name → initial value (vectors as read-only float arrays)."""
        return self._initial_values

    @property
    def vector_sizes(self) -> dict[str, int]:
        """Output name → size, for the outputs that are vectors (the others are objects)."""
        return dict(self._vector_sizes)

    @property
    def initial_status(self) -> Status:
        """The initial state entered at t = 0, its entry actions applied."""
        return self._initial_status

    # --- running -------------------------------------------------------------------------
    def start(self, time: float) -> Status:
        """The initial status, the initial state entered at ``time`` [s] (no transition counted)."""
        s = self._initial_status
        return s if s.entered == time else Status(s.state, time, s.stack, s.values, 0)

    def step(self, status: Status, time: float, read: Callable[[str], np.ndarray]) -> Status:
        """The status after one check at ``time`` [s]: ``status`` itself when no guard holds.

        ``read(port)`` returns the value of a guard's input (called only for the guards
        of the current state, in order, until one holds).

        Raises:
            RuntimeError: an input holds NaN or Inf, or an entry action of the state
                entered does not apply to the stack (naming the state, the action and
                the stack).
        """
        for transition in self._states[status.state].transitions:
            if self._holds(transition.guard, status, time, read):
                return self.enter(transition.target, status, time)
        return status

    def enter(self, state_name: str, status: Status, time: float) -> Status:
        """``state_name`` entered at ``time`` from ``status`` (one more transition counted).

        Raises:
            RuntimeError: an entry action does not apply (naming the state, the action
                and the stack).
        """
        try:
            stack, values = self._run_entry(state_name, status.stack, status.values)
        except StackError as error:
            raise RuntimeError(
                f"sequencer {self._name!r}, entering state {state_name!r}: {error} (t = {time:.4f} s)"
            ) from None
        stack = stack.transition_from(status.stack, start=time, duration=self.transition_time(state_name))
        return Status(state_name, time, stack, values, status.count + 1)

    def transition_time(self, state_name: str) -> float:
        """The time [s] over which entering ``state_name`` blends its change of the stack."""
        own = self._states[state_name].transition_time
        return self._transition_time if own is None else own

    def _run_entry(
        self, state_name: str, stack: Stack, values: Mapping[str, object]
    ) -> tuple[Stack, Mapping[str, object]]:
        """``state_name``'s entry actions applied to ``stack`` and a copy of ``values``.

        StackError naming the action (and, from the stack, the task and the stack it met).
        """
        new_values = None
        for action in self._entries[state_name]:
            if isinstance(action, SetValue):
                if new_values is None:
                    new_values = dict(values)
                new_values[action.output] = action.value
                continue
            try:
                stack = stack.apply(action)
            except StackError as error:
                raise StackError(f"entry action {action!r}: {error}") from None
        return stack, (values if new_values is None else MappingProxyType(new_values))

    def _holds(self, guard: Guard, status: Status, time: float, read: Callable[[str], np.ndarray]) -> bool:
        if isinstance(guard, Timeout):
            return time - status.entered >= guard.seconds - _TIME_TOLERANCE
        u = np.asarray(read(guard.port), dtype=float)
        if not np.all(np.isfinite(u)):
            raise RuntimeError(
                f"sequencer {self._name!r}, state {status.state!r}: input port {guard.port!r} holds "
                f"NaN or Inf at t = {time:.4f} s: {u}"
            )
        if isinstance(guard, Flag):
            return bool(u[0] > 0.5)
        norm = float(np.linalg.norm(u))
        return norm < guard.threshold if isinstance(guard, Below) else norm > guard.threshold

    # --- construction-time checks ----------------------------------------------------
    def _checked_vector(self, key: str, value: object, size: int | None, what: str) -> np.ndarray:
        """``value`` as a read-only float vector of ``size`` (None: any), finite."""
        array = np.array(value, dtype=float).reshape(-1)
        if size is not None and array.size != size:
            raise ValueError(
                f"sequencer {self._name!r}: {what} for output {key!r} has size {array.size}, "
                f"but its initial value has size {size}"
            )
        if not np.all(np.isfinite(array)):
            raise ValueError(f"sequencer {self._name!r}: {what} for output {key!r} holds NaN or Inf: {array}")
        array.setflags(write=False)
        return array

    def _checked_set_value(self, where: str, action: SetValue, initial_values: dict) -> SetValue:
        key = action.output
        if key not in initial_values:
            raise ValueError(
                f"{where}: {action!r} sets output {key!r}, which has no initial value; give one in "
                f"values= (outputs with one: {', '.join(initial_values) or 'none'})"
            )
        if key in self._vector_sizes:
            if not _is_vector(action.value):
                raise ValueError(f"{where}: {action!r}: output {key!r} is a vector, got {action.value!r}")
            # The validated, read-only vector, in a copy of the action (the user's is left alone).
            return SetValue(
                key, self._checked_vector(key, action.value, self._vector_sizes[key], f"{where}: SetValue")
            )
        if not isinstance(action.value, type(initial_values[key])):
            raise ValueError(
                f"{where}: {action!r}: output {key!r} carries {type(initial_values[key]).__name__}, "
                f"got {type(action.value).__name__}"
            )
        return action

    def _check_paths(self, start: Status) -> None:
        """Breadth-first over (state, stack): every stack command must apply on every path."""
        parents: dict[tuple[str, Stack], tuple[str, Stack] | None] = {(start.state, start.stack): None}
        queue = deque(parents)
        while queue and len(parents) < self._PATH_LIMIT:
            node = queue.popleft()
            for transition in self._states[node[0]].transitions:
                try:
                    stack, _ = self._run_entry(transition.target, node[1], self._initial_values)
                except StackError as error:
                    path = [transition.target]
                    at = node
                    while at is not None:
                        path.append(at[0])
                        at = parents[at]
                    raise prefixed(
                        error,
                        f"sequencer {self._name!r}: entering state {transition.target!r} by the path "
                        f"{' → '.join(reversed(path))} would fail (pass check_paths=False if that "
                        f"path cannot happen)",
                    ) from None
                child = (transition.target, stack)
                if child not in parents:
                    parents[child] = node
                    queue.append(child)
