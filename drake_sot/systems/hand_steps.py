"""``StepDecider``: the next footprint from the hands' error in the waist frame (Evrard et al.
2009, III-D), fed to the pattern generator's ``next_footprint`` input.

A thin adapter over :class:`drake_sot.hand_steps.HandStepRule`.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import Context

from drake_sot.footsteps import Footstep
from drake_sot.hand_steps import HandStepRule, stance_frame
from drake_sot.systems.leaf import SotLeafSystem


class StepDecider(SotLeafSystem):
    """Decides the next footprint so that steps regulate the hands' error to zero.

    Input ports:
        hands: (6,) [m] the robot's hand positions in the world ``[right; left]``.
        planned_feet: abstract ``(left Footstep, right Footstep, last side or None)``
            (``PatternGenerator.planned_feet``).

    Output ports (direct feedthrough; the pattern generator reads them at its tick):
        next_footprint: abstract tuple of at most one ``Footstep``: ``(step,)``, or ``()`` when
            the error is below the threshold or no step would reduce it (a tuple, because a
            Drake abstract value cannot hold None since drake 1.58).
        error: (2,) [m] the error ``(forward, lateral)`` in the waist frame over the planned
            stance.
        stance: (3,) ``[x, y, yaw]`` [m, m, rad] that planned stance's waist frame (it changes
            when the pattern generator plans a footprint: for logging the decisions).

    Args:
        rule: the step rule (reference, threshold, step limits; the limits must be the
            pattern generator's).
        name: the system's name.
    """

    def __init__(self, rule: HandStepRule, *, name: str = "step_decider") -> None:
        super().__init__()
        self.set_name(name)
        if not isinstance(rule, HandStepRule):
            raise TypeError(f"rule must be a HandStepRule, got {type(rule).__name__}")
        self._rule = rule
        self._hands = self.DeclareVectorInputPort("hands", 6)
        self._planned = self.DeclareAbstractInputPort("planned_feet", Value[object]((None, None, None)))
        self.DeclareAbstractOutputPort("next_footprint", lambda: Value[object](()), self._calc_next)
        self.DeclareVectorOutputPort("error", 2, self._calc_error)
        self.DeclareVectorOutputPort("stance", 3, self._calc_stance)

    def _inputs(self, context: Context) -> tuple[np.ndarray, Footstep, Footstep, str | None]:
        left, right, last = self._planned.Eval(context)
        return self._hands.Eval(context), left, right, last

    def _calc_next(self, context: Context, value) -> None:
        hands, left, right, last = self._inputs(context)
        step = self._rule.next_footprint(hands, left, right, last)
        value.set_value(() if step is None else (step,))

    def _calc_error(self, context: Context, out) -> None:
        hands, left, right, _ = self._inputs(context)
        out.SetFromVector(self._rule.error(hands, left, right))

    def _calc_stance(self, context: Context, out) -> None:
        left, right, _ = self._planned.Eval(context)
        centre, yaw = stance_frame(left, right)
        out.SetFromVector([centre[0], centre[1], yaw])
