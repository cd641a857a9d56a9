"""``drake-sot study`` in subprocesses, on real (short) runs of ``reach``: a local cluster and a
``dask scheduler`` with two ``dask worker`` processes give the same table; SIGINT and SIGTERM
stop a study within 10 s with its finished runs kept and no process left; ``--workers`` above
the cores is capped with one line; a worker killed mid-run loses no run."""

from __future__ import annotations

import csv
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}

#: A study of its own for ``drake_sot.app.study.main``: RUNS runs of ``reach`` of DURATION s,
#: pushed at 0.1 s by 0, 50, ... N.
DRIVER = """
import sys
from drake_sot.app.study import main
from drake_sot.studies import Grid, Study

if __name__ == "__main__":  # the local cluster's workers are spawned: they import this file
    runs, duration = int(sys.argv[1]), float(sys.argv[2])
    TINY = Study(
        "tiny", "reach pushed", "reach", Grid({"push_force": tuple(50.0 * k for k in range(runs))}),
        duration=duration, metrics=("survived", "min_pelvis_height", "max_final_error_m"),
        fixed={"push_time": 0.1},
    )
    sys.exit(main(sys.argv[3:], {"tiny": TINY}))
"""


def _start(tmp_path: Path, runs: int, duration: float, *argv: str) -> subprocess.Popen:
    driver = tmp_path / "driver.py"
    driver.write_text(DRIVER)
    return subprocess.Popen(
        [sys.executable, str(driver), str(runs), str(duration), "tiny", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
        cwd=tmp_path,
        # a background shell ignores SIGINT in its jobs: the study must see it as Ctrl-C does;
        # a session of its own: a group to send a terminal's Ctrl-C to
        preexec_fn=lambda: (
            [signal.signal(s, signal.SIG_DFL) for s in (signal.SIGINT, signal.SIGTERM)] and os.setsid()
        ),
    )


def _table(path: Path) -> dict[str, dict[str, str]]:
    with open(path, newline="") as file:
        return {row["run_id"]: row for row in csv.DictReader(file)}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _gone(pids: set[int], within: float = 3.0) -> set[int]:
    """The processes of ``pids`` still alive (not zombies) after ``within`` seconds at most."""
    deadline = time.monotonic() + within
    while True:
        alive = set()
        for pid in pids:
            try:
                if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                    alive.add(pid)
            except psutil.NoSuchProcess:
                pass
        if not alive or time.monotonic() > deadline:
            return alive
        time.sleep(0.1)


def test_a_local_cluster_and_a_dask_scheduler_give_the_same_table(tmp_path):
    local = _start(tmp_path, 3, 0.3, "--workers", "2", "--out", str(tmp_path / "local"))
    out, err = local.communicate(timeout=300)
    assert local.returncode == 0, err
    assert "wrote" in out
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "dask"]
    started = [
        subprocess.Popen(
            [*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
            env=ENV,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        for _ in range(2):
            started.append(
                subprocess.Popen(
                    [*dask, "worker", address, "--nthreads", "1", "--no-dashboard", "--host", "127.0.0.1"],
                    env=ENV,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        remote = _start(tmp_path, 3, 0.3, "--scheduler", address, "--out", str(tmp_path / "remote"))
        out, err = remote.communicate(timeout=300)
        assert remote.returncode == 0, err
    finally:
        for process in reversed(started):
            process.terminate()
            process.wait(timeout=30)
    a, b = _table(tmp_path / "local" / "tiny_runs.csv"), _table(tmp_path / "remote" / "tiny_runs.csv")
    assert len(a) == 3 and set(a) == set(b)
    for run_id, row in a.items():
        assert row["status"] == b[run_id]["status"] == "ok"
        for metric in ("survived", "min_pelvis_height", "max_final_error_m", "push_force", "seed"):
            assert row[metric] == b[run_id][metric], (metric, row, b[run_id])
    # the remote runs ran on the two dask workers, not on a cluster of the study's own
    assert all(row["worker"].startswith("tcp://127.0.0.1:") for row in b.values())
    assert not {row["worker"] for row in b.values()} & {row["worker"] for row in a.values()}


@pytest.mark.parametrize(
    ("signum", "group"), [(signal.SIGINT, False), (signal.SIGTERM, False), (signal.SIGINT, True)]
)
def test_a_signal_stops_a_study_within_10_s_keeping_its_finished_runs_and_no_process(tmp_path, signum, group):
    """To the study's process, or (a terminal's Ctrl-C) to its whole group, workers included:
    they leave the decision to the study, which stops without a traceback."""
    proc = _start(tmp_path, 8, 2.0, "--workers", "2", "--out", str(tmp_path))
    children: set[int] = set()
    seen = []
    for line in proc.stderr:
        seen.append(line)
        children |= {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}
        if line.startswith("1/8 runs done"):
            children |= {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}
            sent = time.monotonic()
            if group:
                os.killpg(proc.pid, signum)
            else:
                proc.send_signal(signum)
            break
    else:
        pytest.fail("".join(seen))
    _, rest = proc.communicate(timeout=30)
    took = time.monotonic() - sent
    err = "".join(seen) + rest
    assert proc.returncode == 128 + signum, err
    assert took < 10.0, err
    assert f"interrupted by {signal.Signals(signum).name}" in err
    assert "Traceback" not in err, err
    rows = _table(tmp_path / "tiny_runs.csv")
    assert 1 <= len(rows) < 8 and {r["status"] for r in rows.values()} == {"ok"}
    assert len(children) >= 2  # the two workers were seen
    assert _gone(children) == set()


_WORKER_LOG = """
import logging, sys
from drake_sot.studies.worker import dask_setup
if sys.argv[1] == "preloaded":
    dask_setup(None)
    dask_setup(None)  # a second preload installs no second filter
logging.basicConfig(stream=sys.stderr, format="%(levelname)s %(message)s")
log = logging.getLogger("distributed.worker")
print(len(log.filters), flush=True)
try:
    raise OSError("Stream is closed")
except OSError:
    log.exception("Failed to communicate with scheduler during heartbeat.")  # as distributed logs it
log.error("Unexpected exception during heartbeat. Closing worker.")
logging.getLogger("distributed.nanny").error("Failed to communicate with scheduler during heartbeat.")
"""


@pytest.mark.parametrize("preloaded", [True, False])
def test_a_local_worker_says_nothing_of_a_heartbeat_the_closing_scheduler_cut(preloaded):
    """A local cluster's scheduler is in the study's process: a worker's heartbeat fails only as the
    study closes it, and its traceback came after the study's last line (a worker busy with a run
    is slow to stop). The worker's preload drops that record and that one alone."""
    proc = subprocess.run(
        [sys.executable, "-c", _WORKER_LOG, "preloaded" if preloaded else "bare"],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert proc.stdout.split() == (["1"] if preloaded else ["0"])
    heartbeat = "ERROR Failed to communicate with scheduler during heartbeat."
    # the worker's own record is dropped with its traceback; another logger's, and other errors, stay
    assert lines.count(heartbeat) == (1 if preloaded else 2), lines
    assert ("Traceback (most recent call last):" in lines) is not preloaded
    assert "ERROR Unexpected exception during heartbeat. Closing worker." in lines


def test_workers_above_the_cores_are_capped_with_one_line(tmp_path):
    most = 4 * (os.cpu_count() or 1)  # the most --workers accepts: four per core
    proc = _start(tmp_path, 1, 0.1, "--workers", str(most), "--out", str(tmp_path))
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    capped = [line for line in err.splitlines() if "capped" in line]
    assert capped in (
        [f"--workers {most} capped at 1 (the runs of the study)"],
        [f"--workers {most} capped at 1 (the cores of this machine)"],  # a machine of one core
    )


def _workers(pid: int) -> list[psutil.Process]:
    """The local cluster's worker processes under ``pid`` (spawned, not the resource tracker)."""
    found = []
    for child in psutil.Process(pid).children(recursive=True):
        try:
            command = " ".join(child.cmdline())
            child.cpu_times()
        except psutil.Error:  # ended meanwhile, or a zombie
            continue
        if "spawn_main" in command and "resource_tracker" not in command:
            found.append(child)
    return found


def test_a_worker_killed_mid_run_loses_no_run(tmp_path):
    proc = _start(tmp_path, 2, 4.0, "--workers", "2", "--out", str(tmp_path))
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and time.monotonic() < deadline and proc.poll() is None:
        # a worker running its task: past the ~2 s of CPU of its start and of importing Drake
        # (the task's function imports it), before any run is done (a run takes ~10 s)
        busy = [p for p in _workers(proc.pid) if sum(p.cpu_times()[:2]) > 3.0]
        if busy and not (tmp_path / "tiny_runs.csv").exists():
            busy[0].send_signal(signal.SIGKILL)
            killed = busy[0].pid
        time.sleep(0.2)
    out, err = proc.communicate(timeout=300)
    assert killed is not None, err
    assert proc.returncode == 0, err
    rows = _table(tmp_path / "tiny_runs.csv")
    assert len(rows) == 2 and {r["status"] for r in rows.values()} == {"ok"}, rows


#: When the signals of the next test are sent: seconds after the study's first child process (the
#: local cluster's worker) appears, through the cluster's start; then on the progress line of a
#: run done (``(k, seconds after it)``), through the first runs.
AFTER_START = (0.0, 0.3, 0.6, 1.0, 1.5, 2.0, 3.0)
AFTER_RUN = ((1, 0.0), (1, 0.4), (2, 0.0))


@pytest.mark.parametrize(
    ("when", "signum"),
    [(("start", t), (signal.SIGINT, signal.SIGTERM)[k % 2]) for k, t in enumerate(AFTER_START)]
    + [(("run", r), (signal.SIGTERM, signal.SIGINT)[k % 2]) for k, r in enumerate(AFTER_RUN)],
    ids=[f"start+{t}s" for t in AFTER_START] + [f"run{k}+{t}s" for k, t in AFTER_RUN],
)
def test_a_signal_at_any_point_of_the_clusters_start_or_the_first_runs_ends_the_study_cleanly(
    tmp_path, when, signum
):
    """Exit 128 + the signal, one line besides the progress, no traceback, no process left, and
    every run said done is in the table (and its npz): a signal while the cluster started left it
    half-started (Dask's exit hook then failed on it) and drew the figures of no run."""
    proc = _start(tmp_path, 4, 0.3, "--workers", "1", "--out", str(tmp_path / "out"))
    children: set[int] = set()
    lines: list[str] = []
    try:
        if when[0] == "start":
            deadline = time.monotonic() + 120
            while not children and time.monotonic() < deadline and proc.poll() is None:
                children = {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}
                time.sleep(0.01)
            time.sleep(when[1])
        else:
            runs, after = when[1]
            for line in proc.stderr:
                lines.append(line)
                if line.startswith(f"{runs}/4 runs done"):
                    break
            time.sleep(after)
        children |= {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}
        proc.send_signal(signum)
    except psutil.NoSuchProcess:
        pass
    _, rest = proc.communicate(timeout=120)
    lines += rest.splitlines(keepends=True)
    said = [line.rstrip("\n") for line in lines if " runs done, " not in line]
    assert proc.returncode == 128 + signum, lines
    assert len(said) == 1 and said[0].startswith(f"interrupted by {signal.Signals(signum).name}: "), lines
    assert children and _gone(children) == set(), lines
    done = len(lines) - len(said)  # the progress lines: a line per run recorded
    table = tmp_path / "out" / "tiny_runs.csv"
    rows = _table(table) if table.exists() else {}
    assert len(rows) == done and {r["status"] for r in rows.values()} <= {"ok"}, lines
    if rows:
        with np.load(tmp_path / "out" / "tiny_runs.npz") as npz:
            assert sorted(npz["run_id"]) == sorted(rows)
    if when[0] == "run":
        assert done >= when[1][0]
