"""The stack and the task errors of a served scenario, live in Meshcat's controls.

Meshcat's controls are buttons and sliders: each task of the solver gets a slider per unit of
its error, ``log10 |e| TASK [UNIT]``, holding the decimal logarithm of the norm of the rows of
its error in that unit (a 6D pose task has one in m and one in rad; a task whose units are not
known, one marked ``[?]``), on [:data:`LOG_MIN`, :data:`LOG_MAX`] — a norm outside that range
sits at the end it passed, and a task out of the stack (its error NaN) at :data:`LOG_MIN`. The
stack is a column of buttons ``stack 1: NAME``, ``stack 2: NAME``… (highest priority first),
rewritten when the stack changes. Updated by the serving loop, which owns the context, every
``period`` simulated seconds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.framework import Context

from drake_sot.systems.sot import StackOfTasks
from drake_sot.validation import positive

#: The sliders' range: log10 of an error norm, 1e-6 (a micrometre, a microradian) to 10.
LOG_MIN, LOG_MAX = -6.0, 1.0


class MeshcatStatus:
    """Shows ``sot``'s stack and task errors in ``meshcat``'s controls.

    Args:
        meshcat: the live viewer.
        sot: the solver whose ``errors`` and stack are shown.
        period: simulated seconds between updates, > 0.
        units: each task's unit per row of its error (``Task.units``: "m", "rad", ...); a task
            missing here gets one slider for all its rows, marked ``[?]``.
    """

    def __init__(
        self,
        meshcat: Meshcat,
        sot: StackOfTasks,
        period: float = 0.1,
        units: Mapping[str, Sequence[str]] | None = None,
    ) -> None:
        self._meshcat, self._sot = meshcat, sot
        self._period = positive("period", period, unit="s")
        self._buttons: list[str] = []
        self._due = -math.inf
        #: (slider name, the rows of ``errors`` it shows)
        self._sliders: list[tuple[str, np.ndarray]] = []
        units = units or {}
        for task, rows in sot.error_slices().items():
            indices = np.arange(rows.start, rows.stop)
            per_row = units.get(task)
            if per_row is None or len(per_row) != len(indices):
                self._sliders.append((slider_name(task, "?"), indices))
                continue
            per_row = np.array(per_row, dtype=object)
            for unit in dict.fromkeys(per_row):  # in the order of the rows
                self._sliders.append((slider_name(task, unit or "?"), indices[per_row == unit]))
        for name, _ in self._sliders:
            meshcat.AddSlider(name, LOG_MIN, LOG_MAX, 0.01, LOG_MIN)

    def update(self, root_context: Context) -> None:
        """Refresh the controls when an update is due at the context's time."""
        t = root_context.get_time()
        if t < self._due:
            return
        self._due = t + self._period
        context = self._sot.GetMyContextFromRoot(root_context)
        errors = self._sot.GetOutputPort("errors").Eval(context)
        for name, rows in self._sliders:
            self._meshcat.SetSliderValue(name, log_norm(errors[rows]))
        buttons = [f"stack {i + 1}: {name}" for i, name in enumerate(self._sot.list(root_context))]
        if buttons != self._buttons:
            for name in self._buttons:
                self._meshcat.DeleteButton(name, strict=False)
            for name in buttons:
                self._meshcat.AddButton(name)
            self._buttons = buttons


def slider_name(task: str, unit: str) -> str:
    """The slider of ``task``'s error rows in ``unit``."""
    return f"log10 |e| {task} [{unit}]"


def log_norm(error: np.ndarray) -> float:
    """log10 of ``error``'s norm on the sliders' range: :data:`LOG_MIN` for NaN (out of the
    stack) or a norm below 10^LOG_MIN (zero included), :data:`LOG_MAX` above 10^LOG_MAX."""
    norm = float(np.linalg.norm(error))
    if not (norm > 10.0**LOG_MIN):  # NaN too
        return LOG_MIN
    return min(math.log10(norm), LOG_MAX)
