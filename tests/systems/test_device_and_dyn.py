"""Device (the SoT device), RobotKinematics (dyn) and the quasi-static feed-forward."""

import numpy as np
import pytest
from feature_bench import random_configuration
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.tree import JacobianWrtVariable, MultibodyForces

from drake_sot.configuration import integrate
from drake_sot.statics import contact_torques
from drake_sot.systems.device import Device
from drake_sot.systems.feedforward import TorqueFeedforward
from drake_sot.systems.kinematics import RobotKinematics


def test_device_integrates_on_the_manifold(control_model):
    plant, info, q0 = control_model
    device = Device(plant, info.actuated_joints, q0, period=0.005)
    context = device.CreateDefaultContext()
    rng = np.random.default_rng(0)
    qdot = rng.normal(size=plant.num_velocities())
    device.GetInputPort("qdot").FixValue(context, qdot)
    q = q0.copy()
    for _ in range(10):
        context.SetDiscreteState(device.EvalUniquePeriodicDiscreteUpdate(context))
        q = integrate(q, qdot, 0.005)
    np.testing.assert_allclose(device.GetOutputPort("q").Eval(context), q, atol=1e-12)
    assert abs(np.linalg.norm(device.GetOutputPort("q").Eval(context)[:4]) - 1.0) < 1e-14
    # state_des is [q; v] of the actuated joints in actuator order, read through Drake's joint API.
    state_des = device.GetOutputPort("state_des").Eval(context)
    for k, name in enumerate(info.actuated_joints):
        joint = plant.GetJointByName(name)
        assert state_des[k] == q[joint.position_start()]
        assert state_des[len(info.actuated_joints) + k] == qdot[joint.velocity_start()]


def test_device_refuses_nan(control_model):
    plant, info, q0 = control_model
    device = Device(plant, info.actuated_joints, q0)
    context = device.CreateDefaultContext()
    qdot = np.zeros(plant.num_velocities())
    qdot[7] = np.nan
    device.GetInputPort("qdot").FixValue(context, qdot)
    with pytest.raises(RuntimeError, match="input 'qdot' holds NaN"):
        device.EvalUniquePeriodicDiscreteUpdate(context)


def test_dyn_operational_points_match_the_plant(control_model):
    plant, info, q0 = control_model
    dyn = RobotKinematics(plant)
    dyn.add_operational_point("rleg", info.frames["right_foot"])
    with pytest.raises(ValueError, match="no frame 'nope'.*r_sole"):
        dyn.add_operational_point("x", "nope")
    with pytest.raises(ValueError, match="already exists"):
        dyn.add_operational_point("rleg", info.frames["left_foot"])
    with pytest.raises(
        ValueError, match="outputs 'com', 'Jcom', 'com_frame' is taken"
    ):  # "J" + "com" is taken
        dyn.add_operational_point("com", info.frames["left_foot"])
    with pytest.raises(ValueError, match="outputs 'rleg_frame', 'Jrleg_frame'"):  # the second op's pose port
        dyn.add_operational_point("rleg_frame", info.frames["left_foot"])
    context = dyn.CreateDefaultContext()
    q = random_configuration(plant, q0, np.random.default_rng(1))
    dyn.GetInputPort("q").FixValue(context, q)
    pc = plant.CreateDefaultContext()
    plant.SetPositions(pc, q)
    frame = plant.GetFrameByName(info.frames["right_foot"])
    X = dyn.GetOutputPort("rleg").Eval(context)
    np.testing.assert_allclose(X.GetAsMatrix4(), frame.CalcPoseInWorld(pc).GetAsMatrix4(), atol=1e-14)
    J = plant.CalcJacobianSpatialVelocity(
        pc, JacobianWrtVariable.kV, frame, np.zeros(3), plant.world_frame(), plant.world_frame()
    )
    np.testing.assert_allclose(dyn.GetOutputPort("Jrleg").Eval(context), J, atol=1e-14)
    both = dyn.GetOutputPort("rleg_frame").Eval(context)  # the same pose and Jacobian in one value
    np.testing.assert_allclose(both.rotation, frame.CalcPoseInWorld(pc).rotation().matrix(), atol=1e-14)
    np.testing.assert_allclose(both.translation, frame.CalcPoseInWorld(pc).translation(), atol=1e-14)
    np.testing.assert_allclose(both.jacobian, J, atol=1e-14)
    np.testing.assert_allclose(
        dyn.GetOutputPort("com").Eval(context), plant.CalcCenterOfMassPositionInWorld(pc), atol=1e-14
    )


