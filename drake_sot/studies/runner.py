"""Run a :class:`~drake_sot.studies.description.Study` on Dask (``dask.distributed``), one table.

Without a scheduler address the runs go to a ``LocalCluster`` of worker processes on this machine
(one thread each: a run is CPU-bound on one core), at most one per core and per run; with one,
to an existing cluster (``dask scheduler`` and ``dask worker tcp://HOST:PORT`` on any machines
that have this package). A task carries only names and numbers (the target's name, the run's
parameters, duration and seed) and the measuring function by its importable name: the worker
builds its diagram in its own process and returns the run's metrics.

The table, ``<study>_runs.csv`` in the output directory, has one row per run: its id, every
parameter, every metric, the seed, the duration [s], the worker, the wall time [s], the
drake_sot and drake versions of the worker, the status (``ok`` or ``failed``) and the error text.
A row is appended and flushed as each run finishes, so that nothing finished is lost; a study
given the same directory again skips the runs whose last row is ``ok``. ``<study>_runs.npz``
holds the same columns (the last row of each run), written when the study ends or stops (not
while the table has no row: a scheduler that does not answer leaves no file, nor a directory
made for them).

A run that raises, or whose worker dies, is retried once (Dask ``retries=1``; a worker's death
also makes the scheduler move its task to another worker), then recorded as failed with its error;
the study goes on. A KeyboardInterrupt (Ctrl-C, or SIGTERM turned into one by the caller) cancels
what is pending, keeps every finished row, closes the cluster (its processes end) and is raised
again; one that comes while the cluster and its client start is held until they are up (they
cannot be closed half-started), then raised.
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import re
import signal
import socket
import stat
import struct
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from drake_sot.blas import limit_blas_threads
from drake_sot.parameters import Parameter, check_parameters
from drake_sot.studies.description import Metrics, Plan, Run, Study, plans
from drake_sot.validation import is_number

__all__ = [
    "RUN_COLUMNS",
    "STATUSES",
    "Measure",
    "Progress",
    "StudyOutcome",
    "check_speaks_dask",
    "missing_directories",
    "read_table",
    "remove_empty",
    "run_study",
    "table_columns",
    "worker_count",
]

Measure = Callable[[str, dict[str, Any], float, int], Metrics]
"""``measure(target, parameters, duration, seed)``: simulates one run in the calling process
and returns its metrics by name; raises when the run cannot be simulated. Must be importable
by name (a module-level function) for worker processes to find it."""

#: The columns of the table after the parameters and the metrics.
RUN_COLUMNS = (
    "seed",
    "duration",
    "worker",
    "wall_time",
    "drake_sot_version",
    "drake_version",
    "status",
    "error",
)

Progress = Callable[[int, int, int, float], None]
"""Called after each recorded run with (runs done, of which failed, runs in all, estimated
seconds left — NaN before the first run of this session ends)."""


def table_columns(study: Study) -> tuple[str, ...]:
    """The table's header: ``run_id``, the parameters, the metrics, :data:`RUN_COLUMNS`."""
    return ("run_id", *study.parameter_names(), *study.metrics, *RUN_COLUMNS)


#: The columns of :data:`RUN_COLUMNS` that hold numbers (empty in a failed run's row: its wall time).
NUMBER_COLUMNS = ("seed", "duration", "wall_time")
#: The statuses of a run in the table.
STATUSES = ("ok", "failed")
#: A run id as :func:`~drake_sot.studies.description.run_id` makes it.
_RUN_ID = re.compile("[0-9a-f]{16}")


def _value(text: str) -> bool | float | str:
    """A cell of the table as written: ``True``/``False`` as a bool, a number as a float
    (``nan`` included), anything else as the text."""
    if text in ("True", "False"):
        return text == "True"
    try:
        return float(text)
    except ValueError:
        return text


def _as_written(text: str) -> bool:
    """Whether a cell that reads as a number is one as this module writes it: an int's ``str`` (an
    int a float holds exactly, as it is read back) or a float's ``repr`` (``nan``, ``inf`` and
    ``-inf`` included); not ``1e400``, not 5000 digits, not 2**53 + 1, not ``0.50``. A cell that
    reads as no number is left to its column's check."""
    if not is_number(text):
        return True
    with contextlib.suppress(ValueError, OverflowError):  # not an integer, beyond 4300 digits or floats
        number = int(text)
        if str(number) == text:
            return float(number) == number
    return repr(float(text)) == text


