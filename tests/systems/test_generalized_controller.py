"""GeneralizedHierarchyController on the fixed-base and floating-base humanoid models."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import DiagramBuilder

from drake_sot.generalized import generalized_projectors, inertia_weighted
from drake_sot.models import half_sitting_configuration, make_control_model, sole_corner_points
from drake_sot.quasistatic import SolveStatus
from drake_sot.systems.features import FeaturePoint6d, FeaturePosture
from drake_sot.systems.generalized_controller import (
    SHORTFALL_THRESHOLD,
    ContactPoints,
    ForceTask,
    GeneralizedHierarchyController,
    MotionTask,
    _gravity_rows,
)
from drake_sot.systems.kinematics import RobotKinematics
from drake_sot.systems.task import Task
from drake_sot.transitions import Priorities


def _controller(
    fixed_base: bool,
    *,
    hand: bool = True,
    min_normal_force: float = 0.0,
    gain: float = 1.0,
    lh_offset=(0.0, 0.0, 0.0),
    lh_velocity=None,
    force: tuple[float, float] | None = None,
    **kwargs,
):
    plant, info = make_control_model(fixed_base=fixed_base)
    q0 = half_sitting_configuration(plant, info)
    builder = DiagramBuilder()
    dyn = builder.AddSystem(RobotKinematics(plant))
    dyn.add_operational_point("lh", info.frames["left_hand"])
    context0 = plant.CreateDefaultContext()
    plant.SetPositions(context0, q0)
    X_lh = plant.GetFrameByName(info.frames["left_hand"]).CalcPoseInWorld(context0)
    target = RigidTransform(X_lh.rotation(), X_lh.translation() + np.asarray(lh_offset))
    lh = builder.AddSystem(FeaturePoint6d(name="f_lh", selection="111000", desired=target))
    posture = builder.AddSystem(
        FeaturePosture(plant, list(info.actuated_joints), name="f_posture", desired=q0)
    )
    tasks = {}
    for name, feature in (("taskLH", lh), ("taskPosture", posture)):
        tasks[name] = builder.AddSystem(Task(name, gain=gain))
        builder.Connect(feature.GetOutputPort("feature"), tasks[name].add(feature))
    force_tasks = []
    if force is not None:  # a vertical force task on the left hand, sharing its feature
        tasks["taskLHF"] = builder.AddSystem(Task("taskLHF", gain=gain))
        builder.Connect(lh.GetOutputPort("feature"), tasks["taskLHF"].add(lh, selection="001"))
        force_tasks = [ForceTask(tasks["taskLHF"], *force)]
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
            plant,
            info.actuated_joints,
            motion_tasks=motion,
            force_tasks=force_tasks,
            contacts=contacts,
            q_posture=q0,
            **kwargs,
        )
    )
    for name in controller.task_names:
        builder.Connect(tasks[name].GetOutputPort("task"), controller.GetInputPort(name))
    builder.ExportInput(dyn.GetInputPort("q"), "q")
    builder.ConnectInput("q", posture.GetInputPort("q"))
    builder.ExportInput(controller.GetInputPort("state"), "state")
    builder.ExportInput(controller.GetInputPort("priorities"), "priorities")
    builder.ExportInput(lh.GetInputPort("velocity_des"), "lh_velocity")
    for port in ("taskLHF_desired", "taskLHF_measured") if force is not None else ():
        builder.ExportInput(controller.GetInputPort(port), port)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    nv = plant.num_velocities()
    diagram.GetInputPort("q").FixValue(context, q0)
    diagram.GetInputPort("state").FixValue(context, np.concatenate((q0, np.zeros(nv))))
    if lh_velocity is not None:  # a moving reference: the feature's feed-forward
        diagram.GetInputPort("lh_velocity").FixValue(context, lh_velocity)
    names = controller.task_names
    alpha = np.zeros((len(names), len(names)))
    alpha[names.index("taskPosture"), :] = 1.0  # the posture below every other task
    alpha[names.index("taskPosture"), names.index("taskPosture")] = 0.0
    diagram.GetInputPort("priorities").FixValue(context, Priorities(controller.task_names, alpha))
    return plant, info, q0, controller, diagram, context


def _tick(controller, diagram, context):
    c = controller.GetMyMutableContextFromRoot(context)
    c.SetDiscreteState(controller.EvalUniquePeriodicDiscreteUpdate(c))
    return {port: controller.GetOutputPort(port).Eval(c) for port in OUTPUTS}


OUTPUTS = (
    "tau",
    "status",
    "contact_forces",
    "errors",
    "wrenches",
    "desired_wrenches",
    "shortfall",
    "saturation",
    "report",
)


def _gravity_in_actuator_order(plant, info, q):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    g = -plant.CalcGravityGeneralizedForces(context)
    return np.array([g[plant.GetJointByName(j).velocity_start()] for j in info.actuated_joints])


def test_at_rest_on_target_the_torques_hold_gravity():
    plant, info, q0, controller, diagram, context = _controller(fixed_base=True)
    out = _tick(controller, diagram, context)
    assert out["status"][0] == SolveStatus.OPTIMAL.code
    np.testing.assert_allclose(out["tau"], _gravity_in_actuator_order(plant, info, q0), atol=1e-6)


def test_standing_contacts_carry_the_weight():
    plant, info, q0, controller, diagram, context = _controller(fixed_base=False)
    out = _tick(controller, diagram, context)
    assert out["status"][0] == SolveStatus.OPTIMAL.code
    forces = out["contact_forces"].reshape(-1, 3)
    mass = plant.CalcTotalMass(plant.CreateDefaultContext())
    # The contacts carry the weight (up to the tiny virtual support the ω_r regularisation trades).
    assert forces[:, 2].sum() == pytest.approx(mass * 9.81, rel=1e-4)
    assert np.all(forces[:, 2] >= -1e-9)
    # Inside the friction pyramid: |f_t| ≤ μ/√2 f_n per tangent axis (4 facets, μ = 0.8).
    assert np.all(np.abs(forces[:, :2]) <= 0.8 / np.sqrt(2) * forces[:, 2:3] + 1e-9)


def _sole_corner_jacobians(plant, info, q):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    world = plant.world_frame()
    return np.vstack(
        [
            plant.CalcJacobianTranslationalVelocity(
                context, JacobianWrtVariable.kV, plant.GetFrameByName(info.frames[f]), p, world, world
            )
            for f in ("left_foot", "right_foot")
            for p in sole_corner_points()
        ]
    )


def test_infeasible_qp_falls_back_saturated_at_the_bounds_and_says_what_it_cut():
    """The robot pitched forward by 0.5 rad: its CoM is beyond the soles' support, no contact
    force can hold it (the QP is infeasible). The fallback — the weight shared by the 8 sole
    corners, computed here by least squares on the base rows, plus the posture PD — wants
    about -20 N·m at the left elbow (0.1 rad off its posture, kp = 200) and is held to the
    elbow's 5 N·m bound, which the report names with the cut."""
    limits = {"l_elbow": 5.0}
    plant, info, q0, _, _, _ = _controller(fixed_base=False, hand=False)
    effort = np.array(
        [limits.get(j, plant.GetJointActuatorByName(j).effort_limit()) for j in info.actuated_joints]
    )
    plant, info, q0, controller, diagram, context = _controller(
        fixed_base=False, hand=False, fallback_gains=(200.0, 10.0), effort_limits=effort
    )
    q = q0.copy()
    q[:4] = RollPitchYaw(0.0, 0.5, 0.0).ToQuaternion().wxyz()
    elbow = plant.GetJointByName("l_elbow")
    q[elbow.position_start()] += 0.1  # off the posture: the fallback PD acts on this joint
    v = np.zeros(plant.num_velocities())
    diagram.GetInputPort("q").FixValue(context, q)
    diagram.GetInputPort("state").FixValue(context, np.concatenate((q, v)))
    out = _tick(controller, diagram, context)
    assert out["status"][0] == SolveStatus.INFEASIBLE.code
    context_p = plant.CreateDefaultContext()
    plant.SetPositions(context_p, q)
    g = -plant.CalcGravityGeneralizedForces(context_p)
    J = _sole_corner_jacobians(plant, info, q)
    f = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
    tau_v = g[6:] - J[:, 6:].T @ f
    wanted = np.array([tau_v[plant.GetJointByName(j).velocity_start() - 6] for j in info.actuated_joints])
    k = list(info.actuated_joints).index("l_elbow")
    wanted[k] += 200.0 * (-0.1)
    assert wanted[k] < -5.0  # the bound has to cut it
    np.testing.assert_allclose(out["tau"], np.clip(wanted, -effort, effort), atol=1e-6)
    assert np.all(np.abs(out["tau"]) <= effort)
    np.testing.assert_allclose(out["saturation"], wanted - np.clip(wanted, -effort, effort), atol=1e-6)
    report = out["report"]
    assert report.status == SolveStatus.INFEASIBLE and report.fallback
    assert dict(report.saturated) == pytest.approx({"l_elbow": wanted[k] + 5.0}, abs=1e-6)
    assert "l_elbow" in report.summary() and "fallback" in report.summary()
    np.testing.assert_array_equal(out["contact_forces"], 0.0)
    assert np.isnan(out["wrenches"]).all() and np.isnan(out["shortfall"]).all()


