"""``TaskSequencer``: a state machine that drives the stack of tasks (paper 000, IV-B).

The paper's *DecisionServer* watches the robot while it walks ("tests every 1s ... if
the entity pg is still providing reference values. Once this is not the case, the
server removes the task taskLegs and pushes taskForce and taskForceLH"). Here such a
server is declared as data: states whose *entry actions* are the paper's stack
commands (``push``, ``pop``, ``rm``, ``up``, ``down``, ``clear``, III-B.6) or set a
value on an output port (a task's reference or gain), and *transitions* guarded by
input signals or by time. The sequencer outputs the stack; plug it into
``StackOfTasks``'s ``stack`` input::

    from drake_sot.systems.sequencer import (
        Below, Push, Rm, State, TaskSequencer, Transition,
    )

    server = builder.AddSystem(TaskSequencer(
        [
            State("walk", entry=(Push("taskLegs"),),
                  transitions=(Transition(Below("in_process", 0.5), "manipulate"),)),
            State("manipulate", entry=(Rm("taskLegs"), Push("taskForce"), Push("taskForceLH"))),
        ],
        initial="walk", tasks=sot.task_names, stack=("taskTwofeet", "taskCom"), period=1.0,
    ))
    builder.Connect(pg.GetOutputPort("in_process"), server.GetInputPort("in_process"))
    builder.Connect(server.GetOutputPort("stack"), sot.GetInputPort("stack"))

Every name is checked when the sequencer is built: a stack command naming an unknown
task, a transition to an unknown state, a value set on an output that has no initial
value, ... are refused then, with the known names, not discovered during a run.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, InputPort, LeafSystem
from pydrake.systems.framework import State as DrakeState

from drake_sot.systems._context import own_context

# ---------------------------------------------------------------------------------------
# The declarative definition
# ---------------------------------------------------------------------------------------


def _check_name(value, what: str) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{what} must be a non-empty string, got {value!r}")
    return value


@dataclass(frozen=True)
class Push:
    """Add ``task`` at the lowest priority (the paper's ``sot.push``)."""

    task: str

    def __post_init__(self) -> None:
        _check_name(self.task, "Push.task")


@dataclass(frozen=True)
class Pop:
    """Remove the lowest-priority task (the paper's ``sot.pop``)."""


@dataclass(frozen=True)
class Rm:
    """Remove ``task`` wherever it is in the stack (the paper's ``sot.rm``)."""

    task: str

    def __post_init__(self) -> None:
        _check_name(self.task, "Rm.task")


@dataclass(frozen=True)
class Up:
    """Raise ``task`` by one priority level; no-op at the top (the paper's ``sot.up``)."""

    task: str

    def __post_init__(self) -> None:
        _check_name(self.task, "Up.task")


@dataclass(frozen=True)
class Down:
    """Lower ``task`` by one priority level; no-op at the bottom (the paper's ``sot.down``)."""

    task: str

    def __post_init__(self) -> None:
        _check_name(self.task, "Down.task")


@dataclass(frozen=True)
class Clear:
    """Empty the stack (the paper's ``sot.clear``)."""


@dataclass(frozen=True, eq=False)
class SetValue:
    """Set the sequencer's output port ``output`` to ``value``.

    A number or a 1-D numeric sequence is a vector (the output is a vector port of
    that size, e.g. wired to a feature's vector desired value or to ``Task.gain``);
    anything else (a ``RigidTransform``, ...) is carried on an abstract port of that
    value's type. The output's initial value is given to ``TaskSequencer(values=...)``
    and fixes the port's kind and size; every ``SetValue`` to it must match.
    """

    output: str
    value: object

    def __post_init__(self) -> None:
        _check_name(self.output, "SetValue.output")


Action = Push | Pop | Rm | Up | Down | Clear | SetValue
_ACTIONS = (Push, Pop, Rm, Up, Down, Clear, SetValue)


def _check_port_size(size, what: str) -> None:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ValueError(f"{what}: size {size!r} must be an integer >= 1")


@dataclass(frozen=True)
class Signal:
    """Holds when the (1,) input port ``port`` is > 0.5 (a boolean signal)."""

    port: str

    def __post_init__(self) -> None:
        _check_name(self.port, "Signal.port")

    @property
    def size(self) -> int:
        return 1


@dataclass(frozen=True)
class Below:
    """Holds when the 2-norm of the (size,) input port ``port`` is < ``threshold`` (> 0).

    E.g. a task's error has converged (``Below("error_com", 1e-3, size=3)``), or the
    pattern generator's ``in_process`` flag has dropped (``Below("in_process", 0.5)``).
    """

    port: str
    threshold: float
    size: int = 1

    def __post_init__(self) -> None:
        _check_name(self.port, "Below.port")
        _check_port_size(self.size, f"Below({self.port!r})")
        if not (math.isfinite(self.threshold) and self.threshold > 0.0):
            raise ValueError(
                f"Below({self.port!r}): threshold {self.threshold} must be finite and > 0 (a norm is >= 0)"
            )


@dataclass(frozen=True)
class Above:
    """Holds when the 2-norm of the (size,) input port ``port`` is > ``threshold`` (>= 0)."""

    port: str
    threshold: float
    size: int = 1

    def __post_init__(self) -> None:
        _check_name(self.port, "Above.port")
        _check_port_size(self.size, f"Above({self.port!r})")
        if not (math.isfinite(self.threshold) and self.threshold >= 0.0):
            raise ValueError(f"Above({self.port!r}): threshold {self.threshold} must be finite and >= 0")


@dataclass(frozen=True)
class Timeout:
    """Holds once ``seconds`` have passed since the current state was entered.

    It fires at the first check at or after that time (checks happen every
    ``period``; a 1 ns tolerance absorbs the rounding of event times).
    """

    seconds: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds >= 0.0):
            raise ValueError(f"Timeout: {self.seconds} s must be finite and >= 0")