def _clipped(text: str) -> str:
    """``repr(text)``, its middle cut when it is long (a cell of thousands of characters)."""
    return repr(text) if len(text) <= 40 else f"{text[:16]!r}…{text[-8:]!r} ({len(text)} characters)"


def _odd_cell(
    study: Study, row: Mapping[str, str], declared: Sequence[Parameter] | None
) -> tuple[str, str] | None:
    """The first cell of a whole row that no run writes, and why (None when there is none): in a
    column of numbers (:data:`NUMBER_COLUMNS`, the parameters, the metrics) a number not as
    written (:func:`_as_written`); in :data:`NUMBER_COLUMNS` no number (empty is a failed run's
    wall time); a metric of an ``ok`` run that is no bool nor number (empty included); a
    parameter its declaration in ``declared`` refuses."""
    for column in (*study.parameter_names(), *study.metrics, *NUMBER_COLUMNS):
        if not _as_written(row[column]):
            return column, "not a number as a run writes it"
    for column in NUMBER_COLUMNS:
        if (row[column] or row["status"] == "ok") and not is_number(row[column]):
            return column, "a number (empty in a failed run's row only)"
    if row["status"] == "ok":
        for metric in study.metrics:
            if not (row[metric] in ("True", "False") or is_number(row[metric])):
                return metric, "a metric of an ok run is a number or a bool"
    if declared is not None:
        for name in study.parameter_names():
            try:
                check_parameters(study.scenario, declared, {name: _value(row[name])})
            except ValueError as exc:
                return name, str(exc)
    return None


def read_table(
    path: str | Path,
    study: Study,
    say: Callable[[str], None] = lambda line: None,
    declared: Sequence[Parameter] | None = None,
) -> dict[str, dict[str, Any]]:
    """The rows of the table at ``path`` (none when there is no file) by run id, the last row of
    a run id winning, cells as :func:`_value` reads them. A row that is not whole (a field
    missing, as the last line of a table cut short, or one too many; a run id that is not 16 hex
    digits, a status that is not one of :data:`STATUSES`) is skipped and ``say`` is told how
    many were, with the file: their runs are run again.

    Raises:
        ValueError: the file is not a readable table (not a regular file: a FIFO, a device, a
            link to one, a directory; not UTF-8 text, a NUL byte, a malformed quote), its header
            is not the study's (another study, or other parameters or metrics), or a whole row
            holds a cell no run writes (a number such as ``1e400`` or of 5000 digits, an ``ok``
            run's metric that is empty or no number, a parameter ``declared`` refuses: an edited
            table), naming the file and what is wrong (and the line and column of a cell).
    """
    path = Path(path)
    columns = table_columns(study)
    rows: dict[str, dict[str, Any]] = {}
    skipped = 0
    try:  # not blocking on a FIFO's open: refused by its type below
        handle = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        if os.path.lexists(path):
            raise ValueError(f"{path}: a link to nothing: give another output directory") from None
        return {}
    except OSError as exc:
        raise ValueError(f"{path}: cannot be read ({exc.strerror}): give another output directory") from None
    kind = os.fstat(handle).st_mode
    if not stat.S_ISREG(kind):
        os.close(handle)
        what = "a FIFO" if stat.S_ISFIFO(kind) else "a directory" if stat.S_ISDIR(kind) else "a device"
        raise ValueError(f"{path}: not a regular file ({what}): give another output directory")
    with open(handle, newline="", encoding="utf-8") as file:
        try:
            reader = csv.reader(file)
            header = tuple(next(reader, ()))
            if header != columns:
                raise ValueError(
                    f"{path}: its columns {list(header)} are not those of study {study.name!r} "
                    f"{list(columns)}: give another output directory"
                )
            for cells in reader:
                if not cells:  # a blank line (a line end written after one cut short at its CR)
                    continue
                row = dict(zip(columns, cells, strict=False))
                if (
                    len(cells) != len(columns)
                    or not _RUN_ID.fullmatch(row["run_id"])
                    or row["status"] not in STATUSES
                ):
                    skipped += 1
                    continue
                odd = _odd_cell(study, row, declared)
                if odd is not None:
                    column, why = odd
                    raise ValueError(
                        f"{path}: line {reader.line_num}: {column} = {_clipped(row[column])}: {why} "
                        "(an edited table?): give another output directory"
                    )
                rows[row["run_id"]] = {k: _value(v) for k, v in row.items()}
        except (UnicodeDecodeError, csv.Error) as exc:
            raise ValueError(f"{path}: not a study table ({exc}): give another output directory") from None
    if skipped:
        say(f"{path}: {skipped} rows not whole (a line cut short?) skipped: their runs are run again")
    return rows


