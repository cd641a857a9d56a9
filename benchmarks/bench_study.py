"""Studies on Dask: the throughput of a local cluster against the same runs serially in one
process, and the engine's cost per run.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_study.py [--rounds 2] [--runs 16] [--duration 6]
    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_study.py --baseline COMMIT [--rounds 3] [--runs 8]
        [--duration 2]

**Throughput.** A grid of ``--runs`` runs of ``reach`` (the right hand's gain varied, ``--duration`` s
each)
is run (a) serially, each run built and simulated by ``study_runs.measure`` in this process, and
(b) as a study by ``run_study`` on a new ``LocalCluster`` of 2 worker processes — the cluster's
start, the workers' imports and the table included, as a user gets it. The two alternate, round
after round (this machine's 2 cores are shared: only ratios within a round are compared). The
ratio serial / cluster is the speed-up; 2 is the most 2 cores give.

**Cost per run.** Tiny runs (``reach`` for 0.02 s) through a study on one worker, against the same
runs called directly, for two counts of runs: the difference of the differences, per run, is
what the engine adds to a run (scheduling, the result's transfer, the table's flushed row); what
is left at zero runs is the cluster's start and stop.

**Against a baseline** (``--baseline COMMIT``): the throughput study on a local cluster of 2
workers, run by this tree and by the tree of ``COMMIT`` (``git archive`` into a temporary
directory), each in a fresh interpreter, one after the other round after round (the baseline
first in odd rounds, second in even ones); :func:`on_cluster` alone is timed (the cluster's
start, the runs, the table; not the interpreter's imports). The ratio
baseline / this tree above 1 means this tree is faster.

Prints the tables of benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

from baseline_tree import extract

from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams.study_runs import TARGETS, measure
from drake_sot.studies import Grid, Study
from drake_sot.studies.runner import run_study

GAINS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 7.5, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0)


def study(runs: int, duration: float, name: str) -> Study:
    """``runs`` runs of ``reach`` over the right hand's gain, ``duration`` [s] each."""
    if not (1 <= runs <= len(GAINS)):
        raise SystemExit(f"--runs = {runs}: must be in [1, {len(GAINS)}]")
    return Study(
        name=name,
        description="benchmark",
        scenario="reach",
        runs=Grid({"rh_gain": GAINS[:runs]}),
        duration=duration,
        metrics=("survived", "rh_settle_time"),
        fixed={"robot": "embedded"},
    )


def serial(chosen: Study) -> float:
    """[s] the wall time of the study's runs one after the other in this process."""
    start = time.perf_counter()
    for point in chosen.runs.points():
        measure(chosen.scenario, {**chosen.fixed, **point}, chosen.duration, 0)
    return time.perf_counter() - start


def on_cluster(chosen: Study, workers: int) -> float:
    """[s] the wall time of the study on a new local cluster of ``workers`` processes."""
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        outcome = run_study(
            chosen,
            out,
            declared=TARGETS[chosen.scenario].parameters,
            measure=measure,
            workers=workers,
            say=lambda line: None,
        )
        wall = time.perf_counter() - start
    if outcome.failed or outcome.ran != chosen.total():
        raise SystemExit(f"{chosen.name}: {outcome.failed} of {outcome.ran} runs failed")
    return wall


#: Run in a fresh interpreter on a tree (its ``PYTHONPATH``; argv: this folder, runs, duration):
#: :func:`on_cluster`'s wall time [s] on the throughput study, printed alone on the last line.
TIMED = """
import sys
sys.path.insert(0, sys.argv[1])
from bench_study import limit_blas_threads, on_cluster, study

if __name__ == "__main__":  # the cluster's workers are spawned: they import this file
    limit_blas_threads(1)
    print(on_cluster(study(int(sys.argv[2]), float(sys.argv[3]), "throughput"), 2))
"""


def timed_on(tree: pathlib.Path, runs: int, duration: float) -> float:
    """[s] :func:`on_cluster`'s wall time on the throughput study, in a fresh interpreter on ``tree``."""
    with tempfile.TemporaryDirectory() as scratch:
        script = pathlib.Path(scratch) / "timed_study.py"
        script.write_text(TIMED)
        env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
        out = subprocess.run(
            [
                sys.executable,
                str(script),
                str(pathlib.Path(__file__).resolve().parent),
                str(runs),
                str(duration),
            ],
            env=env,
            cwd=scratch,
            capture_output=True,
            text=True,
            check=True,
        )
    return float(out.stdout.split()[-1])


def against(baseline: str, rounds: int, runs: int, duration: float) -> None:
    """The table of ``--baseline``: this tree's study against ``baseline``'s, round after round."""
    here = pathlib.Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory() as tmp:
        tree = extract(baseline, pathlib.Path(tmp))
        load = os.getloadavg()
        print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
        columns = f"runs x {duration:g} s of reach, 2 workers | {baseline} [s] | this tree [s] | ratio"
        print(f"\n| round | {columns} |")
        print("|---|---|---|---|---|")
        for k in range(rounds):  # in turn first and second: a load that drifts favours neither
            if k % 2:
                now = timed_on(here, runs, duration)
                before = timed_on(tree, runs, duration)
            else:
                before = timed_on(tree, runs, duration)
                now = timed_on(here, runs, duration)
            print(f"| {k + 1} | {runs} | {before:.1f} | {now:.1f} | {before / now:.2f} |", flush=True)
        load = os.getloadavg()
        print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--runs", type=int, default=16, help="runs of the throughput study (<= 16)")
    parser.add_argument("--duration", type=float, default=6.0, help="[s] simulated per run (default 6)")
    parser.add_argument("--baseline", metavar="COMMIT", help="this tree's study against COMMIT's, alone")
    args = parser.parse_args()
    if args.baseline is not None:
        against(args.baseline, args.rounds, args.runs, args.duration)
        return
    limit_blas_threads(1)
    measure("reach", {"robot": "embedded"}, 0.02, 0)  # imports and first-build caches, outside the timing
    load = os.getloadavg()
    print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")

    print(
        f"\n| round | runs x {args.duration:g} s of reach | serial in one process [s] "
        "| local cluster, 2 workers [s] "
        "| speed-up |"
    )
    print("|---|---|---|---|---|")
    throughput = study(args.runs, args.duration, "throughput")
    for k in range(args.rounds):
        s = serial(throughput)
        c = on_cluster(throughput, 2)
        print(f"| {k + 1} | {args.runs} | {s:.1f} | {c:.1f} | {s / c:.2f} |", flush=True)

    print(
        "\n| round | tiny runs (0.02 s) | direct [s] | study, 1 worker [s] | engine per run [ms] "
        "| start and stop [s] |"
    )
    print("|---|---|---|---|---|---|")
    few, many = study(4, 0.02, "few"), study(16, 0.02, "many")
    for k in range(args.rounds):
        direct = {n: serial(s) for n, s in ((4, few), (16, many))}
        engine = {n: on_cluster(s, 1) for n, s in ((4, few), (16, many))}
        per_run = ((engine[16] - engine[4]) - (direct[16] - direct[4])) / 12
        fixed = engine[4] - direct[4] - 4 * per_run
        for n in (4, 16):
            print(
                f"| {k + 1} | {n} | {direct[n]:.2f} | {engine[n]:.2f} | {1000 * per_run:.0f} | {fixed:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
