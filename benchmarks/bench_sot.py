"""Timing of the kinematic SoT, each number beside a baseline measured in the same run.

    python benchmarks/bench_sot.py            (or: make bench)
    python benchmarks/bench_sot.py --tick-baseline 8074b69 --tick-only

``--tick-baseline COMMIT`` picks the tree the lock-step tick is compared with (default
``BASELINE_COMMIT``); ``--tick-only`` runs that comparison alone and prints its figures.

1. ``solve_strict`` (null-space basis form) vs the textbook projector form of paper
   000 eq. 8-9 (n x n projectors, same pseudo-inverse threshold), on the ``reach``
   stack's sizes, calls interleaved so both see the same load; and ``solve_hqp`` vs
   ``solve_strict`` on the same levels (equalities only: the same q̇), then with the
   joint-limit level of the scenarios on top (a 30-row box, not binding).
2. One full control tick of ``reach`` (kinematics, 7 features and tasks, the solve)
   against the 5 ms control period, and against the same tick of the tree of
   ``BASELINE_COMMIT`` (or ``--tick-baseline``), the two trees in two
   interpreters run in lock step (blocks of 10 ticks, alternating).
3. The ``reach`` scenario's real-time factor against the plant alone, standing on
   constant PD set points (no controller), with the same physics settings.
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

import numpy as np
from baseline_tree import extract

# The package's solvers are imported in the functions that use them: the tick server runs this
# file with a baseline tree's drake_sot (bench_tick_against_baseline), which may lack today's modules.


def _timeit(fn, repeat: int) -> list[float]:
    fn()  # warm-up
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def solve_projector_form(levels, rank_threshold=1e-6):
    """Paper 000 eq. 8-9 as written:
    q̇_i = q̇_{i-1} + (J_i P)^+ (ė_i - J_i q̇_{i-1}), P ← P - (J_i P)^+ J_i P."""
    from drake_sot.linalg import pinv

    n = levels[0][0].shape[1]
    qdot, P = np.zeros(n), np.eye(n)
    for J, edot in levels:
        JP = J @ P
        JP_pinv = pinv(JP, rank_threshold)  # same absolute threshold as solve_strict
        qdot = qdot + JP_pinv @ (edot - J @ qdot)
        P = P - JP_pinv @ JP
    return qdot


def bench_solver(repeat: int = 2000) -> dict[str, float]:
    from drake_sot.hierarchy import solve_strict

    rng = np.random.default_rng(0)
    n = 36
    dims = [6, 6, 2, 6, 30]  # feet, feet, CoM xy, right hand, posture (reach)
    levels = [(rng.normal(size=(m, n)), rng.normal(size=m)) for m in dims]
    a = solve_strict(levels).qdot
    b = solve_projector_form(levels)
    assert np.allclose(a, b, atol=1e-8), "the two forms disagree"
    # Interleaved, so that both see the same machine load; the ratio is taken per pair.
    basis, proj = [], []
    for _ in range(repeat):
        basis += _timeit(lambda: solve_strict(levels), 1)
        proj += _timeit(lambda: solve_projector_form(levels), 1)
    ratio = statistics.median(p / b for p, b in zip(proj, basis, strict=True))
    return {
        "basis_us": 1e6 * statistics.median(basis),
        "projector_us": 1e6 * statistics.median(proj),
        "ratio": ratio,
    }


def bench_hqp(repeat: int = 2000) -> dict[str, float]:
    """``solve_hqp`` against ``solve_strict`` on the reach stack's sizes, interleaved, unvalidated
    (as ``StackOfTasks`` calls them): equalities only, then with a box of joint limits on top."""
    from drake_sot.hierarchy import solve_strict
    from drake_sot.hqp import solve_hqp

    rng = np.random.default_rng(0)
    n = 36
    levels = [(rng.normal(size=(m, n)), rng.normal(size=m)) for m in (6, 6, 2, 6, 30)]
    triples = [(J, e, e) for J, e in levels]
    box = (np.eye(n)[6:], -np.full(n - 6, 5.0), np.full(n - 6, 5.0))  # |q̇_joint| <= 5 rad/s: not binding
    limited = [box, *triples]
    strict = solve_strict(levels).qdot
    assert np.allclose(solve_hqp(triples, validate=False).qdot, strict, atol=1e-9), "hqp and strict disagree"
    assert np.allclose(solve_hqp(limited, validate=False).qdot, strict, atol=1e-9), "the box should not bind"
    times: dict[str, list[float]] = {"strict": [], "hqp": [], "limited": []}
    for _ in range(repeat):
        times["strict"] += _timeit(lambda: solve_strict(levels, validate=False), 1)
        times["hqp"] += _timeit(lambda: solve_hqp(triples, validate=False), 1)
        times["limited"] += _timeit(lambda: solve_hqp(limited, validate=False), 1)
    pairs = zip(times["strict"], times["hqp"], times["limited"], strict=True)
    ratios = [(h / s, lim / s) for s, h, lim in pairs]
    return {
        "strict_us": 1e6 * statistics.median(times["strict"]),
        "hqp_us": 1e6 * statistics.median(times["hqp"]),
        "limited_us": 1e6 * statistics.median(times["limited"]),
        "ratio": statistics.median(r for r, _ in ratios),
        "limited_ratio": statistics.median(r for _, r in ratios),
    }


def reach_tick(robot: str = "embedded"):
    """One full control tick of ``reach`` on ``robot`` as a function: a new configuration (which
    invalidates kinematics, features and tasks) then ``StackOfTasks``' periodic update, at t = 1 s
    with the right-hand target just moved (every feature non-trivial). The embedded robot is built
    without the ``robot`` argument, so that the baseline tree (which has none) runs it too."""
    from drake_sot.diagrams import reach

    return ticker(reach.build(None) if robot == "embedded" else reach.build(None, robot=robot))[0]


def ticker(setup, at: float = 1.0):
    """``(tick, context)``: :func:`reach_tick`'s tick on a ``reach`` setup (built, e.g., with
    more tasks), simulated to t = 1 s, its right-hand target then moved, and on to ``at`` [s];
    the simulator's root context, at the configuration ticked about."""
    built = setup.built
    simulator = built.create_simulator()
    context = simulator.get_mutable_context()
    simulator.AdvanceTo(1.0)
    setup.commands[0].apply(context)  # the right hand is moving: every feature is non-trivial
    simulator.AdvanceTo(at)
    sot_context = built.sot.GetMyMutableContextFromRoot(context)
    device_context = built.device.GetMyMutableContextFromRoot(context)
    rng = np.random.default_rng(1)
    q_ref = built.device.GetOutputPort("q").Eval(device_context).copy()

    def tick():
        q = q_ref.copy()
        q[7:] += 1e-4 * rng.normal(size=q.size - 7)
        built.device.set_configuration(device_context, q)
        built.sot.EvalUniquePeriodicDiscreteUpdate(sot_context)

    return tick, context


