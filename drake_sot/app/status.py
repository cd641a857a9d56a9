"""The stack and the task errors of a served scenario, live in Meshcat's controls.

Meshcat's controls are buttons and sliders: each task of the solver gets a slider per unit of
its error, ``log10 |e| TASK [UNIT]``, holding the decimal logarithm of the norm of the rows of
its error in that unit (a 6D pose task has one in m and one in rad; a task whose units are not
known, one marked ``[?]``), on [:data:`LOG_MIN`, :data:`LOG_MAX`] — a norm outside that range
sits at the end it passed, and a task out of the stack (its error NaN) at :data:`LOG_MIN`. The
stack is a column of buttons ``stack 1: NAME``, ``stack 2: NAME``… (highest priority first),
rewritten when the stack changes. The same samples feed the live plot
(:mod:`drake_sot.app.live_plot`). Sampled by the serving loop, which owns the context, every
``period`` simulated seconds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.systems.framework import Context

from drake_sot.systems.sot import StackOfTasks
from drake_sot.validation import positive

#: The sliders' range: log10 of an error norm, 1e-6 (a micrometre, a microradian) to 10.
LOG_MIN, LOG_MAX = -6.0, 1.0

#: Simulated seconds between two samples of the live views.
SAMPLE_PERIOD = 0.1


@dataclass(frozen=True)
class ErrorSample:
    """The task errors and the stack at one tick, as the live views show them.

    Attributes:
        t: simulated time [s].
        norms: slider name (:func:`slider_name`: a task and a unit) → log10 of the norm of the
            task's error rows in that unit (:func:`log_norm`), in the order of the solver's rows.
        stack: the solver's stack, highest priority first.
    """

    t: float
    norms: dict[str, float]
    stack: tuple[str, ...]


class TaskErrorSampler:
    """Samples ``sot``'s task errors (per task and unit, on the log scale) and its stack every
    ``period`` simulated seconds, for the live views.

    Args:
        sot: the solver whose ``errors`` and stack are sampled.
        period: simulated seconds between samples, > 0.
        units: each task's unit per row of its error (``Task.units``: "m", "rad", ...); a task
            missing here gets one series for all its rows, marked ``[?]``.
    """

    def __init__(
        self,
        sot: StackOfTasks,
        period: float = SAMPLE_PERIOD,
        units: Mapping[str, Sequence[str]] | None = None,
    ) -> None:
        self._sot = sot
        self._period = positive("period", period, unit="s")
        self._due = -math.inf
        #: (series name, the rows of ``errors`` it shows)
        self._series: list[tuple[str, np.ndarray]] = []
        units = units or {}
        for task, rows in sot.error_slices().items():
            indices = np.arange(rows.start, rows.stop)
            per_row = units.get(task)
            if per_row is None or len(per_row) != len(indices):
                self._series.append((slider_name(task, "?"), indices))
                continue
            per_row = np.array(per_row, dtype=object)
            for unit in dict.fromkeys(per_row):  # in the order of the rows
                self._series.append((slider_name(task, unit or "?"), indices[per_row == unit]))

    @property
    def names(self) -> list[str]:
        """The series, in the order of the solver's rows."""
        return [name for name, _ in self._series]

    def sample(self, root_context: Context) -> ErrorSample | None:
        """The sample at the context's time when one is due, else None."""
        t = root_context.get_time()
        if t < self._due:
            return None
        self._due = t + self._period
        errors = self._sot.GetOutputPort("errors").Eval(self._sot.GetMyContextFromRoot(root_context))
        norms = {name: log_norm(errors[rows]) for name, rows in self._series}
        return ErrorSample(t, norms, tuple(self._sot.list(root_context)))


class MeshcatStatus:
    """Shows the samples of a :class:`TaskErrorSampler` in ``meshcat``'s controls: a slider per
    series, the stack as a column of buttons.

    Args:
        meshcat: the live viewer.
        names: the sampler's series (:attr:`TaskErrorSampler.names`).
    """

    def __init__(self, meshcat: Meshcat, names: Sequence[str]) -> None:
        self._meshcat = meshcat
        self._buttons: list[str] = []
        for name in names:
            meshcat.AddSlider(name, LOG_MIN, LOG_MAX, 0.01, LOG_MIN)

    def show(self, sample: ErrorSample) -> None:
        """Set the sliders and rewrite the stack's buttons when it changed."""
        for name, value in sample.norms.items():
            self._meshcat.SetSliderValue(name, value)
        buttons = [f"stack {i + 1}: {name}" for i, name in enumerate(sample.stack)]
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
