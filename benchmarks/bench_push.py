"""Push recovery: the largest 0.1 s push survived, stabilizer off vs on; and the ``walk``
real-time factor with the stabilizer beside the plant alone.

    python benchmarks/bench_push.py [--steps N] [--workers W] [--no-rtf]

1. For each case — standing (the README stack: feet, CoM, posture; push at 0.5 s), walking
   in mid single support (t = 2.55 s, the first step: left support) and walking in double
   support (t = 2.9 s, the 0.1 s double support after it) — and each direction, lateral
   (+y) and frontal (+x), on the pelvis: a bisection of the force between a bracket's ends,
   ``--steps`` runs each (the bracket's ends are not run: its lower end is taken as survived
   and its upper end as fallen, and the table says when a bisection never left an end).
   A run is survived when the fall monitor saw no fall within 3 s after the push (the walk
   is cut there: the slow shared machine). Stabilizer off and on.
2. The ``walk`` scenario's real-time factor, stabilizer on and off, beside the humanoid's
   plant alone on constant set points (all with the whole-body collision shapes), run one
   after the other in one process.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from bench_sot import plant_alone_realtime, print_table

PUSH = 0.1  # [s]
AFTER = 3.0  # [s] simulated after the push's start
CASES = {  # name -> (push time [s], bracket of the lateral force [N], of the frontal force [N])
    "standing": (0.5, (250.0, 650.0), (150.0, 550.0)),
    "walk, single support": (2.55, (100.0, 500.0), (100.0, 500.0)),
    "walk, double support": (2.9, (100.0, 500.0), (100.0, 500.0)),
}


def survives(case: str, axis: int, force: float, stabilizer: bool) -> bool:
    """One run: does the robot stand ``AFTER`` s after a push of ``force`` [N] along ``axis``?"""
    from drake_sot.diagrams import walk
    from drake_sot.diagrams.balance import add_stabilizer
    from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
    from drake_sot.diagrams.pushes import ExternalPush
    from drake_sot.diagrams.run import simulate

    t = CASES[case][0]
    vector = [0.0, 0.0, 0.0]
    vector[axis] = force
    pushes = [ExternalPush(t, "pelvis", tuple(vector), PUSH)]
    if case == "standing":
        b = HumanoidSoTBuilder(pushes=pushes)
        b.add_op_point_task("taskLF", "left_foot", gain=5.0)
        b.add_op_point_task("taskRF", "right_foot", gain=5.0)
        b.add_com_task("taskCom", selection="110", gain=3.0)
        b.add_posture_task("taskPosture")
        if stabilizer:
            add_stabilizer(b, "taskCom")
        built, commands = b.build(stack=["taskLF", "taskRF", "taskCom", "taskPosture"]), []
    else:
        setup = walk.build(pushes=pushes, stabilizer=stabilizer)
        built, commands = setup.built, setup.commands
    result = simulate(built.create_simulator(), t + AFTER, commands)
    if not result.completed and result.fell is None:
        raise RuntimeError(f"{case}: {result.failure}")
    return result.fell is None


def bisect(case: str, axis: int, stabilizer: bool, steps: int) -> tuple[float, float, int]:
    """(largest survived, smallest fallen, runs) after ``steps`` bisection runs in the bracket."""
    low, high = CASES[case][1 + (axis == 0)]
    for _ in range(steps):
        middle = round((low + high) / 2)
        if survives(case, axis, middle, stabilizer):
            low = middle
        else:
            high = middle
    return low, high, steps


def _job(job: tuple[str, int, bool, int]) -> tuple[tuple[str, int, bool], tuple[float, float, int], float]:
    case, axis, stabilizer, steps = job
    start = time.perf_counter()
    return (case, axis, stabilizer), bisect(case, axis, stabilizer, steps), time.perf_counter() - start


def push_table(steps: int, workers: int) -> None:
    jobs = [(case, axis, on, steps) for case in CASES for axis in (1, 0) for on in (False, True)]
    results = {}
    with ProcessPoolExecutor(workers) as pool:
        for key, value, seconds in pool.map(_job, jobs):  # each cell as it comes: a long run
            results[key] = value
            print(f"  {key}: survived {value[0]:.0f} N, fell {value[1]:.0f} N ({seconds:.0f} s)", flush=True)
    print(f"Largest survived 0.1 s pelvis push (bisection, {steps} runs per cell; survived / fell, N)")
    print("| case | direction | stabilizer off | stabilizer on |")
    print("|---|---|---|---|")
    for case in CASES:
        for axis, direction in ((1, "lateral (+y)"), (0, "frontal (+x)")):
            cells = []
            for on in (False, True):
                low, high, _ = results[(case, axis, on)]
                bracket = CASES[case][1 + (axis == 0)]
                edge = " (bracket end)" if low == bracket[0] or high == bracket[1] else ""
                cells.append(f"{low:.0f} / {high:.0f}{edge}")
            print(f"| {case} | {direction} | {cells[0]} | {cells[1]} |")


def rtf_table() -> None:
    from drake_sot.diagrams import walk
    from drake_sot.diagrams.run import simulate

    rows, rtf = [], {}
    for on in (True, False):
        setup = walk.build(stabilizer=on)
        result = simulate(setup.built.create_simulator(), setup.duration, setup.commands)
        if not result.completed or result.fell is not None:
            raise RuntimeError(f"walk (stabilizer {on}) did not complete: {result.failure or result.fell}")
        rtf[on] = result.realtime_factor
    plant = plant_alone_realtime(walk.build().duration)
    for on in (True, False):
        rows.append(
            (
                f"walk real-time factor, stabilizer {'on' if on else 'off'}",
                f"{rtf[on]:.2f}",
                f"plant alone (collision shapes): {plant:.2f}",
                f"{rtf[on] / plant:.2f} of baseline",
            )
        )
    print_table(rows)


def main() -> None:
    from drake_sot.blas import limit_blas_threads

    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3, help="bisection runs per cell (default 3)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--no-rtf", action="store_true", help="skip the real-time factor table")
    parser.add_argument("--no-push", action="store_true", help="skip the push-recovery table")
    args = parser.parse_args()
    if not args.no_push:
        push_table(args.steps, args.workers)
    if not args.no_rtf:
        rtf_table()


if __name__ == "__main__":
    main()