def _com_jacobian_by_finite_differences(plant, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """(3, nv): central differences of Drake's CoM position along each generalized velocity."""
    pc = plant.CreateDefaultContext()
    columns = []
    for k in range(plant.num_velocities()):
        v = np.zeros(plant.num_velocities())
        v[k] = 1.0
        ends = []
        for step in (h, -h):
            plant.SetPositions(pc, integrate(q, v, step))
            ends.append(plant.CalcCenterOfMassPositionInWorld(pc))
        columns.append((ends[0] - ends[1]) / (2 * h))
    return np.column_stack(columns)


def test_dyn_com_jacobian_matches_drakes_and_finite_differences(control_model):
    """Jcom (from the mass matrix's base-translation rows on a floating humanoid) against Drake's
    CoM Jacobian and against finite differences of the CoM, at random configurations."""
    plant, _, q0 = control_model
    dyn = RobotKinematics(plant)
    assert dyn._com_rows is not None  # the humanoid takes the mass-matrix path
    context = dyn.CreateDefaultContext()
    pc = plant.CreateDefaultContext()
    world = plant.world_frame()
    rng = np.random.default_rng(4)
    for _ in range(3):
        q = random_configuration(plant, q0, rng)
        dyn.GetInputPort("q").FixValue(context, q)
        plant.SetPositions(pc, q)
        J = dyn.GetOutputPort("Jcom").Eval(context)
        drake_J = plant.CalcJacobianCenterOfMassTranslationalVelocity(
            pc, JacobianWrtVariable.kV, world, world
        )
        np.testing.assert_allclose(J, drake_J, atol=1e-13)
        np.testing.assert_allclose(J, _com_jacobian_by_finite_differences(plant, q), atol=1e-8)


class _CountingPlant:
    """A plant that counts its ``CalcMassMatrix`` calls (everything else passes through)."""

    def __init__(self, plant) -> None:
        self._plant = plant
        self.mass_matrices = 0

    def CalcMassMatrix(self, context):
        self.mass_matrices += 1
        return self._plant.CalcMassMatrix(context)

    def __getattr__(self, name):
        return getattr(self._plant, name)


def test_dyn_computes_the_mass_matrix_once_per_configuration(control_model):
    """``inertia`` and ``Jcom`` (its base-translation rows) read one mass matrix per q: a weighted
    admittance beside a CoM task costs one composite-body pass a tick, not two. Values against
    Drake's mass matrix at the same q."""
    plant, _, q0 = control_model
    dyn = RobotKinematics(plant)
    counting = _CountingPlant(plant)
    dyn._plant = counting
    context = dyn.CreateDefaultContext()
    pc = plant.CreateDefaultContext()
    rng = np.random.default_rng(7)
    for k in (1, 2):
        q = random_configuration(plant, q0, rng)
        dyn.GetInputPort("q").FixValue(context, q)
        A = dyn.GetOutputPort("inertia").Eval(context)
        J = dyn.GetOutputPort("Jcom").Eval(context)
        assert counting.mass_matrices == k
        plant.SetPositions(pc, q)
        np.testing.assert_allclose(A, plant.CalcMassMatrix(pc), rtol=0, atol=1e-12)
        world = plant.world_frame()
        drake_J = plant.CalcJacobianCenterOfMassTranslationalVelocity(
            pc, JacobianWrtVariable.kV, world, world
        )
        np.testing.assert_allclose(J, drake_J, atol=1e-13)


def test_dyn_com_jacobian_with_a_second_free_body_is_drakes():
    """A free box beside the floating robot moves without its base: the mass-matrix rows are not
    m J_com there, so Jcom is Drake's CoM Jacobian (which includes the box)."""
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import SpatialInertia, UnitInertia

    plant = MultibodyPlant(0.0)
    for name, mass in (("base", 3.0), ("box", 2.0)):
        plant.AddRigidBody(name, SpatialInertia(mass, np.zeros(3), UnitInertia.SolidBox(0.1, 0.2, 0.3)))
    plant.Finalize()
    dyn = RobotKinematics(plant)
    assert dyn._com_rows is None
    context = dyn.CreateDefaultContext()
    q = np.array([1.0, 0, 0, 0, 0.1, 0.2, 0.3, 0.6, 0.0, 0.8, 0.0, -0.4, 0.5, 0.6])
    dyn.GetInputPort("q").FixValue(context, q)
    pc = plant.CreateDefaultContext()
    plant.SetPositions(pc, q)
    world = plant.world_frame()
    np.testing.assert_allclose(
        dyn.GetOutputPort("Jcom").Eval(context),
        plant.CalcJacobianCenterOfMassTranslationalVelocity(pc, JacobianWrtVariable.kV, world, world),
        atol=1e-14,
    )
    # The box's velocity moves the CoM by its share of the mass: 2/5 of its translational columns.
    np.testing.assert_allclose(dyn.GetOutputPort("Jcom").Eval(context)[:, 9:12], 0.4 * np.eye(3), atol=1e-14)


def test_contact_torques_at_rest_balance_the_robot_by_inverse_dynamics(control_model):
    """Drake's inverse dynamics at rest, with the computed sole wrenches applied, needs
    no base force and exactly the feed-forward joint torques."""
    plant, info, q0 = control_model
    context = plant.CreateDefaultContext()
    q = q0.copy()
    q[7:] += np.random.default_rng(2).uniform(-0.1, 0.1, q.size - 7)  # an asymmetric posture
    plant.SetPositions(context, q)
    soles = [plant.GetFrameByName(info.frames[k]) for k in ("left_foot", "right_foot")]
    world = plant.world_frame()
    J = np.vstack(
        [
            plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, f, np.zeros(3), world, world)
            for f in soles
        ]
    )
    tau, f = contact_torques(-plant.CalcGravityGeneralizedForces(context), J)
    forces = MultibodyForces(plant)
    plant.CalcForceElementsContribution(context, forces)  # gravity (not included by inverse dynamics)
    for k, frame in enumerate(soles):
        w = f[6 * k : 6 * k + 6]  # [torque; force] at the sole origin, world frame
        body = frame.body()
        p_BoF_W = frame.CalcPoseInWorld(context).translation() - body.EvalPoseInWorld(context).translation()
        torque_about_body_origin = w[:3] + np.cross(p_BoF_W, w[3:])
        body.AddInForceInWorld(context, SpatialForce(torque_about_body_origin, w[3:]), forces)
    tau_id = plant.CalcInverseDynamics(context, np.zeros(plant.num_velocities()), forces)
    np.testing.assert_allclose(tau_id[:6], 0.0, atol=1e-8)
    np.testing.assert_allclose(tau_id[6:], tau, atol=1e-8)
    # The soles carry the weight.
    assert f[5] + f[11] == pytest.approx(plant.CalcTotalMass(context) * 9.81, rel=1e-6)


