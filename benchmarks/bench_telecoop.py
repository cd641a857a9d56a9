"""Tele-cooperation against the delay: tracking, force transparency, real-time factor.

    python benchmarks/bench_telecoop.py [duration_s]

Runs the ``telecooperation`` scenario standing (the operator lifts the board by 5 cm and sets it
back; ``walk=False``) at 0, 70, 140 and 300 ms one way, and prints per delay:

1. tracking: the largest distance [cm] between the operator's intention and the robot's right
   hand after 1 s (what the operator wants against what the robot does: the delay, the
   admittances and the load all count), and between the operator's hand (on the handle) and the
   robot's hand (the local compliance x_Δ and the delay);
2. force transparency: the RMS difference [N] between the force the operator applies on the
   right handle and the external force the robot's right wrist sensor measures (the sign flipped:
   what the operator pushes, the robot's hand pushes on the board), and the mean vertical force
   each side carries (the operator feels the board's weight share that the robot's hand holds);
3. the real-time factor of the run (simulated time over wall time; the whole one-process diagram:
   slave, master, channel and the board), beside the 0 ms run's.
"""

from __future__ import annotations

import functools
import sys
import tempfile
import time

import numpy as np

from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.scenario import Scenario, run_scenario

DELAYS = (0.0, 0.07, 0.14, 0.3)


def main(duration: float) -> None:
    scenario = Scenario(
        name="telecooperation",
        description="standing",
        build=functools.partial(tc.build, walk=False),
        parameters=("delay",),
    )
    rows = []
    for delay in DELAYS:
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            run = run_scenario(scenario, out, duration=duration, record=False, parameters={"delay": delay})
            wall = time.perf_counter() - start
        a = run.arrays
        t = a["time"]
        after = t > 1.0
        intention = np.linalg.norm(a["operator_intention"][after, :3] - a["robot_hands"][after, :3], axis=1)
        handle = np.linalg.norm(a["operator_hands"][after, :3] - a["robot_hands"][after, :3], axis=1)
        f_op = a["operator_forces"][after, :3]
        f_robot = -a["wrench/e_fr"][after, 3:]
        rms = float(np.sqrt(np.mean(np.sum((f_op - f_robot) ** 2, axis=1))))
        rows.append(
            (
                delay,
                100 * intention.max(),
                100 * handle.max(),
                rms,
                f_op[:, 2].mean(),
                f_robot[:, 2].mean(),
                duration / wall,
            )
        )
    base = rows[0][-1]
    print(
        f"{'delay [ms]':>10} {'intent-hand [cm]':>16} {'handle-hand [cm]':>16} {'force RMS [N]':>13} "
        f"{'fz op [N]':>9} {'fz robot [N]':>12} {'RTF':>6} {'RTF / 0 ms':>10}"
    )
    for delay, intent, handle, rms, fz_op, fz_robot, rtf in rows:
        print(
            f"{1000 * delay:10.0f} {intent:16.2f} {handle:16.2f} {rms:13.2f} {fz_op:9.2f} {fz_robot:12.2f} "
            f"{rtf:6.2f} {rtf / base:10.2f}"
        )


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 8.0)
