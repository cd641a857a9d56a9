"""``RandomSteps``: the footprints of a random walk of any length, fed to the pattern generator's
``next_footprint`` input (a thin adapter over :class:`drake_sot.random_steps.RandomStepRule`)."""

from __future__ import annotations

from pydrake.common.value import Value
from pydrake.systems.framework import Context

from drake_sot.random_steps import RandomStepRule
from drake_sot.systems.leaf import SotLeafSystem


class RandomSteps(SotLeafSystem):
    """The next footprint of a random walk from the last planned ones and the time.

    Input ports:
        planned_feet: abstract ``(left Footstep, right Footstep, last side or None)``
            (``PatternGenerator.planned_feet``).

    Output ports (direct feedthrough; the pattern generator reads it at its tick):
        next_footprint: abstract tuple of at most one ``Footstep``: ``(step,)``, or ``()`` during
            a stop (see :class:`~drake_sot.random_steps.RandomStepRule`).

    Args:
        rule: the random walk (its step limits must be the pattern generator's).
        name: the system's name.
    """

    def __init__(self, rule: RandomStepRule, *, name: str = "random_steps") -> None:
        super().__init__()
        self.set_name(name)
        self.rule = rule
        self._planned = self.DeclareAbstractInputPort("planned_feet", Value[object]((None, None, None)))
        self.DeclareAbstractOutputPort("next_footprint", lambda: Value[object](()), self._calc_next)

    def _calc_next(self, context: Context, value) -> None:
        left, right, last = self._planned.Eval(context)
        step = self.rule.next_footprint(left, right, last, context.get_time())
        value.set_value(() if step is None else (step,))
