"""What a study is, as data (pure: no Drake, no Dask): a scenario run many times.

A :class:`Study` names a scenario (or another run target of the measuring side, e.g. the
constant-priority ``priority_switching`` of Liu, Lober, Padois 2016, fig. 11), the runs (a
:class:`Grid` over named parameters, a seeded :class:`RandomSample` or a :class:`Bisection` of one
parameter per cell of a grid), the simulated duration of each run and the metrics recorded.

A run is a plain dict of named parameter values with a stable id (:func:`run_id`: a hash of the
target, the values and the duration, so that a study given the same output directory finds its
finished runs again) and a seed derived from that id. :func:`plans` turns a study into plans:
generators that yield one :class:`Run` at a time and receive its metrics (None when it failed),
so that a bisection chooses its next probe from the last result while the cells run in parallel.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Generator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_sot import validation
from drake_sot.parameters import Parameter, check_parameters

__all__ = [
    "Bisection",
    "Grid",
    "Metrics",
    "Plan",
    "RandomSample",
    "Run",
    "Study",
    "check_study",
    "make_run",
    "plans",
    "run_id",
]

Value = float | int | bool | str
#: What a run measured, by metric name (a number or a bool).
Metrics = dict[str, Value]


@dataclass(frozen=True)
class Grid:
    """Every combination of the values of ``axes`` (name → values), the first axis varying
    slowest."""

    axes: Mapping[str, Sequence[Value]]

    def points(self) -> list[dict[str, Value]]:
        """The combinations, each as name → value."""
        names = list(self.axes)
        return [dict(zip(names, values, strict=True)) for values in itertools.product(*self.axes.values())]


@dataclass(frozen=True)
class RandomSample:
    """``count`` points drawn uniformly in ``ranges`` (name → (low, high)) by a generator seeded
    with ``seed``: the same seed gives the same points."""

    ranges: Mapping[str, tuple[float, float]]
    count: int
    seed: int = 0

    def points(self) -> list[dict[str, Value]]:
        """The drawn points, each as name → value."""
        rng = np.random.default_rng(self.seed)
        draws = {name: rng.uniform(low, high, self.count) for name, (low, high) in self.ranges.items()}
        return [{name: float(draws[name][k]) for name in self.ranges} for k in range(self.count)]


@dataclass(frozen=True)
class Bisection:
    """Per cell of ``cells``, the largest value of ``parameter`` in [``low``, ``high``] for which
    the bool metric ``metric`` is true (e.g. the largest push the robot survives), assuming it is
    true at ``low`` and switches once. ``high`` is tried first (true: the answer is ``high``), then
    ``iterations`` midpoints, so that the answer is within (high - low) / 2**iterations."""

    cells: Grid
    parameter: str
    low: float
    high: float
    iterations: int
    metric: str = "survived"

    def __post_init__(self) -> None:
        validation.positive_int("Bisection.iterations", self.iterations, minimum=1)
        if not (self.low < self.high):
            raise ValueError(f"Bisection: low = {self.low!r}, high = {self.high!r}: need low < high")


@dataclass(frozen=True)
class Study:
    """A named batch of runs of one target.

    Attributes:
        name: the study's name (its files are ``<name>_runs.csv`` and ``<name>_runs.npz``).
        description: one line, for ``drake-sot study --list``.
        scenario: the run target's name (a scenario of the measuring side).
        runs: a :class:`Grid`, a :class:`RandomSample` or a :class:`Bisection`.
        duration: the simulated time of each run [s].
        metrics: the metrics recorded, in the table's column order.
        fixed: parameters every run takes (name → value), beside the varied ones.
    """

    name: str
    description: str
    scenario: str
    runs: Grid | RandomSample | Bisection
    duration: float
    metrics: tuple[str, ...]
    fixed: Mapping[str, Value] = field(default_factory=dict)

    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter of a run, in the table's column order: the fixed ones, then the varied."""
        if isinstance(self.runs, Bisection):
            varied = [*self.runs.cells.axes, self.runs.parameter]
        elif isinstance(self.runs, Grid):
            varied = list(self.runs.axes)
        else:
            varied = list(self.runs.ranges)
        return tuple(dict.fromkeys([*self.fixed, *varied]))

    def total(self) -> int:
        """The number of runs (for a bisection, the most it makes: ``iterations + 1`` per cell)."""
        if isinstance(self.runs, Bisection):
            return len(self.runs.cells.points()) * (self.runs.iterations + 1)
        if isinstance(self.runs, Grid):
            return len(self.runs.points())
        return self.runs.count


