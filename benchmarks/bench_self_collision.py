"""The cost of self-collision avoidance: the control tick of ``reach`` with and without a
``SelfCollisionAvoidance`` level under the joint limits, on each installed robot.

    python benchmarks/bench_self_collision.py

Both diagrams are ``reach`` at t = 3 s, the right hand near its target (+25 cm x, +20 cm z,
moved at t = 1 s), ticked as ``bench_sot.reach_tick`` does (a new configuration, then
``StackOfTasks``' periodic update); the second has the task (``d_s`` = 1 cm, ``d_i`` = 5 cm,
16 rows) second in its stack, under the joint limits, as ``reach`` has it by default (the first
is ``reach`` with ``self_collision=False``). Their ticks alternate in blocks in one
process, so that both see the same load; the ratio is the median of the per-block ratios.
Also printed: the rows the task fills at that posture (the pairs closer than ``d_i``) out of
the pairs of shapes that may collide, and the task's own evaluation (Drake's query and the
witness points' Jacobians), timed on its own.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bench_sot import print_table, ticker

from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams import reach
from drake_sot.diagrams.tasks import SELF_COLLISION_TASK
from drake_sot.robots import ROBOTS, RobotDataMissing, get_robot

TASK = SELF_COLLISION_TASK
#: When the ticks are timed [s]: the right hand, moved at 1 s, is near its target.
AT = 3.0


def _times(tick, n: int) -> list[float]:
    """``n`` calls of ``tick`` [µs each]."""
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        tick()
        out.append(1e6 * (time.perf_counter() - t0))
    return out


def bench(robot: str, blocks: int = 30, block: int = 10) -> dict[str, float]:
    """Tick medians [µs] without and with the task, their ratio, the task's rows and evaluation."""
    off, _ = ticker(reach.build(None, robot=robot, self_collision=False), AT)
    setup = reach.build(None, robot=robot)  # the task on, as the scenario has it by default
    on, context = ticker(setup, AT)
    for tick in (off, on):
        _times(tick, 30)  # warm-up
    samples: dict[str, list[float]] = {"off": [], "on": []}
    ratios = []
    for k in range(blocks):
        got = {
            name: _times(off if name == "off" else on, block)
            for name in (("off", "on"), ("on", "off"))[k % 2]
        }
        for name, times in got.items():
            samples[name] += times
        ratios.append(statistics.median(got["on"]) / statistics.median(got["off"]))
    task = setup.built.tasks[TASK]
    q = task.GetInputPort("q").Eval(task.GetMyContextFromRoot(context))
    alone = task.CreateDefaultContext()

    def evaluate():
        task.GetInputPort("q").FixValue(alone, q)  # a new value: the output is computed again
        return task.GetOutputPort("task").Eval(alone)

    return {
        "off_us": statistics.median(samples["off"]),
        "on_us": statistics.median(samples["on"]),
        "ratio": statistics.median(ratios),
        "task_us": statistics.median(_times(evaluate, 300)),
        "rows": int(np.isfinite(evaluate().lower).sum()),
        "max_rows": task.dimension,
        "pairs": len(task.model.scene_graph.model_inspector().GetCollisionCandidates()),
    }


def main() -> None:
    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    rows = []
    for name in ROBOTS:
        try:
            get_robot(name)
        except RobotDataMissing as exc:
            print(f"skipped {name}: {exc}")
            continue
        r = bench(name)
        rows.append(
            (
                f"{name}: reach tick at {AT:g} s with the task, median "
                f"({r['rows']} of {r['max_rows']} rows filled; {r['pairs']} pairs may collide)",
                f"{r['on_us']:.0f} µs (the task alone: {r['task_us']:.0f} µs)",
                f"without the task: {r['off_us']:.0f} µs",
                f"{r['ratio']:.2f}",
            )
        )
    print_table(rows)


if __name__ == "__main__":
    main()
