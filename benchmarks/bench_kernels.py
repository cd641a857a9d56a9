"""Each compiled kernel against its numpy version (the oracle), calls interleaved in one run.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_kernels.py [--rounds 30] [--calls 200]

Per kernel, on inputs of the size a control tick gives it (the humanoid's nv = 36 columns, the
pattern generator's 1.6 s preview at 5 ms), each round times ``--calls`` calls of the compiled
kernel, then as many of the numpy one; the table gives the median µs per call over the rounds and
their ratio (compiled / numpy, below 1 is faster). Both answers are compared first (to 1e-12).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable

import numpy as np

from drake_sot import features, kernels, so3
from drake_sot.blas import limit_blas_threads
from drake_sot.inequalities import distance_rows_numpy
from drake_sot.preview import PreviewController
from drake_sot.stabilization import StabilizerGains, stabilizer_step, stabilizer_step_numpy


def _cases() -> dict[str, tuple[Callable[[], object], Callable[[], object]]]:
    """Per kernel: (compiled call, numpy call) on fixed random inputs."""
    rng = np.random.default_rng(0)
    core = kernels.compiled
    R, R_des, R_b = (so3.exp(rng.normal(size=3)) for _ in range(3))
    p, p_des, p_b = (rng.normal(size=3) for _ in range(3))
    J, J_b = rng.normal(size=(6, 36)), rng.normal(size=(6, 36))
    velocity = rng.normal(size=6)
    preview = PreviewController()
    reference = np.cumsum(rng.normal(scale=0.01, size=(1200, 2)), axis=0)
    x, s = rng.normal(scale=0.1, size=(3, 2)), rng.normal(size=2)
    distances, normals = rng.uniform(0.0, 0.05, size=4), rng.normal(size=(4, 3))
    witnesses = rng.normal(size=(8, 3, 36))
    pairs = (distances, normals, witnesses[0::2], witnesses[1::2], 0.01, 40.0, 6, 200.0)
    sole = np.array([[-0.1, -0.15], [0.12, -0.15], [0.12, 0.05], [-0.1, 0.05]])
    tick = {
        "com_ref": np.array([0.01, 0.0]),
        "com_vel_ref": np.array([0.1, 0.02]),
        "zmp_ref": np.array([0.0, -0.02]),
        "com": np.array([0.015, 0.003]),
        "com_vel": np.array([0.12, 0.0]),
        "zmp": np.array([0.02, -0.01]),
        "polygon": sole,
        "omega": 3.5,
        "dt": 0.005,
        "gains": StabilizerGains(),
    }
    state = (np.zeros(2), np.zeros(2), np.array([0.01, 0.0]))
    return {
        "stabilization.stabilizer_step (a 4-vertex support polygon)": (
            lambda: stabilizer_step(*state, **tick),
            lambda: stabilizer_step_numpy(*state, **tick),
        ),
        "inequalities.distance_rows (4 pairs in 6 rows, nv 36)": (
            lambda: core.distance_rows(*pairs),
            lambda: distance_rows_numpy(*pairs),
        ),
        "features.point6d (nv 36, moving reference)": (
            lambda: core.point6d(R, p, J, R_des, p_des, velocity),
            lambda: features.point6d_numpy(R, p, J, R_des, p_des, velocity),
        ),
        "features.point6d_relative (nv 36)": (
            lambda: core.point6d_relative(R, p, J, R_b, p_b, J_b, R_des, p_des),
            lambda: features.point6d_relative_numpy(R, p, J, R_b, p_b, J_b, R_des, p_des),
        ),
        "PreviewController.step_at (N 320)": (
            lambda: core.preview_step_at(preview._tick, x, s, reference, 1000),
            lambda: preview.step_numpy(x, s, preview.window(reference, 1000)),
        ),
        "PreviewController.plan (1200 samples), per sample": (
            lambda: core.preview_plan(preview._tick, reference, x, s),
            lambda: preview.run_numpy(reference, x, s),
        ),
    }


PER_SAMPLE = 1200  # the plan's samples: its row is per sample


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=30)
    parser.add_argument("--calls", type=int, default=200)
    args = parser.parse_args()
    if kernels.compiled is None:
        raise SystemExit(f"bench_kernels: the compiled kernels are not in use ({kernels.REASON})")
    limit_blas_threads(1)
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    print("| kernel | compiled µs | numpy µs | compiled / numpy |")
    print("|---|---|---|---|")
    np.seterr(invalid="ignore")
    for name, (compiled, oracle) in _cases().items():
        pair = compiled(), oracle()
        if hasattr(pair[0], "zmp_desired"):  # a StabilizerStep: its arrays
            pair = tuple((r.offset, r.offset_rate, r.zmp_filtered, r.zmp_desired) for r in pair)
        for a, b in zip(*pair, strict=True):
            a, b = np.asarray(a).ravel(), np.asarray(b).ravel()
            same = a == b  # the infinite bounds too (inf - inf is nan below, and not close)
            assert (
                same | (np.abs(a - b) <= 1e-12 * (1 + np.abs(b[np.isfinite(b)]).max(initial=0.0)))
            ).all(), name
        calls = max(1, args.calls // (50 if "plan" in name else 1))
        times: dict[str, list[float]] = {"compiled": [], "numpy": []}
        for _ in range(args.rounds):
            for label, call in (("compiled", compiled), ("numpy", oracle)):
                t0 = time.perf_counter()
                for _ in range(calls):
                    call()
                times[label].append((time.perf_counter() - t0) / calls)
        scale = 1e6 / (PER_SAMPLE if "per sample" in name else 1)
        c, n = (statistics.median(times[label]) * scale for label in ("compiled", "numpy"))
        print(f"| {name} | {c:.1f} | {n:.1f} | {c / n:.2f} |")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
