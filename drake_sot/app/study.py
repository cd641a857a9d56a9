"""``drake-sot study NAME [--scheduler ADDRESS] [--workers N] [--out DIR] [--duration S]`` and
``drake-sot study --list``: a study of :data:`drake_sot.studies.catalog.STUDIES` run on Dask
(:mod:`drake_sot.studies.runner`), its table and figures written into ``--out``.

Without ``--scheduler`` the runs go to a local cluster of worker processes (``--workers``, at
most one per core and per run: one line says so when capped); with ``--scheduler
tcp://HOST:PORT``, to the workers of that Dask scheduler (``dask scheduler``, then ``dask worker
tcp://HOST:PORT`` on each machine). Given the same ``--out`` again, a study runs only what its
table does not hold yet.

Exit status: 0 every run ok, 1 some runs failed (the table says which and why), the scheduler
could not be reached or a figure could not be written (a full disk: one line names it), 2 bad
arguments (nothing run), 130 interrupted by SIGINT (Ctrl-C), 143 by
SIGTERM: the pending runs are cancelled, the finished ones are in the table, the figures cover
them and no worker process is left.
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from drake_sot.diagrams.alpha_sweep import MAX_WORKERS, WORKERS
from drake_sot.diagrams.artifacts import output_directory, report_unwritten
from drake_sot.diagrams.run import MAX_DURATION, check_duration
from drake_sot.diagrams.study_session import run_with_figures
from drake_sot.studies.catalog import STUDIES
from drake_sot.studies.description import Study
from drake_sot.studies.runner import missing_directories, remove_empty
from drake_sot.validation import is_number

EPILOG = (
    "exit status: 0 every run ok, 1 some runs failed (see the table), no scheduler or a figure not "
    "written, 2 bad arguments, "
    "130 interrupted (Ctrl-C), 143 SIGTERM"
)


def _workers(text: str) -> int:
    """An argparse ``type``: ``--workers``, an integer in [1, :data:`MAX_WORKERS`]."""
    try:
        value = int(text)
    except ValueError:  # not an integer, or beyond 4300 digits
        raise argparse.ArgumentTypeError(f"workers = {text!r}: must be {WORKERS.accepted()}") from None
    try:
        return int(WORKERS.check(value))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


#: A Dask scheduler's address: ``tcp://`` or ``tls://``, a host name or an IPv4 address (or an
#: IPv6 one in brackets), a port.
SCHEDULER_ADDRESS = re.compile(r"(?:tcp|tls)://(?:[A-Za-z0-9._-]+|\[[0-9A-Fa-f:.]+\]):([0-9]{1,5})")


def _scheduler(text: str) -> str:
    """An argparse ``type``: ``--scheduler``, ``tcp://HOST:PORT`` (or ``tls://``), PORT in [1, 65535]."""
    match = SCHEDULER_ADDRESS.fullmatch(text)
    if match is None or not (1 <= int(match[1]) <= 65535):
        raise argparse.ArgumentTypeError(
            f"scheduler = {text!r}: must be tcp://HOST:PORT (or tls://HOST:PORT), PORT in [1, 65535]"
        )
    return text


