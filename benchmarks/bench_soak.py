"""Soak: ``walk_random`` for a long time (600 s by default), the process's memory as it goes and
every landing the logs kept.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/bench_soak.py [--duration 600] [--seed 0] [--log-window 300]

The run is the scenario's, without a replay: bounded logs (their last window,
``drake_sot.diagrams.log_window.LOG_WINDOW``), the stack's history, the pattern generator's
executed samples dropped. The resident memory (``VmRSS`` of ``/proc/self/status``) is read at 25,
50, 75 and 100 % of the run: it must stop growing once the logs fill their window. Each landing
in the kept logs is measured on the simulated plant 50 ms after touch-down against its
footprint, the footprints and touch-down times replayed without the diagram
(``walk_random.planned_landings``). Prints one table row for benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams import walk_random
from drake_sot.diagrams.log_window import LOG_WINDOW
from drake_sot.diagrams.scenario import run_scenario

SETTLE = 0.05  # [s] after touch-down, when a landing is measured


def rss_mb(pid: int | str = "self") -> float:
    """The resident memory [MB] of process ``pid`` (this one by default)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return math.nan


def landing_errors(output, duration: float) -> np.ndarray:
    """[m] the horizontal error of every landing whose measurement time the logs kept."""
    built, arrays = output.setup.built, output.arrays
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    rule = built.diagram.GetSubsystemByName("random_steps").rule
    time_log = arrays["time"]
    errors = []
    for touch_down, step in walk_random.planned_landings(
        output.setup.extras.pattern_generator, rule, duration
    ):
        at = touch_down + SETTLE
        if not (time_log[0] <= at <= time_log[-1]):
            continue
        k = int(np.argmin(np.abs(time_log - at)))
        plant.SetPositions(context, info.model_instance, arrays["q"][k])
        X = plant.GetFrameByName(info.frames[f"{step.side}_foot"], info.model_instance).CalcPoseInWorld(
            context
        )
        errors.append(math.hypot(X.translation()[0] - step.x, X.translation()[1] - step.y))
    return np.array(errors)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=600.0, help="simulated seconds (default 600)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--log-window",
        type=float,
        default=LOG_WINDOW,
        help=f"[s] the logs keep the run's last this many seconds (up to twice; default {LOG_WINDOW:g}): "
        "a window well below the duration shows where the memory levels off",
    )
    args = parser.parse_args()
    limit_blas_threads(1)
    marks = {args.duration * f: None for f in (0.25, 0.5, 0.75, 1.0)}

    def progress(t: float, end: float, wall: float) -> None:
        for mark, seen in marks.items():
            if seen is None and t >= mark - 1e-9:
                marks[mark] = rss_mb()

    load = os.getloadavg()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        output = run_scenario(
            walk_random.SCENARIO,
            out,
            duration=args.duration,
            record=False,
            progress=progress,
            parameters={"seed": args.seed},
            log_window=args.log_window,
        )
    wall = time.perf_counter() - start
    result = output.result
    errors = landing_errors(output, args.duration)
    pelvis = output.arrays["q"][:, 6].min()
    rss = " / ".join("-" if marks[m] is None else f"{marks[m]:.0f}" for m in marks)
    if not result.completed:
        print(
            f"the run did not complete: ended at {result.end_time:.2f} s; fell: {result.fell}; "
            f"failure: {result.failure!r}"
        )
    print(f"load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    print(
        "| simulated [s] | wall [s] | completed | min pelvis z in the kept logs [m] | landings kept | "
        "max landing error [mm] | RSS at 25/50/75/100 % [MB] | log window [s] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    print(
        f"| {result.end_time:.0f} | {wall:.0f} | {result.completed} | {pelvis:.3f} | {len(errors)} | "
        f"{1000 * errors.max() if len(errors) else float('nan'):.1f} | {rss} | {args.log_window:g} |"
    )


if __name__ == "__main__":
    main()
