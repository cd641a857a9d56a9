"""``drake-sot study`` refusing, in subprocesses, what it cannot use: an ``--out`` that is no
writable directory (exit 2, as ``run --out``), a runs table in ``--out`` that was edited or is no
regular file (exit 2, one line naming the file, no hang), and a ``--scheduler`` address where
something listens that is no Dask scheduler (exit 1 within 30 s, one line naming the address).
Nothing runs: no cluster starts."""

from __future__ import annotations

import csv
import io
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from drake_sot.diagrams.study_runs import TARGETS
from drake_sot.studies.catalog import GAIN_SWEEP
from drake_sot.studies.description import plans
from drake_sot.studies.runner import table_columns

pytestmark = pytest.mark.slow  # a subprocess each, a few seconds to import drake_sot in it

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}


def _study(*argv: str, timeout: float = 60.0) -> tuple[int, list[str], float]:
    """``drake-sot study gain_sweep ARGV``: (exit status, its stderr's lines, seconds it took)."""
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "drake_sot.app.cli", "study", "gain_sweep", *argv],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=ROOT,
        timeout=timeout,
    )
    return proc.returncode, proc.stderr.splitlines(), time.monotonic() - start


@pytest.mark.parametrize("where", ["a file", "under a file", "unwritable", "empty"])
def test_an_out_that_is_no_writable_directory_exits_2_in_one_line_as_run_out_does(tmp_path, where):
    (tmp_path / "file").write_text("not a directory")
    out = {
        "a file": str(tmp_path / "file"),
        "under a file": str(tmp_path / "file" / "out"),
        "unwritable": "/proc/drake_sot_out",  # no one writes there, root included
        "empty": "",
    }[where]
    status, lines, _ = _study("--out", out, "--workers", "1")
    assert status == 2, lines
    assert len(lines) == 1 and lines[0].startswith("drake-sot study: error: --out: "), lines
    assert repr(out) in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def _table(metric: str | bytes) -> bytes:
    """A whole table of ``gain_sweep`` as a study writes it, every run ok, the first run's
    ``rh_settle_time`` given as ``metric``."""
    columns = table_columns(GAIN_SWEEP)
    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(columns)
    for k, plan in enumerate(plans(GAIN_SWEEP, TARGETS["reach"].parameters)):
        run = next(plan)
        cells = {"run_id": run.run_id, **run.parameters, "seed": run.seed, "duration": run.duration}
        cells |= {"survived": True, "rh_settle_time": 0.5, "final_error/taskRH": 0.001}
        cells |= {"max_final_error_m": 0.001, "max_final_error_rad": 0.01, "worker": "tcp://127.0.0.1:1"}
        cells |= {"wall_time": 1.5, "drake_sot_version": "0.1.0", "drake_version": "1.51.1"}
        cells |= {"status": "ok", "error": ""}
        row = [str(cells[c]) for c in columns]
        if k == 0:
            row[columns.index("rh_settle_time")] = "@"
        writer.writerow(row)
    return text.getvalue().encode().replace(b"@", metric if isinstance(metric, bytes) else metric.encode())


@pytest.mark.parametrize(
    ("metric", "said"),
    [
        ("", "line 2: rh_settle_time = '': a metric of an ok run is a number or a bool"),
        (
            "9" * 5000,
            "line 2: rh_settle_time = '9999999999999999'…'99999999' (5000 characters): not a number",
        ),
        ("1e400", "line 2: rh_settle_time = '1e400': not a number as a run writes it"),
        (b"0.5\xff\xfe", "not a study table ('utf-8' codec can't decode byte 0xff"),
    ],
)
def test_a_table_with_an_edited_metric_is_refused_in_one_line_naming_the_file(tmp_path, metric, said):
    path = tmp_path / "gain_sweep_runs.csv"
    path.write_bytes(_table(metric))
    status, lines, _ = _study("--out", str(tmp_path), "--workers", "1")
    assert status == 2, lines
    assert len(lines) == 1 and lines[0].startswith(f"drake-sot study: error: {path}: {said}"), lines
    assert path.read_bytes() == _table(metric)  # left as it was


@pytest.mark.parametrize("kind", ["fifo", "link to /dev/zero"])
def test_a_table_that_is_no_regular_file_is_refused_in_one_line_without_a_hang(tmp_path, kind):
    path = tmp_path / "gain_sweep_runs.csv"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    status, lines, _ = _study("--out", str(tmp_path), "--workers", "1", timeout=60)
    assert status == 2, lines
    what = "a FIFO" if kind == "fifo" else "a device"
    assert lines == [
        f"drake-sot study: error: {path}: not a regular file ({what}): give another output directory"
    ]


class _Listener:
    """A loopback listener that accepts every connection and keeps it open, saying nothing
    (``garbage=False``) or sending random bytes on each."""

    def __init__(self, garbage: bool) -> None:
        self.socket = socket.create_server(("127.0.0.1", 0))
        self.address = f"tcp://127.0.0.1:{self.socket.getsockname()[1]}"
        self.garbage = garbage
        self.accepted: list[socket.socket] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self.socket.accept()
            except OSError:  # closed
                return
            self.accepted.append(connection)
            if self.garbage:
                connection.sendall(os.urandom(4096))

    def close(self) -> None:
        self.socket.close()
        for connection in self.accepted:
            connection.close()


@pytest.mark.parametrize("garbage", [False, True], ids=["silent", "garbage"])
def test_a_scheduler_address_where_no_dask_scheduler_listens_exits_1_within_30_s(tmp_path, garbage):
    listener = _Listener(garbage)
    try:
        status, lines, took = _study(
            "--scheduler", listener.address, "--out", str(tmp_path / "out"), timeout=60
        )
    finally:
        listener.close()
    assert status == 1, lines
    assert took < 30.0, (took, lines)
    assert listener.accepted  # it was reached
    assert lines[0] == f"connecting to the Dask scheduler at {listener.address}"
    assert len(lines) == 2 and lines[1].startswith(
        f"drake-sot study: no Dask scheduler at {listener.address}: "
    )
    assert not (tmp_path / "out").exists()  # nothing left behind


def test_the_check_of_a_listener_takes_a_dask_schedulers_handshake(tmp_path):
    """The check before a client connects lets a real scheduler through (its handshake read)."""
    from distributed import LocalCluster

    from drake_sot.studies.runner import check_speaks_dask

    with LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster:
        check_speaks_dask(cluster.scheduler_address, timeout=10.0)
    with socket.create_server(("127.0.0.1", 0)) as silent:
        address = f"tcp://127.0.0.1:{silent.getsockname()[1]}"
        start = time.monotonic()
        with pytest.raises(
            ConnectionError, match=f"no Dask scheduler at {address}: .* no handshake in 0.5 s"
        ):
            check_speaks_dask(address, timeout=0.5)
        assert time.monotonic() - start < 5.0
