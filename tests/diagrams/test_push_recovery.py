"""Push recovery with the balance stabilizer: the ``walk`` survives a 200 N, 0.1 s
lateral pelvis push either way, in mid single support and in double support, and completes its
steps; without the stabilizer the same walk falls at a push the stabilizer survives."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from drake_sot.diagrams import walk, walking
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import RunResult, simulate

FORCE = 200.0  # [N]
DURATION = 0.1  # [s]


@functools.cache
def _first_landing() -> float:
    """When the first step lands [s], from the generator's plan (no physics): the steps
    given at ``walking.START`` to a generator standing at its start."""
    setup = walk.build()
    context = setup.built.create_simulator().get_mutable_context()
    context.SetTime(walking.START)
    pg = setup.extras.pattern_generator
    pg.add_steps(context, setup.extras.steps)
    return pg.planned_landings(context)[0][0]


def _push_time(phase: str) -> float:
    """Mid single support of the first step, or the double support that follows its landing."""
    landing = _first_landing()
    return landing - walking.TIMING.single_support / 2 if phase == "single" else landing


@functools.cache
def _walk(phase: str, fy: float, stabilizer: bool) -> tuple[RunResult, dict[str, np.ndarray], list]:
    push = ExternalPush(_push_time(phase), "pelvis", (0.0, fy, 0.0), DURATION)
    setup = walk.build(pushes=[push], stabilizer=stabilizer)
    simulator = setup.built.create_simulator()
    result = simulate(simulator, setup.duration, setup.commands, check=False)
    context = simulator.get_context()
    logs = {name: logger.FindLog(context) for name, logger in setup.built.loggers.items()}
    arrays = {name: log.data().T for name, log in logs.items()}
    arrays["time"] = logs["state"].sample_times()
    arrays["q"] = arrays["state"][:, : setup.built.plant.num_positions()]
    return result, arrays, setup


def test_push_times_fall_in_the_phases_they_are_named_after():
    landing = _first_landing()
    # The first step: steps given at START, then the generator's first double support.
    assert walking.START < landing - walking.TIMING.single_support
    single, double = _push_time("single"), _push_time("double")
    assert landing - walking.TIMING.single_support < single < single + DURATION < landing
    assert double == landing and double + DURATION <= landing + walking.TIMING.double_support + 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["single", "double"])
@pytest.mark.parametrize("fy", [FORCE, -FORCE])
def test_the_walk_survives_a_200_N_lateral_push_and_completes_its_steps(phase, fy):
    result, arrays, setup = _walk(phase, fy, True)
    assert result.completed and result.fell is None, result.fell
    assert arrays["q"][:, 6].min() > 0.6  # the pelvis stayed up
    forces = arrays["push_forces"]
    assert np.abs(forces[:, 1]).max() == FORCE  # the push was applied
    # Every step was taken: each landing ends a single support, and the feet end near the
    # last footprints (within 5 cm: a push can make the stance foot slip).
    phases = arrays["phase"][:, 0]
    landings = np.count_nonzero((phases[:-1] != 0) & (phases[1:] == 0))
    assert landings == len(setup.extras.steps) == 13
    analysis = walking.analyse(setup.built, arrays)
    last = {step.side: step for step in setup.extras.steps}
    for side, step in last.items():
        x, y, yaw = analysis.soles[side][-1]
        assert math.hypot(x - step.x, y - step.y) < 0.05, (side, x - step.x, y - step.y)
    # The stabilizer reported when it had to limit itself, and was not stuck at a limit.
    saturated = arrays["stabilizer_saturated"]
    assert saturated[:, 1].mean() < 0.05


@pytest.mark.slow
def test_without_the_stabilizer_the_walk_falls_where_it_survives_with_it():
    """200 N to the right (-y) in the double support after the first step."""
    off, off_arrays, _ = _walk("double", -FORCE, False)
    assert off.fell is not None, "the walk without the stabilizer survived"
    assert off.fell.time > _push_time("double")
    on, on_arrays, _ = _walk("double", -FORCE, True)
    assert on.completed and on.fell is None, on.fell
    assert on_arrays["q"][:, 6].min() > 0.6
