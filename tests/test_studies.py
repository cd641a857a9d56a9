"""Studies: the description (grids, seeded samples, bisections, run ids) and the Dask runner,
in-process (a local cluster of threads) with fake measuring functions."""

from __future__ import annotations

import collections
import csv
import json
import math
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from drake_sot.channel import MAX_DELAY
from drake_sot.parameters import Parameter
from drake_sot.studies import Bisection, Grid, RandomSample, Study, make_run, plans, run_id, runner
from drake_sot.studies.catalog import DELAY_SWEEP
from drake_sot.studies.runner import read_table, run_study, table_columns, worker_count

DECLARED = (
    Parameter("force", "float", 0.0, "the push", minimum=0.0, maximum=1000.0, unit="N"),
    Parameter("phase", "float", 0.0, "the gait phase", minimum=0.0, maximum=1.0),
    Parameter("stabilizer", "bool", True, "the stabilizer"),
)
#: What the ``telecooperation_standing`` target declares (its declarations are on the measuring
#: side, with Drake): the link's delay, jitter, loss, the leader and the hands' admittance.
TELECOOPERATION_STANDING = (
    Parameter("leader", "choice", "operator", "who leads", choices=("operator", "cooperator")),
    Parameter("delay", "float", 0.14, "one-way delay", minimum=0.0, maximum=MAX_DELAY, unit="s"),
    Parameter("jitter", "float", 0.0, "jitter", minimum=0.0, maximum=MAX_DELAY, unit="s"),
    Parameter("loss", "float", 0.0, "loss", minimum=0.0, maximum=1.0, maximum_excluded=True),
    Parameter("admittance", "choice", "plain", "admittance", choices=("plain", "weighted")),
)
REPO = Path(__file__).resolve().parents[1]
THRESHOLD = 137.3  # [N] the fake robot survives a push below it, with the stabilizer


def fake_measure(scenario: str, parameters: dict, duration: float, seed: int) -> dict:
    """The fake robot: survives a push below THRESHOLD (half of it without the stabilizer)."""
    limit = THRESHOLD if parameters.get("stabilizer", True) else THRESHOLD / 2
    return {"survived": parameters["force"] < limit, "margin": limit - parameters["force"]}


def grid_study(**changes) -> Study:
    fields = dict(
        name="fake",
        description="a fake grid",
        scenario="fake",
        runs=Grid({"force": (0.0, 100.0, 200.0), "phase": (0.0, 0.5)}),
        duration=1.0,
        metrics=("survived", "margin"),
    )
    return Study(**(fields | changes))


def run_in_threads(study: Study, out, measure=fake_measure, **kwargs):
    return run_study(study, out, declared=DECLARED, measure=measure, workers=2, processes=False, **kwargs)


def test_a_grid_is_every_combination_first_axis_slowest():
    runs = [next(p) for p in plans(grid_study(), DECLARED)]
    assert [(r.parameters["force"], r.parameters["phase"]) for r in runs] == [
        (f, p) for f in (0.0, 100.0, 200.0) for p in (0.0, 0.5)
    ]
    assert len({r.run_id for r in runs}) == 6
    assert len({r.seed for r in runs}) == 6


def test_a_run_id_is_a_hash_of_the_parameters_in_any_order_and_changes_with_any_of_them():
    assert run_id("walk", {"a": 1.0, "b": True}, 2.0) == run_id("walk", {"b": True, "a": 1.0}, 2.0)
    ids = {
        run_id("walk", {"a": 1.0, "b": True}, 2.0),
        run_id("walk", {"a": 1.5, "b": True}, 2.0),
        run_id("walk", {"a": 1.0, "b": False}, 2.0),
        run_id("walk", {"a": 1.0, "b": True}, 3.0),
        run_id("reach", {"a": 1.0, "b": True}, 2.0),
    }
    assert len(ids) == 5
    run = make_run("walk", {"a": 1.0}, 2.0)
    assert run.seed == make_run("walk", {"a": 1.0}, 2.0).seed and 0 <= run.seed < 2**31


