"""Timing of ``drake_sot.hqp.solve_hqp`` against the HQP of an older tree, calls interleaved.

    python benchmarks/bench_hqp.py [--baseline d23a96e] [--rounds 200] [--random 60]

The baseline is ``drake_sot/hierarchy.py`` of the commit ``--baseline`` (the tree before
``drake_sot.hqp`` existed), read with ``git show`` and loaded as a module beside this tree's
(it imports this tree's ``drake_sot.linalg`` and ``drake_sot.validation``).

1. Rows at a bound: joint-velocity limits on top of three 6-row tasks and a posture (n = 40),
   the limits tightened to half the unconstrained q̇ on its k largest joints (k = 0, 1, 4, 8,
   16; the table gives how many bind). Per round, one call each: the baseline, this tree cold,
   and this tree warm-started from the last tick's result (the same rows, targets moved by
   1e-3: a tick whose active set did not change). Medians over the rounds, and each one's
   ratio to its own k = 0.
2. Random hierarchies (6-10 levels of 2-13 rows on 38-50 joints, equality levels and levels
   mixing equality, one-sided and two-sided rows, half of them degenerate: rows repeated from
   above, rank-deficient levels, bounds through 0): per problem the baseline and this tree,
   alternately, best of 3 each; the median ratio, and how often the baseline raised.
"""

from __future__ import annotations

import argparse
import importlib.util
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import numpy as np

from drake_sot.blas import limit_blas_threads
from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import solve_hqp

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))  # the tests' random hierarchies: the same problems here

from random_hierarchies import random_hierarchy  # noqa: E402


def load_baseline(commit: str):
    """The module ``drake_sot/hierarchy.py`` of ``commit``, loaded under another name."""
    source = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{commit}:drake_sot/hierarchy.py"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    path = pathlib.Path(tempfile.mkdtemp()) / "baseline_hierarchy.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("baseline_hierarchy", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def limits_and_tasks(bound_rows: int, shift: float = 0.0, n: int = 40) -> list[tuple[np.ndarray, ...]]:
    """Limits on top (tightened on the ``bound_rows`` largest joints of the free q̇), three tasks
    and a posture, all as ``StackOfTasks`` passes them; the targets moved by ``shift``."""
    rng = np.random.default_rng(0)
    tasks = [(rng.normal(size=(6, n)), rng.normal(size=6)) for _ in range(3)]
    posture = (np.eye(n), 0.3 * rng.normal(size=n))
    free = solve_strict([*tasks, posture]).qdot
    limit = 2.0 * np.abs(free) + 1.0
    largest = np.argsort(-np.abs(free))[:bound_rows]
    limit[largest] = 0.5 * np.abs(free[largest])
    levels: list[tuple[np.ndarray, ...]] = [(np.eye(n), -limit, limit)]
    for J, t in (*tasks, posture):
        target = t + shift
        levels.append((J, target, target))
    return levels


def _time(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def bound_rows_table(baseline, rounds: int) -> None:
    print("## rows at a bound (n = 40): median µs, and the ratio to k = 0 of the same column")
    print("| k tightened | rows at a bound | baseline cold | this tree cold | this tree warm | warm / old |")
    print("|---|---|---|---|---|---|")
    zero: dict[str, float] = {}
    for k in (0, 1, 4, 8, 16):
        previous_tick = limits_and_tasks(k)
        tick = limits_and_tasks(k, shift=1e-3)
        warm_from = solve_hqp(previous_tick)
        active = len(warm_from.levels[0].active_lower) + len(warm_from.levels[0].active_upper)
        cold_new = solve_hqp(tick)
        warm_new = solve_hqp(tick, warm_start=warm_from)
        old = baseline.solve_hqp(tick)
        assert np.abs(warm_new.qdot - cold_new.qdot).max() <= 1e-9 * (1 + np.abs(cold_new.qdot).max())
        assert np.abs(old.qdot - cold_new.qdot).max() <= 1e-9 * (1 + np.abs(cold_new.qdot).max())
        calls = {
            "baseline": lambda tick=tick: baseline.solve_hqp(tick, validate=False),
            "cold": lambda tick=tick: solve_hqp(tick, validate=False),
            "warm": lambda tick=tick, w=warm_from: solve_hqp(tick, validate=False, warm_start=w),
        }
        times: dict[str, list[float]] = {name: [] for name in calls}
        for _ in range(rounds):
            for name, call in calls.items():
                times[name].append(_time(call))
        median = {name: statistics.median(values) for name, values in times.items()}
        if k == 0:
            zero = median
        cells = " | ".join(f"{1e6 * median[c]:.0f} (x{median[c] / zero[c]:.1f})" for c in calls)
        print(f"| {k} | {active} | {cells} | {median['warm'] / median['baseline']:.3f} |")


def random_table(baseline, problems: int) -> None:
    rng = np.random.default_rng(2026)
    ratios, raised, unsettled = [], 0, 0
    for _ in range(problems):
        levels = random_hierarchy(
            rng, bool(rng.random() < 0.5), int(rng.integers(38, 51)), int(rng.integers(6, 11))
        )
        new = min(_time(lambda levels=levels: solve_hqp(levels)) for _ in range(3))
        result = solve_hqp(levels)
        unsettled += bool(result.unsettled)
        try:
            old = min(_time(lambda levels=levels: baseline.solve_hqp(levels)) for _ in range(3))
        except RuntimeError:
            raised += 1
            continue
        ratios.append(new / old)
    print(f"\n## {problems} random hierarchies: this tree / baseline, cold")
    print(
        f"median ratio {statistics.median(ratios):.3f} (quartiles {np.quantile(ratios, 0.25):.3f}, "
        f"{np.quantile(ratios, 0.75):.3f}); baseline raised on {raised}; this tree unsettled on {unsettled}"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="d23a96e", help="commit whose hierarchy.py is the baseline")
    parser.add_argument("--rounds", type=int, default=200, help="interleaved rounds per k")
    parser.add_argument("--random", type=int, default=60, help="random hierarchies")
    args = parser.parse_args(argv)
    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    baseline = load_baseline(args.baseline)
    bound_rows_table(baseline, args.rounds)
    random_table(baseline, args.random)


if __name__ == "__main__":
    main(sys.argv[1:])
