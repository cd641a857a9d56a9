"""Scenario ``reach``: stand, reach with the right hand, then push and remove a left-hand task.

Stack (highest priority first, solved by ``solve_hqp``): joint position and velocity
limits (an inequality: velocity bounds over the control period that stop each joint
0.02 rad inside its limits, clipped to its velocity limits), self-collision avoidance
(``taskSelfCollision``, unless ``self_collision`` is off), left foot 6D, right foot
6D, CoM xy, right hand 6D, posture. Script:

- t = 1 s: the right-hand target moves 25 cm forward and 20 cm up from where the hand
  started (orientation kept);
- t = 3 s: ``push taskLH`` (left hand to a second target, 20 cm forward, 15 cm up),
  then ``up taskLH`` so that it ranks above the posture task (a pushed task lands at
  the lowest priority, where the full-rank posture would leave it no freedom);
- t = 5 s: ``rm taskLH``: the left hand is no longer controlled, the posture task
  takes it back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import TimedCommand
from drake_sot.diagrams.scenario import ROBOT, SELF_COLLISION, Scenario, ScenarioSetup

RIGHT_HAND_OFFSET = np.array([0.25, 0.0, 0.20])  # [m] from the initial hand position, world frame
LEFT_HAND_OFFSET = np.array([0.20, 0.0, 0.15])
STACK = ("taskJL", "taskLF", "taskRF", "taskCom", "taskRH", "taskPosture")


def _shifted(X: RigidTransform, offset: np.ndarray) -> RigidTransform:
    return RigidTransform(X.rotation(), X.translation() + offset)


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    robot: str = "embedded",
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``reach`` diagram and its script, with ``pushes`` on ``robot`` (a name of
    ``drake_sot.robots.ROBOTS``), with or without the self-collision task; ``command_server``:
    see :func:`~drake_sot.diagrams.scenario.build_scenario`."""
    b = HumanoidSoTBuilder(meshcat=meshcat, pushes=pushes, robot=robot)
    target_rh = _shifted(b.initial_pose("right_hand"), RIGHT_HAND_OFFSET)
    target_lh = _shifted(b.initial_pose("left_hand"), LEFT_HAND_OFFSET)
    b.add_joint_position_limits_task("taskJL", velocity_scale=1.0)
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    b.add_op_point_task("taskRH", "right_hand", gain=2.5)
    b.add_op_point_task("taskLH", "left_hand", gain=2.5, desired=target_lh)
    b.add_posture_task("taskPosture", gain=1.0)
    stack = b.below_joint_limits(STACK, self_collision)
    built = b.build(stack=stack, solver="hqp", command_server=command_server)
    sot = built.sot
    commands = [
        TimedCommand(
            1.0, "taskRH target +25 cm x, +20 cm z", lambda c: built.set_desired(c, "taskRH", target_rh)
        ),
        TimedCommand(3.0, "push taskLH", lambda c: sot.push(c, "taskLH")),
        TimedCommand(3.0, "up taskLH", lambda c: sot.up(c, "taskLH")),
        TimedCommand(5.0, "rm taskLH", lambda c: sot.rm(c, "taskLH")),
    ]
    return ScenarioSetup(
        built=built,
        commands=commands,
        duration=7.0,
        targets={"right_hand": target_rh, "left_hand": target_lh},
    )


SCENARIO = Scenario(
    name="reach",
    description="stand, reach with the right hand (t=1 s), push then rm a left-hand task (t=3 s, t=5 s)",
    build=build,
    parameters=(ROBOT, SELF_COLLISION),
    servable=True,
)
