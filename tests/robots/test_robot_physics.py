"""TALOS and the Unitree G1 in physics: they stand, reach and walk under the kinematic SoT
(their other scenarios: ``test_robot_scenarios.py``; two files, which ``--dist loadfile`` gives
to the two workers).

Every outcome is measured on the simulated plant (not on the controller's reference):
the pelvis pose, the hand against its target, the landed soles against the planned
footprints, the ZMP of the ankle force sensors against the support polygon of the soles.
"""

from __future__ import annotations

import numpy as np
import pytest
from landings import landing_errors
from robot_data import robot_or_skip
from standing import assert_stands

from drake_sot.diagrams import reach, walk, walking
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow
ROBOTS = ("talos", "g1")


@pytest.mark.parametrize("name", ROBOTS)
def test_stands_5s_with_the_pelvis_within_1cm(name):
    robot_or_skip(name)
    assert_stands(name)


@pytest.mark.parametrize("name", ROBOTS)
def test_reach_brings_the_right_hand_within_1cm_of_its_target(name, tmp_path):
    robot_or_skip(name)
    output = run_scenario(reach.SCENARIO, tmp_path, duration=3.0, record=False, parameters={"robot": name})
    assert output.result.completed, output.result.failure
    built = output.setup.built
    target = output.setup.targets["right_hand"].translation()
    hand = built.frame_pose(output.context, "right_hand").translation()
    assert np.linalg.norm(hand - target) < 0.01, (
        f"{name}: right hand {np.linalg.norm(hand - target):.4f} m off"
    )


@pytest.fixture(scope="module", params=ROBOTS)
def walk_run(request, tmp_path_factory):
    robot_or_skip(request.param)
    output = run_scenario(
        walk.SCENARIO,
        tmp_path_factory.mktemp(f"walk_{request.param}"),
        record=False,
        parameters={"robot": request.param},
    )
    assert output.result.completed, (request.param, output.result.failure, output.result.fell)
    return request.param, output, walking.analyse(output.setup.built, output.arrays)


def test_walk_lands_every_step_within_2cm_of_its_footprint(walk_run):
    name, output, analysis = walk_run
    steps = output.setup.extras.steps
    assert len(steps) == 13
    for side, off, yaw_error in landing_errors(output.arrays, analysis.soles, steps):
        assert off < 0.02, f"{name}: {side} foot landed {off:.3f} m off"
        assert yaw_error < 3.0


def test_walk_keeps_the_zmp_in_the_support_polygon_99_percent(walk_run):
    name, _, analysis = walk_run
    margin = analysis.zmp_margin[np.isfinite(analysis.zmp_margin)]
    assert margin.size > 0.9 * analysis.zmp_margin.size  # the feet carried the robot throughout
    inside = np.mean(margin >= 0.0)
    assert inside >= 0.99, f"{name}: ZMP inside the support polygon in {100 * inside:.1f} % of samples"


def test_walk_ends_upright_where_planned(walk_run):
    name, output, _ = walk_run
    steps = output.setup.extras.steps
    last = {s.side: s for s in steps}
    planned_xy = 0.5 * np.array([last["left"].x + last["right"].x, last["left"].y + last["right"].y])
    q_end = output.arrays["q"][-1]
    assert np.linalg.norm(q_end[4:6] - planned_xy) < 0.05, name
    assert q_end[6] > 0.9 * output.arrays["q"][0, 6], f"{name}: the pelvis sank"