def test_bounds_that_cannot_follow_the_hand_make_it_short_by_name():
    """Fixed base, effort limits 30 % above the gravity torques at q0 (+0.05 N·m), and a
    left-hand target 0.4 m away: the QP stays optimal, but the hand's wrench is cut. The
    status says "short", the report names taskLH with its shortfall, recomputed here from
    the wrench outputs; no torque leaves its bound."""
    plant, info, q0, *_ = _controller(fixed_base=True)
    need = np.abs(_gravity_in_actuator_order(plant, info, q0))
    effort = 1.3 * need + 0.05
    plant, info, q0, controller, diagram, context = _controller(
        fixed_base=True, effort_limits=effort, lh_offset=(0.4, -0.2, 0.2)
    )
    out = _tick(controller, diagram, context)
    slices = controller.error_slices()
    # Independently: the torques the desired wrenches alone would ask for break the bounds.
    context_p = plant.CreateDefaultContext()
    plant.SetPositions(context_p, q0)
    jacobians = []
    for name in controller.task_names:
        task = controller.GetInputPort(name).Eval(controller.GetMyContextFromRoot(context))
        jacobians.append(task.jacobian)
    alpha = np.array([[0.0, 0.0], [1.0, 0.0]])
    P = generalized_projectors(jacobians, alpha)
    g = -plant.CalcGravityGeneralizedForces(context_p)
    unbounded = g + sum(
        P[i] @ J.T @ out["desired_wrenches"][slices[n]]
        for i, (n, J) in enumerate(zip(controller.task_names, jacobians, strict=True))
    )
    order = [plant.GetJointByName(j).velocity_start() for j in info.actuated_joints]
    assert np.any(np.abs(unbounded[order]) > effort)
    assert out["status"][0] == SolveStatus.SHORT.code
    assert np.all(np.abs(out["tau"]) <= effort)
    w, wd = out["wrenches"][slices["taskLH"]], out["desired_wrenches"][slices["taskLH"]]
    shortfall = np.linalg.norm(w - wd) / max(np.linalg.norm(wd), 1.0)
    assert shortfall > SHORTFALL_THRESHOLD
    report = out["report"]
    assert report.status == SolveStatus.SHORT and report.short[0][0] == "taskLH"
    assert report.short[0][1] == pytest.approx(shortfall, rel=1e-9)
    assert report.tasks["taskLH"].shortfall == pytest.approx(shortfall, rel=1e-9)
    np.testing.assert_array_equal(report.tasks["taskLH"].desired, wd)
    assert "taskLH" in report.summary()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (
            {"effort_limits": 0.01},
            r"effort limits cannot hold the robot's weight \(567 N\) at q_posture.*"
            r"r_knee \(needs ~[0-9.]+ N·m, limit 0.01 N·m\)",
        ),
        (
            {"min_normal_force": 1000.0},
            r"min_normal_force per point \(l_sole: 1000 N, r_sole: 1000 N\) over 8 points \(8000 N\) "
            r"exceeds the robot's weight \(567 N\)",
        ),
    ],
)
def test_contacts_and_bounds_that_cannot_hold_the_weight_are_refused_at_construction(kwargs, match):
    plant, _ = make_control_model()
    weight = plant.CalcTotalMass(plant.CreateDefaultContext()) * 9.81
    assert round(weight) == 567  # the weight the messages quote, computed here
    with pytest.raises(ValueError, match=match):
        _controller(fixed_base=False, hand=False, **kwargs)


