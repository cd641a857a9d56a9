"""``StackOfTasks``: the strict-priority solver entity (paper 000 eq. 8-9, III-B.6)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiscreteValues, LeafSystem

from drake_sot.hierarchy import solve_strict
from drake_sot.signals import TaskSignal
from drake_sot.systems._context import own_context
from drake_sot.systems.task import Task

#: Name of the optional input port that drives the stack.
STACK_PORT = "stack"


class StackOfTasks(LeafSystem):
    """Combines the tasks of its stack, in priority order, into one joint velocity q̇.

    Every task the scenario may ever use is wired in at build time (one input port
    each); which of them act, and in which order, is the *stack*, held in the context
    and changed at run time with :meth:`push`, :meth:`pop`, :meth:`rm`, :meth:`up`,
    :meth:`down` and :meth:`clear`, as in the paper. Index 0 of the stack is the
    highest priority; ``push`` appends at the lowest. Tasks outside the stack are not
    evaluated and cost nothing.

    On a periodic discrete update (the control period, 5 ms by default as on HRP-2)
    it evaluates the tasks of the stack and solves them with
    :func:`drake_sot.hierarchy.solve_strict`; outputs are held in state between ticks,
    so physics steps in between do not run any of the controller's Python.

    The stack can instead be *driven*: when the optional ``stack`` input port is
    connected (e.g. to a :class:`~drake_sot.systems.sequencer.TaskSequencer`), the
    stack used at each tick is that input's value and the stack held in the context
    (and the constructor's ``stack``) is not used; the context commands are then
    refused with a ValueError rather than silently overridden.

    Input ports:
        <task name>: one per declared task, abstract :class:`~drake_sot.signals.TaskSignal`.
        stack: optional, abstract ``tuple[str, ...]``, the stack to use, highest
            priority first (the name "stack" is therefore not a valid task name).
            Validated at every tick: an unknown task name or a task listed twice
            raises a RuntimeError naming them and listing the known tasks.
    Output ports:
        qdot: joint velocity (nv,) computed at the last tick [rad/s, m/s] (v layout of the model).
        errors: every declared task's error, concatenated in declaration order
            (Σ m_i,), NaN for the tasks that were not in the stack at the last tick.
        stack: abstract ``tuple[str, ...]``, the current stack, highest priority first:
            the ``stack`` input's value when it is connected, else the context's stack.

    Raises at the tick a RuntimeError naming the task when a task signal has the wrong
    size or non-finite values.
    """

    def __init__(
        self,
        nv: int,
        tasks: Sequence[Task] | Mapping[str, int],
        *,
        period: float = 0.005,
        rank_threshold: float = 1e-6,
        damping: float = 0.0,
        stack: Sequence[str] = (),
        name: str = "sot",
    ) -> None:
        super().__init__()
        self.set_name(name)
        dims = {t.get_name(): t.dimension for t in tasks} if not isinstance(tasks, Mapping) else dict(tasks)
        if not dims:
            raise ValueError("StackOfTasks needs at least one task")
        if STACK_PORT in dims:
            raise ValueError(f"{STACK_PORT!r} cannot be a task name: it is the name of the stack input port")
        if period <= 0.0:
            raise ValueError(f"control period {period} must be > 0")
        self._nv = nv
        self._period = period
        self._rank_threshold = rank_threshold
        self._damping = damping
        self._dims = dims
        self._slices: dict[str, slice] = {}
        start = 0
        for task_name, m in dims.items():
            self._slices[task_name] = slice(start, start + m)
            start += m
        self._ports = {
            task_name: self.DeclareAbstractInputPort(
                task_name,
                AbstractValue.Make(TaskSignal(task_name, np.zeros(0), np.zeros((0, nv)), np.zeros(0))),
            )
            for task_name in dims
        }
        self._stack_input = self.DeclareAbstractInputPort(STACK_PORT, AbstractValue.Make(()))
        self._stack = self.DeclareAbstractState(AbstractValue.Make(self._checked_stack(tuple(stack))))
        self._qdot = self.DeclareDiscreteState(nv)
        self._errors = self.DeclareDiscreteState(np.full(start, np.nan))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareStateOutputPort("qdot", self._qdot)
        self.DeclareStateOutputPort("errors", self._errors)
        self.DeclareAbstractOutputPort(
            "stack",
            lambda: AbstractValue.Make(()),
            lambda context, value: value.set_value(self._current_stack(context)),
            prerequisites_of_calc={
                self.abstract_state_ticket(self._stack),
                self.input_port_ticket(self._stack_input.get_index()),
            },
        )

    # --- what the stack may hold -------------------------------------------------
    @property
    def task_names(self) -> tuple[str, ...]:
        """Every declared task, in declaration order."""
        return tuple(self._dims)

    @property
    def period(self) -> float:
        """The control period [s]."""
        return self._period

    def error_slices(self) -> dict[str, slice]:
        """Where each task's error lies in the ``errors`` output."""
        return dict(self._slices)

    def _known(self, task_name: str) -> str:
        if task_name not in self._dims:
            raise KeyError(f"unknown task {task_name!r}; known tasks: {', '.join(self._dims)}")
        return task_name

    def _checked_stack(self, stack: tuple[str, ...]) -> tuple[str, ...]:
        for task_name in stack:
            self._known(task_name)
        if len(set(stack)) != len(stack):
            raise ValueError(f"stack {stack} holds a task twice")
        return stack

    def _checked_input(self, value) -> tuple[str, ...]:
        """The ``stack`` input's value, validated (RuntimeError: it is a run-time signal)."""
        if not isinstance(value, (tuple, list)) or not all(isinstance(n, str) for n in value):
            raise RuntimeError(
                f"{self.get_name()!r}: input port {STACK_PORT!r} must carry a tuple of task names, "
                f"got {value!r}"
            )
        stack = tuple(value)
        unknown = [n for n in stack if n not in self._dims]
        twice = sorted({n for n in stack if stack.count(n) > 1})
        if unknown or twice:
            problems = []
            if unknown:
                problems.append(f"unknown task(s) {', '.join(map(repr, unknown))}")
            if twice:
                problems.append(f"task(s) listed twice {', '.join(map(repr, twice))}")
            raise RuntimeError(
                f"{self.get_name()!r}: the stack {stack} on input port {STACK_PORT!r} has "
                f"{' and '.join(problems)}; known tasks: {', '.join(self._dims)}"
            )
        return stack

    def _current_stack(self, context: Context) -> tuple[str, ...]:
        """The stack in force for this system's own context."""
        if self._stack_input.HasValue(context):
            return self._checked_input(self._stack_input.Eval(context))
        return context.get_abstract_state(self._stack).get_value()

    def is_driven(self, context: Context) -> bool:
        """True when the ``stack`` input port is connected (own or root context)."""
        return self._stack_input.HasValue(own_context(self, context))

    # --- the paper's commands, acting on a context --------------------------------
    def list(self, context: Context) -> tuple[str, ...]:
        """The stack, highest priority first (own or root context); the input's value when driven."""
        return self._current_stack(own_context(self, context))

    def _editable(self, context: Context, command: str) -> tuple[str, ...]:
        """The context's stack, or a ValueError when the stack is driven by the input port."""
        context = own_context(self, context)
        if self._stack_input.HasValue(context):
            raise ValueError(
                f"{self.get_name()!r}: cannot {command}: the stack is driven by input port {STACK_PORT!r}; "
                f"change its source (e.g. the sequencer) instead"
            )
        return context.get_abstract_state(self._stack).get_value()

    def _set(self, context: Context, stack: tuple[str, ...]) -> None:
        own_context(self, context).get_mutable_abstract_state(self._stack).set_value(
            self._checked_stack(stack)
        )

    def push(self, context: Context, task_name: str) -> None:
        """Add a task at the lowest priority. Refuses an unknown task or one already in the stack."""
        stack = self._editable(context, "push")
        if self._known(task_name) in stack:
            raise ValueError(f"task {task_name!r} is already in the stack {stack}")
        self._set(context, stack + (task_name,))

    def pop(self, context: Context) -> str:
        """Remove and return the lowest-priority task (the last pushed)."""
        stack = self._editable(context, "pop")
        if not stack:
            raise IndexError("pop from an empty stack")
        self._set(context, stack[:-1])
        return stack[-1]

    def _position(self, context: Context, task_name: str, command: str) -> tuple[tuple[str, ...], int]:
        stack = self._editable(context, command)
        if self._known(task_name) not in stack:
            raise ValueError(f"task {task_name!r} is not in the stack {stack}")
        return stack, stack.index(task_name)

    def rm(self, context: Context, task_name: str) -> None:
        """Remove a task wherever it is in the stack."""
        stack, i = self._position(context, task_name, "rm")
        self._set(context, stack[:i] + stack[i + 1 :])

    def up(self, context: Context, task_name: str) -> None:
        """Raise a task's priority by one (no-op at the top)."""
        stack, i = self._position(context, task_name, "up")
        if i > 0:
            s = list(stack)
            s[i - 1], s[i] = s[i], s[i - 1]
            self._set(context, tuple(s))

    def down(self, context: Context, task_name: str) -> None:
        """Lower a task's priority by one (no-op at the bottom)."""
        stack, i = self._position(context, task_name, "down")
        if i < len(stack) - 1:
            s = list(stack)
            s[i], s[i + 1] = s[i + 1], s[i]
            self._set(context, tuple(s))

    def clear(self, context: Context) -> None:
        """Empty the stack (q̇ becomes zero at the next tick)."""
        self._editable(context, "clear")
        self._set(context, ())

    # --- the control law -----------------------------------------------------------
    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        stack = self._current_stack(context)
        errors = np.full(discrete_state.get_vector(self._errors).size(), np.nan)
        levels = []
        for task_name in stack:
            signal = self._ports[task_name].Eval(context)
            m = self._dims[task_name]
            if signal.error.shape != (m,) or signal.jacobian.shape != (m, self._nv):
                raise RuntimeError(
                    f"task {task_name!r}: error {signal.error.shape} / Jacobian {signal.jacobian.shape}, "
                    f"expected ({m},) / ({m}, {self._nv})"
                )
            if not (np.all(np.isfinite(signal.jacobian)) and np.all(np.isfinite(signal.edot_des))):
                raise RuntimeError(
                    f"task {task_name!r}: NaN or Inf in its signal at t = {context.get_time():.4f} s"
                )
            errors[self._slices[task_name]] = signal.error
            levels.append((signal.jacobian, signal.edot_des))
        # Shapes and finiteness were checked above, with the task's name.
        result = solve_strict(
            levels, rank_threshold=self._rank_threshold, damping=self._damping, validate=False
        )
        qdot = result.qdot if levels else np.zeros(self._nv)
        discrete_state.get_mutable_vector(self._qdot).SetFromVector(qdot)
        discrete_state.get_mutable_vector(self._errors).SetFromVector(errors)
