"""``PrioritySchedule``: the priority matrix α(t) of the generalized hierarchy, as a signal."""

from __future__ import annotations

import copy

from pydrake.common.value import Value
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from drake_sot.systems._context import own_context
from drake_sot.transitions import AlphaSchedule


class PrioritySchedule(LeafSystem):
    """Outputs α(t) (paper 004 eq. 4) from an :class:`~drake_sot.transitions.AlphaSchedule`:
    transitions of any number of pairs (i, j) with the smooth profile of eq. 12.

    The schedule given at construction is a script; :meth:`set` and :meth:`switch` add
    transitions on a context while the simulation runs (a state machine or a command
    does that), starting at the context's time.

    Output ports:
        alpha: (n·n,) row-major α matrix over the schedule's tasks, row i = α_i1..α_in
            (the ``GeneralizedHierarchyController.alpha`` input).
    """

    def __init__(self, schedule: AlphaSchedule, *, name: str = "priority_schedule") -> None:
        super().__init__()
        self.set_name(name)
        self._n = len(schedule.task_names)
        self._schedule = self.DeclareAbstractState(Value[object](schedule))
        self.DeclareVectorOutputPort(
            "alpha",
            self._n * self._n,
            self._calc_alpha,
            prerequisites_of_calc={self.time_ticket(), self.abstract_state_ticket(self._schedule)},
        )

    def schedule(self, context: Context) -> AlphaSchedule:
        """The schedule in force (own or root context)."""
        return own_context(self, context).get_abstract_state(self._schedule).get_value()

    def set(self, context: Context, i, j, value: float, *, duration: float) -> None:
        """Move α_ij to ``value`` over ``duration`` [s] from now (eq. 12's profile)."""
        context = own_context(self, context)
        schedule = copy.deepcopy(self.schedule(context))
        schedule.set(i, j, value, start=context.get_time(), duration=duration)
        context.get_mutable_abstract_state(self._schedule).set_value(schedule)

    def switch(self, context: Context, i, j, *, duration: float) -> None:
        """Swap the priority of tasks i and j over ``duration`` [s] from now."""
        context = own_context(self, context)
        schedule = copy.deepcopy(self.schedule(context))
        schedule.switch(i, j, start=context.get_time(), duration=duration)
        context.get_mutable_abstract_state(self._schedule).set_value(schedule)

    def _calc_alpha(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.schedule(context).at(context.get_time()).reshape(-1))
