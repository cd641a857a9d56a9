"""A study of :data:`drake_sot.studies.catalog.STUDIES` run on Dask with its figures: the one call of
:func:`~drake_sot.studies.runner.run_study` that ``drake-sot study NAME`` and ``drake-sot run
alpha_sweep`` share (the target's declarations and :func:`~drake_sot.diagrams.study_runs.measure`,
a :class:`~drake_sot.diagrams.run.SignalGuard`, the table and its figures written even when a
signal stops the study)."""

from __future__ import annotations

import signal
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drake_sot.diagrams import alpha_sweep_plots, delay_sweep_plots, gain_sweep_plots, push_recovery_plots
from drake_sot.diagrams.artifacts import Artefacts
from drake_sot.diagrams.run import Interrupted, SignalGuard
from drake_sot.diagrams.study_runs import TARGETS, measure
from drake_sot.studies.description import Study
from drake_sot.studies.runner import Progress, read_table, run_study

#: What writes the figures of a study from its table's rows, by study name:
#: ``write(study, rows, out_dir)`` -> name -> file.
STUDY_FIGURES: dict[str, Callable[[Study, Mapping[str, Mapping[str, Any]], Path], dict[str, Path]]] = {
    "alpha_sweep": alpha_sweep_plots.write_figures,
    "push_recovery": push_recovery_plots.write_figures,
    "gain_sweep": gain_sweep_plots.write_figures,
    "delay_sweep": delay_sweep_plots.write_figures,
}


@dataclass
class StudySession:
    """What :func:`run_with_figures` did.

    Attributes:
        rows: every run of the table by id (this session's and earlier ones).
        failed: the runs of this session that failed.
        artefacts: the table (``table``, ``runs``) and the figures written (their keys as
            :data:`STUDY_FIGURES` names them); what a full disk kept from being written, in
            ``unwritten``.
        stopped: the signal that stopped the study (None: it ran to its end).
    """

    rows: dict[str, dict[str, Any]]
    failed: int
    artefacts: Artefacts
    stopped: Interrupted | None


def run_with_figures(
    study: Study,
    out: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
) -> StudySession:
    """Run ``study`` into ``out`` (see :func:`~drake_sot.studies.runner.run_study`: a local
    cluster of ``workers`` processes, or the Dask scheduler at ``scheduler``), then write its
    figures (when :data:`STUDY_FIGURES` has some, and a run of its table is ok: none when none
    is, as when a signal stops the study before its first run ends) from every run of its table.
    Ctrl-C or SIGTERM stops it: the pending runs are cancelled, the figures cover the finished ones
    and the signal is in :attr:`StudySession.stopped` (a further signal waits until the files are
    written).

    Raises:
        ValueError: the study, the table in ``out`` or ``workers`` refused before anything ran.
        OSError: ``out`` cannot be written, or no scheduler answers at ``scheduler``.
    """
    stopped: Interrupted | None = None
    declared = TARGETS[study.scenario].parameters
    with SignalGuard() as guard:
        try:
            outcome = run_study(
                study,
                out,
                declared=declared,
                measure=measure,
                scheduler=scheduler,
                workers=workers,
                progress=progress,
                hold=guard.hold,
            )
            rows, failed = outcome.rows, outcome.failed
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (SignalGuard raises Interrupted)
            stopped = exc if isinstance(exc, Interrupted) else Interrupted(signal.SIGINT)
            rows, failed = read_table(out / f"{study.name}_runs.csv", study, declared=declared), 0
        table = {"table": out / f"{study.name}_runs.csv", "runs": out / f"{study.name}_runs.npz"}
        artefacts = Artefacts(files={key: path for key, path in table.items() if path.exists()})
        if study.name in STUDY_FIGURES and any(row["status"] == "ok" for row in rows.values()):
            write = STUDY_FIGURES[study.name]
            artefacts.write_several(str(out / f"{study.name}.*"), lambda: write(study, rows, out))
    return StudySession(rows, failed, artefacts, stopped)