#: Times a run is submitted again when its result was lost with its worker (a worker restarted at
#: its memory limit after the run ended, before its result was fetched), before it counts as failed.
MAX_LOST = 2


def worker_count(requested: int | None, runs: int, cores: int | None = None) -> tuple[int, str | None]:
    """The worker processes of a local cluster: ``requested`` (None: one per core) capped at
    the cores and at the number of runs (at least 1); and the line saying so when it was capped
    (None when not)."""
    cores = cores or os.cpu_count() or 1
    wanted = cores if requested is None else requested
    count = max(1, min(wanted, cores, runs))
    if requested is None or count == requested:
        return count, None
    why = "the cores of this machine" if count == cores else "the runs of the study"
    return count, f"--workers {requested} capped at {count} ({why})"


def _versions() -> dict[str, str]:
    """The drake_sot and drake versions installed in this process's environment."""
    found = {}
    for package in ("drake_sot", "drake"):
        try:
            found[f"{package}_version"] = metadata.version(package)
        except metadata.PackageNotFoundError:
            found[f"{package}_version"] = "not installed"
    return found


def _task(measure: Measure, scenario: str, parameters: dict[str, Any], duration: float, seed: int) -> dict:
    """One run, in a worker: its metrics, the worker's address, the wall time and the versions."""
    from distributed import get_worker

    limit_blas_threads(1)  # small matrices on one core (drake_sot.blas says why)
    start = time.perf_counter()
    metrics = measure(scenario, dict(parameters), duration, seed)
    return {
        "metrics": metrics,
        "worker": get_worker().address,
        "wall_time": time.perf_counter() - start,
        **_versions(),
    }


@dataclass
class StudyOutcome:
    """What :func:`run_study` did.

    Attributes:
        table: the CSV table. npz: its columns as arrays.
        rows: every run of the table by id (this session's and earlier ones).
        ran: runs finished in this session (ok or failed). failed: of which failed.
        skipped: runs found done in the table and not run again.
        brackets: per bisection cell (its parameters), the bracket ``(largest true, smallest
            false)`` of the bisected parameter; ``(high, inf)`` when ``high`` was true, NaN when
            a run of the cell failed.
    """

    table: Path
    npz: Path
    rows: dict[str, dict[str, Any]]
    ran: int = 0
    failed: int = 0
    skipped: int = 0
    brackets: list[tuple[dict[str, Any], tuple[float, float]]] = field(default_factory=list)


class _Table:
    """The CSV table, appended to one flushed row at a time."""

    def __init__(
        self, path: Path, study: Study, say: Callable[[str], None], declared: Sequence[Parameter]
    ) -> None:
        self.path = path
        self.columns = table_columns(study)
        self.rows = read_table(path, study, say, declared)

    def append(self, row: Mapping[str, Any]) -> None:
        new = not self.path.exists() or self.path.stat().st_size == 0
        if not new:  # a last line cut short (no line end): the new row goes on a line of its own
            with open(self.path, "rb+") as file:
                file.seek(-1, os.SEEK_END)
                if file.read(1) != b"\n":
                    file.write(b"\r\n")
        with open(self.path, "a", newline="", encoding="utf-8") as file:
            writer = csv.DictWriter(file, self.columns)
            if new:
                writer.writeheader()
            writer.writerow({k: row.get(k, "") for k in self.columns})
            file.flush()
            os.fsync(file.fileno())
        self.rows[row["run_id"]] = {k: row.get(k, "") for k in self.columns}

    def write_npz(self, path: Path) -> None:
        """The columns as arrays (numbers and bools as floats, NaN where empty; text as str),
        written atomically."""
        arrays = {}
        for column in self.columns:
            cells = [row[column] for row in self.rows.values()]
            numeric = all(isinstance(c, bool | int | float) or c == "" for c in cells)
            arrays[column] = (
                np.array([math.nan if c == "" else float(c) for c in cells])
                if numeric and column not in ("run_id", "worker", "error", "status")
                else np.array([str(c) for c in cells], dtype=str)
            )
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".npz")
        try:
            with os.fdopen(handle, "wb") as file:
                np.savez_compressed(file, **arrays)
            os.replace(temporary, path)
        except BaseException:
            os.unlink(temporary)
            raise


