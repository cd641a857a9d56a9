"""The closed loop's cost: each scenario's real-time factor beside the plant alone's, in one run.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_loop.py [--rounds 3] [--baseline COMMIT]
        [--scenarios walk_then_interact:15 walk:6 reach:4]

For each ``SCENARIO:SECONDS``, one round runs, each in a fresh interpreter and one after the
other (so that all see the same machine load): the humanoid's plant alone on constant PD set
points for the same simulated time (the same robot, 1 ms SAP step and collision shapes; no
controller, ``bench_sot.plant_alone_realtime``), the scenario from this tree, and, with
``--baseline``, the scenario from the tree of that commit (``git archive`` into a temporary
directory). Only ``Simulator.AdvanceTo`` is timed (``drake_sot.diagrams.run.simulate``), not
the diagram's construction, in wall time and in the process's CPU time (the CPU time is the
steadier figure on a shared machine). The table gives per-round ratios
``scenario RTF / plant-alone RTF`` (the controller's share of the loop is ``1 - ratio`` when
the plant costs the same in both), their median and spread.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEFAULT_SCENARIOS = ("walk_then_interact:15", "walk:6", "reach:4")


def _measure(kind: str, scenario: str, duration: float) -> dict[str, float]:
    """Run in the child interpreter: time ``duration`` [s] of ``scenario`` (kind "scenario")
    or of the plant alone (kind "plant"); wall and CPU real-time factors."""
    import importlib

    import numpy as np

    def clocks() -> np.ndarray:
        return np.array([time.perf_counter(), time.process_time()])

    if kind == "plant":
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from bench_sot import plant_alone_realtime

        wall, cpu = plant_alone_realtime(duration, clock=clocks)
        return {"wall": float(wall), "cpu": float(cpu)}
    from drake_sot.diagrams.run import simulate

    setup = importlib.import_module(f"drake_sot.diagrams.{scenario}").build(None)
    simulator = setup.built.create_simulator()
    t0 = clocks()
    result = simulate(simulator, duration, setup.commands)
    if not result.completed:
        raise SystemExit(f"{scenario} failed: {result.failure}")
    wall, cpu = clocks() - t0
    return {"wall": duration / wall, "cpu": duration / cpu}


def _child(tree: pathlib.Path, kind: str, scenario: str, duration: float) -> dict[str, float]:
    """One measurement in a fresh interpreter with ``tree`` first on the path."""
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, __file__, "--child", kind, scenario, str(duration)],
        env=env,
        check=True,
        capture_output=True,
        text=True,
        cwd=tree,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def _baseline_tree(commit: str, into: pathlib.Path) -> pathlib.Path:
    archive = subprocess.run(["git", "archive", commit], cwd=ROOT, check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def _spread(values: list[float]) -> str:
    return f"{statistics.median(values):.3f} ({min(values):.3f}-{max(values):.3f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--rounds", type=int, default=3, help="rounds per scenario (default 3)")
    parser.add_argument("--baseline", metavar="COMMIT", help="also time the scenarios of this commit's tree")
    parser.add_argument(
        "--scenarios",
        nargs="+",
        default=list(DEFAULT_SCENARIOS),
        metavar="NAME:SECONDS",
        help=f"scenarios and simulated seconds (default {' '.join(DEFAULT_SCENARIOS)})",
    )
    parser.add_argument("--child", nargs=3, metavar=("KIND", "SCENARIO", "SECONDS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        kind, scenario, seconds = args.child
        print(json.dumps(_measure(kind, scenario, float(seconds))))
        return
    if not args.rounds >= 1:
        parser.error(f"--rounds {args.rounds}: must be at least 1")
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"this tree": ROOT}
        if args.baseline:
            trees[args.baseline] = _baseline_tree(args.baseline, pathlib.Path(tmp))
        print(f"load average at start: {os.getloadavg()[0]:.1f}")
        print("| scenario | tree | RTF wall (median) | ÷ plant alone, wall | ÷ plant alone, CPU |")
        print("|---|---|---|---|---|")
        for item in args.scenarios:
            scenario, _, seconds = item.partition(":")
            duration = float(seconds or 4.0)
            ratios: dict[str, dict[str, list[float]]] = {
                name: {"wall": [], "cpu": [], "rtf": []} for name in trees
            }
            plant_rtf = []
            for _ in range(args.rounds):
                plant = _child(ROOT, "plant", scenario, duration)
                plant_rtf.append(plant["wall"])
                for name, tree in trees.items():
                    run = _child(tree, "scenario", scenario, duration)
                    ratios[name]["rtf"].append(run["wall"])
                    for clock in ("wall", "cpu"):
                        ratios[name][clock].append(run[clock] / plant[clock])
            print(
                f"| {scenario} ({duration:g} s) | plant alone | {statistics.median(plant_rtf):.2f} | 1 | 1 |"
            )
            for name, r in ratios.items():
                print(
                    f"| {scenario} ({duration:g} s) | {name} | {statistics.median(r['rtf']):.2f} "
                    f"| {_spread(r['wall'])} | {_spread(r['cpu'])} |"
                )
        print(f"load average at end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
