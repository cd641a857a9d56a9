"""Scenario ``walk_random``: a walk of random reachable footsteps for as long as asked — forward,
backward, sideways and turning steps, with a stop every 20 s — kept within 1.5 m of where the
robot started (:class:`drake_sot.random_steps.RandomStepRule`, seeded: the same seed walks the
same steps). The ``walk`` stack (:func:`drake_sot.diagrams.walking.build_walk`), its references
re-anchored on the measured stance foot at each lift-off, the pattern generator fed one
footprint per executed step (its ``next_footprint`` input) by a
:class:`~drake_sot.systems.random_steps.RandomSteps`. A soak of the controller: run it for an hour
(``drake-sot run walk_random --duration 3600 --no-record``) and what it keeps stays bounded
(:mod:`drake_sot.diagrams.log_window`).
"""

from __future__ import annotations

from collections.abc import Sequence

from pydrake.geometry import Meshcat

from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import ROBOT, SELF_COLLISION, Scenario, ScenarioSetup
from drake_sot.diagrams.walking import build_walk, zmp_plot_writer
from drake_sot.footsteps import Footstep, StepLimits, stance_width
from drake_sot.parameters import Parameter
from drake_sot.random_steps import RandomStepRule
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.systems.random_steps import RandomSteps
from drake_sot.walk_planner import FOOTPRINTS_AHEAD

DURATION = 120.0  # [s] the default length of the walk
#: The walk's seed: the same seed walks the same steps.
SEED = Parameter("seed", "int", 0, "walk_random's seed (the same seed walks the same steps)", minimum=0)


def planned_landings(
    pg: PatternGenerator, rule: RandomStepRule, duration: float
) -> list[tuple[float, Footstep]]:
    """``(touch-down time [s], footprint)`` of every step the pattern generator ``pg`` plans in
    ``duration`` [s] of a ``walk_random`` run, without simulating it: the generator's tick
    replayed on its initial planner (the footprints depend on the rule and the planner alone,
    not on the robot's motion), reading ``rule`` at each tick where fewer than
    ``FOOTPRINTS_AHEAD`` landings lie ahead, as the generator does. The touch-down time is that of
    the generator's first double-support sample after the step's single support."""
    planner = pg.planner(pg.CreateDefaultContext())
    landings = []
    for k in range(round(duration / planner.dt) + 1):
        planner = planner.advance()
        if len(planner.landings_ahead()) < FOOTPRINTS_AHEAD:
            step = rule.next_footprint(
                planner.feet["left"], planner.feet["right"], planner.last_side, k * planner.dt
            )
            if step is not None:
                planner = planner.add_steps([step])
                ahead, _ = planner.landings_ahead()[-1]  # ticks from sample k + 1, the current one
                landings.append(((k + 1 + ahead + 1) * planner.dt, step))
    return landings


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    seed: int = 0,
    robot: str = "embedded",
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``walk_random`` diagram: the random walk of ``seed`` (an integer >= 0) on
    ``robot``, with ``pushes``, with or without the self-collision task; ``command_server``:
    see :func:`~drake_sot.diagrams.scenario.build_scenario`."""

    def source(left: Footstep, right: Footstep, limits: StepLimits) -> RandomSteps:
        home = tuple(0.5 * (left.xy + right.xy))
        return RandomSteps(RandomStepRule(seed, stance_width(left, right), limits=limits, home=home))

    setup = build_walk(
        lambda left, right: [],
        meshcat=meshcat,
        pushes=pushes,
        anchored=True,
        robot=robot,
        command_server=command_server,
        footstep_source=source,
        self_collision=self_collision,
    )
    setup.duration = DURATION
    return setup


SCENARIO = Scenario(
    name="walk_random",
    description="random reachable steps (forward, backward, sideways, turning, stops), as long as asked",
    build=build,
    extra_plots=zmp_plot_writer("walk_random"),
    parameters=(SEED, ROBOT, SELF_COLLISION),
    servable=True,
)