def bench_tick(repeat: int = 300, robot: str = "embedded") -> dict[str, float]:
    """Median and p99 of :func:`reach_tick` on ``robot`` [µs]."""
    samples = _timeit(reach_tick(robot), repeat)
    return {
        "tick_median_us": 1e6 * statistics.median(samples),
        "tick_p99_us": 1e6 * float(np.percentile(samples, 99)),
    }


#: The default commit whose ``reach`` tick is the baseline of the tick row: the tree before the speed
#: work on the tick (solve_hqp's active set on every level, numpy's SVD wrapper, one errstate per task).
BASELINE_COMMIT = "9ecd1f9"
#: Command-line flag that makes this file a tick server (see :func:`serve_ticks`).
SERVE_FLAG = "--serve-ticks"


def serve_ticks() -> None:
    """A tick server for :func:`bench_tick_against_baseline`: builds :func:`reach_tick` with the
    ``drake_sot`` that ``PYTHONPATH`` gives, says ``ready``, then for each line ``N`` of stdin
    runs N ticks and prints their times [µs] as one JSON list."""
    tick = reach_tick()
    for _ in range(30):  # warm-up
        tick()
    print("ready", flush=True)
    for line in sys.stdin:
        times = []
        for _ in range(int(line)):
            t0 = time.perf_counter()
            tick()
            times.append(1e6 * (time.perf_counter() - t0))
        print(json.dumps(times), flush=True)


