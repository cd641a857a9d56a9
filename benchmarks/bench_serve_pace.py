"""A served run's pace beside a plain run's: ``serve`` unpaced against ``run``, rounds interleaved.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_serve_pace.py [--scenario walk_then_interact]
        [--seconds 10] [--rounds 4] [--baseline COMMIT]

Per round, one after the other so that both see the same machine load: ``drake-sot run SCENARIO
--duration S --out TMP`` (it records the replay and writes the artefacts; only its simulation is
timed, the real-time factor it prints) and ``drake-sot serve SCENARIO --duration S --realtime 1000
--port 0`` (as fast as the machine goes; a served run draws its live view, records the replay and
steps one control period at a time, answering clients between ticks; none connects here). With
``--baseline``, the same pair from that commit's tree too. Prints each run's real-time factor and,
per round, serve ÷ run of the same tree; their median is the figure.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile

from baseline_tree import extract

ROOT = pathlib.Path(__file__).resolve().parent.parent
_FACTOR = re.compile(r"real-time factor ([0-9.]+)")


def _factor(tree: pathlib.Path, command: list[str]) -> float:
    """The real-time factor ``drake-sot COMMAND`` run from ``tree`` prints on its last lines."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run(
        [sys.executable, "-m", "drake_sot.app.cli", *command],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        timeout=900,
        stdin=subprocess.DEVNULL,
    )
    found = _FACTOR.findall(done.stdout + done.stderr)
    if done.returncode or not found:
        raise SystemExit(f"{' '.join(command)} in {tree} exited {done.returncode}: {done.stderr[-400:]}")
    return float(found[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="walk_then_interact")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--baseline", metavar="COMMIT")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"this tree": ROOT}
        if args.baseline:
            trees[args.baseline] = extract(args.baseline, pathlib.Path(tmp) / "baseline")
        duration = ["--duration", f"{args.seconds:g}"]
        print(f"load average at start: {os.getloadavg()[0]:.1f}")
        print("| round | tree | run RTF | serve RTF (unpaced) | serve ÷ run |")
        print("|---|---|---|---|---|")
        ratios: dict[str, list[float]] = {name: [] for name in trees}
        for k in range(args.rounds):
            for name, tree in trees.items():
                out = pathlib.Path(tmp) / f"run-{k}-{len(ratios[name])}-{name.replace(' ', '_')}"
                run = _factor(tree, ["run", args.scenario, *duration, "--out", str(out)])
                serve = _factor(
                    tree, ["serve", args.scenario, *duration, "--realtime", "1000", "--port", "0"]
                )
                ratios[name].append(serve / run)
                print(f"| {k + 1} | {name} | {run:.2f} | {serve:.2f} | {serve / run:.2f} |")
        for name, values in ratios.items():
            print(f"| median | {name} | | | {statistics.median(values):.2f} |")
        print(f"load average at end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
