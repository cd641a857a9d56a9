"""``StackOfTasks``: the strict-priority solver entity (Mansard, Stasse, Evrard, Kheddar 2009,
eq. 8-9 and III-B.6)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiscreteValues
from pydrake.systems.framework import State as DrakeState

from drake_sot import validation
from drake_sot.errors import prefixed
from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import LevelReport, bound_sides, level_report, solve_hqp
from drake_sot.signals import BoundedTaskSignal, TaskSignal
from drake_sot.stack import Clear, Down, Pop, Push, Rm, Stack, StackCommand, StackError, Up
from drake_sot.systems._context import own_context, settable_context
from drake_sot.systems.inequalities import InequalityTask
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.systems.task import Task

#: Name of the optional input port that drives the stack.
STACK_PORT = "stack"
#: The solvers a ``StackOfTasks`` can use.
SOLVERS = ("svd", "hqp")
#: Name of the optional input port of stack commands (``commands_input=True``).
COMMANDS_PORT = "commands"


# --- stack commands sent by another system (a remote command server) -------------------------
@dataclass(frozen=True)
class TimedStackCommand:
    """A stack command (:data:`drake_sot.stack.StackCommand`: its task and its transition time, by
    name) given at ``time`` [s], where its transition starts (see :class:`StackOfTasks`)."""

    time: float
    command: StackCommand


@dataclass(frozen=True)
class StackCommands:
    """The value of the ``commands`` input: the commands of ``batch`` (numbered from 1, in the
    order the sender took them); the solver applies each batch once."""

    batch: int = 0
    commands: tuple[TimedStackCommand, ...] = ()


@dataclass(frozen=True)
class StackCommandResults:
    """The value of the ``command_results`` output: per command of ``batch``, ``(True, output)``
    when it was applied (output: the task ``pop`` removed, else ""), ``(False, error)`` when it
    was refused (the error names the task and lists the stack)."""

    batch: int = 0
    results: tuple[tuple[bool, str], ...] = ()


@dataclass(frozen=True)
class _Remote:
    """The last batch committed, and the ``stack`` input's value it acted on (None: not driven)."""

    results: StackCommandResults = StackCommandResults()
    base: tuple[str, ...] | None = None


