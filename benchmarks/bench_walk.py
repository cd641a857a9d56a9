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
4. ``--stabilizer``: instead of 1-3, the ``walk`` (collision shapes) with the balance
   stabilizer, without it, and the plant alone, interleaved ``--rounds`` times in one process;
   each real-time factor by wall time and by the process's CPU time (less moved by the
   other processes of a shared machine), and the load average before each round.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import LeafSystem

from drake_sot.blas import limit_blas_threads
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


def _walk_realtime(stabilizer: bool) -> tuple[float, float, float]:
    """(simulated duration [s], wall time [s], CPU time [s]) of the whole ``walk``."""
    from drake_sot.diagrams import walk
    from drake_sot.diagrams.run import simulate

    setup = walk.build(stabilizer=stabilizer)
    simulator = setup.built.create_simulator()
    cpu = time.process_time()
    result = simulate(simulator, setup.duration, setup.commands)
    cpu = time.process_time() - cpu
    if not result.completed or result.fell is not None:
        raise RuntimeError(
            f"walk (stabilizer {stabilizer}) did not complete: {result.failure or result.fell}"
        )
    return setup.duration, result.wall_time, cpu


def bench_stabilizer_realtime(rounds: int = 3) -> None:
    """The walk with and without the stabilizer beside the plant alone, interleaved; a row per round."""
    print(
        "| round (load average) | plant alone | walk, stabilizer on (ratio) | walk, stabilizer off (ratio) |"
    )
    print("|---|---|---|---|")
    for k in range(rounds):
        load = os.getloadavg()[0]
        duration, on_wall, on_cpu = _walk_realtime(True)
        plant_wall = plant_alone_realtime(duration)
        plant_cpu = plant_alone_realtime(duration, clock=time.process_time)
        _, off_wall, off_cpu = _walk_realtime(False)
        cells = [f"wall {plant_wall:.2f} / CPU {plant_cpu:.2f}"]
        for wall, cpu in ((on_wall, on_cpu), (off_wall, off_cpu)):
            cells.append(
                f"wall {duration / wall:.2f} ({duration / wall / plant_wall:.2f}) / "
                f"CPU {duration / cpu:.2f} ({duration / cpu / plant_cpu:.2f})"
            )
        print(f"| {k + 1} ({load:.1f}) | {' | '.join(cells)} |", flush=True)


def main() -> None:
    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stabilizer", action="store_true", help="only the walk with/without the stabilizer")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of --stabilizer (default 3)")
    args = parser.parse_args()
    if args.stabilizer:
        bench_stabilizer_realtime(args.rounds)
        return
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
