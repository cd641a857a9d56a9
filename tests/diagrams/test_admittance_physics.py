"""Admittance-controlled hand in physics: a 20 N pull moves it at f/B, the rest stays put."""

import numpy as np
import pytest

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.systems.partner import ConstantForce, Partner

FORCE = 20.0  # [N], forward (+x)
DAMPING = 400.0  # [N·s/m]: steady speed f/B = 5 cm/s, ~10 cm over the pull, inside the arm's reach
PULL = (1.0, 3.0)  # [s]


@pytest.fixture(scope="module")
def pulled():
    b = HumanoidSoTBuilder()
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", gain=3.0)
    b.add_admittance_task(
        # Stiff in rotation: the push acts at the hand body's origin, 7 cm from the tool point.
        "taskForce",
        "right",
        mass=(4.0, 4.0, 4.0, 0.2, 0.2, 0.2),
        damping=(DAMPING, DAMPING, DAMPING, 40.0, 40.0, 40.0),
    )
    b.add_op_point_task("taskLH", "left_hand", gain=5.0)
    b.add_posture_task("taskPosture")
    hand_body = b.plant.GetJointByName(b.info.force_sensors["right_wrist"]).child_body().name()
    partner = b.builder.AddSystem(Partner(b.plant, {hand_body: [ConstantForce(*PULL, (FORCE, 0.0, 0.0))]}))
    b.builder.Connect(b.plant.get_body_poses_output_port(), partner.GetInputPort("body_poses"))
    b.builder.Connect(
        b.plant.get_body_spatial_velocities_output_port(), partner.GetInputPort("body_spatial_velocities")
    )
    b.builder.Connect(partner.GetOutputPort("spatial_forces"), b.plant.get_applied_spatial_force_input_port())
    built = b.build(stack=["taskLF", "taskRF", "taskCom", "taskForce", "taskLH", "taskPosture"])
    simulator = built.create_simulator()
    samples = {}
    for t in (0.9, 2.0, 3.0, 3.7, 4.2):
        simulator.AdvanceTo(t)
        context = simulator.get_context()
        samples[t] = {
            key: built.frame_pose(context, key).translation()
            for key in ("right_hand", "left_hand", "left_foot", "right_foot")
        }
    return samples


def test_hand_moves_along_the_force_at_f_over_b(pulled):
    # After the transient (the soft arm servos first give way under the push).
    a, b = pulled[2.0]["right_hand"], pulled[3.0]["right_hand"]
    velocity = (b - a) / 1.0
    assert velocity[0] == pytest.approx(FORCE / DAMPING, rel=0.10)
    assert np.linalg.norm(velocity[1:]) < 0.2 * abs(velocity[0])  # along the force


def test_hand_stops_when_the_force_is_removed(pulled):
    drift = np.linalg.norm(pulled[4.2]["right_hand"] - pulled[3.7]["right_hand"]) / 0.5
    assert drift < 0.005  # [m/s]


def test_feet_and_left_hand_stay(pulled):
    for key in ("left_foot", "right_foot"):
        assert np.linalg.norm(pulled[4.2][key][:2] - pulled[0.9][key][:2]) < 0.002
    assert np.linalg.norm(pulled[4.2]["left_hand"] - pulled[0.9]["left_hand"]) < 0.01
