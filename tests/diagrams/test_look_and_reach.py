"""The ``look_and_reach`` scenario in physics: the object's image in the head camera and the
hand's distance to it, measured on the simulated plant (its logged configuration, Drake's
kinematics of the simulated model and the object's path), not on the controller's features."""

import numpy as np
import pytest
from joint_limits import limit_excess

from drake_sot.diagrams import look_and_reach
from drake_sot.diagrams.scenario import run_scenario


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    output = run_scenario(
        look_and_reach.SCENARIO, tmp_path_factory.mktemp("look_and_reach"), duration=6.0, record=False
    )
    assert output.result.completed, output.result.failure
    return output


def test_the_object_stays_within_5_percent_of_the_image_centre(run):
    """Normalised image coordinates x = X/Z, y = Y/Z of the object in the simulated head camera:
    |x|, |y| <= 0.05 from CONVERGED_AFTER (1 s) to the end, through the reach, while the
    object keeps moving; at the start it was far off-centre."""
    time = run.arrays["time"]
    image = look_and_reach.image_points(run.setup.built, run.arrays, look_and_reach.OBJECT_PATH)
    assert np.linalg.norm(image[0]) > 0.5  # the head had to turn to it
    after = time >= look_and_reach.CONVERGED_AFTER
    worst = np.abs(image[after]).max(axis=0)
    assert np.all(worst <= 0.05), f"max |x|, |y| after convergence: {worst}"
    moved = look_and_reach.OBJECT_PATH(time[-1])[0] - look_and_reach.OBJECT_PATH(time[after][0])[0]
    assert np.linalg.norm(moved) > 0.05  # the object moved meanwhile


def test_the_right_hand_reaches_the_object_and_follows_it(run):
    time = run.arrays["time"]
    distance = look_and_reach.hand_distances(run.setup.built, run.arrays, look_and_reach.OBJECT_PATH)
    assert distance[time < look_and_reach.REACH_AT].min() > 0.5  # out of reach before the push
    assert distance[time > 3.5].max() < 0.01


def test_the_robot_stands_and_the_plot_is_written(run):
    built, arrays = run.setup.built, run.arrays
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    feet = []
    for q in arrays["q"][::20]:
        plant.SetPositions(context, info.model_instance, q)
        feet.append(
            [
                plant.GetFrameByName(info.frames[f], info.model_instance)
                .CalcPoseInWorld(context)
                .translation()
                for f in ("left_foot", "right_foot")
            ]
        )
    slide = np.linalg.norm(np.array(feet)[:, :, :2] - np.array(feet)[0, :, :2], axis=2)
    assert slide.max() < 0.002
    assert arrays["q"][:, 6].min() > 0.55  # pelvis height
    assert run.files["look_and_reach_image"].stat().st_size > 10_000


def test_no_joint_passes_its_position_or_velocity_limit(run):
    """Joint position and velocity limits on top of the stack (solver "hqp"), measured on the
    plant; the reference stays the margin (0.02 rad) inside, though the gaze wants the head
    pitch close to its limit."""
    excess = limit_excess(run.setup.built, run.arrays)
    assert excess.position < 1e-3, f"{excess.position_joint} {excess.position:.4f} rad past its limit"
    assert excess.velocity < 1e-3, f"{excess.velocity_joint} {excess.velocity:.4f} rad/s past its limit"
    assert excess.reference <= -0.02 + 1e-9, f"reference {excess.reference_joint} {excess.reference:.4f}"