def bench_tick_against_baseline(
    blocks: int = 60, block: int = 10, baseline_commit: str = BASELINE_COMMIT
) -> dict[str, float]:
    """The reach tick of this tree and of ``baseline_commit``'s tree (``git archive`` into a
    temporary directory), each in its own interpreter (:func:`serve_ticks`), run in lock step:
    ``blocks`` alternations of ``block`` ticks each, the order swapped every block, so that both
    see the same machine load within milliseconds. Returns the medians of all the ticks and the
    median of the per-block ratios of medians."""
    root = pathlib.Path(__file__).resolve().parent.parent

    def start(tree: pathlib.Path) -> subprocess.Popen:
        # One BLAS thread in both (as this tree's front-ends pin it, drake_sot.blas): the ratio is the code's.
        env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
        server = subprocess.Popen(
            [sys.executable, __file__, SERVE_FLAG],
            cwd=tree,
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        return server

    def ticks(server: subprocess.Popen) -> list[float]:
        server.stdin.write(f"{block}\n")
        server.stdin.flush()
        return json.loads(server.stdout.readline())

    with tempfile.TemporaryDirectory() as baseline:
        extract(baseline_commit, pathlib.Path(baseline))
        servers = {"baseline": start(pathlib.Path(baseline)), "tree": start(root)}
        try:
            for server in servers.values():
                if server.stdout.readline().strip() != "ready":
                    raise RuntimeError("a tick server did not start")
            samples: dict[str, list[float]] = {"baseline": [], "tree": []}
            ratios = []
            for k in range(blocks):
                order = ("baseline", "tree") if k % 2 == 0 else ("tree", "baseline")
                got = {name: ticks(servers[name]) for name in order}
                for name, times in got.items():
                    samples[name] += times
                ratios.append(statistics.median(got["tree"]) / statistics.median(got["baseline"]))
        finally:
            for server in servers.values():
                server.stdin.close()
                server.wait()
    return {
        "baseline_us": statistics.median(samples["baseline"]),
        "tick_us": statistics.median(samples["tree"]),
        "ratio": statistics.median(ratios),
        "ratio_of_medians": statistics.median(samples["tree"]) / statistics.median(samples["baseline"]),
    }


def plant_alone_realtime(
    duration: float,
    *,
    body_collision: bool = True,
    robot: str = "embedded",
    clock=time.perf_counter,
    add_systems=None,
) -> float:
    """Real-time factor of the humanoid's plant alone (SAP, 1 ms, point contact) standing on
    constant PD set points (half-sitting) for ``duration`` [s], with no controller; ``clock``
    times it (wall time by default; ``time.process_time``: the process's CPU time).
    ``add_systems(builder)``, when given, adds systems of its own beside the plant before the
    diagram is built (``bench_loop.py``'s floor)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_sot.diagrams.world import add_humanoid_plant
    from drake_sot.models import half_sitting_configuration

    builder = DiagramBuilder()
    plant, _, info = add_humanoid_plant(builder, body_collision=body_collision, robot=robot)
    q0 = half_sitting_configuration(plant, info)
    x_des = np.concatenate(
        [
            [q0[plant.GetJointByName(j).position_start()] for j in info.actuated_joints],
            np.zeros(len(info.actuated_joints)),
        ]
    )
    source = builder.AddSystem(ConstantVectorSource(x_des))
    builder.Connect(source.get_output_port(), plant.get_desired_state_input_port(info.model_instance))
    if add_systems is not None:
        add_systems(builder)
    baseline = Simulator(builder.Build())
    plant.SetPositions(plant.GetMyMutableContextFromRoot(baseline.get_mutable_context()), q0)
    baseline.Initialize()
    t0 = clock()
    baseline.AdvanceTo(duration)
    return duration / (clock() - t0)


def bench_realtime(duration: float | None = 4.0, scenario=None, robot: str = "embedded") -> dict[str, float]:
    """Real-time factor of a scenario module (``reach`` by default; its whole script when
    ``duration`` is None) and of the plant alone on constant set points, same duration, on ``robot``."""
    from drake_sot.diagrams import reach
    from drake_sot.diagrams.run import simulate

    setup = (scenario or reach).build(None, robot=robot)
    duration = duration or setup.duration
    rtf_plant = plant_alone_realtime(duration, robot=robot)
    simulator = setup.built.create_simulator()
    result = simulate(simulator, duration, setup.commands)
    if not result.completed:
        raise RuntimeError(f"the scenario failed: {result.failure}")
    return {"rtf_plant": rtf_plant, "rtf_scenario": result.realtime_factor}


def against_row(against: dict[str, float], baseline_commit: str, blocks: int) -> tuple[str, ...]:
    """The table row of :func:`bench_tick_against_baseline`'s figures."""
    return (
        f"reach tick, two interpreters in lock step with the baseline tree ({10 * blocks} ticks each)",
        f"{against['tick_us']:.0f} µs",
        f"commit {baseline_commit}: {against['baseline_us']:.0f} µs",
        f"tick / baseline tick: {against['ratio']:.2f} (median of {blocks} blocks; "
        f"of all ticks: {against['ratio_of_medians']:.2f})",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument(
        "--tick-baseline",
        default=BASELINE_COMMIT,
        metavar="COMMIT",
        help=f"the commit whose reach tick the lock-step row compares with (default {BASELINE_COMMIT})",
    )
    parser.add_argument("--tick-only", action="store_true", help="run the lock-step tick comparison alone")
    parser.add_argument("--blocks", type=int, default=60, help="lock-step blocks of 10 ticks (default 60)")
    args = parser.parse_args()
    from drake_sot.blas import limit_blas_threads  # not at the top: the baseline tree has none

    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    if args.tick_only:
        against = bench_tick_against_baseline(args.blocks, baseline_commit=args.tick_baseline)
        print_table([against_row(against, args.tick_baseline, args.blocks)])
        return
    solver = bench_solver()
    hqp = bench_hqp()
    tick = bench_tick()
    against = bench_tick_against_baseline(args.blocks, baseline_commit=args.tick_baseline)
    rtf = bench_realtime()
    rows = [
        (
            "solve_strict, reach stack (n=36, 5 levels, 50 rows)",
            f"{solver['basis_us']:.0f} µs",
            f"projector form eq. 8-9: {solver['projector_us']:.0f} µs",
            f"projector / basis time: {solver['ratio']:.2f}",
        ),
        (
            "solve_hqp, the same levels (equalities only: the same q̇)",
            f"{hqp['hqp_us']:.0f} µs",
            f"solve_strict: {hqp['strict_us']:.0f} µs",
            f"hqp / strict time: {hqp['ratio']:.2f}",
        ),
        (
            "solve_hqp, the same below a level of joint limits (+30 rows, not binding)",
            f"{hqp['limited_us']:.0f} µs",
            f"solve_strict without them: {hqp['strict_us']:.0f} µs",
            f"hqp / strict time: {hqp['limited_ratio']:.2f}",
        ),
        (
            "full control tick of reach (median / p99)",
            f"{tick['tick_median_us']:.0f} / {tick['tick_p99_us']:.0f} µs",
            "control period: 5000 µs",
            f"{tick['tick_median_us'] / 5000:.1%} of the period",
        ),
        against_row(against, args.tick_baseline, args.blocks),
        (
            "reach scenario real-time factor",
            f"{rtf['rtf_scenario']:.2f}",
            f"plant alone on constant set points: {rtf['rtf_plant']:.2f}",
            f"{rtf['rtf_scenario'] / rtf['rtf_plant']:.2f} of baseline",
        ),
    ]
    print_table(rows)


def print_table(rows) -> None:
    """A markdown table of (measurement, drake_sot, baseline, ratio) rows."""
    print("| measurement | drake_sot | baseline (same run) | ratio |")
    print("|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    if sys.argv[1:] == [SERVE_FLAG]:
        serve_ticks()
    else:
        main()
