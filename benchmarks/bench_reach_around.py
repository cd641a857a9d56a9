"""The clearance of ``reach_around`` in physics: how close the simulated robot's shapes come, and
its reference's, on each installed robot.

    python benchmarks/bench_reach_around.py [ROBOT ...]

Each robot's ``reach_around`` with the self-collision task, simulated once (no replay). At every
logged sample (the control period) the least signed distance of the pairs of collision shapes the
simulated plant's SceneGraph may collide, the ground's and the soles' against the table left
out (the soles stand on them), is asked of that SceneGraph twice, by the physics test's own
function (``tests/diagrams/test_reach_around.py``, ``closest_pairs``): at the simulated q and at the
reference q the controller integrated (``q_ref``). Printed per robot: the least of each over the
run (when, which pair), the task's margin ``d_s``, and how far the simulated hand is from each
reachable target at the end of its time. The physics test of the scenario asserts the first
against ``d_s`` less 2 mm; this prints where the difference between the two comes from (the
reference inside ``d_s``, or the actuators lagging it).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# The physics test's module, and the test helpers it imports.
sys.path.insert(0, str(Path(__file__).parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "diagrams"))
from test_reach_around import closest_pairs  # the physics test's own query

from drake_sot.diagrams import reach_around
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.robots import ROBOTS, RobotDataMissing, get_robot


def hand_errors(robot: str, output) -> dict[str, float]:
    """The simulated hand's distance [m] to each reachable target, 50 ms before the next one."""
    built, arrays = output.setup.built, output.arrays
    g = reach_around.geometry(robot)
    context = built.diagram.CreateDefaultContext()
    errors = {}
    for k, target in enumerate(reach_around.targets(g, reach_around.table(g))):
        if not target.reachable:
            continue
        i = int(
            np.argmin(np.abs(arrays["time"] - (reach_around.START + (k + 1) * reach_around.DWELL - 0.05)))
        )
        built.plant.SetPositions(
            built.plant.GetMyMutableContextFromRoot(context), built.info.model_instance, arrays["q"][i]
        )
        errors[target.name] = float(
            np.linalg.norm(built.frame_pose(context, "right_hand").translation() - target.position)
        )
    return errors


def main(robots: list[str]) -> None:
    print("| robot | least distance, simulated | least distance, reference | hand off its targets | wall |")
    print("|---|---|---|---|---|")
    for robot in robots:
        try:
            get_robot(robot)
        except RobotDataMissing as error:
            print(f"| {robot} | skipped: {error} | | | |")
            continue
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            output = run_scenario(
                reach_around.SCENARIO, Path(out), record=False, parameters={"robot": robot}, log_window=None
            )
            wall = time.perf_counter() - t0
        cells = []
        for c in (closest_pairs(output, "q"), closest_pairs(output, "q_ref")):
            a, b = (name.split("::")[-1] for name in c.pair)
            cells.append(f"{1000 * c.distance:.2f} mm at {c.time:.2f} s ({a}, {b})")
        hands = ", ".join(f"{name} {100 * e:.2f} cm" for name, e in hand_errors(robot, output).items())
        print(f"| {robot} | {cells[0]} | {cells[1]} | {hands} | {wall:.0f} s |")


if __name__ == "__main__":
    main(sys.argv[1:] or list(ROBOTS))