def test_gravity_feedforward_in_actuator_order(control_model):
    plant, info, q0 = control_model
    feedforward = TorqueFeedforward(
        plant, info.actuated_joints, [info.frames["left_foot"], info.frames["right_foot"]]
    )
    context = feedforward.CreateDefaultContext()
    feedforward.GetInputPort("q").FixValue(context, q0)
    tau = feedforward.GetOutputPort("tau").Eval(context)
    pc = plant.CreateDefaultContext()
    plant.SetPositions(pc, q0)
    tau_g = plant.CalcGravityGeneralizedForces(pc)
    # An arm joint carries only its distal subtree: its torque is -τ_g of that joint.
    k = list(info.actuated_joints).index("r_shoulder_pitch")
    v = plant.GetJointByName("r_shoulder_pitch").velocity_start()
    assert tau[k] == pytest.approx(-tau_g[v], abs=1e-9)
    assert abs(tau[k]) > 0.1  # the arm hangs nearly straight: small but not zero


def test_dyn_keeps_two_contexts_apart(control_model):
    """One scratch plant context serves every Drake context: evaluating two contexts in turn,
    and changing q in one of them, gives each its own configuration's pose (Drake's)."""
    plant, info, q0 = control_model
    dyn = RobotKinematics(plant)
    dyn.add_operational_point("rh", info.frames["right_hand"])
    frame = plant.GetFrameByName(info.frames["right_hand"])
    rng = np.random.default_rng(4)
    contexts = [dyn.CreateDefaultContext() for _ in range(2)]
    for _ in range(3):
        qs = [random_configuration(plant, q0, rng) for _ in contexts]
        for context, q in zip(contexts, qs, strict=True):
            dyn.GetInputPort("q").FixValue(context, q)
        for context, q in [*zip(contexts, qs, strict=True), *zip(contexts[::-1], qs[::-1], strict=True)]:
            pc = plant.CreateDefaultContext()
            plant.SetPositions(pc, q)
            X = frame.CalcPoseInWorld(pc)
            np.testing.assert_allclose(dyn.GetOutputPort("rh").Eval(context).GetAsMatrix4(), X.GetAsMatrix4())
            np.testing.assert_allclose(
                dyn.GetOutputPort("rh_frame").Eval(context).translation, X.translation()
            )