def _row(run: Run, study: Study, outcome: dict | None, error: BaseException | None) -> dict[str, Any]:
    """The table row of ``run``: from its worker's ``outcome``, or failed with ``error``."""
    row: dict[str, Any] = {"run_id": run.run_id, **run.parameters, "seed": run.seed, "duration": run.duration}
    if outcome is not None:
        metrics = outcome["metrics"]
        row |= {name: metrics.get(name, math.nan) for name in study.metrics}
        row |= {k: outcome[k] for k in ("worker", "wall_time", "drake_sot_version", "drake_version")}
        row |= {"status": "ok", "error": ""}
    else:
        row |= {"status": "failed", "error": f"{type(error).__name__}: {error}".replace("\n", " ")}
    return row


def run_study(
    study: Study,
    out_dir: str | Path,
    *,
    declared: Sequence[Parameter],
    measure: Measure,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    say: Callable[[str], None] = lambda line: print(line, file=sys.stderr, flush=True),
    hold: Callable[[], None] = lambda: None,
    processes: bool = True,
) -> StudyOutcome:
    """Run ``study`` into ``out_dir`` (created if needed), resuming its table there.

    Args:
        declared: the parameters the target declares (every run's values are checked
            through them before anything starts).
        measure: runs one run (see :data:`Measure`).
        scheduler: the address of an existing Dask scheduler (``tcp://HOST:PORT``); None for a
            local cluster of ``workers`` processes (None: one per core), capped at the cores and
            the runs (``say`` is told when capped).
        progress: see :data:`Progress`.
        say: told what the study does (one line at a time).
        hold: called once the study stops submitting (finished, or interrupted), before the
            cluster is closed and the table's npz is written (e.g. ``SignalGuard.hold``: a later
            signal then waits for them).
        processes: the local cluster's workers are processes (False: threads of this process,
            for measuring functions that are not importable, as in tests).

    Raises:
        ValueError: a study the target's ``declared`` parameters refuse, a table in ``out_dir``
            that :func:`read_table` refuses (other columns, an edited row, not a regular file),
            ``workers`` with ``scheduler`` or below 1 (before anything starts).
        OSError: ``out_dir`` cannot be written (before anything starts), or no scheduler answers
            at ``scheduler``, or what answers there is no Dask scheduler (:func:`check_speaks_dask`:
            ConnectionError; the directories made for ``out_dir`` are removed again when empty).
        KeyboardInterrupt: the study was interrupted: the pending runs were cancelled, every
            finished run is in the table and the cluster is closed.
    """
    study_plans = plans(study, declared)
    if scheduler is not None and workers is not None:
        raise ValueError(f"workers = {workers}: the cluster at {scheduler} has its own workers")
    if workers is not None and not (workers >= 1):
        raise ValueError(f"workers = {workers!r}: must be an integer >= 1")
    out = Path(out_dir)
    created = missing_directories(out)
    out.mkdir(parents=True, exist_ok=True)
    table = _Table(out / f"{study.name}_runs.csv", study, say, declared)
    outcome = StudyOutcome(table.path, out / f"{study.name}_runs.npz", table.rows)
    total = study.total()
    per_plan = total // len(study_plans)
    submitted: dict[Any, tuple[int, Run]] = {}  # future -> (plan index, run)
    lost: dict[str, int] = {}  # run id -> times its result was lost with its worker
    pending: list[tuple[int, Run]] = []
    probes = [0] * len(study_plans)

    def advance(index: int, metrics: Metrics | None, first: bool = False) -> None:
        """Feed the plan its last run's metrics and queue its next run, taking from the table
        the runs already done; record a finished plan's bracket."""
        nonlocal total
        plan: Plan = study_plans[index]
        try:
            run = next(plan) if first else plan.send(metrics)
            while run.run_id in table.rows and table.rows[run.run_id]["status"] == "ok":
                outcome.skipped += 1
                probes[index] += 1
                run = plan.send(table.rows[run.run_id])
        except StopIteration as stop:
            total -= per_plan - probes[index]
            if stop.value is not None:
                outcome.brackets.append((study.runs.cells.points()[index], stop.value))  # type: ignore[union-attr]
            return
        probes[index] += 1
        pending.append((index, run))

    for index in range(len(study_plans)):
        advance(index, None, first=True)
    if not pending:
        hold()
        table.write_npz(outcome.npz)
        say(f"{study.name}: all {outcome.skipped} runs already in {table.path}")
        return outcome
    client = cluster = None
    try:
        # in the try: a signal while the cluster starts closes what started
        try:
            if scheduler is not None:
                say(f"connecting to the Dask scheduler at {scheduler}")
                check_speaks_dask(scheduler)
            with _signals_deferred():  # a cluster or a client started in part cannot be closed
                client, cluster = _connect(scheduler, workers, len(pending), processes, say)
        except Exception:  # no scheduler there: no directory of ours is left behind either
            remove_empty(created)
            raise
        start = time.perf_counter()
        from distributed import as_completed

        def submit(index: int, run: Run) -> Any:
            future = client.submit(
                _task,
                measure,
                run.scenario,
                run.parameters,
                run.duration,
                run.seed,
                key=f"{study.name}-{run.run_id}-{time.time_ns()}",
                retries=1,
                pure=False,
            )
            submitted[future] = (index, run)
            return future

        futures = as_completed([submit(i, r) for i, r in pending])
        pending.clear()
        for future in futures:
            index, run = submitted.pop(future)
            if future.status == "lost" and lost.get(run.run_id, 0) < MAX_LOST:
                # done, but its worker was restarted (at its memory limit) before the result came
                lost[run.run_id] = lost.get(run.run_id, 0) + 1
                futures.add(submit(index, run))
                continue
            result, error = None, None
            if future.status == "finished":
                result = future.result()
            elif future.status == "error":  # raised twice, or its worker died (KilledWorker)
                error = future.exception()
            else:  # cancelled or lost: the scheduler, the connection to it, or its worker again and again
                why = "the scheduler, the connection to it or the run's worker was lost"
                error = RuntimeError(f"the task ended {future.status} ({why})")
            row = _row(run, study, result, error)
            table.append(row)
            outcome.ran += 1
            outcome.failed += result is None
            advance(index, None if result is None else row)
            for i, r in pending:
                futures.add(submit(i, r))
            pending.clear()
            if progress is not None:
                done = outcome.ran + outcome.skipped
                elapsed = time.perf_counter() - start
                progress(done, outcome.failed, total, elapsed / outcome.ran * (total - done))
    except BaseException:
        hold()
        for future in submitted:
            future.cancel()
        raise
    finally:
        hold()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
        if table.path.exists():  # some run recorded
            table.write_npz(outcome.npz)
    return outcome


