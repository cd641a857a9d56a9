"""``PrioritySchedule``: the priority matrix α(t) of the generalized hierarchy, as a named signal."""

from __future__ import annotations

import copy

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.systems.framework import BasicVector, Context

from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.transitions import AlphaSchedule, Priorities


class PrioritySchedule(SotLeafSystem):
    """Outputs α(t) (Liu, Lober, Padois 2016, eq. 4) from an
    :class:`~drake_sot.transitions.AlphaSchedule`: transitions of any number of pairs (i, j)
    with the smooth profile of eq. 12.

    The schedule given at construction is a script; :meth:`set` and :meth:`switch` add
    transitions on a context while the simulation runs (a state machine or a command
    does that), starting at the context's time. Tasks are named, as in the schedule.

    Output ports:
        priorities: abstract :class:`~drake_sot.transitions.Priorities`, α with its task
            names (plug it into ``GeneralizedHierarchyController.priorities``, which looks
            the tasks up by name).
        alpha: (n·n,) the same α row-major over :attr:`task_names`, row i = α_i1..α_in
            (dimensionless, in [0, 1]); for logs and plots, not for controllers.
    """

    def __init__(self, schedule: AlphaSchedule, *, name: str = "priority_schedule") -> None:
        super().__init__()
        self.set_name(name)
        if not isinstance(schedule, AlphaSchedule):
            raise TypeError(f"PrioritySchedule needs an AlphaSchedule, got {type(schedule).__name__}")
        self._names = schedule.task_names
        n = len(self._names)
        self._schedule = self.DeclareAbstractState(Value[object](schedule))
        ticket = {self.time_ticket(), self.abstract_state_ticket(self._schedule)}
        self._priorities = self.DeclareAbstractOutputPort(
            "priorities",
            lambda: AbstractValue.Make(Priorities(self._names, np.zeros((n, n)))),
            self._calc_priorities,
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort("alpha", n * n, self._calc_alpha, prerequisites_of_calc=ticket)

    @property
    def task_names(self) -> tuple[str, ...]:
        """The schedule's tasks, in the order of the ``alpha`` output's rows and columns."""
        return self._names

    def schedule(self, context: Context) -> AlphaSchedule:
        """The schedule in force (own or root context)."""
        return own_context(self, context).get_abstract_state(self._schedule).get_value()

    def set(self, context: Context, i: str | int, j: str | int, value: float, *, duration: float) -> None:
        """Move α_ij to ``value`` over ``duration`` [s] from now (eq. 12's profile)."""
        context = own_context(self, context)
        schedule = copy.deepcopy(self.schedule(context))
        schedule.set(i, j, value, start=context.get_time(), duration=duration)
        context.get_mutable_abstract_state(self._schedule).set_value(schedule)

    def switch(self, context: Context, i: str | int, j: str | int, *, duration: float) -> None:
        """Swap the priority of tasks i and j over ``duration`` [s] from now."""
        context = own_context(self, context)
        schedule = copy.deepcopy(self.schedule(context))
        schedule.switch(i, j, start=context.get_time(), duration=duration)
        context.get_mutable_abstract_state(self._schedule).set_value(schedule)

    def _calc_priorities(self, context: Context, value: AbstractValue) -> None:
        value.set_value(self.schedule(context).priorities(context.get_time()))

    def _calc_alpha(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._priorities.Eval(context).alpha.reshape(-1))
