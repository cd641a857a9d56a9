"""Push recovery: the push-recovery map of each robot (the ``push_recovery`` study on Dask),
and the ``walk`` real-time factor with the stabilizer beside the plant alone.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_push.py [--robots embedded,talos,g1]
        [--iterations 5] [--stabilizer both|on|off] [--times 4] [--workers 2] [--no-rtf] [--no-push]

1. Per robot, the ``push_recovery`` study (``drake_sot.studies.catalog.PUSH_RECOVERY``): the
   largest 0.1 s pelvis push the ``walk`` survives, by bisection in [0, 800] N, per push time x
   direction (0°, 90°, 180°, 270°) x stabilizer off/on. The push times are a quarter of the
   robot's step apart (its own step timing) over one step, as the catalog's study on the embedded
   robot; each run
   lasts until 2.3 s after the latest push. ``--times 2`` keeps the first two (mid single
   support is the second), ``--iterations`` the bisection's depth (5: to 25 N). Its table and
   npz go to ``out/bench_push/<robot>``: a run again resumes there.
2. The ``walk`` scenario's real-time factor, stabilizer on and off, beside the humanoid's
   plant alone on constant set points (all with the whole-body collision shapes), run one
   after the other in one process.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from bench_sot import plant_alone_realtime, print_table

from drake_sot.studies.catalog import PUSH_DIRECTIONS, PUSH_RECOVERY
from drake_sot.studies.description import Bisection, Grid, Study

FIRST_STEP = 0.5  # [s] when the walk's steps begin
AFTER = 2.3  # [s] simulated after the latest push


def robot_study(robot: str, iterations: int, stabilizer: str, times: int) -> Study:
    """``push_recovery`` on ``robot``, its push times from the robot's step timing (those of the
    catalog's study on the embedded robot: 2.1, 2.3, 2.5 and 2.7 s)."""
    from drake_sot.robots import get_robot

    step = get_robot(robot).step_timing.period
    push_times = tuple(round(FIRST_STEP + 2 * step + k * step / 4, 3) for k in range(4))[:times]
    on = {"both": (True, False), "on": (True,), "off": (False,)}[stabilizer]
    cells = Grid({"stabilizer": on, "push_time": push_times, "push_direction": PUSH_DIRECTIONS})
    return dataclasses.replace(
        PUSH_RECOVERY,
        runs=dataclasses.replace(PUSH_RECOVERY.runs, cells=cells, iterations=iterations),
        duration=round(push_times[-1] + AFTER, 3),
        fixed={**PUSH_RECOVERY.fixed, "robot": robot},
    )


def push_map(robot: str, iterations: int, stabilizer: str, times: int, workers: int) -> None:
    """Run the study on ``robot`` and print its map."""
    from drake_sot.diagrams.study_runs import TARGETS, measure
    from drake_sot.studies.runner import run_study

    study = robot_study(robot, iterations, stabilizer, times)
    start = time.perf_counter()
    outcome = run_study(
        study,
        Path("out/bench_push") / robot,
        declared=TARGETS[study.scenario].parameters,
        measure=measure,
        workers=workers,
    )
    wall = time.perf_counter() - start
    brackets = {(c["stabilizer"], c["push_time"], c["push_direction"]): b for c, b in outcome.brackets}
    assert isinstance(study.runs, Bisection)
    cells = study.runs.cells.axes
    print(
        f"\n{robot}: the largest survived 0.1 s pelvis push [N] (bisection in [0, 800] N, "
        f"{iterations} iterations: survived / fell; {outcome.ran} runs of {study.duration:g} s, "
        f"{outcome.skipped} from the table, {outcome.failed} failed, {wall:.0f} s wall)"
    )
    print("| stabilizer | push time [s] | " + " | ".join(f"{d:g}°" for d in cells["push_direction"]) + " |")
    print("|---|---|" + "---|" * len(cells["push_direction"]))
    for on in cells["stabilizer"]:
        for t in cells["push_time"]:
            row = []
            for d in cells["push_direction"]:
                low, high = brackets.get((on, t, d), (math.nan, math.nan))
                row.append(
                    "failed"
                    if math.isnan(low)
                    else f"{low:.0f} / {'-' if math.isinf(high) else f'{high:.0f}'}"
                )
            print(f"| {'on' if on else 'off'} | {t:g} | " + " | ".join(row) + " |", flush=True)


def rtf_table() -> None:
    from drake_sot.diagrams import walk
    from drake_sot.diagrams.run import simulate

    rows, rtf = [], {}
    for on in (True, False):
        setup = walk.build(stabilizer=on)
        result = simulate(setup.built.create_simulator(), setup.duration, setup.commands)
        if not result.completed or result.fell is not None:
            raise RuntimeError(f"walk (stabilizer {on}) did not complete: {result.failure or result.fell}")
        rtf[on] = result.realtime_factor
    plant = plant_alone_realtime(walk.build().duration)
    for on in (True, False):
        rows.append(
            (
                f"walk real-time factor, stabilizer {'on' if on else 'off'}",
                f"{rtf[on]:.2f}",
                f"plant alone (collision shapes): {plant:.2f}",
                f"{rtf[on] / plant:.2f} of baseline",
            )
        )
    print_table(rows)


def main() -> None:
    from drake_sot.blas import limit_blas_threads

    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="embedded,talos,g1", help="comma-separated robot names")
    parser.add_argument("--iterations", type=int, default=5, help="bisection depth (default 5: 25 N)")
    parser.add_argument("--stabilizer", choices=("both", "on", "off"), default="both")
    parser.add_argument("--times", type=int, choices=(1, 2, 3, 4), default=4, help="push times kept")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--no-rtf", action="store_true", help="skip the real-time factor table")
    parser.add_argument("--no-push", action="store_true", help="skip the push-recovery table")
    args = parser.parse_args()
    if not args.no_push:
        for robot in args.robots.split(","):
            push_map(robot, args.iterations, args.stabilizer, args.times, args.workers)
    if not args.no_rtf:
        rtf_table()


if __name__ == "__main__":
    main()