def missing_directories(out: Path) -> list[Path]:
    """``out`` and those of its parents that do not exist yet, the deepest first."""
    missing = []
    for path in (out, *out.parents):
        if path.exists():
            break
        missing.append(path)
    return missing


def remove_empty(directories: Sequence[Path]) -> None:
    """Remove ``directories`` (the deepest first), stopping at the first that is not empty."""
    for directory in directories:
        try:
            directory.rmdir()
        except (OSError, ValueError):  # not empty, gone; a name no directory can have (a NUL byte)
            return


@contextlib.contextmanager
def _signals_deferred(signals: Sequence[signal.Signals] = (signal.SIGINT, signal.SIGTERM)) -> Iterator[None]:
    """Hold ``signals`` while the block runs, then deliver the first that came (its handler runs,
    e.g. raises KeyboardInterrupt, as the block ends). Around the start of a cluster and of its
    client: interrupted in their middle, they returned nothing to close, and Dask's own clean-up at
    exit failed on a worker still starting (``AssertionError: Status.init``) while its processes
    lived on; deferred, the signal comes once they are up, and they are closed. Only the signals
    with a Python handler are held (not one ignored, nor SIGTERM's default: it ends the process),
    and only in the main thread (the only one Python delivers signals to)."""
    held: list[int] = []
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for signum in signals:
            handler = signal.getsignal(signum)
            if callable(handler):
                previous[signum] = handler
                signal.signal(signum, lambda number, frame: held.append(number))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if held:
            signal.raise_signal(held[0])


def _pauses(dask_worker: Any) -> bool:
    """Whether a Dask worker pauses at a share of its memory limit (run on it by :func:`_connect`)."""
    manager = dask_worker.memory_manager
    return bool(manager.memory_limit and manager.memory_pause_fraction)


#: How long a scheduler has to send its first message, Dask's handshake [s].
HANDSHAKE_TIMEOUT = 10.0
#: The most bytes a scheduler's handshake may announce (distributed 2026.8 sends 58: its
#: compression, Python version and pickle protocol).
MAX_HANDSHAKE = 64 * 1024


