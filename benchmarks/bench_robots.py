"""The robots side by side: control-tick time and real-time factors on the embedded humanoid,
TALOS and the Unitree G1, measured in one run.

    python benchmarks/bench_robots.py          (or: make bench)

Per robot (those whose models are installed):
1. the full control tick of ``reach`` (kinematics, features, tasks, ``solve_hqp``), as
   ``bench_sot.bench_tick`` times it on the embedded robot;
2. the real-time factor of ``reach`` (4 s) and of ``walk`` (its first 6 s), each beside the
   same robot's plant standing on constant PD set points with no controller (same duration).
The embedded robot's row is the baseline of the ratios.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from bench_sot import bench_realtime, bench_tick, print_table

from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams import walk
from drake_sot.robots import ROBOTS, RobotDataMissing, get_robot


def main() -> None:
    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    results = {}
    for name in ROBOTS:
        try:
            robot = get_robot(name)
        except RobotDataMissing as exc:
            print(f"skipped {name}: {exc}")
            continue
        tick = bench_tick(robot=name)
        reach = bench_realtime(4.0, robot=name)
        walking = bench_realtime(6.0, scenario=walk, robot=name)
        results[name] = (robot, tick, reach, walking)
    base_tick = results["embedded"][1]["tick_median_us"]
    rows = []
    for name, (robot, tick, reach, walking) in results.items():
        n = len(robot.drives)
        rows.append(
            (
                f"{name}: reach control tick, median / p99 ({n} joints)",
                f"{tick['tick_median_us']:.0f} / {tick['tick_p99_us']:.0f} µs",
                f"embedded: {base_tick:.0f} µs",
                f"{tick['tick_median_us'] / base_tick:.2f}",
            )
        )
        for label, rtf in (("reach (4 s)", reach), ("walk (first 6 s)", walking)):
            rows.append(
                (
                    f"{name}: {label} real-time factor",
                    f"{rtf['rtf_scenario']:.2f}",
                    f"its plant alone: {rtf['rtf_plant']:.2f}",
                    f"{rtf['rtf_scenario'] / rtf['rtf_plant']:.2f} of baseline",
                )
            )
    print_table(rows)


if __name__ == "__main__":
    main()
