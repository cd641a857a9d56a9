"""``RemoteCommandServer``: the command server's system in the diagram (the coshell of Mansard,
Stasse, Evrard, Kheddar 2009, III-C).

The network runs in a thread of its own (:class:`~drake_sot.remote.network.NetworkThread`),
which never touches a context: it only queues the requests it accepted. This system takes
them, in arrival order, in its own periodic event at the control tick, and applies in its
own state what a Drake system may change — its own outputs:

- **stack commands** (``SOT.push|rm|up|down TASK``, ``SOT.pop``, ``SOT.clear``, ``SOT`` being the
  solver's name given here; each may end with a transition time in seconds, ``SOT.push TASK 0.5``,
  over which the change is blended; read by :func:`drake_sot.script.stack_command`, the
  vocabulary's parser, into :data:`drake_sot.stack.StackCommand` values) go out as a batch
  on the ``commands`` output, which a
  :class:`~drake_sot.systems.sot.StackOfTasks` made with ``commands_input=True`` applies at
  the same tick (after its held stack; its ``command_results`` says, per command, if it acted);
- **writable signals** declared when the diagram is built (the explicit allowlist): with
  :meth:`declare_writable`, each a vector output port holding the last value written, and with
  :meth:`declare_desired_pose`, a 6D task's desired pose, whose position clients write as
  ``TASK.position_des`` (orientation kept), on an abstract output port wired into the feature's
  ``position_des`` input. Each written value is of the declared size, finite and within the
  declared bound, else refused: :meth:`Writable.check`, the one check of every remote write. It is
  written in this system's state at the tick that takes it, so every write of a batch acts at that
  tick. A *timed* write (``at``, see :mod:`~drake_sot.remote.protocol`) is applied at the first
  tick at or after its ``at`` instead, the newest by its sending time ``t`` winning (a
  :class:`~drake_sot.channel.Link`'s receiving end per signal); one that comes after the tick it
  was due at is refused, naming both times.

Each ``run`` line is parsed once, here (:func:`drake_sot.script.parse_script`): a line out of the
grammar is refused here, and the parsed statement goes with the request to whoever applies it.

A Drake event can change only its own system's context. Everything else a request asks —
reads, subscriptions, ``list``, script lines that set another system's parameter
(``task.controlGain``, ``pg.parsecmd``, ``set``) — is left, in order, in :meth:`taken` for the host
that owns the simulator and the root context (:class:`~drake_sot.app.serving.Serving`), which
answers or applies it after the tick. The host's changes act at the following tick; so that every
change acts in arrival order, the requests that come after one of them are held in the server's
state and taken at that tick. Reads are therefore the values at the last tick, evaluated by that
host on any output port of the diagram: declaring a readable input port per signal would copy every
signal at every tick for the few a client reads, and could not reach the signals nobody wired.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context, OutputPort
from pydrake.systems.framework import State as DrakeState

from drake_sot import validation
from drake_sot.channel import Link
from drake_sot.errors import unknown_name_message
from drake_sot.remote.protocol import Request
from drake_sot.script import COMMAND_SOURCE, Call, Get, ScriptError, Statement, parse_script, stack_command
from drake_sot.stack import StackError
from drake_sot.systems._context import own_context
from drake_sot.systems.features import check_desired_pose
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.systems.sot import StackCommands, TimedStackCommand

#: Times within this of a tick count as that tick [s] (sampled times are sums of floats).
_EPS = 1e-9

#: How a taken request is answered: applied by the server, sent to the solver, or for the host.
DONE, STACK, HOST = "done", "stack", "host"

#: The name of the signal holding a 6D task's desired position, ``TASK.position_des``.
DESIRED_POSITION = "position_des"

Inbox = Callable[[], list[tuple[int, Request | None]]]
"""Returns the queued ``(connection, request)`` pairs (None: the connection closed), in order."""


@dataclass(frozen=True)
class Writable:
    """A signal clients may write, the one type of them: its ``size``, ``units``, ``bound`` (the
        largest magnitude of each entry, in its units: a finite value can still be absurd, and one
        beyond what the signal can mean is refused before it reaches Drake) and ``radius`` (the largest
        Euclidean norm of the whole value, in its units — a position's distance from the origin of its
        frame — or None: no such bound) and ``reach`` (the largest Euclidean distance of the value from
    ``anchor``, in its units — a stance foot's target from where the foot stood — or None: no such
    bound). ``list`` shows them.

        Raises:
            ValueError: a size < 1, a bound not finite and > 0, a radius or a reach neither None nor
                finite and > 0, a reach without an anchor of ``size`` finite values (or one without
                the other).
    """

    size: int
    units: str
    bound: float
    radius: float | None = None
    reach: float | None = None
    anchor: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "size", validation.positive_int("Writable.size", self.size))
        object.__setattr__(self, "bound", validation.positive("Writable.bound", self.bound, unit=self.units))
        for name in ("radius", "reach"):
            if getattr(self, name) is not None:
                object.__setattr__(
                    self, name, validation.positive(f"Writable.{name}", getattr(self, name), unit=self.units)
                )
        if (self.reach is None) != (self.anchor is None):
            raise ValueError("Writable: a reach is measured from an anchor: give both or neither")
        if self.anchor is not None:
            anchor = validation.vector("Writable.anchor", self.anchor, self.size)
            object.__setattr__(self, "anchor", tuple(float(x) for x in anchor))

    def check(self, signal: str, value: Sequence[float]) -> str | None:
        """Why writing ``value`` to ``signal`` is refused — not ``size`` values, an entry not
        finite or beyond ``bound``, a norm beyond ``radius`` (each named) — or None."""
        if len(value) != self.size:
            return f"{signal}: {len(value)} values, expected {self.size}"
        for i, x in enumerate(value):
            if not math.isfinite(x):
                return f"{signal}: value[{i}] = {x!r}: not finite"
            if not (abs(x) <= self.bound):
                return f"{signal}: value[{i}] = {x!r}: beyond the bound |x| <= {self.bound:g} ({self.units})"
        if self.radius is not None:
            norm = math.hypot(*value)  # finite: every entry is within the bound
            if not (norm <= self.radius):
                return f"{signal}: |value| = {norm:g}: beyond the radius {self.radius:g} ({self.units})"
        if self.reach is not None:
            distance = math.dist(value, self.anchor)
            if not (distance <= self.reach):
                return (
                    f"{signal}: value = {_shown(value)}: {distance:g} from {_shown(self.anchor)}, beyond "
                    f"the reach {self.reach:g} ({self.units}) of that anchor"
                )
        return None


def _shown(value: Sequence[float]) -> str:
    """A short vector for a message: ``[0.01, 0.095, 1.5]``."""
    return "[" + ", ".join(f"{x:.4g}" for x in value) + "]"


#: What a client may write in a 6D task's desired pose: its position (m, world frame), each
#: coordinate within ±``REACH_BOUND`` and within ``WORKSPACE_RADIUS`` of the world origin, the
#: bounds of a feature's desired position (:func:`~drake_sot.systems.features.check_desired_pose`).
DESIRED_POSITION_WRITABLE = Writable(
    3, "m, world frame", validation.REACH_BOUND, radius=validation.WORKSPACE_RADIUS
)


@dataclass(frozen=True)
class _Slot:
    """Where a writable signal is held: a vector discrete state (``pose`` False), or an abstract
    state holding a ``RigidTransform`` whose translation is written (``pose`` True)."""

    writable: Writable
    index: int
    pose: bool = False


@dataclass(frozen=True)
class TakenRequest:
    """A request the server took at a tick, and how it is answered.

    ``kind``: :data:`DONE` (applied by the server: ``error`` is None, or says why it was refused),
    :data:`STACK` (the ``index``-th command of the tick's batch to the solver) or :data:`HOST`.
    ``statement``: a ``run`` line as parsed here (None: a blank or comment line, ``help``, or
    another op), for whoever applies it: the line is parsed once.
    """

    connection: int
    request: Request | None
    kind: str
    error: str | None = None
    index: int = -1
    statement: Statement | None = None


@dataclass(frozen=True)
class Taken:
    """The requests taken at the last tick that took any; ``serial`` counts those ticks."""

    serial: int = 0
    time: float = 0.0
    requests: tuple[TakenRequest, ...] = ()


class RemoteCommandServer(SotLeafSystem):
    """Takes the queued remote requests at each control tick and applies the stack commands
    and the writes of declared signals in its own state (see the module docstring).

    Input ports: none.
    Output ports:
        commands: abstract :class:`~drake_sot.systems.sot.StackCommands`, the batch of stack
            commands of the last tick that took some (plug into ``StackOfTasks.commands``).
        <writable>: one per :meth:`declare_writable`, a vector of its size in its units, the
            last value written (the initial value until then).
        <TASK>.position_des: one per :meth:`declare_desired_pose`, abstract ``RigidTransform``,
            the task's desired pose in world [m] (plug into the feature's ``position_des``).

    Args:
        period: the control period [s], finite and > 0.
        sot: the solver's name in script lines (``sot.push taskLH``).
        name: the system's name.
    """

    def __init__(self, period: float, *, sot: str = "sot", name: str = "remote") -> None:
        super().__init__()
        self.set_name(name)
        self.period = validation.positive(f"{name}: period", period, unit="s")
        self.sot_name = sot
        self._inbox: Inbox | None = None
        self._signals: dict[str, _Slot] = {}  # the allowlist: signal name -> where it is held
        self._taken = self.DeclareAbstractState(AbstractValue.Make(Taken()))
        self._commands = self.DeclareAbstractState(AbstractValue.Make(StackCommands()))
        self._held = self.DeclareAbstractState(AbstractValue.Make(()))  # taken at the next tick
        self._timed = self.DeclareAbstractState(AbstractValue.Make({}))  # signal -> Link (timed writes)
        self.DeclareStateOutputPort("commands", self._commands)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self.period, 0.0, self._tick)

    def declare_writable(
        self, name: str, size: int, units: str, initial: np.ndarray | None = None, *, bound: float
    ) -> OutputPort:
        """Allow clients to write ``<system>.<name>``: a vector output port of ``size`` [``units``]
        starting at ``initial`` (zeros by default), each entry of a written value within
        ``±bound`` [``units``] (see :class:`Writable`). Call before the diagram is built.

        Raises:
            ValueError: a name taken by another port, a size < 1, a bound not finite and > 0, an
                initial value of another size, not finite or beyond the bound.
        """
        signal = f"{self.get_name()}.{name}"
        if signal in self._signals or name == "commands":
            raise ValueError(f"{self.get_name()}: writable {name!r} is declared already")
        writable = Writable(validation.positive_int(f"writable {name!r}: size", size), units, bound)
        value = (
            np.zeros(writable.size)
            if initial is None
            else validation.vector(f"writable {name!r}", initial, writable.size)
        )
        refused = writable.check(f"writable {name!r}: initial", value.tolist())
        if refused is not None:
            raise ValueError(refused)
        index = self.DeclareDiscreteState(value)
        self._signals[signal] = _Slot(writable, index)
        return self.DeclareStateOutputPort(name, index)

    def declare_desired_pose(
        self, task: str, initial: RigidTransform, *, reach: float | None = None
    ) -> OutputPort:
        """Hold the desired pose of the 6D task ``task`` (world frame), starting at ``initial``:
        clients write its position as ``<task>.position_des`` (:data:`DESIRED_POSITION_WRITABLE`,
        the orientation kept); the host sets the whole pose with :meth:`set_desired_pose`. Returns
        the abstract ``RigidTransform`` output port to wire into the feature's ``position_des``.
        ``reach`` [m]: a written position also stays within it of the initial one (a stance foot's
        target near where the foot stands); None: no such bound. Call before the diagram is built.

        Raises:
            ValueError: a task declared already; an initial pose not finite, or its position
                beyond ``WORKSPACE_RADIUS`` of the world origin; a reach not finite and > 0.
            TypeError: an initial value that is not a ``RigidTransform``.
        """
        signal = f"{task}.{DESIRED_POSITION}"
        if signal in self._signals:
            raise ValueError(f"{self.get_name()}: the desired pose of {task!r} is declared already")
        initial = check_desired_pose(signal, initial)
        writable = DESIRED_POSITION_WRITABLE
        if reach is not None:
            writable = dataclasses.replace(writable, reach=reach, anchor=tuple(initial.translation()))
        index = self.DeclareAbstractState(AbstractValue.Make(initial))
        self._signals[signal] = _Slot(writable, index, pose=True)
        return self.DeclareStateOutputPort(signal, index)

    def holds_desired_pose(self, task: str) -> bool:
        """True when the desired pose of ``task`` is held here (:meth:`declare_desired_pose`)."""
        return f"{task}.{DESIRED_POSITION}" in self._signals

    def set_desired_pose(self, context: Context, task: str, pose: RigidTransform) -> None:
        """Set the desired pose of ``task`` (own or root context), as a feature's ``set_desired``
        does: for the host's own commands (a scenario's timed target).

        Raises:
            KeyError: a task whose desired pose is not held here.
            TypeError, ValueError: a pose refused by
                :func:`~drake_sot.systems.features.check_desired_pose` (named).
        """
        signal = f"{task}.{DESIRED_POSITION}"
        slot = self._signals.get(signal)
        if slot is None or not slot.pose:
            held = [name for name, s in self._signals.items() if s.pose]
            raise KeyError(f"{signal}: not held by {self.get_name()!r} (held: {', '.join(held) or 'none'})")
        own_context(self, context).get_mutable_abstract_state(slot.index).set_value(
            check_desired_pose(signal, pose)
        )

    @property
    def writables(self) -> dict[str, Writable]:
        """The allowlist: signal name (``remote.gain``, ``taskRH.position_des``) → its size, units
        and bounds."""
        return {signal: slot.writable for signal, slot in self._signals.items()}

    def attach(self, inbox: Inbox | None) -> None:
        """Take the requests from ``inbox`` (e.g. ``NetworkThread.drain``) from the next tick on;
        None: take nothing (the diagram then runs as if the server were not there)."""
        self._inbox = inbox

    def taken(self, context: Context) -> Taken:
        """The requests taken at the last tick that took any (own or root context)."""
        return own_context(self, context).get_abstract_state(self._taken).get_value()

    def held(self, context: Context) -> tuple[tuple[int, Request | None], ...]:
        """The requests held for the next tick (they came after one the host applies)."""
        return own_context(self, context).get_abstract_state(self._held).get_value()

    def _tick(self, context: Context, state: DrakeState) -> None:
        held = context.get_abstract_state(self._held).get_value()
        requests = [*held, *(self._inbox() if self._inbox is not None else [])]
        timed = context.get_abstract_state(self._timed).get_value()
        if not requests and not timed:
            return
        t = context.get_time()
        commands: list[TimedStackCommand] = []
        taken = []
        timed = dict(timed)
        for connection, request in requests:
            taken.append(self._take(connection, request, t, commands, state, timed))
            if taken[-1].kind == HOST and _host_changes_context(taken[-1]):
                break  # the host applies it after this tick: the next ones wait for the next tick
        self._deliver(timed, t, state)
        if not requests:
            return
        rest = tuple(requests[len(taken) :])
        if rest or held:
            state.get_mutable_abstract_state(self._held).set_value(rest)
        previous = context.get_abstract_state(self._taken).get_value()
        state.get_mutable_abstract_state(self._taken).set_value(Taken(previous.serial + 1, t, tuple(taken)))
        if commands:
            batch = context.get_abstract_state(self._commands).get_value().batch + 1
            state.get_mutable_abstract_state(self._commands).set_value(StackCommands(batch, tuple(commands)))

    def _take(
        self,
        connection: int,
        request: Request | None,
        t: float,
        commands: list[TimedStackCommand],
        state: DrakeState,
        timed: dict[str, Link],
    ) -> TakenRequest:
        if request is None:
            return TakenRequest(connection, None, HOST)
        if request.op == "write":
            error = self._check(request.signal, request.value)
            if error is None and request.timed:
                error = self._schedule(request, t, state, timed)
            elif error is None:
                self._write(self._signals[request.signal], request.value, state)
            return TakenRequest(connection, request, DONE, error)
        if request.op != "run" or request.cmd.strip() == "help":
            return TakenRequest(connection, request, HOST)
        try:
            statements = parse_script(request.cmd, source=COMMAND_SOURCE)
        except ScriptError as error:
            return TakenRequest(connection, request, DONE, f"ScriptError: {error}")
        if len(statements) > 1:
            return TakenRequest(
                connection, request, DONE, f"one command at a time, got {len(statements)} lines"
            )
        statement = statements[0] if statements else None
        command = _stack_command(statement, self.sot_name, t)
        if isinstance(command, str):
            return TakenRequest(connection, request, DONE, command)
        if command is not None:
            commands.append(command)
            return TakenRequest(connection, request, STACK, index=len(commands) - 1, statement=statement)
        return TakenRequest(connection, request, HOST, statement=statement)

    def _schedule(self, request: Request, t: float, state: DrakeState, timed: dict[str, Link]) -> str | None:
        """Put a timed write in flight on its signal's receiving end; why it is refused, or None."""
        if request.at <= t - self.period + _EPS:  # due at a tick already simulated
            return (
                f"{request.signal}: a write due at t = {request.at:.6f} s (sent at "
                f"{request.sent_at:.6f} s) came at the tick of t = {t:.6f} s, after it"
            )
        link = timed.get(request.signal)
        if link is None:
            link = Link.start(None, self._value(self._signals[request.signal], state))
        timed[request.signal] = link.carry(request.sent_at, request.at, request.value)
        return None

    def _deliver(self, timed: dict[str, Link], t: float, state: DrakeState) -> None:
        """Apply the timed writes due by ``t`` (the newest of each signal by sending time)."""
        for signal, link in timed.items():
            delivered = link.receive(t)
            if delivered.sent_at != link.sent_at:
                self._write(self._signals[signal], delivered.value, state)
            timed[signal] = delivered
        state.get_mutable_abstract_state(self._timed).set_value(timed)

    @staticmethod
    def _value(slot: _Slot, state: DrakeState) -> np.ndarray:
        """The value ``slot`` holds in ``state`` (a pose's translation)."""
        if slot.pose:
            return state.get_abstract_state(slot.index).get_value().translation().copy()
        return state.get_discrete_state().get_vector(slot.index).get_value().copy()

    @staticmethod
    def _write(slot: _Slot, value: Sequence[float], state: DrakeState) -> None:
        """Hold ``value`` (checked) in ``slot`` (a pose: its translation, the orientation kept)."""
        if slot.pose:
            pose = state.get_mutable_abstract_state(slot.index)
            pose.set_value(RigidTransform(pose.get_value().rotation(), np.array(value)))
        else:
            state.get_mutable_discrete_state(slot.index).SetFromVector(np.array(value))

    def _check(self, signal: str, value: tuple[float, ...]) -> str | None:
        """Why a write of ``value`` to ``signal`` is refused, or None."""
        slot = self._signals.get(signal)
        if slot is None:
            return unknown_name_message("writable signal", signal, self._signals)
        return slot.writable.check(signal, value)


#: The commands that only read (an entity's ``list``, ``help``): the host answers them, after the
#: tick, and they change nothing; every other command of the solver is a stack command.
_QUERIES = ("list", "help")


def _host_changes_context(item: TakenRequest) -> bool:
    """True for a request the host applies to the context (a script line other than ``get``,
    ``list``, ``help``): what comes after it waits for the tick after."""
    if item.statement is None:
        return False
    command = item.statement.command
    return not (isinstance(command, Get) or isinstance(command, Call) and command.command in _QUERIES)


def _stack_command(statement: Statement | None, sot: str, t: float) -> TimedStackCommand | str | None:
    """The stack command of a script line ``SOT.VERB …`` for solver ``sot``, given at ``t``; the
    vocabulary's error message when it is not one (an unknown verb, wrong arguments); None when the
    line is something else (for the host)."""
    command = statement.command if statement is not None else None
    if not (isinstance(command, Call) and command.entity == sot and command.command not in _QUERIES):
        return None
    try:
        return TimedStackCommand(t, stack_command(command))
    except StackError as error:
        return f"{statement.text!r}: {error}"
