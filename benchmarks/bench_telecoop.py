"""Tele-cooperation against the delay: tracking, force transparency, real-time factors.

    python benchmarks/bench_telecoop.py [duration_s]

Runs the ``telecooperation`` scenario standing (the operator lifts the board by 5 cm and sets it
back; ``walk=False``) at 0, 70, 140 and 300 ms one way with the plain admittance, and at 140 ms
with the weighted one (Evrard et al. 2009, III-B: the virtual mass is the hand's apparent
inertia), and prints per run:

1. tracking: the largest distance [cm] between the operator's intention and the robot's right
   hand after 1 s (what the operator wants against what the robot does: the delay, the
   admittances and the load all count), and between the operator's hand (on the handle) and the
   robot's hand (the local compliance x_Δ and the delay);
2. force transparency: the RMS difference [N] between the force the operator applies on the
   right handle and the external force the robot's right wrist sensor measures (the sign flipped:
   what the operator pushes, the robot's hand pushes on the board), and the mean vertical force
   each side carries (the operator feels the board's weight share that the robot's hand holds);
3. the joint motion: the RMS speed [rad/s] of the shoulders' pitch and the elbows after 1 s;
4. the real-time factor of the run (simulated time over wall time; the whole one-process diagram:
   slave, master, channel and the board), beside the 0 ms run's.

Then, in the same run and for the same duration, three times interleaved (medians): the
real-time factors, over wall time and over the process's CPU time (less sensitive to the other
processes on the machine), of the whole diagram at 140 ms, of the slave side alone (the robot,
its seven tasks, the board and the co-operator: ``telecooperation``'s diagram with
``remote=True``, as ``telecoop_slave`` serves it, the master's named signals held at their initial values
since no client writes it) and of the plant alone (the robot on constant half-sitting set points,
no controller, no board: ``bench_sot.plant_alone_realtime``). The load average is printed before
and after.
"""

from __future__ import annotations

import datetime
import functools
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.run import simulate
from drake_sot.diagrams.scenario import Scenario, run_scenario

sys.path.insert(0, str(Path(__file__).parent))
from bench_sot import plant_alone_realtime

REPEATS = 3
RUNS = (("plain", 0.0), ("plain", 0.07), ("plain", 0.14), ("plain", 0.3), ("weighted", 0.14))


def coupled_run(admittance: str, delay: float, duration: float) -> tuple[float, ...]:
    """One standing run of the whole diagram: (intention − hand [cm], handle − hand [cm], force RMS
    [N], mean f_z operator [N], mean f_z robot [N], arm joint speed RMS [rad/s], real-time factor)."""
    scenario = Scenario(
        name="telecooperation",
        description="standing",
        build=functools.partial(tc.build, walk=False),
        parameters=(tc.DELAY, tc.ADMITTANCE),
    )
    with tempfile.TemporaryDirectory() as out:
        run = run_scenario(
            scenario,
            out,
            duration=duration,
            record=False,
            parameters={"delay": delay, "admittance": admittance},
        )
    if not run.result.completed:
        raise RuntimeError(f"{admittance} at {delay} s: the run did not complete ({run.result})")
    a = run.arrays
    after = a["time"] > 1.0
    intention = np.linalg.norm(a["operator_intention"][after, :3] - a["robot_hands"][after, :3], axis=1)
    handle = np.linalg.norm(a["operator_hands"][after, :3] - a["robot_hands"][after, :3], axis=1)
    f_op = a["operator_forces"][after, :3]
    f_robot = -a["wrench/e_fr"][after, 3:]
    rms = float(np.sqrt(np.mean(np.sum((f_op - f_robot) ** 2, axis=1))))
    speed = float(np.sqrt(np.mean(tc.arm_speeds(run.setup, a["v"][after]) ** 2)))
    return (
        100 * intention.max(),
        100 * handle.max(),
        rms,
        f_op[:, 2].mean(),
        f_robot[:, 2].mean(),
        speed,
        run.result.realtime_factor,
    )


def diagram_realtime(duration: float, remote: bool) -> tuple[float, float]:
    """(wall, CPU) real-time factors of ``telecooperation`` standing at 140 ms: the whole diagram,
    or (``remote``) the slave side alone (no master, no channel)."""
    setup = tc.build(None, walk=False, remote=remote)
    simulator = setup.built.create_simulator()
    wall, cpu = time.perf_counter(), time.process_time()
    result = simulate(simulator, duration, setup.commands)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    if not result.completed:
        raise RuntimeError(f"telecooperation (remote={remote}) did not complete ({result})")
    return duration / wall, duration / cpu


def realtime_factors(duration: float, repeats: int) -> dict[str, tuple[float, float]]:
    """Median (wall, CPU) real-time factors of the whole diagram, the slave side alone and the
    plant alone, each run ``repeats`` times, interleaved (the machine's load hits all alike)."""
    samples: dict[str, list[tuple[float, float]]] = {"whole": [], "slave": [], "plant": []}
    for _ in range(repeats):
        samples["whole"].append(diagram_realtime(duration, remote=False))
        samples["slave"].append(diagram_realtime(duration, remote=True))
        samples["plant"].append(
            (plant_alone_realtime(duration), plant_alone_realtime(duration, clock=time.process_time))
        )
    return {name: tuple(np.median(np.array(values), axis=0)) for name, values in samples.items()}


def main(duration: float) -> None:
    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    start = datetime.datetime.now(datetime.UTC)
    load_before = os.getloadavg()
    rows = [(admittance, delay, *coupled_run(admittance, delay, duration)) for admittance, delay in RUNS]
    factors = realtime_factors(duration, REPEATS)
    load_after = os.getloadavg()
    before, after = (" ".join(f"{x:.1f}" for x in load) for load in (load_before, load_after))
    print(
        f"{start:%Y-%m-%d %H:%M} UTC, {duration:g} s simulated per run, "
        f"load average (1, 5, 15 min) {before} before, {after} after"
    )
    print(
        "| admittance | one-way delay | operator intention − robot hand | handle − robot hand "
        "| force RMS (operator vs wrist) | f_z operator / robot wrist | arm joint speed RMS "
        "| real-time factor (/ 0 ms) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    base = rows[0][-1]
    for admittance, delay, intent, handle, rms, fz_op, fz_robot, speed, rtf in rows:
        print(
            f"| {admittance} | {1000 * delay:.0f} ms | {intent:.2f} cm | {handle:.2f} cm | {rms:.2f} N "
            f"| {fz_op:.2f} / {fz_robot:.2f} N | {speed:.4f} rad/s | {rtf:.2f} ({rtf / base:.2f}) |"
        )
    print()
    print(
        f"| real-time factor, standing (median of {REPEATS}) | wall | / plant alone | CPU time "
        "| / plant alone |"
    )
    print("|---|---|---|---|---|")
    plant_wall, plant_cpu = factors["plant"]
    for name, key in (
        ("whole diagram (slave, master, channel; 140 ms)", "whole"),
        ("slave side alone (robot, tasks, board, co-operator)", "slave"),
        ("plant alone (constant set points, no board)", "plant"),
    ):
        wall, cpu = factors[key]
        print(f"| {name} | {wall:.2f} | {wall / plant_wall:.2f} | {cpu:.2f} | {cpu / plant_cpu:.2f} |")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 8.0)
