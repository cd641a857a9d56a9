"""``solve_hqp`` on random hierarchies: the compiled solver against the numpy one and DAQP.

    python benchmarks/bench_hqp_random.py [--problems 300] [--repeats 3] [--seed 2026]

Problems: ``random_hierarchy`` of ``tests/random_hierarchies.py`` (the tests' large hierarchies:
6-10 levels of 2-13 rows on 38-50 joints, equality levels and levels mixing equality, one-sided
and two-sided rows, half of them degenerate). Per problem, interleaved, best of ``--repeats`` each,
in process CPU time (threads that spin count):

- ``compiled``: ``solve_hqp`` as a caller runs it (validation included), on the compiled kernels
  (``drake_sot/kernels/hqp.cpp``), with 1 BLAS thread and with the BLAS's default thread count;
- ``numpy``: the same call on the numpy solver of this tree (``_solve_numpy``: the solver of
  abdad51, unchanged), with 1 BLAS thread;
- ``daqp``: DAQP's hierarchical mode (``daqp.solve(None, None, A, bu, bl, sense,
  break_points=...)``, its default settings) on the stacked rows, built beforehand (only the call
  is timed), with 1 BLAS thread. A speed reference, not an answer: it softens each level with a
  fixed penalty, so its q̇ is off the strict hierarchy's (the max difference is printed).

Prints the mean and median time of each, the ratios compiled / numpy and compiled / DAQP (of the
means, and the median of the per-problem ratios), how many calls raised, how many left a level
unsettled, and the largest difference between the compiled and numpy answers.
"""

from __future__ import annotations

import argparse
import pathlib
import statistics
import sys
import time
from collections.abc import Callable

import daqp
import numpy as np

from drake_sot import hqp, kernels
from drake_sot.blas import limit_blas_threads
from drake_sot.hqp import solve_hqp

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))  # the tests' random hierarchies: the same problems here

from random_hierarchies import Level3, random_hierarchy  # noqa: E402


def _cpu(fn: Callable[[], object], repeats: int) -> tuple[float, object]:
    """The best process CPU time of ``repeats`` calls (s), and the last call's result (or the
    exception it raised)."""
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.process_time_ns()
        try:
            out = fn()
        except Exception as error:  # noqa: BLE001 (counted: "never raises" is what is measured)
            out = error
        best = min(best, (time.process_time_ns() - t0) * 1e-9)
    return best, out


def _numpy_path(levels: list[Level3]) -> hqp.HqpResult:
    """``solve_hqp`` on the numpy solver (the compiled kernels hidden for the call)."""
    compiled, kernels.compiled = kernels.compiled, None
    try:
        return solve_hqp(levels)
    finally:
        kernels.compiled = compiled


def _daqp_call(levels: list[Level3]) -> Callable[[], object]:
    """DAQP's hierarchical mode on ``levels``, its arrays built once: the call to time."""
    A = np.vstack([J for J, _, _ in levels])
    lower = np.maximum(np.concatenate([lo for _, lo, _ in levels]), -1e30)
    upper = np.minimum(np.concatenate([hi for _, _, hi in levels]), 1e30)
    sense = np.where(lower == upper, 5, 0).astype(np.int32)
    breaks = np.cumsum([J.shape[0] for J, _, _ in levels]).astype(np.int32)
    return lambda: daqp.solve(None, None, A, upper, lower, sense, break_points=breaks)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", type=int, default=300, help="random hierarchies (>= 1)")
    parser.add_argument(
        "--repeats", type=int, default=3, help="calls per problem and solver; the best counts"
    )
    parser.add_argument("--seed", type=int, default=2026)
    args = parser.parse_args(argv)
    if not (args.problems >= 1 and args.repeats >= 1):
        parser.error("--problems and --repeats must be >= 1")
    if kernels.compiled is None:
        sys.exit(f"the compiled kernels are not loaded ({kernels.REASON}): nothing to compare")
    default_threads = max(limit_blas_threads(1).values(), default=1)
    rng = np.random.default_rng(args.seed)
    names = ("compiled", "compiled, default BLAS threads", "numpy", "daqp")
    times: dict[str, list[float]] = {name: [] for name in names}
    raised = dict.fromkeys(names, 0)
    unsettled = {"compiled": 0, "numpy": 0}
    worst_numpy, worst_daqp = 0.0, 0.0
    for _ in range(args.problems):
        degenerate = bool(rng.random() < 0.5)
        levels = random_hierarchy(rng, degenerate, int(rng.integers(38, 51)), int(rng.integers(6, 11)))
        daqp_call = _daqp_call(levels)
        limit_blas_threads(1)
        elapsed, compiled = _cpu(lambda levels=levels: solve_hqp(levels), args.repeats)
        times["compiled"].append(elapsed)
        elapsed, numpy_result = _cpu(lambda levels=levels: _numpy_path(levels), args.repeats)
        times["numpy"].append(elapsed)
        elapsed, daqp_result = _cpu(daqp_call, args.repeats)
        times["daqp"].append(elapsed)
        limit_blas_threads(default_threads)
        elapsed, _ = _cpu(lambda levels=levels: solve_hqp(levels), args.repeats)
        times["compiled, default BLAS threads"].append(elapsed)
        for name, result in (("compiled", compiled), ("numpy", numpy_result), ("daqp", daqp_result)):
            raised[name] += isinstance(result, Exception)
        if isinstance(compiled, Exception) or isinstance(numpy_result, Exception):
            continue
        unsettled["compiled"] += bool(compiled.unsettled)
        unsettled["numpy"] += bool(numpy_result.unsettled)
        scale = 1.0 + float(np.abs(numpy_result.qdot).max())
        worst_numpy = max(worst_numpy, float(np.abs(compiled.qdot - numpy_result.qdot).max()) / scale)
        if not isinstance(daqp_result, Exception):
            x = np.asarray(daqp_result[0])
            worst_daqp = max(worst_daqp, float(np.abs(x - compiled.qdot).max()) / scale)
    limit_blas_threads(default_threads)

    print(f"## {args.problems} random hierarchies, best of {args.repeats}, process CPU time")
    print(f"BLAS threads: 1, and the default ({default_threads}) where named\n")
    print("| solver | mean | median | raised | unsettled |")
    print("|---|---|---|---|---|")
    for name in names:
        values = times[name]
        left = unsettled.get(name.split(",")[0], "-") if name != "daqp" else "-"
        print(
            f"| {name} | {1e6 * statistics.fmean(values):.0f} µs | {1e6 * statistics.median(values):.0f} µs "
            f"| {raised[name]} | {left} |"
        )
    compiled_times = np.array(times["compiled"])
    print("\n| ratio | of the means | median of the per-problem ratios |")
    print("|---|---|---|")
    for label, other in (
        ("compiled / numpy", "numpy"),
        ("compiled / daqp", "daqp"),
        ("compiled, default BLAS threads / 1 thread", "compiled, default BLAS threads"),
    ):
        baseline = np.array(times[other])
        if other.startswith("compiled,"):  # the default threads' time over the 1-thread time
            mean, median = baseline.mean() / compiled_times.mean(), np.median(baseline / compiled_times)
        else:
            mean, median = compiled_times.mean() / baseline.mean(), np.median(compiled_times / baseline)
        print(f"| {label} | {mean:.3f} | {median:.3f} |")
    print(
        f"\nmax |q̇_compiled - q̇_numpy| / (1 + |q̇|) = {worst_numpy:.1e}; "
        f"max |q̇_daqp - q̇_compiled| / (1 + |q̇|) = {worst_daqp:.1e} (DAQP's softened levels)"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
