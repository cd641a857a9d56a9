"""``TaskSequencer``: runs a :class:`drake_sot.sequencing.StateMachine` at a period and
drives the stack of tasks with it (the DecisionServer of Mansard, Stasse, Evrard,
Kheddar 2009, IV-B).

The machine itself — states, guards, actions, its validation and its transitions — is
pure data in :mod:`drake_sot.sequencing`; this system only reads the guard inputs from
the context, holds the machine's :class:`~drake_sot.sequencing.Status` in its state and
publishes the stack and the values on ports::

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
    builder.Connect(pg.GetOutputPort("in_process"), server.GetInputPort("in_process"))
    builder.Connect(server.GetOutputPort("stack"), sot.GetInputPort("stack"))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, InputPort
from pydrake.systems.framework import State as DrakeState

from drake_sot import validation
from drake_sot.sequencing import State, StateMachine, Status
from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem

#: The sequencer's own output ports (not valid names for a ``SetValue`` output).
RESERVED_OUTPUTS = ("stack", "smooth_stack", "state", "transitions")


class TaskSequencer(SotLeafSystem):
    """A state machine over stack commands and reference/gain values (the paper's DecisionServer).

    Semantics (those of :class:`~drake_sot.sequencing.StateMachine`): a periodic check
    every ``period`` seconds (the paper's server checked every 1 s; 5 ms makes it react
    within a control tick) fires at most one transition, the first of the current
    state's whose guard holds; entering a state runs its entry actions in order, all or
    nothing. A default context already holds the initial state entered at t = 0; an
    initialization event re-enters it at the current time, so ``Simulator.Initialize``
    (re)starts the machine in its initial state and a ``Timeout`` counts from there.

    The sequencer's unrestricted update runs before the discrete updates of the same
    instant (Drake's order), so a ``StackOfTasks`` ticking at the same times uses the
    new stack at the very tick the transition fires.

    Input ports:
        <guard port>: one per distinct port named by a ``Flag`` (size 1), ``Below``
            or ``Above`` (size ``size``) guard, in order of first appearance. Only the
            ports of the current state's guards are read; one that is then
            unconnected, or carries NaN/Inf, raises a RuntimeError naming it.
    Output ports:
        stack: abstract ``tuple[str, ...]``, the active task names, highest priority
            first (plug into ``StackOfTasks``'s ``stack`` input, which checks them).
        smooth_stack: abstract :class:`~drake_sot.stack.Stack`, the same stack with the change
            in progress that leads to it when the state was entered with a transition time
            (``transition_time``): plug it into ``StackOfTasks``'s ``stack`` input instead of
            ``stack`` and q̇ moves continuously over that time instead of jumping.
        state: abstract ``str``, the current state's name.
        transitions: (1,) number of transitions fired so far (for logging).
        <value name>: one per key of ``values``, set by ``SetValue`` entry actions:
            a vector port of the initial value's size, or an abstract port of its type.

    Args:
        states, initial, tasks, stack, values, check_paths: the machine, as
            :class:`~drake_sot.sequencing.StateMachine` takes them (``tasks``: e.g.
            ``sot.task_names``).
        period: time between checks [s], finite and > 0.
        transition_time: the time [s] over which entering a state blends its change of the
            stack on ``smooth_stack``, for states without their own ``State.transition_time``
            (finite, >= 0; 0: at once; :class:`~drake_sot.sequencing.StateMachine`).
        name: the system's name.

    Raises:
        ValueError: at construction, as ``StateMachine`` (with the known names), for a
            bad ``period``, and for a ``values`` key that is one of the sequencer's own
            outputs (``stack``, ``state``, ``transitions``).
    """

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
        transition_time: float = 0.0,
        name: str = "sequencer",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._period = validation.positive(f"sequencer {name!r}: period", period, unit="s")
        values = dict(values or {})
        reserved = [key for key in values if key in RESERVED_OUTPUTS]
        if reserved:
            raise ValueError(
                f"sequencer {name!r}: output {', '.join(map(repr, reserved))} is reserved "
                f"({', '.join(RESERVED_OUTPUTS)} are the sequencer's own outputs)"
            )
        self._machine = StateMachine(
            states,
            initial,
            tasks=tasks,
            stack=stack,
            values=values,
            check_paths=check_paths,
            transition_time=transition_time,
            name=name,
        )

        self._inputs: dict[str, InputPort] = {
            port: self.DeclareVectorInputPort(port, size) for port, size in self._machine.guard_ports.items()
        }
        self._status = self.DeclareAbstractState(AbstractValue.Make(self._machine.initial_status))
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._tick)
        ticket = {self.abstract_state_ticket(self._status)}
        self.DeclareAbstractOutputPort(
            "stack",
            lambda: AbstractValue.Make(()),
            lambda c, v: v.set_value(self._current(c).stack.active),
            prerequisites_of_calc=ticket,
        )
        self.DeclareAbstractOutputPort(
            "smooth_stack",
            lambda: AbstractValue.Make(self._machine.initial_status.stack),
            lambda c, v: v.set_value(self._current(c).stack),
            prerequisites_of_calc=ticket,
        )
        self.DeclareAbstractOutputPort(
            "state",
            lambda: AbstractValue.Make(""),
            lambda c, v: v.set_value(self._current(c).state),
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort(
            "transitions",
            1,
            lambda c, out: out.SetAtIndex(0, float(self._current(c).count)),
            prerequisites_of_calc=ticket,
        )
        vector_sizes = self._machine.vector_sizes
        for key, value in self._machine.initial_values.items():
            if key in vector_sizes:
                self.DeclareVectorOutputPort(
                    key,
                    vector_sizes[key],
                    lambda c, out, key=key: out.SetFromVector(self._current(c).values[key]),
                    prerequisites_of_calc=ticket,
                )
            else:
                self.DeclareAbstractOutputPort(
                    key,
                    lambda value=value: AbstractValue.Make(value),
                    lambda c, v, key=key: v.set_value(self._current(c).values[key]),
                    prerequisites_of_calc=ticket,
                )

    # --- the adapter ----------------------------------------------------------------------
    def _current(self, context: Context) -> Status:
        return context.get_abstract_state(self._status).get_value()

    def _initialize(self, context: Context, state: DrakeState) -> None:
        state.get_mutable_abstract_state(self._status).set_value(self._machine.start(context.get_time()))

    def _tick(self, context: Context, state: DrakeState) -> None:
        status = self._current(context)

        def read(port_name: str) -> np.ndarray:
            port = self._inputs[port_name]
            if not port.HasValue(context):
                raise RuntimeError(
                    f"sequencer {self.get_name()!r}, state {status.state!r}: a guard reads input port "
                    f"{port_name!r}, which is not connected"
                )
            return port.Eval(context)

        new = self._machine.step(status, context.get_time(), read)
        if new is not status:
            state.get_mutable_abstract_state(self._status).set_value(new)

    # --- introspection ------------------------------------------------------------------
    @property
    def machine(self) -> StateMachine:
        """The validated state machine this system runs."""
        return self._machine

    @property
    def period(self) -> float:
        """Time between checks [s]."""
        return self._period

    @property
    def state_names(self) -> tuple[str, ...]:
        """Every state, in declaration order."""
        return tuple(self._machine.states)

    @property
    def task_names(self) -> tuple[str, ...]:
        """The task names the sequencer's stack commands may use."""
        return self._machine.tasks

    @property
    def guard_ports(self) -> dict[str, int]:
        """Name → size of every guard input port."""
        return self._machine.guard_ports

    def current_state(self, context: Context) -> str:
        """The current state's name (own or root context)."""
        return self._current(own_context(self, context)).state

    def stack(self, context: Context) -> tuple[str, ...]:
        """The active tasks the sequencer currently outputs, highest priority first (own or root context)."""
        return self._current(own_context(self, context)).stack.active
