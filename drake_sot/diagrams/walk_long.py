"""Scenario ``walk_long``: 30 steps in physics — forward, turning left, turning right,
sideways, backward, stop — on the ``walk`` stack (:func:`drake_sot.diagrams.walking.build_walk`).

The steps (each relative to the other foot's last footprint, :func:`~drake_sot.footsteps.relative_steps`,
at the initial stance width ``w``; feet alternate, right first):

- 8 forward, 0.2 m each;
- 5 turning left in place: the right foot beside the left one, then four of π/8 (90° in all);
- 6 turning right in place: the left foot beside the right one, then four of −π/8, then the right
  foot beside the left one (back to the initial heading);
- 6 sideways to the left: the left foot 0.1 m out, the right foot brought back beside it (0.3 m);
- 4 backward, 0.15 m each;
- 1 closing step: the left foot beside the right one; the robot stops in double support.

The walking references pass through a ``StanceAnchor`` (``anchored=True``): at each lift-off
they are re-anchored on the measured stance foot, so that the landing errors, one step's
tracking error each, do not add up over the 30 steps (:mod:`drake_sot.anchoring`).

Every step is within :class:`~drake_sot.footsteps.StepLimits`, and the timing is ``walk``'s
(0.7 s single support, 0.1 s double support, 5 cm step height: inside
:data:`~drake_sot.footsteps.WALKING_BOUNDS`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pydrake.geometry import Meshcat

from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import SELF_COLLISION, Scenario, ScenarioSetup
from drake_sot.diagrams.walking import build_walk, zmp_plot_writer
from drake_sot.footsteps import Footstep, other_side, relative_steps, stance_width

SIDEWAYS = 0.1  # [m] each sideways step of the left foot
BACKWARD = 0.15  # [m] each backward step
STRIDE = 0.2  # [m] each forward step
TURN = math.pi / 8  # [rad] each turning step
# [s] added to build_walk's duration, which does not count the generator's preview delay (1.6 s):
# the last landing is due at 26.1 s, the run ends at 30 s.
SETTLE = 3.5


def long_walk_steps(left: Footstep, right: Footstep) -> list[Footstep]:
    """The 30 footprints of the long walk from the stance ``left``, ``right`` (see the module)."""
    w = stance_width(left, right)

    def pairs(
        n: int, dx: float, yaw: float, first: str, out: float = 0.0
    ) -> list[tuple[str, float, float, float]]:
        """``n`` moves of alternating feet from ``first``: ``dx`` ahead, turned by ``yaw``, the
        left foot ``out`` further than the stance width."""
        sides = [first if k % 2 == 0 else other_side(first) for k in range(n)]
        return [(s, dx, (w + out) if s == "left" else -w, yaw) for s in sides]

    moves = (
        pairs(8, STRIDE, 0.0, "right")
        + [("right", 0.0, -w, 0.0)]
        + pairs(4, 0.0, TURN, "left")
        + [("left", 0.0, w, 0.0)]
        + pairs(4, 0.0, -TURN, "right")
        + [("right", 0.0, -w, 0.0)]
        + pairs(6, 0.0, 0.0, "left", out=SIDEWAYS)
        + pairs(4, -BACKWARD, 0.0, "left")
        + [("left", 0.0, w, 0.0)]
    )
    return relative_steps(left, right, moves)


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``walk_long`` diagram and its script, with ``pushes`` on the robot, with or
    without the self-collision task; ``command_server``: see
    :func:`~drake_sot.diagrams.scenario.build_scenario`."""
    setup = build_walk(
        long_walk_steps,
        meshcat=meshcat,
        pushes=pushes,
        anchored=True,
        command_server=command_server,
        self_collision=self_collision,
    )
    setup.duration += SETTLE
    return setup


SCENARIO = Scenario(
    name="walk_long",
    description="30 steps: forward, turning left and right, sideways, backward, stop (ZMP preview control)",
    build=build,
    extra_plots=zmp_plot_writer("walk_long"),
    parameters=(SELF_COLLISION,),
    servable=True,
)