def test_the_refused_knee_limit_is_what_the_statics_need():
    """The knee need quoted in the message is the knee torque of a static solution: no
    contact distribution holds the robot with less than the quoted factor on every bound."""
    with pytest.raises(ValueError) as refused:
        _controller(fixed_base=False, hand=False, effort_limits=1.0)
    factor = float(str(refused.value).split("would need to be ")[1].split(" times")[0])
    _controller(fixed_base=False, hand=False, effort_limits=1.01 * factor)  # builds
    with pytest.raises(ValueError, match="effort limits"):
        _controller(fixed_base=False, hand=False, effort_limits=0.99 * factor)


def test_priorities_are_applied_by_name_in_any_order():
    plant, info, q0, controller, diagram, context = _controller(fixed_base=True, lh_offset=(0.1, 0.0, 0.0))
    reference = _tick(controller, diagram, context)["tau"]
    names = controller.task_names
    assert names == ("taskLH", "taskPosture")
    # The same hierarchy with the rows and columns listed the other way round.
    swapped = Priorities((names[1], names[0]), np.array([[0.0, 1.0], [0.0, 0.0]]))
    diagram.GetInputPort("priorities").FixValue(context, swapped)
    np.testing.assert_array_equal(_tick(controller, diagram, context)["tau"], reference)
    # The hierarchy inverted by name changes the torques: the permutation is not a no-op.
    inverted = Priorities(names, np.array([[0.0, 1.0], [0.0, 0.0]]))
    diagram.GetInputPort("priorities").FixValue(context, inverted)
    assert np.abs(_tick(controller, diagram, context)["tau"] - reference).max() > 1e-3


