"""Scenario ``walk``: the humanoid walks in physics on pattern-generator references.

Stack (highest priority first, solved by ``solve_hqp``): joint position and velocity
limits (an inequality task), self-collision avoidance (``taskSelfCollision``, unless
``self_collision`` is off), left foot 6D, right foot 6D (references
and velocity feed-forward from the pattern generator), CoM xy (preview-control CoM),
waist orientation (yaw midway between the feet), both hands held relative to the
waist, posture. Script: at t = 0.5 s, 8 steps of 0.2 m forward, then 4 steps turning
90° in all (π/8 each) and a closing step that sets the feet side by side; the robot
stops in double support.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pydrake.geometry import Meshcat

from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import ROBOT, SELF_COLLISION, Scenario, ScenarioSetup
from drake_sot.diagrams.walking import STABILIZER, build_walk, forward_steps, zmp_plot_writer
from drake_sot.footsteps import Footstep, alternating_steps


def walk_steps(left: Footstep, right: Footstep, stride: float = 0.2, n_forward: int = 8) -> list[Footstep]:
    """``n_forward`` steps of ``stride`` forward (right foot first), then 4 steps turning
    left by π/8 each and a closing step bringing the left foot beside the right one."""
    forward = forward_steps(left, right, n_forward, stride)
    last = {s.side: s for s in [left, right, *forward]}
    # Turning left: the left foot opens first, so the feet never cross.
    turns = [math.pi / 8] * 4 + [0.0]
    return forward + alternating_steps(last["left"], last["right"], 5, turn=turns, first_side="left")


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    stabilizer: bool = True,
    robot: str = "embedded",
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``walk`` diagram and its script, with ``pushes`` on ``robot`` (a name of
    ``drake_sot.robots.ROBOTS``), with or without the balance stabilizer and the self-collision
    task; ``command_server``: see :func:`~drake_sot.diagrams.scenario.build_scenario`."""
    return build_walk(
        walk_steps,
        meshcat=meshcat,
        pushes=pushes,
        stabilizer=stabilizer,
        robot=robot,
        command_server=command_server,
        self_collision=self_collision,
    )


write_plots = zmp_plot_writer("walk")


SCENARIO = Scenario(
    name="walk",
    description="8 steps of 0.2 m forward, 4 steps turning 90°, stop in double support (ZMP preview control)",
    build=build,
    extra_plots=write_plots,
    parameters=(STABILIZER, ROBOT, SELF_COLLISION),
    servable=True,
)
