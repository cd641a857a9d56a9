"""The stack and the task errors of a served scenario, live in Meshcat's controls.

Meshcat's controls are buttons and sliders: each task of the solver gets a slider
``|e| TASK`` holding the norm of its error (clipped to [0, 1]; 0 while the task is out of
the stack), and the stack is a column of buttons ``stack 1: NAME``, ``stack 2: NAME``…
(highest priority first), rewritten when the stack changes. Updated by the serving loop,
which owns the context, every ``period`` simulated seconds.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.framework import Context

from drake_sot.systems.sot import StackOfTasks
from drake_sot.validation import positive


class MeshcatStatus:
    """Shows ``sot``'s stack and task errors in ``meshcat``'s controls.

    Args:
        meshcat: the live viewer.
        sot: the solver whose ``errors`` and stack are shown.
        period: simulated seconds between updates, > 0.
    """

    def __init__(self, meshcat: Meshcat, sot: StackOfTasks, period: float = 0.1) -> None:
        self._meshcat, self._sot = meshcat, sot
        self._period = positive("period", period, unit="s")
        self._slices = sot.error_slices()
        self._buttons: list[str] = []
        self._due = -math.inf
        for task in self._slices:
            meshcat.AddSlider(self._slider(task), 0.0, 1.0, 1e-4, 0.0)

    @staticmethod
    def _slider(task: str) -> str:
        return f"|e| {task}"

    def update(self, root_context: Context) -> None:
        """Refresh the controls when an update is due at the context's time."""
        t = root_context.get_time()
        if t < self._due:
            return
        self._due = t + self._period
        context = self._sot.GetMyContextFromRoot(root_context)
        errors = self._sot.GetOutputPort("errors").Eval(context)
        for task, rows in self._slices.items():
            norm = float(np.linalg.norm(errors[rows]))
            self._meshcat.SetSliderValue(self._slider(task), min(norm, 1.0) if math.isfinite(norm) else 0.0)
        buttons = [f"stack {i + 1}: {name}" for i, name in enumerate(self._sot.list(root_context))]
        if buttons != self._buttons:
            for name in self._buttons:
                self._meshcat.DeleteButton(name, strict=False)
            for name in buttons:
                self._meshcat.AddButton(name)
            self._buttons = buttons