def test_priorities_naming_an_unknown_task_are_refused_with_the_known_names():
    plant, info, q0, controller, diagram, context = _controller(fixed_base=True)
    bad = Priorities(("taskLH", "taskHead"), np.zeros((2, 2)))
    diagram.GetInputPort("priorities").FixValue(context, bad)
    with pytest.raises(
        ValueError,
        match=r"priorities name unknown task\(s\) \['taskHead'\]; no priority for task\(s\) "
        r"\['taskPosture'\]; known tasks: taskLH, taskPosture",
    ):
        _tick(controller, diagram, context)


def test_error_slices_follow_the_task_names():
    _, _, _, controller, diagram, context = _controller(fixed_base=True, lh_offset=(0.1, -0.05, 0.02))
    out = _tick(controller, diagram, context)
    slices = controller.error_slices()
    assert list(slices) == list(controller.task_names)
    np.testing.assert_allclose(out["errors"][slices["taskLH"]], [-0.1, 0.05, -0.02], atol=1e-12)  # s - s*
    assert slices["taskPosture"].stop - slices["taskPosture"].start == 30


def test_the_task_gain_and_feedforward_are_not_used():
    """The module docstring's rule: neither a Task's λ nor a moving reference's feed-forward
    changes the torques (the MotionTask's kp, kd make the law), though both change the
    desired error rate the kinematic SoT would use."""
    runs = []
    for gain, velocity in ((1.0, None), (50.0, None), (1.0, [0.3, -0.2, 0.1, 0.0, 0.0, 0.0])):
        _, _, _, controller, diagram, context = _controller(
            fixed_base=True, gain=gain, lh_offset=(0.1, 0.0, 0.0), lh_velocity=velocity
        )
        task = controller.GetInputPort("taskLH").Eval(controller.GetMyContextFromRoot(context))
        runs.append((_tick(controller, diagram, context)["tau"], task.edot_des))
    for tau, edot_des in runs[1:]:
        np.testing.assert_array_equal(tau, runs[0][0])
        assert np.abs(edot_des - runs[0][1]).max() > 0.05


