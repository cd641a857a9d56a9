"""``StackHistory``: the changes of a stack of tasks (the last ones), with their times, for logs and plots."""

from __future__ import annotations

from dataclasses import dataclass

from pydrake.common.value import AbstractValue, Value
from pydrake.systems.framework import Context, State

from drake_sot.immutable import Immutable
from drake_sot.stack import StackError, task_names
from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem

#: The changes a :class:`StackHistory` keeps: the last ones (a client that changes the stack every
#: tick for an hour would otherwise grow its memory without bound).
MAX_CHANGES = 10_000

Changes = tuple[tuple[float, tuple[str, ...]], ...]


@dataclass(frozen=True)
class _Records(Immutable):
    """The state: the recorded changes. Drake copies it at every tick; a bare tuple would be walked
    record by record (85 ms a tick at :data:`MAX_CHANGES` changes): its copy is itself."""

    changes: Changes = ()


class StackHistory(SotLeafSystem):
    """Records the stack each time it changes (checked at ``period``), keeping the last
    :data:`MAX_CHANGES` records.

    A change made by another system's event at a tick is recorded at the next tick (all
    events of one instant read the state before it), so times are at most one period late.

    Input ports:
        stack: abstract ``tuple[str, ...]``, distinct task names, highest priority first
            (``StackOfTasks.stack``); anything else raises a RuntimeError naming the port.
    Output ports:
        history: abstract ``tuple[tuple[float, tuple[str, ...]], ...]``: (time [s],
            stack) of the initial stack and of every change (the last :data:`MAX_CHANGES`).
    """

    def __init__(self, *, period: float = 0.005, name: str = "stack_history") -> None:
        super().__init__()
        self.set_name(name)
        self._stack = self.DeclareAbstractInputPort("stack", AbstractValue.Make(()))
        self._history = self.DeclareAbstractState(Value[object](_Records()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)
        self.DeclareAbstractOutputPort(
            "history",
            lambda: Value[object](()),
            lambda context, value: value.set_value(self._changes(context)),
            prerequisites_of_calc={self.abstract_state_ticket(self._history)},
        )

    def history(self, context: Context) -> Changes:
        """The recorded history (this system's context or the root's)."""
        return self._changes(own_context(self, context))

    def _changes(self, context: Context) -> Changes:
        return context.get_abstract_state(self._history).get_value().changes

    def _update(self, context: Context, state: State) -> None:
        history = self._changes(context)
        try:
            stack = task_names(self._stack.Eval(context), what="the stack")
        except StackError as error:
            raise RuntimeError(f"{self.get_name()!r}: input port 'stack': {error}") from None
        if not history or history[-1][1] != stack:
            state.get_mutable_abstract_state(self._history).set_value(
                _Records(history[-(MAX_CHANGES - 1) :] + ((context.get_time(), stack),))
            )


def stack_changes(history) -> list[tuple[float, str]]:
    """``(time, label)`` of each change after the first stack; the label lists the tasks
    added (+) and removed (−), or says ``reordered``."""
    changes = []
    for (_, before), (t, after) in zip(history, history[1:], strict=False):
        added = [f"+{task}" for task in after if task not in before]
        removed = [f"−{task}" for task in before if task not in after]
        changes.append((t, " ".join(added + removed) or "reordered"))
    return changes
