"""``walk_random`` in physics: two minutes of random reachable steps of every kind, with stops
and the turns that lead it back home; the robot stays up, every landing is on its footprint,
and the balance stabilizer's CoM offset stays small (it once grew with the stance anchor's
drift, to 8 cm after 2 minutes: past the edge of a sole, and the robot fell).

The footprints and their touch-down times are computed without the diagram (the pattern
generator's tick replayed on its own planner, :func:`walk_random.planned_landings`); the
landings are measured on the simulated plant."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.math import RollPitchYaw

from drake_sot.diagrams import walk_random
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow

DURATION = 120.0  # [s] six stops, and the home radius crossed and turned back from
SETTLE = 10  # ticks (50 ms) after touch-down, when a landing is measured


@pytest.fixture(scope="module")
def random_walk(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("walk_random")
    output = run_scenario(
        walk_random.SCENARIO, out_dir, duration=DURATION, record=False, parameters={"seed": 0}
    )
    return output


def _landings(output) -> list:
    """(touch-down time, footprint) of the steps the generator planned (replayed without the diagram)."""
    rule = output.setup.built.diagram.GetSubsystemByName("random_steps").rule
    return walk_random.planned_landings(output.setup.extras.pattern_generator, rule, DURATION)


def test_the_random_walk_completes_upright(random_walk):
    assert random_walk.result.completed, random_walk.result.failure
    assert random_walk.arrays["q"][:, 6].min() > 0.55  # the pelvis stays up (standing: 0.65 m)


def test_the_stabilizer_offset_stays_within_the_sole(random_walk):
    """The CoM offset corrects the model's errors, a few cm at most: below 4 cm it keeps the CoM
    over the sole however the robot turns (a sole's half-width is 6.5 cm, the desired ZMP is kept
    1 cm inside)."""
    offset = np.abs(random_walk.arrays["stabilizer_offset"]).max()
    print(f"max |offset| {1000 * offset:.1f} mm")
    assert offset < 0.04


def test_every_landing_is_on_its_footprint_and_the_steps_are_of_every_kind(random_walk):
    built, arrays = random_walk.setup.built, random_walk.arrays
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    phase = arrays["phase"][:, 0]
    ticks = [k for k in range(1, len(phase) - SETTLE) if phase[k - 1] != 0 and phase[k] == 0]
    landings = _landings(random_walk)[: len(ticks)]
    assert len(ticks) >= 120, len(ticks)  # 20 steps in each 16 s of walking of the 20 s period
    # the replay's touch-down times are the logged ones (single to double support), within a tick
    np.testing.assert_allclose([t for t, _ in landings], arrays["time"][ticks], atol=0.0051)
    steps = [step for _, step in landings]
    errors = []
    for k, step in zip(ticks, steps, strict=True):
        plant.SetPositions(context, info.model_instance, arrays["q"][k + SETTLE])
        X = plant.GetFrameByName(info.frames[f"{step.side}_foot"], info.model_instance).CalcPoseInWorld(
            context
        )
        errors.append(math.hypot(X.translation()[0] - step.x, X.translation()[1] - step.y))
        yaw = RollPitchYaw(X.rotation()).yaw_angle()
        assert abs(math.remainder(yaw - step.yaw, 2 * math.pi)) < math.radians(3.0)
    print(f"{len(errors)} landings, max error {1000 * max(errors):.1f} mm")
    assert max(errors) < 0.02
    # of every kind: forward and backward along the heading, turning both ways, and a stop
    forward = [
        math.cos(b.yaw) * (b.x - a.x) + math.sin(b.yaw) * (b.y - a.y)
        for a, b in zip(steps[::2], steps[2::2], strict=False)
    ]
    assert max(forward) > 0.05 and min(forward) < -0.03
    turns = np.diff([s.yaw for s in steps])
    assert turns.max() > 0.05 and turns.min() < -0.05
    # the stop of every 20 s: over a second in double support (a step's is 0.1 s)
    double = np.flatnonzero(phase == 0)
    runs = np.split(double, np.flatnonzero(np.diff(double) > 1) + 1)
    longest = max(len(run) for run in runs if arrays["time"][run[0]] > 5.0)
    assert longest * np.median(np.diff(arrays["time"])) > 1.0, longest