def test_a_random_sample_is_reproduced_by_its_seed_and_stays_in_its_ranges():
    def sample(seed):
        study = grid_study(
            runs=RandomSample({"force": (10.0, 20.0), "phase": (0.2, 0.4)}, count=50, seed=seed)
        )
        return [next(p).parameters for p in plans(study, DECLARED)]

    first, again, other = sample(7), sample(7), sample(8)
    assert first == again and first != other
    forces = np.array([p["force"] for p in first])
    assert ((forces >= 10.0) & (forces <= 20.0)).all() and forces.std() > 2.0  # spread, not one value


@pytest.mark.parametrize(
    ("study", "message"),
    [
        (grid_study(runs=Grid({"force": (0.0, -1.0)})), "force = -1"),
        (grid_study(runs=Grid({"gain": (1.0,)})), "unknown parameter 'gain'"),
        (grid_study(fixed={"stabilizer": "yes"}), "stabilizer = 'yes'"),
        (grid_study(runs=RandomSample({"force": (0.0, 2000.0)}, count=3)), "force = 2000"),
        (grid_study(runs=Bisection(Grid({"phase": (0.0,)}), "force", 0.0, 5000.0, 3)), "force = 5000"),
        (grid_study(runs=Bisection(Grid({}), "stabilizer", 0.0, 1.0, 3)), "a bool"),
        (grid_study(runs=Grid({"force": ()})), "no run"),
        (grid_study(duration=math.nan), "duration"),
    ],
)
def test_a_study_the_declarations_refuse_is_refused_before_anything_runs(tmp_path, study, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        run_in_threads(study, tmp_path, measure=refuse)
    assert not (tmp_path / "fake_runs.csv").exists()


def test_the_table_has_a_row_per_run_with_parameters_metrics_seed_and_versions(tmp_path):
    seen = []
    outcome = run_in_threads(grid_study(), tmp_path, progress=lambda *a: seen.append(a))
    with open(outcome.table, newline="") as file:
        rows = list(csv.DictReader(file))
    assert tuple(rows[0]) == table_columns(grid_study())
    assert len(rows) == 6 and {r["status"] for r in rows} == {"ok"}
    for row in rows:
        force = float(row["force"])
        assert row["survived"] == str(force < THRESHOLD)
        assert float(row["margin"]) == pytest.approx(THRESHOLD - force)
        assert row["run_id"] == run_id("fake", {"force": force, "phase": float(row["phase"])}, 1.0)
        assert row["drake_sot_version"] and row["worker"] and float(row["wall_time"]) >= 0
    assert [s[:3] for s in seen] == [(k, 0, 6) for k in range(1, 7)]
    assert seen[-1][3] == 0.0  # nothing left
    arrays = np.load(outcome.npz)
    assert sorted(arrays["force"]) == [0.0, 0.0, 100.0, 100.0, 200.0, 200.0]
    assert arrays["survived"].sum() == 4


#: The forces the measuring functions below were called with (Dask pickles a test's function by
#: name: a closure holding a lock would not pickle).
CALLS: list[float] = []
_LOCK = threading.Lock()


def counting(scenario: str, parameters: dict, duration: float, seed: int) -> dict:
    with _LOCK:
        CALLS.append(parameters["force"])
    return fake_measure(scenario, parameters, duration, seed)


def flaky(scenario: str, parameters: dict, duration: float, seed: int) -> dict:
    """Always raises at 100 N; raises at the first attempt at 200 N."""
    with _LOCK:
        CALLS.append(parameters["force"])
        attempts = CALLS.count(parameters["force"])
    if parameters["force"] == 100.0:
        raise RuntimeError(f"diverged at {parameters['force']} N")
    if parameters["force"] == 200.0 and attempts == 1:
        raise RuntimeError("a first attempt that fails")
    return fake_measure(scenario, parameters, duration, seed)


def refuse(scenario: str, parameters: dict, duration: float, seed: int) -> dict:
    raise AssertionError("a run was made")


@pytest.fixture
def calls():
    CALLS.clear()
    yield CALLS
    CALLS.clear()


def test_a_study_given_its_directory_again_runs_only_what_is_not_done(tmp_path, calls):
    small = grid_study(runs=Grid({"force": (0.0, 100.0), "phase": (0.0, 0.5)}))
    run_in_threads(small, tmp_path, measure=counting)
    assert len(calls) == 4
    calls.clear()
    outcome = run_in_threads(grid_study(), tmp_path, measure=counting)  # the grid grew by 200 N
    assert sorted(calls) == [200.0, 200.0]
    assert (outcome.skipped, outcome.ran) == (4, 2)
    assert len(read_table(outcome.table, grid_study())) == 6


def test_a_table_of_another_study_is_refused(tmp_path):
    run_in_threads(grid_study(), tmp_path)
    with pytest.raises(ValueError, match="give another output directory"):
        run_in_threads(grid_study(metrics=("survived",)), tmp_path)


def test_a_run_that_raises_is_retried_once_then_recorded_as_failed_and_the_study_goes_on(tmp_path, calls):
    attempts = calls
    study = grid_study(runs=Grid({"force": (0.0, 100.0, 200.0)}))
    outcome = run_in_threads(study, tmp_path, measure=flaky)
    assert sorted(attempts) == [0.0, 100.0, 100.0, 200.0, 200.0]  # each failing run tried twice
    rows = {row["force"]: row for row in outcome.rows.values()}
    assert rows[100.0]["status"] == "failed" and "diverged at 100.0 N" in rows[100.0]["error"]
    assert rows[200.0]["status"] == "ok" and rows[0.0]["status"] == "ok"
    assert (outcome.ran, outcome.failed) == (3, 1)
    # resumed, the failed run is run again (and only it)
    attempts.clear()
    run_in_threads(study, tmp_path, measure=flaky)
    assert attempts == [100.0, 100.0]


def test_a_bisection_brackets_a_known_threshold_per_cell(tmp_path):
    study = grid_study(
        runs=Bisection(Grid({"stabilizer": (True, False)}), "force", 0.0, 1000.0, iterations=8)
    )
    outcome = run_in_threads(study, tmp_path)
    brackets = {cell["stabilizer"]: bracket for cell, bracket in outcome.brackets}
    for stabilizer, threshold in ((True, THRESHOLD), (False, THRESHOLD / 2)):
        true, false = brackets[stabilizer]
        assert true < threshold <= false
        assert false - true == pytest.approx(1000.0 / 2**8)
    assert outcome.ran == 2 * 9
    # resumed: the bisections replay from the table without running anything
    again = run_in_threads(study, tmp_path, measure=refuse)
    assert sorted(again.brackets, key=str) == sorted(outcome.brackets, key=str)
    assert again.skipped == 18 and again.ran == 0


def test_a_bisection_whose_top_survives_stops_there():
    study = grid_study(runs=Bisection(Grid({}), "force", 0.0, 50.0, iterations=5))
    (plan,) = plans(study, DECLARED)
    run = next(plan)
    assert run.parameters["force"] == 50.0
    with pytest.raises(StopIteration) as stop:
        plan.send({"survived": True})
    assert stop.value.value == (50.0, math.inf)


def test_workers_are_capped_at_the_cores_and_the_runs_with_one_line():
    assert worker_count(None, 10, cores=4) == (4, None)
    assert worker_count(2, 10, cores=4) == (2, None)
    assert worker_count(100000, 10, cores=4) == (
        4,
        "--workers 100000 capped at 4 (the cores of this machine)",
    )
    assert worker_count(3, 2, cores=4) == (2, "--workers 3 capped at 2 (the runs of the study)")


def test_the_delay_sweep_runs_each_delay_per_jitter_and_loss_and_stays_within_the_links_largest_delay():
    runs = [next(p) for p in plans(DELAY_SWEEP, TELECOOPERATION_STANDING)]
    points = [(r.parameters["jitter"], r.parameters["loss"], r.parameters["delay"]) for r in runs]
    delays = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25)
    assert points == [
        (j, p, d) for j in (0.0, 0.04) for p in (0.0, 0.3) for d in delays
    ]  # a curve's runs together
    assert DELAY_SWEEP.total() == len(runs) == 24
    assert all(d + j <= MAX_DELAY for j, _, d in points)  # no run refused by the link
    assert all(r.parameters["leader"] == "operator" and r.parameters["admittance"] == "plain" for r in runs)
    assert len({r.seed for r in runs}) == 24  # each run's packets drawn from its own seed
    assert {"tracking_error_rms", "tracking_error_max", "force_error_rms", "force_ratio", "survived"} <= set(
        DELAY_SWEEP.metrics
    )


