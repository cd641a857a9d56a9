"""Walking: the pattern generator's time per control tick and the ``walk`` scenario's
real-time factor, each beside a baseline measured in the same run.

    python benchmarks/bench_walk.py            (or: make bench)

1. PatternGenerator alone in a Simulator, walking with ``set_velocity`` (footprints
   made and sampled as it goes): the wall time of each tick (time between simulator
   monitor calls), beside a system with an empty periodic unrestricted update (Drake's
   own cost of such a tick) and the bare ``PreviewController.step`` call.
2. The ``walk`` scenario (no recording) beside the same plant standing on constant
   PD set points with no controller.
3. That plant alone with its whole-body collision shapes beside the same plant whose
   soles alone collide: the price of the shapes when nothing but the soles touches
   (alternated, best of three each).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import LeafSystem

from drake_sot.footsteps import Footstep
from drake_sot.preview import PreviewController
from drake_sot.systems.pattern_generator import PatternGenerator

sys.path.insert(0, str(Path(__file__).parent))
from bench_sot import bench_realtime, plant_alone_realtime, print_table

DT = 0.005


class _EmptyTick(LeafSystem):
    """A periodic unrestricted update that does nothing: Drake's cost of a tick."""

    def __init__(self) -> None:
        super().__init__()
        self.DeclareAbstractState(Value[object](0))
        self.DeclarePeriodicUnrestrictedUpdateEvent(DT, 0.0, lambda context, state: None)


def _tick_times(system: LeafSystem, setup, duration: float) -> list[float]:
    simulator = Simulator(system)
    setup(simulator.get_mutable_context())
    stamps: list[float] = []
    simulator.set_monitor(lambda context: stamps.append(time.perf_counter()))
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    return list(np.diff(stamps))


def bench_pattern_generator(duration: float = 20.0) -> dict[str, float]:
    pg = PatternGenerator(
        Footstep(0.0, 0.095, 0.0, "left"), Footstep(0.0, -0.095, 0.0, "right"), com_height=0.81
    )
    pg_ticks = _tick_times(pg, lambda c: pg.set_velocity(c, 0.2, 0.0, 0.1), duration)
    empty_ticks = _tick_times(_EmptyTick(), lambda c: None, duration)
    controller = PreviewController(dt=DT, z_c=0.81)
    x, e, window = np.zeros((3, 2)), np.zeros(2), np.zeros((controller.N, 2))
    step_times = []
    for _ in range(4000):
        t0 = time.perf_counter()
        controller.step(x, e, window)
        step_times.append(time.perf_counter() - t0)
    return {
        "pg_median_us": 1e6 * statistics.median(pg_ticks),
        "pg_p99_us": 1e6 * float(np.percentile(pg_ticks, 99)),
        "empty_median_us": 1e6 * statistics.median(empty_ticks),
        "step_median_us": 1e6 * statistics.median(step_times),
    }


def bench_walk_realtime() -> dict[str, float]:
    from drake_sot.diagrams import walk

    return bench_realtime(duration=None, scenario=walk)


def bench_body_collision(duration: float = 5.0, repeat: int = 3) -> dict[str, float]:
    body, soles = [], []
    for _ in range(repeat):
        body.append(plant_alone_realtime(duration, body_collision=True))
        soles.append(plant_alone_realtime(duration, body_collision=False))
    return {"rtf_body": max(body), "rtf_soles": max(soles)}


def main() -> None:
    pg = bench_pattern_generator()
    rtf = bench_walk_realtime()
    collision = bench_body_collision()
    rows = [
        (
            "PatternGenerator tick, walking (median / p99)",
            f"{pg['pg_median_us']:.1f} / {pg['pg_p99_us']:.1f} µs",
            f"empty periodic update: {pg['empty_median_us']:.1f} µs; "
            f"preview step alone: {pg['step_median_us']:.1f} µs",
            f"{pg['pg_median_us'] / pg['empty_median_us']:.1f}x an empty tick",
        ),
        (
            "walk scenario real-time factor",
            f"{rtf['rtf_scenario']:.2f}",
            f"plant alone on constant set points: {rtf['rtf_plant']:.2f}",
            f"{rtf['rtf_scenario'] / rtf['rtf_plant']:.2f} of baseline",
        ),
        (
            "plant alone standing, whole-body collision shapes",
            f"{collision['rtf_body']:.2f}",
            f"soles alone collide: {collision['rtf_soles']:.2f}",
            f"{collision['rtf_body'] / collision['rtf_soles']:.2f} of baseline",
        ),
    ]
    print_table(rows)


if __name__ == "__main__":
    main()
