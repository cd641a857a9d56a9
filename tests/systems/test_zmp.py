"""ZmpEstimator (ankle force sensors) against the centre of pressure of the contact forces."""

import numpy as np
import pytest

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.statics import zmp_from_wrenches
from drake_sot.systems.zmp import ZmpEstimator


def test_zmp_formula_on_a_hand_example():
    # 100 N straight down at (0.1, 0.2) plus a pure moment of 5 N·m about x: the ZMP moves by 5/100 in y.
    z = zmp_from_wrenches(
        np.array([[0.1, 0.2, 0.3]]), np.array([[0.0, 0.0, 100.0]]), np.array([[5.0, 0.0, 0.0]])
    )
    np.testing.assert_allclose(z, [0.1, 0.25, 100.0])
    assert np.isnan(
        zmp_from_wrenches(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3)), 5.0)[0]
    )


def _contact_cop(plant, plant_context):
    results = plant.get_contact_results_output_port().Eval(plant_context)
    points, normal = [], []
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        points.append(info.contact_point()[:2])
        normal.append(abs(info.contact_force()[2]))
    normal = np.array(normal)
    return (np.array(points) * normal[:, None]).sum(axis=0) / normal.sum(), normal.sum()


def test_sensor_zmp_matches_the_contact_centre_of_pressure():
    b = HumanoidSoTBuilder()
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    com_des = b.initial_com() + [0.03, 0.025, 0.0]  # lean forward and to the left
    b.add_com_task("taskCom", gain=3.0, desired=com_des)
    b.add_posture_task("taskPosture")
    zmp = b.builder.AddSystem(
        ZmpEstimator(b.plant, [b.info.force_sensors["left_ankle"], b.info.force_sensors["right_ankle"]])
    )
    b.builder.Connect(b.plant.get_reaction_forces_output_port(), zmp.GetInputPort("reaction_forces"))
    b.builder.Connect(b.plant.get_body_poses_output_port(), zmp.GetInputPort("body_poses"))
    built = b.build(stack=["taskLF", "taskRF", "taskCom", "taskPosture"])
    simulator = built.create_simulator()
    simulator.AdvanceTo(3.0)  # the forward lean settles slowly
    context = simulator.get_context()
    plant_context = built.plant.GetMyContextFromRoot(context)
    zmp_context = zmp.GetMyContextFromRoot(context)
    measured = zmp.GetOutputPort("zmp").Eval(zmp_context)
    cop, normal = _contact_cop(built.plant, plant_context)
    np.testing.assert_allclose(measured, cop, atol=0.001)
    # At rest the ZMP is under the CoM, which went where it was asked.
    com = built.plant.CalcCenterOfMassPositionInWorld(plant_context)
    np.testing.assert_allclose(measured, com[:2], atol=0.003)
    np.testing.assert_allclose(com[:2], com_des[:2], atol=0.003)
    # Sensors plus the feet's weight carry the whole robot, as the contacts do.
    assert zmp.GetOutputPort("normal_force").Eval(zmp_context)[0] == pytest.approx(normal, rel=0.01)
    assert normal == pytest.approx(built.plant.CalcTotalMass(plant_context) * 9.81, rel=0.01)
    # Per foot: the two shares make the total; leaning left, the left foot carries more.
    left, right = zmp.GetOutputPort("foot_forces").Eval(zmp_context)
    assert left + right == pytest.approx(normal, rel=0.01)
    assert left > right > 0.0


def test_zmp_formula_is_the_point_where_the_horizontal_moment_vanishes():
    # Random wrenches: about the returned point (z = 0), the total moment Σ τ + Σ (p - zmp) × f
    # (numpy's cross product, not the function's dot products) has no horizontal component.
    rng = np.random.default_rng(3)
    for _ in range(50):
        points, forces, torques = rng.normal(size=(3, 4, 3))
        forces[:, 2] = np.abs(forces[:, 2]) + 10.0
        x, y, fz = zmp_from_wrenches(points, forces, torques)
        about = points - np.array([x, y, 0.0])
        moment = torques.sum(axis=0) + np.cross(about, forces).sum(axis=0)
        np.testing.assert_allclose(moment[:2], 0.0, atol=1e-9)
        assert fz == pytest.approx(forces[:, 2].sum())