#: A study on worker processes whose runs each keep 40 MB (as Drake keeps each diagram), with a
#: memory limit the workers reach after a few runs; run as a script, so that its measure is
#: pickled by value for the workers, and with a timeout, since a paused worker hangs the study.
LEAKY_STUDY = """
import csv, json, sys, time
import distributed
from drake_sot.parameters import Parameter
from drake_sot.studies import Grid, Study
from drake_sot.studies.runner import run_study

def leaky_measure(scenario, parameters, duration, seed):
    # resident, never freed: kept by a module of the worker (this function is sent by value)
    sys.__dict__.setdefault("kept_by_the_test", []).append(b"x" * (40 << 20))
    time.sleep(0.3)  # a run's time: the nanny checks the memory every 0.1 s
    return {"survived": True}

_LocalCluster = distributed.LocalCluster

def limited(*args, **kwargs):
    return _LocalCluster(*args, memory_limit=sys.argv[2], **kwargs)

if __name__ == "__main__":
    distributed.LocalCluster = limited
    study = Study(name="leaky", description="", scenario="fake", runs=Grid({"force": tuple(range(40))}),
                  duration=0.01, metrics=("survived",))
    declared = (Parameter("force", "float", 0.0, "", minimum=0.0, maximum=100.0),)
    outcome = run_study(study, sys.argv[1], declared=declared, measure=leaky_measure, workers=2,
                        say=lambda line: None)
    with open(outcome.table, newline="") as file:
        rows = list(csv.DictReader(file))
    statuses, workers = sorted({row["status"] for row in rows}), len({row["worker"] for row in rows})
    print(json.dumps({"runs": len(rows), "statuses": statuses, "workers": workers}))
"""