def run_id(scenario: str, parameters: Mapping[str, Value], duration: float) -> str:
    """A stable id of a run: 16 hex digits of the SHA-256 of the target, the sorted parameters and
    the duration (as JSON), the same in every process and session."""
    text = json.dumps(
        {"scenario": scenario, "parameters": dict(sorted(parameters.items())), "duration": duration},
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Run:
    """One run: its id, target, parameters (name → value), duration [s] and seed."""

    run_id: str
    scenario: str
    parameters: dict[str, Value]
    duration: float
    seed: int


def make_run(scenario: str, parameters: Mapping[str, Value], duration: float) -> Run:
    """The :class:`Run` of ``parameters``; its seed is the first 31 bits of its id."""
    identifier = run_id(scenario, parameters, duration)
    return Run(identifier, scenario, dict(parameters), duration, int(identifier[:8], 16) >> 1)


def check_study(study: Study, declared: Sequence[Parameter]) -> list[dict[str, Value]]:
    """Every parameter value the study can give a run, checked through the target's ``declared``
    parameters; returns the checked points of the study (a bisection's cells with ``low`` and
    ``high``).

    Raises:
        ValueError: a bad duration, an empty study, a parameter the target does not declare
            (listing those it does) or a value its declaration refuses (naming it and what is
            accepted), a random range of a parameter that is not a float, or a bisection on a
            parameter that is not a float.
    """
    validation.positive("duration", study.duration, unit="s")
    by_name = {p.name: p for p in declared}
    if isinstance(study.runs, Bisection):
        bisected = by_name.get(study.runs.parameter)
        if bisected is not None and bisected.kind != "float":
            raise ValueError(f"{study.name}: bisection on {study.runs.parameter!r}, a {bisected.kind}")
        cells = study.runs.cells.points()
        points = [c | {study.runs.parameter: v} for c in cells for v in (study.runs.low, study.runs.high)]
    elif isinstance(study.runs, RandomSample):
        validation.positive_int("RandomSample.count", study.runs.count, minimum=1)
        for name in study.runs.ranges:
            if name in by_name and by_name[name].kind != "float":
                raise ValueError(f"{study.name}: a random range on {name!r}, a {by_name[name].kind}")
        points = [{name: bounds[end] for name, bounds in study.runs.ranges.items()} for end in (0, 1)]
    else:
        points = study.runs.points()
    if not points:
        raise ValueError(f"{study.name}: no run (an axis without values)")
    return [check_parameters(study.scenario, declared, {**study.fixed, **point}) for point in points]


Plan = Generator[Run, Metrics | None, tuple[float, float] | None]
"""Yields runs one at a time and is sent each one's metrics (None: it failed); a bisection's
plan returns its bracket (largest true, smallest false), the others None."""


def plans(study: Study, declared: Sequence[Parameter]) -> list[Plan]:
    """The study's plans (see :data:`Plan`), each run's parameters checked through ``declared``
    (raises as :func:`check_study` does, before any plan starts)."""
    check_study(study, declared)

    def run_of(point: Mapping[str, Value]) -> Run:
        checked = check_parameters(study.scenario, declared, {**study.fixed, **point})
        return make_run(study.scenario, checked, study.duration)

    if isinstance(study.runs, Bisection):
        return [_bisect(study.runs, cell, run_of) for cell in study.runs.cells.points()]
    return [_single(run_of(point)) for point in study.runs.points()]


def _single(run: Run) -> Plan:
    yield run
    return None


def _bisect(bisection: Bisection, cell: Mapping[str, Value], run_of: Any) -> Plan:
    """Bisection on ``bisection.parameter`` in ``cell``: ``high``, then the midpoints. A failed
    run ends the cell with an unknown bracket (NaN, NaN)."""
    true, false = bisection.low, bisection.high
    metrics = yield run_of({**cell, bisection.parameter: false})
    if metrics is None:
        return math.nan, math.nan
    if metrics.get(bisection.metric) is True:
        return false, math.inf
    for _ in range(bisection.iterations):
        middle = 0.5 * (true + false)
        metrics = yield run_of({**cell, bisection.parameter: middle})
        if metrics is None:
            return math.nan, math.nan
        if metrics.get(bisection.metric) is True:
            true = middle
        else:
            false = middle
    return true, false