class StackOfTasks(SotLeafSystem):
    """Combines the tasks of its stack, in priority order, into one joint velocity q̇.

    Every task the scenario may ever use is wired in at build time (one input port
    each); which of them act, and in which order, is the *stack*, a
    :class:`drake_sot.stack.Stack` value held in the context and changed at run time
    with :meth:`push`, :meth:`pop`, :meth:`rm`, :meth:`up`, :meth:`down` and
    :meth:`clear`, as in the paper, or with :meth:`apply` and any
    :data:`drake_sot.stack.StackCommand` (the algebra and its errors are ``Stack``'s). Index 0
    of the stack is the highest priority; ``push`` appends at the lowest. Tasks outside
    the stack are not evaluated and cost nothing.

    On a periodic discrete update (the control period, 5 ms by default as on HRP-2)
    it evaluates the tasks of the stack and solves them with
    :func:`drake_sot.hierarchy.solve_strict` (``solver="svd"``: equality tasks only) or
    :func:`drake_sot.hqp.solve_hqp` (``solver="hqp"``: the stack may also hold
    inequality tasks, :class:`~drake_sot.systems.inequalities.InequalityTask`, at any
    level; with equality tasks only both give the same q̇); outputs are held in state
    between ticks, so physics steps in between do not run any of the controller's Python.
    With ``solver="hqp"`` the tick keeps, in a discrete state, which rows of its inequality
    tasks were at a bound at its q̇, and the next tick's solve is warm-started from them
    (``solve_hqp``'s ``warm_start``: while the same rows bind, one equality solve instead of
    the active set; the q̇ is the same either way).

    Smooth changes (``transition=T`` on a command, T > 0 [s]): q̇ moves continuously,
    over T, from the solution of the stack before the command to that of the stack
    after it, with Mansard, Remazeilles and Chaumette's (2009) continuous inverse.
    There, the features of a set J are activated by H = diag(h_i), h_i ∈ [0, 1], and
    the pseudo-inverse is replaced by

        J^⊕H = Σ_{P ⊆ {1..m}} (Π_{i∈P} h_i) (Π_{i∉P} (1 - h_i)) J_P^+,

    the mean of the pseudo-inverses of the sub-sets P of the features, J_P^+ = (H_P J)^+
    with H_P the 0/1 selection of P: continuous in H, J^+ when H = I, and (H J)^+ when H
    is a 0/1 matrix. A push or rm of task k is the activation of one block of features,
    the rows of k, by h (push: h = h(t), rm: h = 1 - h(t)); the strict hierarchy (eq. 8)
    takes the place of the pseudo-inverse, and only two sub-sets have a weight, the stack
    with k and the stack without it:

        q̇(t) = (1 - h(t)) q̇*(S⁻) + h(t) q̇*(S⁺),
        h(t) = 0.5 - 0.5 cos(π (t - t0) / T) on [t0, t0 + T]  (Liu, Lober, Padois 2016, eq. 12),

    with S⁻ the stack before the command, given at t0, S⁺ the stack after it, q̇*(S)
    the strict solution of S for the task signals of the tick. ``up`` and ``down`` are
    the same law between the two orders. q̇ is continuous in time because q̇*(S⁻) and
    q̇*(S⁺) are (they are evaluated at the same state) and h is; a tick changes h by at
    most π·period / (2T) (1.6 % of the gap for T = 0.5 s at 5 ms). Scaling ė* of the
    pushed task by h alone would not do: its rows would take their freedom from the lower
    levels at once (q̇ jumps at h = 0⁺); here the lower levels keep their solution of S⁻
    with the weight 1 - h. The levels above the change in both stacks are not disturbed:
    both solutions minimise their residuals, and so does any mean of the two. Two
    differences from the paper: the inverse is applied to ė*, not to H ė* (both are
    continuous; this one keeps each end stack's solution exact), and the features of a
    task move together (one activation per task, not per row). Changes that overlap in
    time nest (the later one leads from the whole blend of the earlier one; see
    :meth:`drake_sot.stack.Stack.blend`): the tick solves one strict hierarchy per stack
    of the blend, two for a single change. During a change the ``stack`` output is the
    stack reached, and ``errors`` holds the error of every task of the blend.

    Making a ``StackOfTasks`` leaves the process's BLAS threads as they are: on the tick's
    small matrices more threads gain nothing and, on a loaded machine, cost milliseconds, so
    the front-ends (the command line, serving, the study workers) call
    :func:`drake_sot.blas.limit_blas_threads` when they start a run; a notebook decides for itself.

    The stack can instead be *driven*: when the optional ``stack`` input port is
    connected (e.g. to a :class:`~drake_sot.systems.sequencer.TaskSequencer`), the
    stack used at each tick is that input's value and the stack held in the context
    (and the constructor's ``stack``) is not used; the context commands are then
    refused with a ValueError rather than silently overridden.

    Input ports:
        <task name>: one per declared task, abstract :class:`~drake_sot.signals.TaskSignal`
            carrying that task's name; e (m,), J (m, nv), ė* (m,) with m the task's
            dimension; or, with ``solver="hqp"``, a
            :class:`~drake_sot.signals.BoundedTaskSignal` (error (m,), J (m, nv), bounds
            (m,) of J q̇, ±inf allowed).
        stack: optional, abstract ``tuple[str, ...]``, the active task names, highest
            priority first (the name "stack" is therefore not a valid task name); or a
            :class:`~drake_sot.stack.Stack`, which may carry a change in progress that is then
            blended as a command's ``transition`` is (``TaskSequencer.smooth_stack``).
            Validated when it changes: an unknown task name or a task listed twice
            raises a RuntimeError naming them and listing the known tasks.
        commands: only with ``commands_input=True``; abstract :class:`StackCommands`, batches of
            stack commands from another system (a
            :class:`~drake_sot.systems.command_server.RemoteCommandServer`). A new batch acts at the
            tick that sees it, after the stack held in the context, in its order; a command
            that cannot act (an unknown task, a push of a task in the stack, up of the top
            task: :meth:`drake_sot.stack.Stack.apply`'s errors) is skipped and
            reported on ``command_results``. A periodic unrestricted update commits the batch
            into the held stack at the next tick (a context command commits it first), so that
            the commands of the context and of the port act in the order they were given.
            With the ``stack`` input connected too (a sequencer), the commands act on its
            stack, and its next change replaces what they made: the newer decision wins.
    Output ports:
        qdot: joint velocity (nv,) computed at the last tick [rad/s, m/s] (v layout of the model).
        errors: every declared task's error (an inequality task's: how far it is outside
            its allowed set), concatenated in declaration order
            (Σ m_i,), NaN for the tasks that were not in the stack at the last tick
            (:meth:`error_slices` gives each task's rows).
        stack: abstract ``tuple[str, ...]``, the current active task names, highest
            priority first: the ``stack`` input's value when it is connected, else the
            context's stack.
        command_results: only with ``commands_input=True``; abstract
            :class:`StackCommandResults` of the last batch of the ``commands`` input.
        report: only with ``report=True``; abstract ``tuple`` of
            :class:`~drake_sot.hqp.LevelReport`, one per task of the stack of the last tick
            (the stack reached, during a change), highest priority first, each named by its task:
            ``slack`` (m,) = ``J q̇ - clip(J q̇, lower, upper)`` at the ``qdot`` output (an
            equality task's ``J q̇ - ė*``; 0 on a row that holds) [the task's rows' units /s],
            and ``active_lower`` / ``active_upper``, the rows of an inequality task within
            :data:`~drake_sot.hqp.TOLERANCE` of that bound (indices into the task's rows).
            Empty before the first tick. The tick writes the slacks and the active rows to a
            discrete state (one product ``J q̇`` per task of the stack); the
            tuple is built only when the port is evaluated. Without ``report=True`` none of it
            exists and the tick does not pay for it.

    Args:
        nv: size of q̇ (the model's number of velocities), >= 1.
        tasks: the tasks (their names and dimensions; inequality tasks need ``solver="hqp"``), or
            task name → dimension (the kind of each task is then known from its signal).
        period: the control period [s], finite and > 0; each :class:`~drake_sot.systems.task.Task`
            of ``tasks`` is told it (:meth:`~drake_sot.systems.task.Task.use_period`) and its gain
            checked against it (``λ·period <= 1``, :data:`drake_sot.gains.MAX_GAIN_PERIOD`).
        rank_threshold: singular values at or below it are treated as zero (finite, >= 0;
            see :func:`~drake_sot.hierarchy.solve_strict`).
        damping: damped least-squares factor μ (finite, >= 0, in the units of the tasks'
            Jacobians; 0 is the exact pseudo-inverse): with ``solver="svd"``
            :func:`~drake_sot.hierarchy.solve_strict`'s, every task damped; with
            ``solver="hqp"`` :func:`~drake_sot.hqp.solve_hqp`'s, every task damped, or a mapping
            from task names to their μ (the others exact): e.g. a hand's position task that an
            arm's joint limit above it leaves singular (``solve_hqp`` says why).
        stack: the initial active tasks, highest priority first.
        name: the system's name.
        solver: ``"svd"`` (:func:`~drake_sot.hierarchy.solve_strict`) or ``"hqp"``
            (:func:`~drake_sot.hqp.solve_hqp`, equalities and inequalities).
        commands_input: declare the ``commands`` input and the ``command_results`` output.
        report: declare the ``report`` output (the per-task slacks and active rows of each tick).

    Raises:
        ValueError: at construction, naming the bad argument (a task name twice, a
            task named "stack", a dimension < 1, a NaN period, a task's gain too large for
            the period, ...); an initial stack
            naming an unknown task raises :class:`~drake_sot.stack.UnknownTaskError`
            (a ValueError and a KeyError) listing the known tasks; an inequality task with
            ``solver="svd"``, a damping per task with ``solver="svd"`` or naming an unknown
            task, an unknown solver. At the tick, a
            RuntimeError naming the task when its signal carries another task's name,
            has the wrong sizes (e, J or ė*; or the bounds), holds NaN/Inf (NaN only, in
            bounds), has a lower bound above its upper one (naming the row), or is an
            inequality task's signal while ``solver="svd"``. An active set of
            :func:`~drake_sot.hqp.solve_hqp` that does not settle raises nothing: the tick
            takes the iterate it reached (:attr:`~drake_sot.hqp.HqpResult.unsettled`).
    """

    def __init__(
        self,
        nv: int,
        tasks: Sequence[Task | InequalityTask] | Mapping[str, int],
        *,
        period: float = 0.005,
        rank_threshold: float = 1e-6,
        damping: float | Mapping[str, float] = 0.0,
        stack: Sequence[str] = (),
        name: str = "sot",
        solver: str = "svd",
        commands_input: bool = False,
        report: bool = False,
    ) -> None:
        super().__init__()
        self.set_name(name)
        where = f"StackOfTasks {name!r}"
        self._nv = validation.positive_int(f"{where}: nv", nv)
        if solver not in SOLVERS:
            raise ValueError(f"{where}: solver = {solver!r}: must be one of {', '.join(map(repr, SOLVERS))}")
        self._solver = solver
        if isinstance(tasks, Mapping):
            pairs = list(tasks.items())
            bounded: set[str] = set()
        else:
            pairs = [(t.get_name(), t.dimension) for t in tasks]
            bounded = {t.get_name() for t in tasks if isinstance(t, InequalityTask)}
        if bounded and solver != "hqp":
            raise ValueError(
                f"{where}: inequality tasks {sorted(bounded)} need solver='hqp' (solver={solver!r})"
            )
        if not pairs:
            raise ValueError(f"{where} needs at least one task")
        try:
            empty = Stack(tuple(task_name for task_name, _ in pairs))
            initial = empty.with_active(stack)
        except StackError as error:
            raise prefixed(error, where) from None
        if STACK_PORT in empty.tasks:
            raise ValueError(f"{STACK_PORT!r} cannot be a task name: it is the name of the stack input port")
        if commands_input and COMMANDS_PORT in empty.tasks:
            raise ValueError(f"{COMMANDS_PORT!r} cannot be a task name with commands_input=True (its port)")
        dims = {
            task_name: validation.positive_int(f"{where}: dimension of task {task_name!r}", m)
            for task_name, m in pairs
        }
        self._period = validation.positive(f"{where}: period", period, unit="s")
        for task in () if isinstance(tasks, Mapping) else tasks:
            if isinstance(task, Task):  # its gain's range depends on the period (drake_sot.gains)
                task.use_period(self._period)
        self._rank_threshold = validation.nonnegative(f"{where}: rank_threshold", rank_threshold)
        self._damping = _damping(where, damping, solver, {task_name for task_name, _ in pairs})
        self._dims = dims
        #: The shapes of (error, J, ė*) each equality task's signal must have.
        self._shapes = {task_name: ((m,), (m, nv), (m,)) for task_name, m in dims.items()}
        self._empty = empty
        self._slices: dict[str, slice] = {}
        start = 0
        for task_name, m in dims.items():
            self._slices[task_name] = slice(start, start + m)
            start += m
        self._ports = {
            task_name: self.DeclareAbstractInputPort(
                task_name,
                AbstractValue.Make(
                    BoundedTaskSignal(task_name, np.zeros(0), np.zeros((0, nv)), np.zeros(0), np.zeros(0))
                    if task_name in bounded
                    else TaskSignal(task_name, np.zeros(0), np.zeros((0, nv)), np.zeros(0))
                ),
            )
            for task_name in dims
        }
        self._stack_input = self.DeclareAbstractInputPort(STACK_PORT, AbstractValue.Make(()))
        # The last tuple the stack input held and its stack, checked: a pure function of the
        # tuple, so one entry serves every context; the check runs once per stack change.
        self._driven: tuple[tuple[str, ...] | None, Stack] = (None, empty)
        self._stack = self.DeclareAbstractState(AbstractValue.Make(initial))
        self._qdot = self.DeclareDiscreteState(nv)
        self._errors = self.DeclareDiscreteState(np.full(start, np.nan))
        self._errors_size = start
        #: solver="hqp": per declared row (as ``errors``), its side at the last tick's q̇ (+1 at its
        #: upper bound, -1 at its lower one, 0 otherwise): the next tick's warm start.
        self._sides = self.DeclareDiscreteState(np.zeros(start)) if solver == "hqp" else None
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareStateOutputPort("qdot", self._qdot)
        self.DeclareStateOutputPort("errors", self._errors)
        self._commands_input = self._declare_commands_input() if commands_input else None
        remote = (
            set()
            if self._commands_input is None
            else {
                self.abstract_state_ticket(self._committed),
                self.input_port_ticket(self._commands_input.get_index()),
            }
        )
        self.DeclareAbstractOutputPort(
            "stack",
            lambda: AbstractValue.Make(()),
            lambda context, value: value.set_value(self._current_stack(context).active),
            prerequisites_of_calc={
                self.abstract_state_ticket(self._stack),
                self.input_port_ticket(self._stack_input.get_index()),
                *remote,
            },
        )
        self._report = self._declare_report() if report else None

    # --- what the stack may hold -------------------------------------------------
    @property
    def task_names(self) -> tuple[str, ...]:
        """Every declared task, in declaration order."""
        return self._empty.tasks

    @property
    def solver(self) -> str:
        """``"svd"`` or ``"hqp"``."""
        return self._solver

    @property
    def period(self) -> float:
        """The control period [s]."""
        return self._period

    def error_slices(self) -> dict[str, slice]:
        """Where each task's error lies in the ``errors`` output."""
        return dict(self._slices)

    def task_errors(self, context: Context) -> tuple[tuple[str, float], ...]:
        """``(task, ‖e‖)`` for each task of the stack at the last tick, largest error first (own or
        root context; ‖e‖ in the task's own units: m, rad, ...): a solver whose every level is
        "optimal" may still leave a task far from its goal (a target out of reach, a lower task in
        conflict with a higher one), and this names it and says by how much. Empty before the first
        tick."""
        errors = own_context(self, context).get_discrete_state(self._errors).get_value()
        return self._error_norms(errors)

    def _error_norms(self, errors: np.ndarray) -> tuple[tuple[str, float], ...]:
        """``(task, ‖e‖)`` of the tasks whose rows of ``errors`` are not NaN, largest first."""
        norms = [
            (task_name, float(np.linalg.norm(errors[rows])))
            for task_name, rows in self._slices.items()
            if not np.isnan(errors[rows]).any()
        ]
        return tuple(sorted(norms, key=lambda pair: -pair[1]))

    def _current_stack(self, context: Context) -> Stack:
        """The stack in force for this system's own context (the input's, validated, when driven)."""
        if self._commands_input is not None:
            return self._with_batch(context, self._before_batch(context))[0]
        if not self._stack_input.HasValue(context):
            return context.get_abstract_state(self._stack).get_value()
        return self._driven_stack(context)

    def _driven_stack(self, context: Context) -> Stack:
        """The ``stack`` input's value, validated (when it changes)."""
        names = self._stack_input.Eval(context)
        if names is self._driven[0] or (type(names) is tuple and names == self._driven[0]):
            return self._driven[1]  # checked when it changed (a tuple or a Stack cannot change in place)
        try:
            stack = (
                names.over(self._empty.tasks) if isinstance(names, Stack) else self._empty.with_active(names)
            )
        except StackError as error:
            raise RuntimeError(f"{self.get_name()!r}: input port {STACK_PORT!r}: {error}") from None
        if type(names) is tuple or isinstance(names, Stack):
            self._driven = (names, stack)
        return stack

    def is_driven(self, context: Context) -> bool:
        """True when the ``stack`` input port is connected (own or root context)."""
        return self._stack_input.HasValue(own_context(self, context))

    # --- the paper's commands, acting on a context --------------------------------
    def list(self, context: Context) -> tuple[str, ...]:
        """The active tasks, highest priority first (own or root context); the input's when driven."""
        return self._current_stack(own_context(self, context)).active

    def apply(self, context: Context, command: StackCommand) -> Stack:
        """Apply a stack command (:data:`drake_sot.stack.StackCommand`) to the context's stack with
        :meth:`drake_sot.stack.Stack.apply`, its transition starting at the context's time;
        return the stack before. The paper's commands below make their command and call this.

        Raises:
            ValueError: the ``stack`` input drives the stack.
            drake_sot.stack.StackError: the command does not apply (a ValueError; an unknown task
                is an :class:`~drake_sot.stack.UnknownTaskError` listing the known tasks).
            TypeError: ``command`` is not a stack command.
        """
        context = settable_context(self, context, self._stack_input, command=str(command), what="the stack")
        if self._commands_input is not None:
            self._commit(context, context.get_mutable_state())  # the port's commands came first
        before = context.get_abstract_state(self._stack).get_value()
        after = before.apply(command, at=context.get_time())
        context.get_mutable_abstract_state(self._stack).set_value(after)
        return before

    def push(self, context: Context, task_name: str, *, transition: float = 0.0) -> None:
        """Add a task at the lowest priority, over ``transition`` seconds (0: at once; see the
        class docstring). Refuses an unknown task or one already in the stack."""
        self.apply(context, Push(task_name, transition=transition))

    def pop(self, context: Context, *, transition: float = 0.0) -> str:
        """Remove and return the lowest-priority task (the last pushed); refused on an empty stack."""
        return self.apply(context, Pop(transition=transition)).active[-1]

    def rm(self, context: Context, task_name: str, *, transition: float = 0.0) -> None:
        """Remove a task wherever it is in the stack, over ``transition`` seconds (0: at once)."""
        self.apply(context, Rm(task_name, transition=transition))

    def up(self, context: Context, task_name: str, *, transition: float = 0.0) -> None:
        """Raise a task's priority by one, over ``transition`` seconds; refused at the top."""
        self.apply(context, Up(task_name, transition=transition))

    def down(self, context: Context, task_name: str, *, transition: float = 0.0) -> None:
        """Lower a task's priority by one, over ``transition`` seconds; refused at the bottom."""
        self.apply(context, Down(task_name, transition=transition))

    def clear(self, context: Context, *, transition: float = 0.0) -> None:
        """Empty the stack (q̇ becomes zero at the next tick, or over ``transition`` seconds)."""
        self.apply(context, Clear(transition=transition))

    # --- stack commands from the ``commands`` input (commands_input=True) ---------------------
    def _declare_commands_input(self):
        port = self.DeclareAbstractInputPort(COMMANDS_PORT, AbstractValue.Make(StackCommands()))
        self._committed = self.DeclareAbstractState(AbstractValue.Make(_Remote()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._commit)
        self.DeclareAbstractOutputPort(
            "command_results",
            lambda: AbstractValue.Make(StackCommandResults()),
            lambda context, value: value.set_value(self._with_batch(context, self._before_batch(context))[1]),
            prerequisites_of_calc={
                self.abstract_state_ticket(self._stack),
                self.abstract_state_ticket(self._committed),
                self.input_port_ticket(port.get_index()),
                self.input_port_ticket(self._stack_input.get_index()),
            },
        )
        return port

    def _before_batch(self, context: Context) -> Stack:
        """The stack the input's next batch acts on: the held one; when the ``stack`` input drives
        the stack, its value, or the held one if the commands changed it since the input changed."""
        held = context.get_abstract_state(self._stack).get_value()
        if not self._stack_input.HasValue(context):
            return held
        driven = self._driven_stack(context)
        return (
            held if context.get_abstract_state(self._committed).get_value().base == driven.active else driven
        )

    def _with_batch(self, context: Context, before: Stack) -> tuple[Stack, StackCommandResults]:
        """``before`` with the input's batch applied when it is not committed yet, and its results."""
        committed = context.get_abstract_state(self._committed).get_value().results
        if not self._commands_input.HasValue(context):
            return before, committed
        sent = self._commands_input.Eval(context)
        if sent.batch <= committed.batch:
            return before, committed
        stack, results = before, []
        for sent_command in sent.commands:
            try:
                after = stack.apply(sent_command.command, at=sent_command.time)
            except (StackError, TypeError) as error:
                results.append((False, str(error)))
                continue
            results.append((True, stack.active[-1] if isinstance(sent_command.command, Pop) else ""))
            stack = after
        return stack, StackCommandResults(sent.batch, tuple(results))

    def _commit(self, context: Context, state: DrakeState) -> None:
        """Hold the stack with the input's batch applied (once per batch), and, when driven, the
        input's value it was applied to; forget that value when the input changed since."""
        remote = context.get_abstract_state(self._committed).get_value()
        stack, results = self._with_batch(context, self._before_batch(context))
        driven = self._driven_stack(context).active if self._stack_input.HasValue(context) else None
        if results is not remote.results:
            state.get_mutable_abstract_state(self._stack).set_value(stack)
            state.get_mutable_abstract_state(self._committed).set_value(_Remote(results, driven))
        elif remote.base is not None and remote.base != driven:  # the input's newer stack wins
            state.get_mutable_abstract_state(self._committed).set_value(_Remote(results, None))

    # --- the per-task report of each tick (report=True) ----------------------------------------
    def _declare_report(self) -> int:
        """The discrete state ``[order; slack; flags]`` the tick writes and the ``report`` output that
        reads it: ``order`` (one entry per declared task) the declaration indices of the stack's tasks,
        highest priority first, then -1; per declared row (as ``errors``), its slack and its flags
        (1: at its lower bound, 2: at its upper bound, 3: both), NaN for the tasks not reported."""
        self._task_index = {task_name: k for k, task_name in enumerate(self.task_names)}
        index = self.DeclareDiscreteState(self._empty_report())
        self.DeclareAbstractOutputPort(
            "report",
            lambda: AbstractValue.Make(()),
            self._calc_report,
            prerequisites_of_calc={self.discrete_state_ticket(index)},
        )
        return index

    def _empty_report(self) -> np.ndarray:
        """The ``report`` discrete state with no task reported."""
        return np.concatenate((np.full(len(self._dims), -1.0), np.full(2 * self._errors_size, np.nan)))

    def _report_state(
        self, active: tuple[str, ...], signals: dict[str, tuple[np.ndarray, ...]], qdot: np.ndarray
    ) -> np.ndarray:
        """The ``report`` discrete state of a tick whose stack is ``active`` and whose q̇ is ``qdot``."""
        tasks, rows = len(self._dims), self._errors_size
        state = self._empty_report()
        order, slack, flags = state[:tasks], state[tasks : tasks + rows], state[tasks + rows :]
        for k, task_name in enumerate(active):
            level = signals[task_name]
            report = level_report(task_name, level[0], level[1], level[-1], qdot)
            rows_of_task = self._slices[task_name]
            order[k] = self._task_index[task_name]
            slack[rows_of_task] = report.slack
            task_flags = np.zeros(report.slack.size)
            task_flags[list(report.active_lower)] += 1.0
            task_flags[list(report.active_upper)] += 2.0
            flags[rows_of_task] = task_flags
        return state

    def _calc_report(self, context: Context, value: AbstractValue) -> None:
        state = context.get_discrete_state(self._report).get_value()
        tasks, rows = len(self._dims), self._errors_size
        slack, flags = state[tasks : tasks + rows], state[tasks + rows :]
        reports = []
        for k in state[:tasks]:
            if k < 0:
                break
            task_name = self.task_names[int(k)]
            task_flags = flags[self._slices[task_name]]
            reports.append(
                LevelReport(
                    name=task_name,
                    slack=slack[self._slices[task_name]].copy(),
                    active_lower=tuple(np.flatnonzero(task_flags % 2 == 1).tolist()),
                    active_upper=tuple(np.flatnonzero(task_flags >= 2).tolist()),
                )
            )
        value.set_value(tuple(reports))

    # --- the control law -----------------------------------------------------------
    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        stack = self._current_stack(context)
        # One stack, weight 1, unless a change is in progress.
        blend = ((stack.active, 1.0),) if stack.transition is None else stack.blend(context.get_time())
        errors = np.full(self._errors_size, np.nan)
        signals: dict[str, tuple[np.ndarray, ...]] = {}  # task name -> its level
        ports = self._ports
        needed = blend[0][0] if len(blend) == 1 else dict.fromkeys(n for active, _ in blend for n in active)
        if self._report is not None:  # the stack reached is reported (at a change's start, not in the blend)
            needed = {**dict.fromkeys(needed), **dict.fromkeys(stack.active)}
        evaluated = {task_name: ports[task_name].Eval(context) for task_name in needed}
        with np.errstate(over="ignore"):  # one for all the finiteness sums of _level (it says why)
            for task_name, signal in evaluated.items():
                signals[task_name] = self._level(task_name, signal, context, errors)
        qdot = None
        if self._sides is not None:
            previous = context.get_discrete_state(self._sides).get_value()
            sides = np.zeros(self._errors_size)
        for active, weight in blend:
            if not active:
                continue
            levels = [signals[task_name] for task_name in active]
            # Shapes, finiteness and bounds were checked above, with the task's name.
            if self._sides is not None:
                bounded = [
                    task_name for task_name in active if signals[task_name][1] is not signals[task_name][2]
                ]
                warm = {task_name: previous[self._slices[task_name]] for task_name in bounded}
                # An active set that does not settle gives its last iterate (solve_hqp's unsettled).
                result = solve_hqp(
                    levels,
                    names=active,
                    rank_threshold=self._rank_threshold,
                    validate=False,
                    warm_start=warm,
                    damping=self._damping,
                )
                for task_name in bounded:
                    J, lower, upper = signals[task_name]
                    sides[self._slices[task_name]] = bound_sides(J, lower, upper, result.qdot)
            else:
                result = solve_strict(
                    levels, rank_threshold=self._rank_threshold, damping=self._damping, validate=False
                )
            qdot = weight * result.qdot if qdot is None else qdot + weight * result.qdot
        qdot = np.zeros(self._nv) if qdot is None else qdot
        discrete_state.set_value(self._qdot, qdot)  # one binding call
        discrete_state.set_value(self._errors, errors)
        if self._sides is not None:
            discrete_state.set_value(self._sides, sides)
        if self._report is not None:
            discrete_state.set_value(self._report, self._report_state(stack.active, signals, qdot))

    def _level(
        self, task_name: str, signal: TaskSignal | BoundedTaskSignal, context: Context, errors: np.ndarray
    ) -> tuple[np.ndarray, ...]:
        """The solver's level of a task of the stack, its signal checked (RuntimeError naming the
        task otherwise); writes the task's error into ``errors``. Call under
        ``np.errstate(over="ignore")``: an overflowing finiteness sum is looked at entry by entry."""
        if signal.name != task_name:
            raise RuntimeError(
                f"{self.get_name()!r}: input port {task_name!r} carries the signal of task "
                f"{signal.name!r}: a task is wired into another task's port"
            )
        if isinstance(signal, BoundedTaskSignal):
            errors[self._slices[task_name]] = signal.error
            return self._bounded_level(task_name, signal, self._dims[task_name], context)
        J, edot = signal.jacobian, signal.edot_des
        shapes = (signal.error.shape, J.shape, edot.shape)
        if shapes != self._shapes[task_name]:
            m = self._dims[task_name]
            raise RuntimeError(
                f"task {task_name!r}: error {shapes[0]}, Jacobian {shapes[1]}, "
                f"ė* (edot_des) {shapes[2]}; expected ({m},), ({m}, {self._nv}), ({m},)"
            )
        # A sum of squares (two BLAS dots, cheaper than two sums) is finite when every entry is;
        # only if it is not (NaN, Inf, or an overflow of large finite values) look entry by entry.
        flat = J.ravel("K")  # a view unless J is not contiguous
        if not math.isfinite(flat.dot(flat) + edot.dot(edot)) and not (  # overflow: see the caller's errstate
            np.isfinite(J).all() and np.isfinite(edot).all()
        ):
            raise RuntimeError(
                f"task {task_name!r}: NaN or Inf in its signal at t = {context.get_time():.4f} s"
            )
        errors[self._slices[task_name]] = signal.error
        return (J, edot, edot) if self._solver == "hqp" else (J, edot)

    def _bounded_level(
        self, task_name: str, signal: BoundedTaskSignal, m: int, context: Context
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(J, lower, upper)`` of an inequality task's signal, checked, or RuntimeError naming the task."""
        if self._solver != "hqp":
            raise RuntimeError(
                f"task {task_name!r} is an inequality task: it needs StackOfTasks(solver='hqp') "
                f"({self.get_name()!r} has solver={self._solver!r})"
            )
        J, lower, upper = signal.jacobian, signal.lower, signal.upper
        shapes = (signal.error.shape, J.shape, lower.shape, upper.shape)
        if shapes != ((m,), (m, self._nv), (m,), (m,)):
            raise RuntimeError(
                f"task {task_name!r}: error {shapes[0]}, Jacobian {shapes[1]}, lower {shapes[2]}, "
                f"upper {shapes[3]}; expected ({m},), ({m}, {self._nv}), ({m},), ({m},)"
            )
        flat = J.ravel("K")  # a sum of squares, as in _level; under its errstate
        if not math.isfinite(flat.dot(flat)) and not np.isfinite(J).all():
            raise RuntimeError(
                f"task {task_name!r}: NaN or Inf in its Jacobian at t = {context.get_time():.4f} s"
            )
        # validation.bounds' test, its message (naming the row) built only when it fails.
        if not ((lower <= upper) & (lower < math.inf) & (upper > -math.inf)).all():
            try:
                validation.bounds(f"task {task_name!r} at t = {context.get_time():.4f} s", lower, upper, m)
            except ValueError as error:
                raise RuntimeError(str(error)) from None
        return J, lower, upper


def _damping(
    where: str, damping: float | Mapping[str, float], solver: str, tasks: set[str]
) -> float | dict[str, float]:
    """``damping`` checked: a finite float >= 0, or (``solver="hqp"``) a mapping from known task
    names to finite floats >= 0; ValueError naming the bad value and what is accepted."""
    if not isinstance(damping, Mapping):
        return validation.nonnegative(f"{where}: damping", damping)
    if solver != "hqp":
        raise ValueError(
            f"{where}: a damping per task needs solver='hqp' (solver={solver!r}); or give one float"
        )
    unknown = sorted(set(damping) - tasks)
    if unknown:
        raise ValueError(f"{where}: damping of unknown tasks {unknown}; the tasks are {sorted(tasks)}")
    return {
        task_name: validation.nonnegative(f"{where}: damping[{task_name!r}]", mu)
        for task_name, mu in damping.items()
    }