Guard = Signal | Below | Above | Timeout
_GUARDS = (Signal, Below, Above, Timeout)
_TIME_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Transition:
    """Go to state ``target`` when ``guard`` holds."""

    guard: Guard
    target: str

    def __post_init__(self) -> None:
        if not isinstance(self.guard, _GUARDS):
            raise TypeError(
                f"Transition guard must be one of {', '.join(g.__name__ for g in _GUARDS)}, "
                f"got {self.guard!r}"
            )
        _check_name(self.target, "Transition.target")


@dataclass(frozen=True)
class State:
    """A state: its entry actions (run in order on entering it) and its transitions.

    The transitions are tested in order at each check; the first whose guard holds
    fires. A state without transitions is final.
    """

    name: str
    entry: tuple[Action, ...] = ()
    transitions: tuple[Transition, ...] = field(default=())

    def __post_init__(self) -> None:
        _check_name(self.name, "State.name")
        entry = (self.entry,) if isinstance(self.entry, _ACTIONS) else tuple(self.entry)
        transitions = (
            (self.transitions,) if isinstance(self.transitions, Transition) else tuple(self.transitions)
        )
        for action in entry:
            if not isinstance(action, _ACTIONS):
                raise TypeError(
                    f"state {self.name!r}: entry action {action!r} is not one of "
                    f"{', '.join(a.__name__ for a in _ACTIONS)}"
                )
        for transition in transitions:
            if not isinstance(transition, Transition):
                raise TypeError(f"state {self.name!r}: {transition!r} is not a Transition")
        object.__setattr__(self, "entry", entry)
        object.__setattr__(self, "transitions", transitions)


# ---------------------------------------------------------------------------------------
# Applying actions (shared by the construction-time check and the run)
# ---------------------------------------------------------------------------------------


class _ActionError(Exception):
    """A stack command that does not apply to the stack it meets."""


