"""Your own robot, in physics: the URDF the project ships for the purpose
(``examples/robot/humanoid.urdf``) with its description file, loaded through the path any
user's robot takes (``robot=`` the description's path: the TOML reader, the URDF fixes and
Drake's parser, not the embedded humanoid's code), stands and walks; the same robot from its
MJCF (``humanoid.xml``) stands.

Every outcome is measured on the simulated plant: the pelvis and the soles standing, the
landed soles against the planned footprints walking; the same walk with the description that
``drake-sot robot draft`` writes for the URDF, unedited.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from landings import landing_errors
from standing import assert_stands

from drake_sot.diagrams import walk, walking
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.robots.draft import draft_description

pytestmark = pytest.mark.slow
DESCRIPTION = Path(__file__).resolve().parents[2] / "examples" / "robot" / "humanoid.toml"


def test_the_robot_is_loaded_from_its_files():
    b = HumanoidSoTBuilder(robot=str(DESCRIPTION))
    assert b.robot.model_file == DESCRIPTION.parent / "humanoid.urdf"
    assert b.info.robot == "humanoid-urdf"
    # the logical frames with an offset are frames the loader added, not the embedded model's
    assert b.info.frames["left_foot"] == "sot_left_foot"


def test_stands_5s_with_the_pelvis_within_1cm():
    assert_stands(str(DESCRIPTION))


def test_the_robot_from_its_mjcf_stands_2_5s():
    """The same robot from its MJCF (Drake's other parser, the MJCF fixes, the welds Drake names)
    stands; that the three files are one robot is checked without simulating, in test_robot_formats."""
    assert_stands(str(DESCRIPTION.with_name("humanoid_mjcf.toml")), seconds=2.5)


def drafted(tmp_path: Path) -> Path:
    """The shipped URDF with the description ``drake-sot robot draft`` writes for it, unedited."""
    model = tmp_path / "drafted.urdf"
    shutil.copy(DESCRIPTION.with_suffix(".urdf"), model)
    model.with_suffix(".toml").write_text(draft_description(model).text)
    return model


@pytest.mark.parametrize("robot", [lambda _: DESCRIPTION, drafted], ids=["shipped", "drafted"])
def test_walk_lands_every_step_within_2cm_of_its_footprint(tmp_path, robot):
    """The shipped description, and the draft of its URDF as drafted (the knees bent less, the
    gains from the effort limits): a model and a drafted description are a robot that walks."""
    output = run_scenario(
        walk.SCENARIO, tmp_path / "out", record=False, parameters={"robot": str(robot(tmp_path))}
    )
    assert output.result.completed, (output.result.failure, output.result.fell)
    steps = output.setup.extras.steps
    assert len(steps) >= 6
    analysis = walking.analyse(output.setup.built, output.arrays)
    for side, off, yaw_error in landing_errors(output.arrays, analysis.soles, steps):
        assert off < 0.02, f"{side} foot landed {off:.3f} m off"
        assert yaw_error < 3.0
    q_end = output.arrays["q"][-1]
    assert q_end[6] > 0.9 * output.arrays["q"][0, 6], "the pelvis sank"
