"""What compiling a feature's numerics with numba would buy and cost, against the package's numpy.

    pip install --target /tmp/nbpkgs numba==0.68.0   # not a dependency of the package
    PYTHONPATH=.:/tmp/nbpkgs .venv/bin/python benchmarks/bench_compiled.py [--calls 20000]

The function compiled is the 6D pose error of Mansard et al. 2009's ``FeaturePoint6d``
(:func:`drake_sot.features.point6d`: ``e = [p - p*; log(R R*ᵀ)]``, ``J_e = [J_v; J_l⁻¹(e_o)
J_ω]``), the feature every 6D task of the scenarios evaluates at each control tick, on a 36-column
Jacobian (the humanoid's nv): the same equations written for ``numba.njit``, its answer checked
against the package's to 1e-12. Printed, in one process, alternating: the time of a call of each
(median of ``--rounds`` rounds of ``--calls`` calls); the first call's compile time with numba's
on-disk cache empty (a temporary ``NUMBA_CACHE_DIR``), then, in a fresh interpreter, the first
call's time with that cache filled (what every new process would pay: a Dask worker, a served
run, a test's subprocess), and numba's import time.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

try:
    import numba
except ImportError:
    sys.exit("numba is not installed (it is no dependency of drake_sot): see this file's docstring")

from drake_sot import so3
from drake_sot.features import point6d


@numba.njit(cache=True)
def _log(R: np.ndarray) -> np.ndarray:
    """:func:`drake_sot.so3.log` away from π (the benchmark's rotations are)."""
    vx, vy, vz = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    theta = math.atan2(
        0.5 * math.sqrt(vx * vx + vy * vy + vz * vz), 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    )
    scale = 0.5 if theta < 1e-6 else theta / (2.0 * math.sin(theta))
    out = np.empty(3)
    out[0], out[1], out[2] = scale * vx, scale * vy, scale * vz
    return out


@numba.njit(cache=True)
def _left_jacobian_inverse(w: np.ndarray) -> np.ndarray:
    """:func:`drake_sot.so3.left_jacobian_inverse`."""
    x, y, z = w[0], w[1], w[2]
    t2 = x * x + y * y + z * z
    coef = 1.0 / 12.0 if t2 < 1e-12 else (1.0 - 0.5 * math.sqrt(t2) / math.tan(0.5 * math.sqrt(t2))) / t2
    M = np.empty((3, 3))
    M[0, 0], M[0, 1], M[0, 2] = 1.0 + coef * (x * x - t2), 0.5 * z + coef * x * y, -0.5 * y + coef * x * z
    M[1, 0], M[1, 1], M[1, 2] = -0.5 * z + coef * x * y, 1.0 + coef * (y * y - t2), 0.5 * x + coef * y * z
    M[2, 0], M[2, 1], M[2, 2] = 0.5 * y + coef * x * z, -0.5 * x + coef * y * z, 1.0 + coef * (z * z - t2)
    return M


@numba.njit(cache=True)
def point6d_compiled(R, p, J, R_des, p_des):
    """:func:`drake_sot.features.point6d` for a still reference."""
    e_o = _log(R @ R_des.T)
    e = np.empty(6)
    e[:3], e[3:] = p - p_des, e_o
    J_e = np.empty((6, J.shape[1]))
    J_e[:3] = J[3:]
    J_e[3:] = _left_jacobian_inverse(e_o) @ np.ascontiguousarray(J[:3])
    return e, J_e, np.zeros(6)


def _problem(nv: int = 36) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(0)
    return (
        so3.exp(rng.normal(size=3)),
        rng.normal(size=3),
        rng.normal(size=(6, nv)),
        so3.exp(rng.normal(size=3)),
        rng.normal(size=3),
    )


def _first_call() -> float:
    """Seconds of the first call of the compiled function in this interpreter."""
    args = _problem()
    start = time.perf_counter()
    point6d_compiled(*args)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--first-call", action="store_true", help=argparse.SUPPRESS)  # the child's role
    args = ap.parse_args()
    if args.first_call:
        print(_first_call())
        return
    if os.environ.get("NUMBA_CACHE_DIR") is None:  # a cache of our own, empty: the cold compile
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            sys.exit(
                subprocess.run([sys.executable, __file__, *sys.argv[1:]], env=env, check=False).returncode
            )
    compile_s = _first_call()
    problem = _problem()
    for got, want in zip(point6d_compiled(*problem), point6d(*problem), strict=True):
        if not np.allclose(got, want, rtol=0, atol=1e-12):
            sys.exit("the compiled point6d does not give the package's answer")
    fresh = subprocess.run(
        [sys.executable, __file__, "--first-call"], capture_output=True, text=True, check=True, env=os.environ
    )
    cached_s = float(fresh.stdout.split()[-1])
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import numba"], check=True)
    import_s = time.perf_counter() - start
    times: dict[str, list[float]] = {"numpy": [], "numba": []}
    for _ in range(args.rounds):
        for name, f in (("numpy", point6d), ("numba", point6d_compiled)):
            start = time.perf_counter()
            for _ in range(args.calls):
                f(*problem)
            times[name].append(1e6 * (time.perf_counter() - start) / args.calls)
    numpy_us, numba_us = statistics.median(times["numpy"]), statistics.median(times["numba"])
    versions = f"numba {numba.__version__}, numpy {np.__version__}, Python {sys.version.split()[0]}"
    print(f"{versions}, load {os.getloadavg()[0]:.1f}")
    print("| measurement | value |")
    print("|---|---|")
    print(f"| `point6d`, numpy (the package) | {numpy_us:.2f} µs a call |")
    print(f"| `point6d`, numba | {numba_us:.2f} µs a call ({numba_us / numpy_us:.2f} of numpy's) |")
    print(f"| saved a call | {numpy_us - numba_us:.2f} µs |")
    print(f"| first call, cache empty (compile) | {compile_s:.2f} s |")
    print(f"| first call in a fresh interpreter, cache filled | {cached_s:.2f} s |")
    print(f"| a fresh interpreter importing numba (start-up included) | {import_s:.2f} s |")


if __name__ == "__main__":
    main()
