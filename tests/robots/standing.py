"""A robot standing (5 s unless told) under the README's stack, measured on the simulated plant: the check the
catalog's robots and a robot from its files share."""

from __future__ import annotations

import math

import numpy as np

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder


def assert_stands(robot: str, seconds: float = 5.0) -> None:
    """``robot`` (a name or a description's path) stands ``seconds`` on the feet, CoM and posture tasks:
    its pelvis within 1 cm of where it started, its soles on the ground (3 mm) and flat (1°)."""
    b = HumanoidSoTBuilder(robot=robot)
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    b.add_posture_task("taskPosture", gain=1.0)
    built = b.build(stack=["taskLF", "taskRF", "taskCom", "taskPosture"])
    simulator = built.create_simulator()
    context = simulator.get_context()
    start = built.frame_pose(context, "pelvis").translation()
    drift = []
    for t in np.arange(0.5, seconds + 0.01, 0.5):
        simulator.AdvanceTo(t)
        drift.append(np.linalg.norm(built.frame_pose(context, "pelvis").translation() - start))
    assert max(drift) < 0.01, f"{robot}: pelvis drifted {max(drift):.4f} m"
    for foot in ("left_foot", "right_foot"):  # on the ground at the half-sitting height, flat
        X = built.frame_pose(context, foot)
        assert abs(X.translation()[2]) < 0.003, f"{robot} {foot} at z = {X.translation()[2]:.4f}"
        assert X.rotation().matrix()[2, 2] > math.cos(math.radians(1.0))