def test_force_task_follows_eq_3_and_does_not_wind_up_while_deactivated():
    """A vertical force task on the left hand: w* = -30 N, measured -20 N (e_w = 10 N),
    kp = 0.5, ki = 4, period 5 ms. Active (α_ii = 0), its desired wrench after k ticks is
    w* - kp e_w - ki (k e_w dt) (eq. 3 by hand); deactivated (α_ii = 1) the integral stays 0."""
    kp, ki, dt = 0.5, 4.0, 0.005
    for deactivated in (False, True):
        _, _, _, controller, diagram, context = _controller(fixed_base=True, force=(kp, ki), period=dt)
        names = controller.task_names
        alpha = np.zeros((3, 3))
        alpha[names.index("taskPosture")] = [1.0, 0.0, 1.0] if names[1] == "taskPosture" else [1.0, 1.0, 0.0]
        alpha[names.index("taskLHF"), names.index("taskLHF")] = 1.0 if deactivated else 0.0
        diagram.GetInputPort("priorities").FixValue(context, Priorities(names, alpha))
        diagram.GetInputPort("taskLHF_desired").FixValue(context, [-30.0])
        diagram.GetInputPort("taskLHF_measured").FixValue(context, [-20.0])
        sl = controller.error_slices()["taskLHF"]
        for k in range(1, 4):
            out = _tick(controller, diagram, context)
            integral = 0.0 if deactivated else k * 10.0 * dt
            assert out["desired_wrenches"][sl] == pytest.approx([-30.0 - kp * 10.0 - ki * integral])
            assert out["errors"][sl] == pytest.approx([10.0])  # measured - desired


def test_the_force_integral_restarts_after_a_fallback():
    """The fallback does not act through the force task: its integral is reset (no wind-up)."""
    kp, ki, dt = 0.5, 4.0, 0.005
    plant, _, q0, controller, diagram, context = _controller(
        fixed_base=False, hand=False, force=(kp, ki), period=dt
    )
    diagram.GetInputPort("taskLHF_desired").FixValue(context, [-30.0])
    diagram.GetInputPort("taskLHF_measured").FixValue(context, [-20.0])
    sl = controller.error_slices()["taskLHF"]
    pitched = q0.copy()
    pitched[:4] = RollPitchYaw(0.0, 0.5, 0.0).ToQuaternion().wxyz()
    v = np.zeros(plant.num_velocities())
    names = controller.task_names
    active = np.zeros((2, 2))
    active[names.index("taskPosture")] = [name != "taskPosture" for name in names]
    # While pitched, the force task is deactivated (α_ii = 1: it neither integrates nor,
    # projected to nothing, carries the robot) and the posture is not projected along it
    # (which would give the posture's projected Jacobian root columns): nothing holds the
    # base, the QP is infeasible and the controller falls back.
    off = np.zeros((2, 2))
    off[names.index("taskLHF"), names.index("taskLHF")] = 1.0
    statuses, desired = [], []
    for q, alpha in ((q0, active), (q0, active), (pitched, off), (q0, active)):
        diagram.GetInputPort("priorities").FixValue(context, Priorities(names, alpha))
        diagram.GetInputPort("q").FixValue(context, q)
        diagram.GetInputPort("state").FixValue(context, np.concatenate((q, v)))
        out = _tick(controller, diagram, context)
        statuses.append(out["status"][0])
        desired.append(out["desired_wrenches"][sl][0])
    assert statuses[2] == SolveStatus.INFEASIBLE.code and statuses[3] != SolveStatus.INFEASIBLE.code
    step = ki * 10.0 * dt
    assert desired[1] == pytest.approx(-30.0 - kp * 10.0 - 2 * step)  # two ticks integrated
    # restarted from 0 after the fallback (else 3 steps: the deactivated tick adds nothing)
    assert desired[3] == pytest.approx(-30.0 - kp * 10.0 - step)


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
    got = inertia_weighted(np.concatenate(jacobians), tasks, M, a, blocks, 1e-8)
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