def _apply_stack(action: Action, stack: tuple[str, ...]) -> tuple[str, ...]:
    if isinstance(action, Push):
        if action.task in stack:
            raise _ActionError(f"task {action.task!r} is already in the stack")
        return stack + (action.task,)
    if isinstance(action, Pop):
        if not stack:
            raise _ActionError("pop from an empty stack")
        return stack[:-1]
    if isinstance(action, Clear):
        return ()
    if isinstance(action, (Rm, Up, Down)):
        if action.task not in stack:
            raise _ActionError(f"task {action.task!r} is not in the stack")
        i = stack.index(action.task)
        s = list(stack)
        if isinstance(action, Rm):
            del s[i]
        elif isinstance(action, Up) and i > 0:
            s[i - 1], s[i] = s[i], s[i - 1]
        elif isinstance(action, Down) and i < len(s) - 1:
            s[i], s[i + 1] = s[i + 1], s[i]
        return tuple(s)
    return stack  # SetValue


@dataclass(frozen=True)
class _Machine:
    """The sequencer's whole state, never mutated (Drake copies it at each update: O(1))."""

    state: str
    entered: float  # time the current state was entered [s]
    stack: tuple[str, ...]
    values: Mapping[str, object]  # read-only
    count: int  # transitions so far

    def __deepcopy__(self, memo) -> _Machine:
        return self


def _is_vector(value) -> bool:
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


def _frozen_vector(value) -> np.ndarray:
    array = np.array(value, dtype=float).reshape(-1)
    array.setflags(write=False)
    return array


# ---------------------------------------------------------------------------------------
# The system
# ---------------------------------------------------------------------------------------


