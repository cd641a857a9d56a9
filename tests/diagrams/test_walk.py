"""The ``walk`` scenario in physics: the robot walks 8 steps, turns 90° and stops, upright."""

import math

import numpy as np
import pytest
from joint_limits import limit_excess
from landings import landing_errors

from drake_sot.diagrams import walk, walking
from drake_sot.diagrams.scenario import run_scenario


@pytest.fixture(scope="module")
def walk_run(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("walk")
    output = run_scenario(walk.SCENARIO, out_dir, record=False)
    assert output.result.completed, output.result.failure
    return output, walking.analyse(output.setup.built, output.arrays), out_dir


def test_does_not_fall(walk_run):
    output, _, _ = walk_run
    built, q = output.setup.built, output.arrays["q"]
    assert q[:, 6].min() > 0.6, "pelvis dropped below 0.6 m"
    context = built.plant.CreateDefaultContext()
    torso = built.plant.GetBodyByName("torso", built.info.model_instance)
    tilt = []
    for qk in q[::10]:
        built.plant.SetPositions(context, built.info.model_instance, qk)
        z_axis = torso.EvalPoseInWorld(context).rotation().matrix()[:, 2]
        tilt.append(math.degrees(math.acos(min(1.0, z_axis[2]))))
    assert max(tilt) < 10.0


def test_measured_zmp_stays_in_the_support_polygon(walk_run):
    _, analysis, _ = walk_run
    margin = analysis.zmp_margin[np.isfinite(analysis.zmp_margin)]
    assert margin.size > 0.9 * analysis.zmp_margin.size  # the feet carried the robot throughout
    assert np.mean(margin >= 0.0) >= 0.95


def test_each_foot_lands_on_its_footprint(walk_run):
    output, analysis, _ = walk_run
    steps = output.setup.extras.steps
    assert len(steps) == 13
    for side, off, yaw_error in landing_errors(output.arrays, analysis.soles, steps):
        assert off < 0.02, f"{side} foot landed {off:.3f} m off"
        assert yaw_error < 3.0


def test_final_pose_matches_the_plan(walk_run):
    output, _, _ = walk_run
    steps = output.setup.extras.steps
    last = {s.side: s for s in steps}
    planned_xy = 0.5 * np.array([last["left"].x + last["right"].x, last["left"].y + last["right"].y])
    q_end = output.arrays["q"][-1]
    assert np.linalg.norm(q_end[4:6] - planned_xy) < 0.05
    w, x, y, z = q_end[:4]
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    assert yaw == pytest.approx(math.pi / 2, abs=math.radians(5))


def test_walk_artefacts(walk_run):
    _, _, out_dir = walk_run
    for name in ("walk.svg", "walk.png", "walk.npz", "walk_zmp.png"):
        assert (out_dir / name).stat().st_size > 1000, name
    logs = np.load(out_dir / "walk.npz")
    for key in ("zmp", "zmp_ref", "com_ref", "phase", "contacts"):
        assert logs[key].shape[0] == logs["time"].shape[0]


def test_no_joint_passes_its_position_or_velocity_limit(walk_run):
    """Joint position and velocity limits on top of the stack (solver "hqp"), measured on the plant."""
    output, _, _ = walk_run
    excess = limit_excess(output.setup.built, output.arrays)
    assert excess.position < 1e-3, f"{excess.position_joint} {excess.position:.4f} rad past its limit"
    assert excess.velocity < 1e-3, f"{excess.velocity_joint} {excess.velocity:.4f} rad/s past its limit"
    # The reference stays the margin (0.02 rad) inside: the plant alone would not tell (Drake's
    # discrete plant holds a joint at its limit; without the limit tasks reach's reference went
    # 0.079 rad past chest_pitch's while the plant stayed within 3e-8 rad of it).
    assert excess.reference <= -0.02 + 1e-9, f"reference {excess.reference_joint} {excess.reference:.4f}"
