"""Study ``alpha_sweep`` (Liu, Lober, Padois 2016, fig. 11): steady-state errors of the head and left-hand
tasks of ``priority_switching`` over a grid of constant (α_lh,head, α_head,lh).

Each grid point is one run of the fixed-base robot with constant priorities
(:data:`drake_sot.studies.catalog.ALPHA_SWEEP`, measured by
:func:`drake_sot.diagrams.study_runs.measure`), on Dask (:mod:`drake_sot.studies.runner`):
``drake-sot study alpha_sweep``, or ``drake-sot run alpha_sweep`` (:func:`run`, a local cluster).
:func:`drake_sot.diagrams.alpha_sweep_plots.write_figures` turns the runs' table into the grid's
npz and heat maps.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from drake_sot.diagrams.artifacts import Artefacts, output_directory
from drake_sot.diagrams.study_runs import measure
from drake_sot.diagrams.study_session import run_with_figures
from drake_sot.parameters import Parameter
from drake_sot.robots import get_robot
from drake_sot.studies.catalog import ALPHA_GRID, ALPHA_SWEEP
from drake_sot.studies.description import Grid
from drake_sot.validation import positive

GRID = ALPHA_GRID  # {0, 0.2, ..., 1}
SETTLE = ALPHA_SWEEP.duration  # [s] simulated per point; errors averaged over the last second
#: The most worker processes ``run`` accepts: four per core of this machine (the local cluster
#: then starts at most one per core, and says so: a run is CPU-bound on one core, and each
#: worker holds its own Drake, ~0.3 GB).
MAX_WORKERS = 4 * (os.cpu_count() or 1)


#: The worker processes of a study, at most :data:`MAX_WORKERS` (capped at the cores).
WORKERS = Parameter(
    "workers",
    "int",
    2,
    f"worker processes (at most one per core of this machine's {MAX_WORKERS // 4} is started)",
    minimum=1,
    maximum=MAX_WORKERS,
)


def steady_errors(
    alpha_lh_head: float, alpha_head_lh: float, duration: float = SETTLE, robot: str = "embedded"
) -> tuple[float, float]:
    """(head, left-hand) mean error norm [m] over the last second of a run with constant α on
    ``robot`` (a name of ``drake_sot.robots.ROBOTS``), in this process.

    Raises:
        RuntimeError: the run failed.
    """
    metrics = measure(
        ALPHA_SWEEP.scenario,
        {"alpha_lh_head": alpha_lh_head, "alpha_head_lh": alpha_head_lh, "robot": robot},
        duration,
        0,
    )
    return metrics["steady_error_head"], metrics["steady_error_lh"]


@dataclass(frozen=True)
class StudyScenario:
    """A study as ``drake-sot run`` runs it, beside the scenarios: on a local cluster, with its
    own options (what the study itself is, a :class:`drake_sot.studies.Study`, is its ``run``'s)."""

    name: str
    description: str
    run: Callable[..., Artefacts]
    parameters: tuple[Parameter, ...] = ()  # keyword arguments ``run`` takes (the CLI's options)


def run(
    out_dir: str | Path,
    *,
    grid: Sequence[float] = GRID,
    duration: float = SETTLE,
    workers: int = 2,
    progress: Callable[[float, float, float], None] | None = None,
    robot: str = "embedded",
) -> Artefacts:
    """Run the sweep on ``robot`` on a local Dask cluster of ``workers`` processes (at most
    :data:`MAX_WORKERS`, capped at the cores); write the runs' table (``alpha_sweep_runs.csv``
    and ``.npz``), ``alpha_sweep.npz`` and ``alpha_sweep.png`` (returned; what a full disk kept
    from being written is in ``unwritten``); ``progress(done, total, wall time)``. An unknown
    robot, or one whose models are missing, is refused before any worker
    starts. Given the same ``out_dir`` again, the points already done are not run again.

    Ctrl-C or SIGTERM stops the sweep: the points not yet done are cancelled (their errors
    stay NaN, and ``done`` in the npz says which were), the workers end, the files are written
    (a further signal waits for them), then the signal is raised again as
    :class:`~drake_sot.diagrams.run.Interrupted` for the caller (the command exits 130/143).

    Raises:
        ValueError: a bad ``duration``, ``workers``, grid value or robot name.
    """
    duration = positive("duration", duration, unit="s")
    workers = WORKERS.check(workers)
    get_robot(robot)
    study = dataclasses.replace(
        ALPHA_SWEEP,
        runs=Grid({"alpha_lh_head": tuple(grid), "alpha_head_lh": tuple(grid)}),
        duration=duration,
        fixed={"robot": robot},
    )
    start = time.perf_counter()

    def report(done: int, failed: int, total: int, left: float) -> None:
        if progress is not None:
            progress(done, total, time.perf_counter() - start)

    session = run_with_figures(study, output_directory(out_dir), workers=workers, progress=report)
    if session.stopped is not None:
        raise session.stopped
    return session.artefacts


STUDY = StudyScenario(
    name="alpha_sweep",
    description="steady head and left-hand errors over a 6x6 grid of priorities, on a local Dask "
    "cluster (Liu, Lober, Padois 2016, fig. 11; 'drake-sot study alpha_sweep' also runs it on a cluster)",
    run=run,
    parameters=(WORKERS,),
)