@pytest.mark.slow  # worker processes started, and restarted
def test_a_study_whose_workers_keep_memory_restarts_them_at_their_limit_instead_of_hanging(tmp_path):
    """Drake keeps every diagram with Python systems alive, so a worker's memory grows with each
    run. Dask pauses a worker at 80 % of its memory limit until its memory goes down: here it never
    does, and the study hung for good (a real study of ``reach`` after ~1,200 runs a worker on this
    24 GB machine). The workers are restarted at the limit instead, and every run is done."""
    script = tmp_path / "leaky_study.py"
    script.write_text(LEAKY_STUDY)
    study = subprocess.Popen(
        [sys.executable, str(script), str(tmp_path / "out"), "600MB"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        start_new_session=True,  # its workers too are stopped on a timeout
    )
    try:
        stdout, stderr = study.communicate(timeout=120)  # ~10 s; paused workers never end
    except subprocess.TimeoutExpired:
        os.killpg(study.pid, signal.SIGKILL)
        study.communicate()
        pytest.fail("the study did not end in 120 s: its workers paused at their memory limit")
    assert study.returncode == 0, stderr[-3000:]
    table = json.loads(stdout.strip().splitlines()[-1])
    assert table["runs"] == 40 and table["statuses"] == ["ok"], table
    assert table["workers"] > 2, "no worker reached the limit: the test does not test the restart"


class _Future:
    """A finished Dask future, or one whose result was lost with its worker."""

    def __init__(self, status: str, result: dict | None = None) -> None:
        self.status, self._result = status, result

    def result(self) -> dict | None:
        return self._result

    def cancel(self) -> None:
        pass


class _AsCompleted:
    """``distributed.as_completed`` over futures that are already done: in order, new ones last."""

    def __init__(self, futures) -> None:
        self._queue = collections.deque(futures)

    def add(self, future: _Future) -> None:
        self._queue.append(future)

    def __iter__(self):
        while self._queue:
            yield self._queue.popleft()


class _LosingClient:
    """A Dask client whose futures of a run end "lost" (its worker restarted before the result was
    fetched) the first ``times`` times the run is submitted, then finish with the run's metrics."""

    def __init__(self, times: int) -> None:
        self.times = times
        self.submitted: collections.Counter = collections.Counter()

    def submit(self, task, measure, scenario, parameters, duration, seed, **options) -> _Future:
        run = tuple(sorted(parameters.items()))
        self.submitted[run] += 1
        if self.submitted[run] <= self.times:
            return _Future("lost")
        metrics = measure(scenario, parameters, duration, seed)
        versions = {"drake_sot_version": "0", "drake_version": "0"}
        return _Future("finished", {"metrics": metrics, "worker": "fake", "wall_time": 0.0, **versions})

    def close(self) -> None:
        pass


@pytest.mark.parametrize("losses", [1, runner.MAX_LOST, runner.MAX_LOST + 1])
def test_a_run_whose_result_is_lost_with_its_worker_is_run_again_a_few_times(tmp_path, monkeypatch, losses):
    """A worker restarted at its memory limit after a run ended, before the result was fetched,
    loses the result (Dask's "lost"): the run is submitted again, at most MAX_LOST times, and only
    then recorded as failed."""
    import distributed

    client = _LosingClient(losses)
    monkeypatch.setattr(runner, "_connect", lambda *args: (client, None))
    monkeypatch.setattr(distributed, "as_completed", _AsCompleted)
    outcome = run_study(
        grid_study(), tmp_path, declared=DECLARED, measure=fake_measure, say=lambda line: None
    )
    statuses = {row["status"] for row in outcome.rows.values()}
    assert len(outcome.rows) == 6 and outcome.ran == 6
    if losses <= runner.MAX_LOST:
        assert statuses == {"ok"} and outcome.failed == 0
        assert set(client.submitted.values()) == {losses + 1}
    else:
        assert statuses == {"failed"} and outcome.failed == 6
        assert set(client.submitted.values()) == {runner.MAX_LOST + 1}
        assert all("ended lost" in row["error"] for row in outcome.rows.values())


@pytest.mark.parametrize("pause", [0.8, False])
def test_a_scheduler_whose_workers_pause_at_their_memory_limit_is_named_before_the_study(tmp_path, pause):
    """Workers that pause at a share of their memory limit hang a long study (its memory never goes
    down): the workers of a scheduler given with ``scheduler`` are not the study's to configure,
    so it says which ones pause and how to start them; workers started without the pause: nothing."""
    import dask
    from distributed import LocalCluster

    with dask.config.set({"distributed.worker.memory.pause": pause}):
        cluster = LocalCluster(n_workers=2, processes=False, memory_limit="4GB", dashboard_address=None)
    said = []
    try:
        addresses = sorted(cluster.scheduler_info["workers"])
        study = grid_study(runs=Grid({"force": (0.0,)}))
        run_study(
            study,
            tmp_path,
            declared=DECLARED,
            measure=fake_measure,
            scheduler=cluster.scheduler_address,
            say=said.append,
        )
    finally:
        cluster.close()
    warned = [line for line in said if "DASK_DISTRIBUTED__WORKER__MEMORY__PAUSE=False" in line]
    if pause:
        assert len(warned) == 1 and warned[0].startswith("2 of the scheduler's workers"), said
        assert all(address in warned[0] for address in addresses), (addresses, warned)
    else:
        assert warned == [], said


def test_a_scheduler_whose_workers_cannot_be_asked_is_not_left_connected(tmp_path, monkeypatch):
    import distributed
    from distributed import LocalCluster

    def unanswerable(dask_worker):
        raise RuntimeError("this worker cannot tell its memory settings")

    monkeypatch.setattr(runner, "_pauses", unanswerable)
    cluster = LocalCluster(n_workers=1, processes=False, dashboard_address=None)
    try:
        with pytest.raises(RuntimeError, match="cannot tell its memory settings"):
            run_study(
                grid_study(),
                tmp_path,
                declared=DECLARED,
                measure=fake_measure,
                scheduler=cluster.scheduler_address,
                say=lambda line: None,
            )
        with pytest.raises(ValueError, match="No clients found"):
            distributed.default_client()
    finally:
        cluster.close()
