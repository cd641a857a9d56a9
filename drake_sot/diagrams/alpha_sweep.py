"""Study ``alpha_sweep`` (Liu, Lober, Padois 2016, fig. 11): steady-state errors of the head and left-hand
tasks of ``priority_switching`` over a grid of constant (α_lh,head, α_head,lh).

Each grid point is one simulation of the fixed-base robot with constant priorities; the
points run in parallel worker processes.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams import priority_switching as ps
from drake_sot.diagrams.alpha_sweep_plots import plot_alpha_sweep
from drake_sot.diagrams.artifacts import Artefacts, output_directory, write_npz
from drake_sot.diagrams.run import Interrupted, SignalGuard, simulate
from drake_sot.parameters import Parameter
from drake_sot.robots import get_robot
from drake_sot.transitions import AlphaSchedule
from drake_sot.validation import positive

GRID = tuple(np.round(np.linspace(0.0, 1.0, 6), 3))  # {0, 0.2, ..., 1}
SETTLE = 4.0  # [s] simulated per point; errors averaged over the last second
#: The most worker processes a study starts: four per core of this machine. A worker
#: simulates one run at a time on one core and holds its own Drake (~0.3 GB): more only
#: wait for a core and fill the memory (``--workers 100000`` started 225 processes and
#: 10 GB before it was killed).
MAX_WORKERS = 4 * (os.cpu_count() or 1)


#: The worker processes of a study, at most :data:`MAX_WORKERS`.
WORKERS = Parameter(
    "workers",
    "int",
    2,
    f"worker processes (at most four per core of this machine's {MAX_WORKERS // 4})",
    minimum=1,
    maximum=MAX_WORKERS,
)


def steady_errors(
    alpha_lh_head: float, alpha_head_lh: float, duration: float = SETTLE, robot: str = "embedded"
) -> tuple[float, float]:
    """(head, left-hand) mean error norm [m] over the last second of a run with constant α on
    ``robot`` (a name of ``drake_sot.robots.ROBOTS``)."""
    setup = ps.build_with(
        AlphaSchedule(list(ps.TASKS), ps.initial_alpha(alpha_lh_head, alpha_head_lh)),
        duration=duration,
        robot=robot,
    )
    simulator = setup.built.create_simulator()
    result = simulate(simulator, duration)
    if not result.completed:
        raise RuntimeError(f"α = ({alpha_lh_head}, {alpha_head_lh}): {result.failure}")
    log = setup.built.loggers["errors"].FindLog(simulator.get_context())
    slices = setup.built.error_slices()
    window = log.sample_times() >= duration - 1.0
    data = log.data()[:, window]
    return tuple(
        float(np.mean(np.linalg.norm(data[slices[name]], axis=0))) for name in ("taskHead", "taskLH")
    )


def _point(args: tuple[float, float, float, str]) -> tuple[float, float, float, float]:
    a, b, duration, robot = args
    return (a, b, *steady_errors(a, b, duration, robot))


@dataclass(frozen=True)
class Study:
    """A named batch of simulations of the ``drake-sot`` command."""

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
    """Run the sweep on ``robot`` in ``workers`` processes (at most :data:`MAX_WORKERS`); write
    ``alpha_sweep.npz`` and ``alpha_sweep.png`` (returned: a file that could not be written, a full
    disk, is in ``unwritten`` and the other is still written). An unknown robot, or one whose
    models are missing, is refused before any worker starts.

    Ctrl-C or SIGTERM stops the sweep: the points not yet done are cancelled (their errors
    stay NaN, and ``done`` in the npz says which were), the workers are terminated, both
    files are written (a further signal waits for them), then the signal is raised again as
    :class:`~drake_sot.diagrams.run.Interrupted` for the caller (the command exits 130/143).
    """
    duration = positive("duration", duration, unit="s")
    workers = WORKERS.check(workers)
    get_robot(robot)
    out = output_directory(out_dir)
    points = [(a, b, duration, robot) for a in grid for b in grid]
    head = np.full((len(grid), len(grid)), np.nan)
    lh = np.full_like(head, np.nan)
    index = {value: k for k, value in enumerate(grid)}
    start = time.perf_counter()
    stopped: Interrupted | None = None
    with SignalGuard() as guard:
        # spawn, not fork: the caller may already run Drake or Meshcat threads. The workers
        # ignore SIGINT (a terminal sends it to the whole group): this process decides.
        pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_start_worker)
        try:
            for done, (a, b, e_head, e_lh) in enumerate(pool.imap_unordered(_point, points), start=1):
                head[index[a], index[b]], lh[index[a], index[b]] = e_head, e_lh
                if progress:
                    progress(done, len(points), time.perf_counter() - start)
            pool.close()
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (SignalGuard raises Interrupted)
            stopped = exc if isinstance(exc, Interrupted) else Interrupted(signal.SIGINT)
            pool.terminate()
        finally:
            guard.hold()
            pool.join()
        arrays = {
            "alpha_lh_head": np.array(grid),
            "alpha_head_lh": np.array(grid),
            "head_error": head,
            "lh_error": lh,
            "done": np.isfinite(head) & np.isfinite(lh),
        }
        artefacts = Artefacts()
        artefacts.write("npz", out / "alpha_sweep.npz", lambda path: write_npz(arrays, path))
        artefacts.write(
            "png", out / "alpha_sweep.png", lambda path: plot_alpha_sweep(np.array(grid), head, lh, path)
        )
    if stopped is not None:
        raise stopped
    return artefacts


def _start_worker() -> None:
    """A study worker's start: it ignores SIGINT (the parent decides) and runs its small
    matrices on one BLAS thread (:mod:`drake_sot.blas` says why)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    limit_blas_threads(1)


STUDY = Study(
    name="alpha_sweep",
    description="steady head and left-hand errors over a 6x6 grid of priorities, in parallel "
    "(Liu, Lober, Padois 2016, fig. 11)",
    run=run,
    parameters=(WORKERS,),
)
