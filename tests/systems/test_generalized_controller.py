"""GeneralizedHierarchyController on the fixed-base and floating-base humanoid models."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from drake_sot.models import half_sitting_configuration, make_control_model, sole_corner_points
from drake_sot.systems.features import FeaturePoint6d, FeaturePosture
from drake_sot.systems.generalized_controller import (
    STATUS_INFEASIBLE,
    STATUS_OPTIMAL,
    ContactPoints,
    GeneralizedHierarchyController,
    MotionTask,
    _inertia_weighted,
)
from drake_sot.systems.kinematics import RobotKinematics
from drake_sot.systems.task import Task


def _controller(fixed_base: bool, *, hand: bool = True, min_normal_force: float = 0.0, **kwargs):
    plant, info = make_control_model(fixed_base=fixed_base)
    q0 = half_sitting_configuration(plant, info)
    builder = DiagramBuilder()
    dyn = builder.AddSystem(RobotKinematics(plant))
    dyn.add_operational_point("lh", info.frames["left_hand"])
    context0 = plant.CreateDefaultContext()
    plant.SetPositions(context0, q0)
    X_lh = plant.GetFrameByName(info.frames["left_hand"]).CalcPoseInWorld(context0)
    lh = builder.AddSystem(FeaturePoint6d(name="f_lh", selection="111000", desired=X_lh))
    posture = builder.AddSystem(
        FeaturePosture(plant, list(info.actuated_joints), name="f_posture", desired=q0)
    )
    tasks = {}
    for name, feature in (("taskLH", lh), ("taskPosture", posture)):
        tasks[name] = builder.AddSystem(Task(name))
        builder.Connect(feature.GetOutputPort("feature"), tasks[name].add(feature))
    builder.Connect(dyn.GetOutputPort("lh"), lh.GetInputPort("position"))
    builder.Connect(dyn.GetOutputPort("Jlh"), lh.GetInputPort("Jq"))
    contacts = (
        []
        if fixed_base
        else [
            ContactPoints(info.frames[f], sole_corner_points(), min_normal_force=min_normal_force)
            for f in ("left_foot", "right_foot")
        ]
    )
    motion = ([MotionTask(tasks["taskLH"], 100.0, 20.0)] if hand else []) + [
        MotionTask(tasks["taskPosture"], 16.0, 8.0)
    ]
    controller = builder.AddSystem(
        GeneralizedHierarchyController(
            plant, info.actuated_joints, motion_tasks=motion, contacts=contacts, q_posture=q0, **kwargs
        )
    )
    for name in controller.task_names:
        builder.Connect(tasks[name].GetOutputPort("task"), controller.GetInputPort(name))
    builder.ExportInput(dyn.GetInputPort("q"), "q")
    builder.ConnectInput("q", posture.GetInputPort("q"))
    builder.ExportInput(controller.GetInputPort("state"), "state")
    builder.ExportInput(controller.GetInputPort("alpha"), "alpha")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    nv = plant.num_velocities()
    diagram.GetInputPort("q").FixValue(context, q0)
    diagram.GetInputPort("state").FixValue(context, np.concatenate((q0, np.zeros(nv))))
    n_t = len(controller.task_names)
    alpha = np.zeros((n_t, n_t))
    alpha[-1, :-1] = 1.0  # the posture below the hand
    diagram.GetInputPort("alpha").FixValue(context, alpha.reshape(-1))
    return plant, info, q0, controller, diagram, context


def _tick(controller, diagram, context):
    c = controller.GetMyMutableContextFromRoot(context)
    c.SetDiscreteState(controller.EvalUniquePeriodicDiscreteUpdate(c))
    return {
        name: controller.GetOutputPort(name).Eval(c) for name in ("tau", "status", "contact_forces", "errors")
    }


def _gravity_in_actuator_order(plant, info, q):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    g = -plant.CalcGravityGeneralizedForces(context)
    return np.array([g[plant.GetJointByName(j).velocity_start()] for j in info.actuated_joints])


def test_at_rest_on_target_the_torques_hold_gravity():
    plant, info, q0, controller, diagram, context = _controller(fixed_base=True)
    out = _tick(controller, diagram, context)
    assert out["status"][0] == STATUS_OPTIMAL
    np.testing.assert_allclose(out["tau"], _gravity_in_actuator_order(plant, info, q0), atol=1e-6)


def test_standing_contacts_carry_the_weight():
    plant, info, q0, controller, diagram, context = _controller(fixed_base=False)
    out = _tick(controller, diagram, context)
    assert out["status"][0] == STATUS_OPTIMAL
    forces = out["contact_forces"].reshape(-1, 3)
    mass = plant.CalcTotalMass(plant.CreateDefaultContext())
    # The contacts carry the weight (up to the tiny virtual support the ω_r regularisation trades).
    assert forces[:, 2].sum() == pytest.approx(mass * 9.81, rel=1e-4)
    assert np.all(forces[:, 2] >= -1e-9)
    # Inside the friction pyramid: |f_t| ≤ μ/√2 f_n per tangent axis (4 facets, μ = 0.8).
    assert np.all(np.abs(forces[:, :2]) <= 0.8 / np.sqrt(2) * forces[:, 2:3] + 1e-9)


def test_infeasible_qp_falls_back_to_gravity_compensation_and_posture():
    """Each of the 8 sole corners must push with at least 100 N, but the robot weighs 567 N
    and only the contacts can hold the base (the posture task has no root component)."""
    plant, info, q0, controller, diagram, context = _controller(
        fixed_base=False, hand=False, min_normal_force=100.0, fallback_gains=(200.0, 10.0)
    )
    q = q0.copy()
    elbow = plant.GetJointByName("l_elbow")
    q[elbow.position_start()] += 0.1  # off the posture: the fallback PD acts on this joint
    v = np.zeros(plant.num_velocities())
    diagram.GetInputPort("q").FixValue(context, q)
    diagram.GetInputPort("state").FixValue(context, np.concatenate((q, v)))
    out = _tick(controller, diagram, context)
    assert out["status"][0] == STATUS_INFEASIBLE
    # Fallback: the static torques with the weight shared by the 8 contact points (computed
    # here independently by least squares on the base equilibrium), plus the posture PD.
    context_p = plant.CreateDefaultContext()
    plant.SetPositions(context_p, q)
    g = -plant.CalcGravityGeneralizedForces(context_p)
    from pydrake.multibody.tree import JacobianWrtVariable

    world = plant.world_frame()
    J = np.vstack(
        [
            plant.CalcJacobianTranslationalVelocity(
                context_p, JacobianWrtVariable.kV, plant.GetFrameByName(info.frames[f]), p, world, world
            )
            for f in ("left_foot", "right_foot")
            for p in sole_corner_points()
        ]
    )
    f = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
    tau_v = g[6:] - J[:, 6:].T @ f
    expected = np.array([tau_v[plant.GetJointByName(j).velocity_start() - 6] for j in info.actuated_joints])
    expected[list(info.actuated_joints).index("l_elbow")] += 200.0 * (-0.1)
    np.testing.assert_allclose(out["tau"], expected, atol=1e-6)
    np.testing.assert_array_equal(out["contact_forces"], 0.0)


@pytest.mark.parametrize("dependent", [False, True])
def test_inertia_weighted_desired_wrenches_match_per_task_pseudo_inverses(dependent):
    """Λ_i a_i for all tasks at once (one Cholesky) against numpy's pinv of J_i M⁻¹ J_iᵀ per
    task; a zero row (inactive joint limit) gets zero; dependent rows take the fallback."""
    rng = np.random.default_rng(3)
    nv = 12
    X = rng.normal(size=(nv, nv))
    M = X @ X.T + nv * np.eye(nv)
    M_inv = np.linalg.inv(M)
    J2 = rng.normal(size=(4, nv))
    J2[1] = 0.0
    J3 = rng.normal(size=(3, nv))
    if dependent:
        J3[2] = J3[0] - 2.0 * J3[1]
    jacobians = [rng.normal(size=(2, nv)), J2, J3]
    a = rng.normal(size=9)
    blocks = np.zeros((9, 9), dtype=bool)
    for begin, m in ((0, 2), (2, 4), (6, 3)):
        blocks[begin : begin + m, begin : begin + m] = True
    tasks = [slice(0, 2), slice(2, 6), slice(6, 9)]
    got = _inertia_weighted(np.concatenate(jacobians), tasks, M, a, blocks, 1e-8)
    expected, begin = [], 0
    for J in jacobians:
        m = J.shape[0]
        rows = np.flatnonzero(np.abs(J).sum(axis=1) > 0)
        w = np.zeros(m)
        w[rows] = np.linalg.pinv(J[rows] @ M_inv @ J[rows].T, rcond=1e-10) @ a[begin : begin + m][rows]
        expected.append(w)
        begin += m
    np.testing.assert_allclose(got, np.concatenate(expected), rtol=1e-8, atol=1e-10)
    assert got[3] == 0.0