class TaskSequencer(LeafSystem):
    """A state machine over stack commands and reference/gain values (the paper's DecisionServer).

    Semantics: a periodic check every ``period`` seconds (the paper's server checked
    every 1 s; 5 ms makes it react within a control tick). At each check the
    transitions of the current state are tested in their declared order and the first
    whose guard holds fires: at most one transition per check. Entering a state runs
    its entry actions in order, on a copy of the stack and values (all or nothing).
    The initial state's entry actions are applied to the initial ``stack`` and
    ``values`` when the sequencer is built (so a default context already holds them)
    and again, with the entry time set to the current time, by an initialization
    event: ``Simulator.Initialize`` (re)starts the machine in its initial state.

    The sequencer's unrestricted update runs before the discrete updates of the same
    instant (Drake's order), so a ``StackOfTasks`` ticking at the same times uses the
    new stack at the very tick the transition fires.

    Input ports:
        <guard port>: one per distinct port named by a ``Signal`` (size 1), ``Below``
            or ``Above`` (size ``size``) guard, in order of first appearance. Only the
            ports of the current state's guards are read; one that is then
            unconnected, or carries NaN/Inf, raises a RuntimeError naming it.
    Output ports:
        stack: abstract ``tuple[str, ...]``, the stack, highest priority first (plug
            into ``StackOfTasks``'s ``stack`` input).
        state: abstract ``str``, the current state's name.
        transitions: (1,) number of transitions fired so far (for logging).
        <value name>: one per key of ``values``, set by ``SetValue`` entry actions:
            a vector port of the initial value's size, or an abstract port of its type.

    Args:
        states: the states (unique names).
        initial: name of the initial state.
        tasks: the task names the ``StackOfTasks`` knows (e.g. ``sot.task_names``).
        stack: the initial stack, before the initial state's entry actions.
        period: time between checks [s].
        values: the initial value of every ``SetValue`` output.
        check_paths: also simulate the stack commands along every path of the
            state graph at construction, so that, e.g., an ``Rm`` of a task that is not
            in the stack when its state can be reached is refused then (the message
            gives the path). Guards are not evaluated: every transition is assumed
            possible. The search covers at most 10 000 (state, stack) pairs; beyond
            that (and with ``check_paths=False``) such a command raises a
            RuntimeError at run time, naming the state, the action and the stack.
        name: the system's name.

    Raises:
        ValueError: at construction, for any inconsistent name or value (with the known
            names): an action naming an unknown task, a transition to an unknown state,
            duplicate state names, an unknown initial state, a ``SetValue`` to an output
            without an initial value (or of another kind/size/type), a guard port used
            with two sizes, an output name clashing with ``stack``/``state``/``transitions``.
    """

    _RESERVED_OUTPUTS = ("stack", "state", "transitions")
    _PATH_LIMIT = 10_000

    def __init__(
        self,
        states: Sequence[State],
        initial: str,
        *,
        tasks: Sequence[str],
        stack: Sequence[str] = (),
        period: float = 0.005,
        values: Mapping[str, object] | None = None,
        check_paths: bool = True,
        name: str = "sequencer",
    ) -> None:
        super().__init__()
        self.set_name(name)
        values = dict(values or {})
        if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0.0):
            raise ValueError(f"sequencer {name!r}: period {period!r} must be finite and > 0")
        self._period = float(period)

        # --- tasks and the initial stack
        if isinstance(tasks, str) or not all(isinstance(t, str) for t in tasks):
            raise TypeError(f"sequencer {name!r}: tasks must be a sequence of task names, got {tasks!r}")
        self._tasks = tuple(tasks)
        if len(set(self._tasks)) != len(self._tasks):
            raise ValueError(f"sequencer {name!r}: tasks {self._tasks} holds a name twice")
        if isinstance(stack, str):
            raise TypeError(f"sequencer {name!r}: stack must be a sequence of task names, got {stack!r}")
        stack = tuple(stack)
        unknown = [t for t in stack if t not in self._tasks]
        if unknown:
            raise ValueError(
                f"sequencer {name!r}: initial stack {stack} names unknown task(s) "
                f"{', '.join(map(repr, unknown))}; known tasks: {self._known_tasks()}"
            )
        if len(set(stack)) != len(stack):
            raise ValueError(f"sequencer {name!r}: initial stack {stack} holds a task twice")

        # --- states
        states = list(states)
        if not states:
            raise ValueError(f"sequencer {name!r} needs at least one state")
        self._states: dict[str, State] = {}
        for state in states:
            if not isinstance(state, State):
                raise TypeError(f"sequencer {name!r}: {state!r} is not a State")
            if state.name in self._states:
                raise ValueError(f"sequencer {name!r}: two states are named {state.name!r}")
            self._states[state.name] = state
        known_states = ", ".join(self._states)
        if initial not in self._states:
            raise ValueError(
                f"sequencer {name!r}: initial state {initial!r} does not exist; states: {known_states}"
            )
        self._initial = initial

        # --- outputs set by SetValue: kinds and sizes from the initial values
        for key in values:
            _check_name(key, f"sequencer {name!r}: a key of values")
            if key in self._RESERVED_OUTPUTS:
                raise ValueError(
                    f"sequencer {name!r}: output {key!r} is reserved "
                    f"({', '.join(self._RESERVED_OUTPUTS)} are the sequencer's own outputs)"
                )
        self._vector_sizes: dict[str, int] = {}
        initial_values: dict[str, object] = {}
        for key, value in values.items():
            if _is_vector(value):
                initial_values[key] = self._checked_vector(key, value, None, "initial value")
                self._vector_sizes[key] = initial_values[key].size
            else:
                initial_values[key] = value
        set_outputs: set[str] = set()
        guard_sizes: dict[str, tuple[int, str]] = {}

        self._entries: dict[str, tuple[Action, ...]] = {}  # entry actions, SetValue values validated
        for state in states:
            where = f"sequencer {name!r}, state {state.name!r}"
            entry = []
            for action in state.entry:
                if isinstance(action, (Push, Rm, Up, Down)) and action.task not in self._tasks:
                    raise ValueError(
                        f"{where}: entry action {action!r} names unknown task {action.task!r}; "
                        f"known tasks: {self._known_tasks()}"
                    )
                if isinstance(action, SetValue):
                    action = self._check_set_value(where, action, initial_values)
                    set_outputs.add(action.output)
                entry.append(action)
            self._entries[state.name] = tuple(entry)
            for transition in state.transitions:
                if transition.target not in self._states:
                    raise ValueError(
                        f"{where}: transition to unknown state {transition.target!r}; states: {known_states}"
                    )
                guard = transition.guard
                if isinstance(guard, Timeout):
                    continue
                previous = guard_sizes.setdefault(
                    guard.port, (guard.size, f"{guard!r} in state {state.name!r}")
                )
                if previous[0] != guard.size:
                    raise ValueError(
                        f"{where}: guard {guard!r} reads input port {guard.port!r} of size {guard.size}, "
                        f"but {previous[1]} reads it with size {previous[0]}"
                    )
        unused = [key for key in initial_values if key not in set_outputs]
        if unused:
            raise ValueError(
                f"sequencer {name!r}: values {', '.join(map(repr, unused))} are set by no SetValue action "
                f"(outputs set by SetValue: {', '.join(sorted(set_outputs)) or 'none'})"
            )

        # --- the initial record, and the static check of every path
        start = self._enter(initial, stack, MappingProxyType(initial_values), 0.0, 0, static=True)
        if check_paths:
            self._check_paths(start)
        self._start = start

        # --- ports and state
        self._inputs: dict[str, InputPort] = {
            port: self.DeclareVectorInputPort(port, size) for port, (size, _) in guard_sizes.items()
        }
        self._machine = self.DeclareAbstractState(AbstractValue.Make(start))
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._tick)
        ticket = {self.abstract_state_ticket(self._machine)}
        self.DeclareAbstractOutputPort(
            "stack",
            lambda: AbstractValue.Make(()),
            lambda c, v: v.set_value(self._record(c).stack),
            prerequisites_of_calc=ticket,
        )
        self.DeclareAbstractOutputPort(
            "state",
            lambda: AbstractValue.Make(""),
            lambda c, v: v.set_value(self._record(c).state),
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort(
            "transitions",
            1,
            lambda c, out: out.SetAtIndex(0, float(self._record(c).count)),
            prerequisites_of_calc=ticket,
        )
        for key, value in initial_values.items():
            if key in self._vector_sizes:
                self.DeclareVectorOutputPort(
                    key,
                    self._vector_sizes[key],
                    lambda c, out, key=key: out.SetFromVector(self._record(c).values[key]),
                    prerequisites_of_calc=ticket,
                )
            else:
                self.DeclareAbstractOutputPort(
                    key,
                    lambda value=value: AbstractValue.Make(value),
                    lambda c, v, key=key: v.set_value(self._record(c).values[key]),
                    prerequisites_of_calc=ticket,
                )

    # --- construction-time checks ----------------------------------------------------
    def _known_tasks(self) -> str:
        return ", ".join(self._tasks) or "(none)"

    def _checked_vector(self, key: str, value, size: int | None, what: str) -> np.ndarray:
        array = _frozen_vector(value)
        if size is not None and array.size != size:
            raise ValueError(
                f"sequencer {self.get_name()!r}: {what} for output {key!r} has size {array.size}, "
                f"but its initial value has size {size}"
            )
        if not np.all(np.isfinite(array)):
            raise ValueError(
                f"sequencer {self.get_name()!r}: {what} for output {key!r} holds NaN or Inf: {array}"
            )
        return array

    def _check_set_value(self, where: str, action: SetValue, initial_values: dict) -> SetValue:
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
            # ValueError like every other inconsistency of the definition (see the class docstring).
            raise ValueError(
                f"{where}: {action!r}: output {key!r} carries {type(initial_values[key]).__name__}, "
                f"got {type(action.value).__name__}"
            )
        return action

    def _check_paths(self, start: _Machine) -> None:
        """Breadth-first over (state, stack): every stack command must apply on every path."""
        parents: dict[tuple[str, tuple[str, ...]], tuple[str, tuple[str, ...]] | None] = {
            (start.state, start.stack): None
        }
        queue = deque([(start.state, start.stack)])
        while queue and len(parents) < self._PATH_LIMIT:
            node = queue.popleft()
            for transition in self._states[node[0]].transitions:
                try:
                    stack = self._entry_stack(transition.target, node[1])
                except _ActionError as error:
                    path = [transition.target]
                    at = node
                    while at is not None:
                        path.append(at[0])
                        at = parents[at]
                    raise ValueError(
                        f"sequencer {self.get_name()!r}: entering state {transition.target!r} "
                        f"by the path {' → '.join(reversed(path))} would fail: {error} "
                        f"(pass check_paths=False if that path cannot happen)"
                    ) from None
                child = (transition.target, stack)
                if child not in parents:
                    parents[child] = node
                    queue.append(child)

    def _entry_stack(self, state_name: str, stack: tuple[str, ...]) -> tuple[str, ...]:
        """The stack after ``state_name``'s entry actions; _ActionError naming the action."""
        for action in self._entries[state_name]:
            try:
                stack = _apply_stack(action, stack)
            except _ActionError as error:
                raise _ActionError(f"{action!r}: {error} {stack}") from None
        return stack

    # --- the machine --------------------------------------------------------------------
    def _enter(
        self,
        state_name: str,
        stack: tuple[str, ...],
        values: Mapping[str, object],
        time: float,
        count: int,
        *,
        static: bool = False,
    ) -> _Machine:
        """Run ``state_name``'s entry actions on copies of ``stack`` and ``values``."""
        new_values = None
        for action in self._entries[state_name]:
            if isinstance(action, SetValue):
                if new_values is None:
                    new_values = dict(values)
                new_values[action.output] = action.value
                continue
            try:
                stack = _apply_stack(action, stack)
            except _ActionError as error:
                message = (
                    f"sequencer {self.get_name()!r}, entering state {state_name!r}: entry action {action!r} "
                    f"fails on the stack {stack}: {error}"
                )
                if static:
                    raise ValueError(message) from None
                raise RuntimeError(f"{message} (t = {time:.4f} s)") from None
        if new_values is not None:
            values = MappingProxyType(new_values)
        return _Machine(state=state_name, entered=time, stack=stack, values=values, count=count)

    def _record(self, context: Context) -> _Machine:
        return context.get_abstract_state(self._machine).get_value()

    def _initialize(self, context: Context, state: DrakeState) -> None:
        record = self._start
        if record.entered != context.get_time():
            record = _Machine(record.state, context.get_time(), record.stack, record.values, 0)
        state.get_mutable_abstract_state(self._machine).set_value(record)

    def _holds(self, guard: Guard, context: Context, record: _Machine) -> bool:
        if isinstance(guard, Timeout):
            return context.get_time() - record.entered >= guard.seconds - _TIME_TOLERANCE
        port = self._inputs[guard.port]
        if not port.HasValue(context):
            raise RuntimeError(
                f"sequencer {self.get_name()!r}, state {record.state!r}: guard {guard!r} reads input port "
                f"{guard.port!r}, which is not connected"
            )
        u = port.Eval(context)
        if not np.all(np.isfinite(u)):
            raise RuntimeError(
                f"sequencer {self.get_name()!r}, state {record.state!r}: input port {guard.port!r} holds "
                f"NaN or Inf at t = {context.get_time():.4f} s: {u}"
            )
        if isinstance(guard, Signal):
            return bool(u[0] > 0.5)
        norm = float(np.linalg.norm(u))
        return norm < guard.threshold if isinstance(guard, Below) else norm > guard.threshold

    def _tick(self, context: Context, state: DrakeState) -> None:
        record = self._record(context)
        for transition in self._states[record.state].transitions:
            if self._holds(transition.guard, context, record):
                state.get_mutable_abstract_state(self._machine).set_value(
                    self._enter(
                        transition.target, record.stack, record.values, context.get_time(), record.count + 1
                    )
                )
                return

    # --- introspection ------------------------------------------------------------------
    @property
    def period(self) -> float:
        """Time between checks [s]."""
        return self._period

    @property
    def state_names(self) -> tuple[str, ...]:
        """Every state, in declaration order."""
        return tuple(self._states)

    @property
    def task_names(self) -> tuple[str, ...]:
        """The task names the sequencer's stack commands may use."""
        return self._tasks

    @property
    def guard_ports(self) -> dict[str, int]:
        """Name → size of every guard input port."""
        return {name: port.size() for name, port in self._inputs.items()}

    def current_state(self, context: Context) -> str:
        """The current state's name (own or root context)."""
        return self._record(own_context(self, context)).state

    def stack(self, context: Context) -> tuple[str, ...]:
        """The stack the sequencer currently outputs (own or root context)."""
        return self._record(own_context(self, context)).stack