def test_priorities_of_another_type_are_refused():
    _, _, _, controller, diagram, context = _controller(fixed_base=True)
    diagram.GetInputPort("priorities").FixValue(context, ("taskLH", "taskPosture"))
    with pytest.raises(TypeError, match=r"input port 'priorities' carries a tuple, not a .*Priorities"):
        _tick(controller, diagram, context)


def test_a_nan_force_reading_is_refused_with_the_port_name():
    _, _, _, controller, diagram, context = _controller(fixed_base=True, force=(0.5, 4.0))
    diagram.GetInputPort("taskLHF_desired").FixValue(context, [-30.0])
    diagram.GetInputPort("taskLHF_measured").FixValue(context, [np.nan])
    with pytest.raises(ValueError, match=r"input 'taskLHF_measured' contains NaN or Inf"):
        _tick(controller, diagram, context)


def test_gravity_from_the_mass_matrix_rows_is_drakes():
    """``-τ_g = w M[rows]`` (Σ m_i J_iᵀ g through the momentum rows of M) against Drake's
    gravity forces at random configurations of the floating humanoid; no such rows on the
    fixed-base model, nor with gravity switched off for a model instance."""
    plant, info = make_control_model(fixed_base=False)
    rows, weight = _gravity_rows(plant)
    pc = plant.CreateDefaultContext()
    q0 = half_sitting_configuration(plant, info)
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = q0.copy()
        q[:4] = rng.normal(size=4)
        q[:4] /= np.linalg.norm(q[:4])
        q[4:7] += rng.normal(size=3)
        q[7:] += rng.uniform(-0.3, 0.3, size=q.size - 7)
        plant.SetPositions(pc, q)
        np.testing.assert_allclose(
            weight @ plant.CalcMassMatrix(pc)[rows],
            -plant.CalcGravityGeneralizedForces(pc),
            atol=1e-10 * np.abs(plant.CalcGravityGeneralizedForces(pc)).max(),
        )
    assert _gravity_rows(make_control_model(fixed_base=True)[0]) is None
    assert _gravity_rows(_free_pendulum(gravity=True)) is not None
    assert _gravity_rows(_free_pendulum(gravity=False)) is None


def _free_pendulum(gravity: bool):
    """A free base with a link on a revolute joint, its own model instance, gravity on or off."""
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import RevoluteJoint, SpatialInertia, UnitInertia

    plant = MultibodyPlant(0.0)
    instance = plant.AddModelInstance("pendulum")
    inertia = SpatialInertia(1.0, np.zeros(3), UnitInertia.SolidBox(0.1, 0.1, 0.1))
    base = plant.AddRigidBody("base", instance, inertia)
    link = plant.AddRigidBody("link", instance, inertia)
    plant.AddJoint(RevoluteJoint("hinge", base.body_frame(), link.body_frame(), [0.0, 1.0, 0.0]))
    plant.gravity_field().set_enabled(instance, gravity)
    plant.Finalize()
    return plant