def check_speaks_dask(address: str, timeout: float = HANDSHAKE_TIMEOUT) -> None:
    """Check that what listens at ``address`` (``tcp://HOST:PORT``) is a Dask scheduler before a
    Dask client talks to it: the first message a scheduler sends on a new connection is its
    handshake, a small msgpack map; a Dask client waits for it without a deadline (a listener that
    says nothing hangs it) and makes room for as many bytes as its first 8 announce (random bytes
    ask for exbibytes). Here the handshake must come within ``timeout`` seconds and announce at
    most :data:`MAX_HANDSHAKE` bytes. Nothing is checked at a ``tls://`` address (the handshake
    comes after TLS's), nor when the connection itself fails (the Dask client retries it, and
    names the address when it gives up).

    Raises:
        ConnectionError: naming ``address``, when what listens there sends nothing within
            ``timeout``, or what is not a Dask handshake.
    """
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.protocol.core import loads
    from distributed.protocol.utils import unpack_frames

    scheme, location = parse_address(address)
    if scheme != "tcp":
        return
    deadline = time.monotonic() + timeout
    try:
        connection = socket.create_connection(parse_host_port(location), timeout=timeout)
    except OSError:
        return
    with connection:
        try:
            (size,) = struct.unpack("Q", _receive(connection, 8, deadline))
            if not (0 < size <= MAX_HANDSHAKE):
                raise ConnectionError(f"its first message announces {size} bytes")
            frames, buffers = unpack_frames(_receive(connection, size, deadline), partial=True)
            handshake = loads(frames, deserialize=False)
            if buffers or not (
                isinstance(handshake, dict) and {"python", "pickle-protocol"} <= set(handshake)
            ):
                raise ConnectionError("its first message is no handshake")
        except TimeoutError:
            raise ConnectionError(
                f"no Dask scheduler at {address}: what listens there sent no handshake in {timeout:g} s"
            ) from None
        except Exception as exc:  # noqa: BLE001 - Dask's frames and msgpack, given any bytes, raise anything
            why = str(exc) if isinstance(exc, ConnectionError) else "its first message is not Dask's"
            raise ConnectionError(f"no Dask scheduler at {address}: {why}") from None


def _receive(connection: socket.socket, size: int, deadline: float) -> bytes:
    """``size`` bytes from ``connection`` by ``deadline`` (``time.monotonic``); TimeoutError when
    they do not come by then, ConnectionError when the connection is closed before."""
    data = bytearray()
    while len(data) < size:
        left = deadline - time.monotonic()
        if not (left > 0):
            raise TimeoutError
        connection.settimeout(left)
        chunk = connection.recv(min(size - len(data), 65536))
        if not chunk:
            raise ConnectionError(f"it closed the connection after {len(data)} of {size} bytes")
        data += chunk
    return bytes(data)


def _connect(
    scheduler: str | None, workers: int | None, runs: int, processes: bool, say: Callable[[str], None]
) -> tuple[Any, Any]:
    """A Dask client of the scheduler at ``scheduler``, or of a new local cluster (returned too,
    to be closed), the count of workers capped (:func:`worker_count`)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        client = Client(scheduler, timeout="10s")
        try:
            pausing = sorted(address for address, pauses in client.run(_pauses).items() if pauses)
        except BaseException:  # a worker that cannot answer (another distributed?): not left connected
            client.close()
            raise
        if pausing:  # theirs to change: say so before the study hangs
            say(
                f"{len(pausing)} of the scheduler's workers ({', '.join(pausing)}) pause at a share of their "
                "memory limit, and a study's memory never goes down (Drake keeps every run's diagrams): "
                "start them with DASK_DISTRIBUTED__WORKER__MEMORY__PAUSE=False, or the study may hang"
            )
        return client, None
    count, capped = worker_count(workers, runs)
    if capped is not None:
        say(capped)
    # A worker's memory grows with every run: Drake keeps every diagram with Python systems alive
    # (the pydrake of drake 1.51-1.58: ~7 MB a run of reach). Dask pauses a worker at 80 % of its
    # memory limit until its memory goes down, which it never does here: the study stalled for good
    # after ~1,200 runs a worker on 24 GB. Without the pause, the nanny restarts the worker at 95 %,
    # and the run it was on is run again on the fresh one.
    with dask.config.set({"distributed.worker.memory.pause": False}):
        cluster = LocalCluster(
            n_workers=count,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=":0",  # any free port (8787 may be taken), a dashboard when bokeh is installed
            silence_logs=40,  # logging.ERROR: the workers' chatter stays off the terminal
            # Ctrl-C: this process decides
            **({"preload": ["drake_sot.studies.worker"]} if processes else {}),
        )
    try:
        return Client(cluster), cluster
    except BaseException:
        cluster.close()
        raise