def _duration(text: str) -> float:
    """An argparse ``type``: ``--duration``, checked by :func:`check_duration`."""
    try:
        return check_duration("duration", float(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            str(exc) if is_number(text) else f"duration = {text!r}: must be a number"
        ) from None


def add_arguments(parser: argparse.ArgumentParser, studies: Mapping[str, Study] = STUDIES) -> None:
    """The arguments of ``study``, on ``parser`` (which :func:`study_command` reports errors with)."""
    parser.set_defaults(study_parser=parser)
    names = sorted(studies)
    parser.add_argument("name", nargs="?", metavar="NAME", help=f"the study, one of: {', '.join(names)}")
    parser.add_argument("--list", action="store_true", help="list the studies")
    parser.add_argument(
        "--scheduler",
        type=_scheduler,
        default=None,
        metavar="ADDRESS",
        help="the Dask scheduler to run on (tcp://HOST:PORT, see 'dask scheduler'); default: a local "
        "cluster of worker processes",
    )
    parser.add_argument(
        "--workers",
        type=_workers,
        default=None,
        metavar="N",
        help=f"local worker processes, at most {MAX_WORKERS} (default: one per core; at most one per core "
        "and per run are started)",
    )
    parser.add_argument("--out", default="out", metavar="DIR", help="output directory (default: out/)")
    parser.add_argument(
        "--duration",
        type=_duration,
        default=None,
        metavar="S",
        help=f"simulated seconds of each run (default: the study's), at most {MAX_DURATION:g}",
    )


def _progress(done: int, failed: int, total: int, left: float) -> None:
    eta = "" if left != left else f", about {left:.0f} s left"
    print(f"{done}/{total} runs done, {failed} failed{eta}", file=sys.stderr, flush=True)


def _check_out(parser: argparse.ArgumentParser, out: str) -> None:
    """Exit 2 with one line, as ``run --out`` does, when ``out`` cannot be the output directory (an
    empty name, a file, a path under a file, no write permission); the directories the check made
    are removed again (the study makes them, and removes them when no scheduler answers); a name
    that is no path (a NUL byte, a character the file system's encoding refuses) is refused too."""
    made: list[Path] = []
    try:
        made = missing_directories(Path(out)) if out else []
        output_directory(out)
    except ValueError as exc:  # a NUL byte, a lone surrogate the file system's encoding refuses
        parser.error(f"--out: {out!r}: not a path ({exc})")
    except OSError as exc:
        parser.error(f"--out: {exc}")
    finally:
        remove_empty(made)


def describe(study: Study) -> str:
    """The line ``--list`` (and ``drake-sot list``) gives ``study`` after its name."""
    return f"{study.description} ({study.total()} runs of {study.scenario})"


def study_command(args: argparse.Namespace, studies: Mapping[str, Study] = STUDIES) -> int:
    """Run ``drake-sot study`` with the ``args`` parsed by a parser given :func:`add_arguments`;
    its exit status (see the module)."""
    parser: argparse.ArgumentParser = args.study_parser
    if args.list:
        for name in sorted(studies):
            print(f"{name:20s} {describe(studies[name])}")
        return 0
    if args.name is None:
        parser.error("give a study's NAME (or --list)")
    if args.name not in studies:
        parser.error(f"study {args.name!r}: unknown; one of: {', '.join(sorted(studies))}")
    if args.scheduler is not None and args.workers is not None:
        parser.error("--workers is for the local cluster: a --scheduler's cluster has its own workers")
    _check_out(parser, args.out)
    study = studies[args.name]
    if args.duration is not None:
        study = dataclasses.replace(study, duration=args.duration)
    try:
        session = run_with_figures(
            study, Path(args.out), scheduler=args.scheduler, workers=args.workers, progress=_progress
        )
    except ValueError as exc:  # refused before anything ran: the study, the table, the workers
        parser.error(str(exc))
    except OSError as exc:  # no scheduler at --scheduler (or --out made unwritable since its check)
        print(f"drake-sot study: {exc}", file=sys.stderr)
        return 1
    files, unwritten = session.artefacts.files, session.artefacts.unwritten
    for path in files.values():
        print(f"wrote {path}")
    report_unwritten(unwritten)
    table = Path(args.out) / f"{study.name}_runs.csv"
    if session.stopped is not None:
        done = f"the {len(session.rows)} runs done are in {table}" if session.rows else "no run was done"
        print(f"interrupted by {session.stopped.signum.name}: {done}", file=sys.stderr)
        return 128 + session.stopped.signum
    if session.failed:
        print(f"{session.failed} runs failed: their errors are in {table}", file=sys.stderr)
        return 1
    return 1 if unwritten else 0


def main(argv: Sequence[str] | None = None, studies: Mapping[str, Study] = STUDIES) -> int:
    """``drake-sot study`` alone, on ``studies`` (e.g. a study of one's own); its exit status."""
    parser = argparse.ArgumentParser(prog="drake-sot study", epilog=EPILOG)
    add_arguments(parser, studies)
    return study_command(parser.parse_args(argv), studies)
