"""Inequality tasks as Drake systems, and StackOfTasks(solver="hqp").

Jacobians against finite differences on the configuration manifold (as the features'),
quantities against Drake's own kinematics, bounds against the model's limits, and a
closed loop (solver + device, no physics) that keeps the reference inside the limits.
"""

import numpy as np
import pytest
from feature_bench import FeatureBench, random_configuration, retract
from pydrake.math import RigidTransform
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import solve_hqp
from drake_sot.models import half_sitting_configuration
from drake_sot.models.humanoid import SOLE
from drake_sot.robots import make_robot_control_model
from drake_sot.signals import BoundedTaskSignal, TaskSignal
from drake_sot.support import signed_distance_inside, sole_corners, support_polygon
from drake_sot.systems import sot as sot_module
from drake_sot.systems.device import Device
from drake_sot.systems.features import FeaturePosture
from drake_sot.systems.inequalities import (
    CoMInSupportPolygon,
    DistanceAbove,
    JointPositionLimits,
    JointVelocityLimits,
    PointAbovePlane,
)
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task

EPS = 1e-6
PERIOD = 0.005


def task_signal(system, context) -> BoundedTaskSignal:
    return system.GetOutputPort("task").Eval(system.GetMyContextFromRoot(context))


class Bench(FeatureBench):
    """FeatureBench for inequality tasks: the ``task`` output at any q."""

    def bounded(self, task, q) -> BoundedTaskSignal:
        self.diagram.get_input_port(0).FixValue(self.context, q)
        return task_signal(task, self.context)


def fd_check(bench, task, gain, plant, q, rng, n_dirs=5):
    """J v against d s/dε on the bounded rows, s recovered from the lower bound λ (s_min - s)."""
    signal = bench.bounded(task, q)
    rows = np.isfinite(signal.lower)
    for _ in range(n_dirs):
        v = rng.normal(size=plant.num_velocities())
        plus = bench.bounded(task, retract(plant, q, v, EPS)).lower[rows]
        minus = bench.bounded(task, retract(plant, q, v, -EPS)).lower[rows]
        ds = -(plus - minus) / (2 * EPS) / gain
        np.testing.assert_allclose((signal.jacobian @ v)[rows], ds, atol=2e-6 * (1 + np.abs(ds).max()))
    return signal


# --- joint limits -------------------------------------------------------------------------


def test_joint_position_limits_are_velocity_bounds_over_the_period(control_model):
    plant, info, q0 = control_model
    joints = ["r_knee", "l_elbow", "chest_pitch"]
    margin = 0.03
    task = JointPositionLimits(plant, period=PERIOD, joints=joints, margin=margin, name="jl")
    context = task.CreateDefaultContext()
    objs = [plant.GetJointByName(j) for j in joints]
    low = np.array([j.position_lower_limits()[0] for j in objs]) + margin
    high = np.array([j.position_upper_limits()[0] for j in objs]) - margin
    q = q0.copy()
    q[objs[0].position_start()] = low[0] - 0.01  # the knee past its margin
    task.GetInputPort("q").FixValue(context, q)
    signal = task_signal(task, context)
    joint_q = q[[j.position_start() for j in objs]]
    np.testing.assert_allclose(signal.lower, (low - joint_q) / PERIOD, rtol=1e-12)
    np.testing.assert_allclose(signal.upper, (high - joint_q) / PERIOD, rtol=1e-12)
    np.testing.assert_allclose(signal.error, [-0.01, 0.0, 0.0], atol=1e-12)
    expected_J = np.zeros((3, plant.num_velocities()))
    expected_J[range(3), [j.velocity_start() for j in objs]] = 1.0
    np.testing.assert_array_equal(signal.jacobian, expected_J)
    # The q̇ already committed moves the joints first: the bounds are taken from there.
    committed = np.zeros(plant.num_velocities())
    committed[objs[1].velocity_start()] = 0.4
    task.GetInputPort("qdot").FixValue(context, committed)
    ahead = joint_q + PERIOD * committed[[j.velocity_start() for j in objs]]
    np.testing.assert_allclose(task_signal(task, context).upper, (high - ahead) / PERIOD, rtol=1e-12)


def test_joint_velocity_limits_are_the_models(control_model):
    plant, info, q0 = control_model
    task = JointVelocityLimits(plant, joints=["r_knee", "head_yaw"], scale=0.5, name="vl")
    signal = task_signal(task, task.CreateDefaultContext())
    limits = [plant.GetJointByName(j).velocity_upper_limits()[0] for j in ("r_knee", "head_yaw")]
    assert all(np.isfinite(limits)) and min(limits) > 0.0
    np.testing.assert_allclose(signal.upper, 0.5 * np.array(limits))
    np.testing.assert_allclose(signal.lower, -0.5 * np.array(limits))
    assert task.dimension == 2 and not signal.error.any()


def closed_loop(
    plant, info, q0, *, target, solver, with_limits=True, latency_input=True, combined=False, duration=1.5
):
    """Posture task toward ``target`` (gain 20/s) under joint velocity then position limits (two
    levels, or one with ``combined``), solved and integrated at the control period
    (StackOfTasks + Device, no physics). Returns the device's q and v logs (one sample per tick)."""
    b = DiagramBuilder()
    joints = list(info.actuated_joints)
    feature = b.AddSystem(FeaturePosture(plant, joints, name="feature_posture", desired=target))
    posture = b.AddSystem(Task("taskPosture", gain=20.0))
    b.Connect(feature.GetOutputPort("feature"), posture.add(feature))
    tasks = [posture]
    if with_limits:
        position = b.AddSystem(
            JointPositionLimits(
                plant, period=PERIOD, joints=joints, velocity_scale=1.0 if combined else None, name="taskJL"
            )
        )
        tasks = [position, posture]
        if not combined:
            tasks.insert(0, b.AddSystem(JointVelocityLimits(plant, joints=joints, name="taskVL")))
    sot = b.AddSystem(
        StackOfTasks(
            plant.num_velocities(), tasks, period=PERIOD, stack=[t.get_name() for t in tasks], solver=solver
        )
    )
    device = b.AddSystem(Device(plant, joints, q0, period=PERIOD))
    for t in tasks:
        b.Connect(t.GetOutputPort("task"), sot.GetInputPort(t.get_name()))
    b.Connect(sot.GetOutputPort("qdot"), device.GetInputPort("qdot"))
    b.Connect(device.GetOutputPort("q"), feature.GetInputPort("q"))
    if with_limits:
        b.Connect(device.GetOutputPort("q"), position.GetInputPort("q"))
        if latency_input:
            b.Connect(sot.GetOutputPort("qdot"), position.GetInputPort("qdot"))
    q_log = LogVectorOutput(device.GetOutputPort("q"), b, PERIOD)
    v_log = LogVectorOutput(device.GetOutputPort("v"), b, PERIOD)
    diagram = b.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(duration)
    context = simulator.get_context()
    return q_log.FindLog(context).data(), v_log.FindLog(context).data()


def _limits(plant, info, margin=0.02):
    objs = [plant.GetJointByName(j) for j in info.actuated_joints]
    q_index = [j.position_start() for j in objs]
    v_index = [j.velocity_start() for j in objs]
    low = np.array([j.position_lower_limits()[0] for j in objs]) + margin
    high = np.array([j.position_upper_limits()[0] for j in objs]) - margin
    vmax = np.array([j.velocity_upper_limits()[0] for j in objs])
    return q_index, v_index, low, high, vmax


@pytest.mark.parametrize("combined", [False, True], ids=["two levels", "one level"])
def test_limits_on_top_keep_the_reference_inside_while_a_posture_pulls_out(control_model, combined):
    """A posture 0.5 rad past every joint's upper limit, reached at 20/s: with the limits on top
    (velocity limits above position limits, or both in one level) the reference stops at the
    margin and never moves faster than the model allows; without them it goes past."""
    plant, info, q0 = control_model
    q_index, v_index, low, high, vmax = _limits(plant, info)
    target = q0.copy()
    target[q_index] = high + 0.5
    q, v = closed_loop(plant, info, q0, target=target, solver="hqp", combined=combined)
    joints_q, joints_v = q[q_index], v[v_index]
    assert (joints_q <= high[:, None] + 1e-9).all() and (joints_q >= low[:, None] - 1e-9).all()
    assert (np.abs(joints_v) <= vmax[:, None] + 1e-9).all()
    np.testing.assert_allclose(joints_q[:, -1], high, atol=1e-6)  # every joint ends on its bound
    assert (np.abs(joints_v) >= vmax[:, None] - 1e-9).any()  # the velocity limit did bind
    # The same pull without the limits (the svd solver) passes them: the check above can fail.
    q_free, _ = closed_loop(plant, info, q0, target=target, solver="svd", with_limits=False, duration=0.5)
    assert (q_free[q_index, -1] > high + 0.1).all()


def test_velocity_limits_in_the_position_rows_equal_a_level_above_them(control_model):
    """Clipping the position bounds to the velocity limits (one level) gives the reference of a
    velocity-limit level above a position-limit level, here with the limits binding both ways."""
    plant, info, q0 = control_model
    q_index, *_ = _limits(plant, info)
    target = q0.copy()
    target[q_index] += np.where(np.arange(len(q_index)) % 2, 3.0, -3.0)
    two, _ = closed_loop(plant, info, q0, target=target, solver="hqp", duration=0.6)
    one, _ = closed_loop(plant, info, q0, target=target, solver="hqp", combined=True, duration=0.6)
    np.testing.assert_allclose(one, two, atol=1e-9)


def test_without_the_committed_velocity_the_bound_is_overshot(control_model):
    """The device applies q̇ one tick late: bounds taken from q alone let the joint pass them."""
    plant, info, q0 = control_model
    q_index, _, _, high, _ = _limits(plant, info)
    target = q0.copy()
    target[q_index] = high + 0.5
    q, _ = closed_loop(plant, info, q0, target=target, solver="hqp", latency_input=False, duration=0.5)
    assert (q[q_index] - high[:, None]).max() > 1e-3


# --- CoM in the support polygon ------------------------------------------------------------


def test_com_support_rows_are_the_distances_inside_the_edges(control_model):
    plant, info, q0 = control_model
    rng = np.random.default_rng(0)
    square = np.array([[-0.1, -0.15], [0.12, -0.15], [0.12, 0.15], [-0.1, 0.15]])
    task = CoMInSupportPolygon(margin=0.02, gain=4.0, max_vertices=6, name="support")
    bench = Bench(plant, [task])
    bench.connect(bench.dyn.GetOutputPort("com"), task.GetInputPort("com"))
    bench.connect(bench.dyn.GetOutputPort("Jcom"), task.GetInputPort("Jcom"))
    bench.build()
    task.GetInputPort("polygon").FixValue(task.GetMyMutableContextFromRoot(bench.context), square)
    context = plant.CreateDefaultContext()
    for _ in range(3):
        q = random_configuration(plant, q0, rng, spread=0.2)
        signal = fd_check(bench, task, 4.0, plant, q, rng)
        plant.SetPositions(context, q)
        c = plant.CalcCenterOfMassPositionInWorld(context)[:2]
        # Distances to the four edges' lines, by hand, then the damper's bound.
        s = np.array([c[1] + 0.15, 0.12 - c[0], 0.15 - c[1], c[0] + 0.1])
        np.testing.assert_allclose(signal.lower[:4], 4.0 * (0.02 - s), atol=1e-12)
        np.testing.assert_allclose(signal.error[:4], np.minimum(s - 0.02, 0.0), atol=1e-12)
        assert (signal.upper == np.inf).all()
        # The two spare rows constrain nothing.
        assert (signal.lower[4:] == -np.inf).all() and not signal.jacobian[4:].any()


def test_com_support_from_the_feet_in_contact(control_model):
    plant, info, q0 = control_model
    task = CoMInSupportPolygon(sole_size=SOLE, margin=0.0, gain=1.0, name="support")
    feet = [("left_sole", info.frames["left_foot"]), ("right_sole", info.frames["right_foot"])]
    bench = Bench(plant, [task], op_points=feet)
    bench.connect(bench.dyn.GetOutputPort("com"), task.GetInputPort("com"))
    bench.connect(bench.dyn.GetOutputPort("Jcom"), task.GetInputPort("Jcom"))
    for port, _ in feet:
        bench.connect(bench.dyn.GetOutputPort(port), task.GetInputPort(port))
    bench.build()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q0)
    c = plant.CalcCenterOfMassPositionInWorld(context)[:2]
    soles = []
    for _, frame in feet:
        X = plant.GetFrameByName(frame).CalcPoseInWorld(context)
        soles.append(sole_corners(*X.translation()[:2], X.rotation().ToRollPitchYaw().yaw_angle(), SOLE))
    task_context = task.GetMyMutableContextFromRoot(bench.context)
    for contacts, used in (((1.0, 1.0), soles), ((1.0, 0.0), soles[:1]), ((0.0, 1.0), soles[1:])):
        task.GetInputPort("contacts").FixValue(task_context, np.array(contacts))
        signal = bench.bounded(task, q0)
        rows = np.isfinite(signal.lower)
        # With λ = 1 and no margin, the tightest row is -(distance inside the polygon).
        inside = signed_distance_inside(support_polygon(used), c)
        assert signal.lower[rows].max() == pytest.approx(-inside, abs=1e-12)
    task.GetInputPort("contacts").FixValue(task_context, np.zeros(2))
    with pytest.raises(ValueError, match="no foot in contact"):
        bench.bounded(task, q0)


# --- a point above a plane, a distance between bodies ----------------------------------------


def test_hand_above_a_plane_and_hands_apart(control_model):
    plant, info, q0 = control_model
    rng = np.random.default_rng(1)
    offset = np.array([0.02, -0.01, 0.05])
    plane = PointAbovePlane(
        normal=(0.1, 0.0, 1.0), origin=(0.3, 0.0, 0.7), clearance=0.05, offset=offset, gain=3.0, name="plane"
    )
    apart = DistanceAbove(minimum=0.3, offset_a=offset, offset_b=(0.0, 0.03, 0.0), gain=2.0, name="apart")
    hands = [("rh", info.frames["right_hand"]), ("lh", info.frames["left_hand"])]
    bench = Bench(plant, [plane, apart], op_points=hands)
    bench.connect(bench.dyn.GetOutputPort("rh"), plane.GetInputPort("position"))
    bench.connect(bench.dyn.GetOutputPort("Jrh"), plane.GetInputPort("Jq"))
    for (op, _), k in zip(hands, "ab", strict=True):
        bench.connect(bench.dyn.GetOutputPort(op), apart.GetInputPort(f"position_{k}"))
        bench.connect(bench.dyn.GetOutputPort("J" + op), apart.GetInputPort(f"Jq_{k}"))
    bench.build()
    context = plant.CreateDefaultContext()
    normal = np.array([0.1, 0.0, 1.0]) / np.linalg.norm([0.1, 0.0, 1.0])
    for _ in range(3):
        q = random_configuration(plant, q0, rng)
        fd_check(bench, plane, 3.0, plant, q, rng)
        fd_check(bench, apart, 2.0, plant, q, rng)
        plant.SetPositions(context, q)

        def point(frame, p):
            return plant.CalcPointsPositions(context, plant.GetFrameByName(frame), p, plant.world_frame())[
                :, 0
            ]

        p_rh, p_lh = (
            point(info.frames["right_hand"], offset),
            point(info.frames["left_hand"], [0.0, 0.03, 0.0]),
        )
        height = normal @ (p_rh - [0.3, 0.0, 0.7])
        assert bench.bounded(plane, q).lower[0] == pytest.approx(3.0 * (0.05 - height), abs=1e-12)
        distance = np.linalg.norm(p_rh - p_lh)
        assert bench.bounded(apart, q).lower[0] == pytest.approx(2.0 * (0.3 - distance), abs=1e-12)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: JointPositionLimits(p, period=0.0), "period = 0.0"),
        (lambda p: JointPositionLimits(p, period=PERIOD, margin=2.0), "margin = 2.0: must leave room"),
        (lambda p: JointPositionLimits(p, period=PERIOD, joints=["nose"]), r"unknown joints \['nose'\]"),
        (lambda p: JointVelocityLimits(p, scale=0.0), "scale = 0.0: must be > 0"),
        (lambda p: JointVelocityLimits(p, scale=1.5), "scale = 1.5: must be in"),
        (lambda p: CoMInSupportPolygon(max_vertices=2), "max_vertices = 2: must be an integer >= 3"),
        (lambda p: CoMInSupportPolygon(gain=np.nan), "gain = nan"),
        (lambda p: PointAbovePlane(normal=(0, 0, 0)), "normal = .*: must not be zero"),
        (lambda p: PointAbovePlane(clearance=np.inf), "clearance = inf"),
        (lambda p: DistanceAbove(minimum=-0.1), "minimum = -0.1"),
        (lambda p: DistanceAbove(minimum=0.1, name=""), "task name = '': must be a non-empty string"),
    ],
)
def test_bad_arguments_are_refused_with_names(control_model, make, message):
    with pytest.raises(ValueError, match=message):
        make(control_model[0])


# --- StackOfTasks(solver="hqp") --------------------------------------------------------------

NV = 5


def _tick(sot, context):
    context.SetDiscreteState(sot.EvalUniquePeriodicDiscreteUpdate(context))
    return sot.GetOutputPort("qdot").Eval(context), sot.GetOutputPort("errors").Eval(context)


def test_hqp_stack_solves_inequality_and_equality_tasks_by_name():
    rng = np.random.default_rng(2)
    box = BoundedTaskSignal("box", np.array([0.0, 0.1]), np.eye(NV)[:2], -np.full(2, 0.2), np.full(2, 0.2))
    reach = TaskSignal("reach", rng.normal(size=3), rng.normal(size=(3, NV)), rng.normal(size=3))
    sot = StackOfTasks(NV, {"reach": 3, "box": 2}, stack=("box", "reach"), solver="hqp")
    context = sot.CreateDefaultContext()
    sot.GetInputPort("box").FixValue(context, box)
    sot.GetInputPort("reach").FixValue(context, reach)
    qdot, errors = _tick(sot, context)
    expected = solve_hqp([(box.jacobian, box.lower, box.upper), (reach.jacobian, reach.edot_des)])
    np.testing.assert_allclose(qdot, expected.qdot, atol=1e-14)
    assert (np.abs(qdot[:2]) <= 0.2 + 1e-12).all()
    np.testing.assert_array_equal(errors[sot.error_slices()["box"]], box.error)
    # Equality tasks only: the two solvers agree.
    sot.rm(context, "box")
    hqp, _ = _tick(sot, context)
    np.testing.assert_allclose(hqp, solve_strict([(reach.jacobian, reach.edot_des)]).qdot, atol=1e-12)


def test_inequality_tasks_need_the_hqp_solver_and_sound_bounds(control_model):
    plant = control_model[0]
    velocity = JointVelocityLimits(plant, name="taskVL")
    with pytest.raises(ValueError, match=r"inequality tasks \['taskVL'\] need solver='hqp' \(solver='svd'\)"):
        StackOfTasks(plant.num_velocities(), [velocity])
    with pytest.raises(ValueError, match="solver = 'qp': must be one of 'svd', 'hqp'"):
        StackOfTasks(NV, {"a": 1}, solver="qp")
    with pytest.raises(ValueError, match=r"a damping per task needs solver='hqp' \(solver='svd'\)"):
        StackOfTasks(NV, {"a": 1}, damping={"a": 0.1})
    with pytest.raises(ValueError, match=r"damping of unknown tasks \['b'\]; the tasks are \['a'\]"):
        StackOfTasks(NV, {"a": 1}, solver="hqp", damping={"b": 0.1})
    with pytest.raises(ValueError, match=r"damping\['a'\] = -0.1: must be finite and >= 0"):
        StackOfTasks(NV, {"a": 1}, solver="hqp", damping={"a": -0.1})
    # A bounded signal reaching an svd stack (built from names only) is refused at the tick.
    sot = StackOfTasks(NV, {"a": 1}, stack=("a",))
    context = sot.CreateDefaultContext()
    bounded = BoundedTaskSignal("a", np.zeros(1), np.ones((1, NV)), -np.ones(1), np.ones(1))
    sot.GetInputPort("a").FixValue(context, bounded)
    with pytest.raises(RuntimeError, match="task 'a' is an inequality task: it needs StackOfTasks"):
        _tick(sot, context)
    sot = StackOfTasks(NV, {"a": 2}, stack=("a",), solver="hqp")
    context = sot.CreateDefaultContext()
    for lower, upper, message in (
        (
            [0.0, 1.0],
            [1.0, 0.5],
            r"task 'a' at t = 0.0000 s: row 1: lower = 1.0, upper = 0.5 \(lower > upper\)",
        ),
        ([0.0, np.nan], [1.0, 1.0], r"task 'a' at t = 0.0000 s: row 1: lower = nan"),
        ([0.0], [1.0], r"task 'a': error \(2,\), Jacobian \(2, 5\), lower \(1,\), upper \(1,\)"),
    ):
        signal = BoundedTaskSignal("a", np.zeros(2), np.ones((2, NV)), np.array(lower), np.array(upper))
        sot.GetInputPort("a").FixValue(context, signal)
        with pytest.raises(RuntimeError, match=message):
            _tick(sot, context)
    bad_J = BoundedTaskSignal("a", np.zeros(2), np.full((2, NV), np.inf), np.zeros(2), np.ones(2))
    sot.GetInputPort("a").FixValue(context, bad_J)
    with pytest.raises(RuntimeError, match="task 'a': NaN or Inf in its Jacobian"):
        _tick(sot, context)


def test_a_pose_task_above_a_plane_stops_at_the_table():
    """An inequality at the top, an equality below: a point (the frame's origin, its velocity the
    last three components of q̇) is sent 10 cm down, through a table 5 cm below it; it stops on
    the table (λ = 1/period: the bound is reached in one step, not passed)."""
    nv = 6
    plane = PointAbovePlane(origin=(0.0, 0.0, -0.05), gain=1.0 / PERIOD, name="table")
    sot = StackOfTasks(nv, {"table": 1, "reach": 3}, stack=("table", "reach"), solver="hqp")
    sot_context = sot.CreateDefaultContext()
    plane_context = plane.CreateDefaultContext()
    J = np.hstack((np.zeros((3, 3)), np.eye(3)))
    position = np.zeros(3)
    for _ in range(400):
        plane.GetInputPort("position").FixValue(plane_context, RigidTransform(position))
        plane.GetInputPort("Jq").FixValue(plane_context, np.vstack((np.zeros((3, nv)), J)))
        sot.GetInputPort("table").FixValue(sot_context, plane.GetOutputPort("task").Eval(plane_context))
        error = position - [0.0, 0.0, -0.10]
        sot.GetInputPort("reach").FixValue(sot_context, TaskSignal("reach", error, J, -5.0 * error))
        qdot, _ = _tick(sot, sot_context)
        position = position + PERIOD * (J @ qdot)
        assert position[2] >= -0.05 - 1e-12
    assert position[2] == pytest.approx(-0.05, abs=1e-9)


def test_hqp_stack_warm_starts_each_tick_from_the_last_and_gives_the_cold_answer(monkeypatch):
    """A tick sequence whose rows at a limit come and go (a reach task turning around, beyond the
    limits |q̇_i| <= 1 half of the time): each tick's solve is warm-started from the rows that were
    at a bound at the last tick's q̇, and its q̇ is the cold solve's of the same levels (1e-9)."""
    warm_starts = []

    def spy(levels, **kwargs):
        warm = kwargs.get("warm_start")  # copied: its arrays may be views of the context's state
        warm_starts.append(None if warm is None else {name: np.array(side) for name, side in warm.items()})
        return solve_hqp(levels, **kwargs)

    monkeypatch.setattr(sot_module, "solve_hqp", spy)
    rng = np.random.default_rng(5)
    J = rng.normal(size=(3, NV))
    sot = StackOfTasks(
        NV, {"limits": NV, "reach": 3, "posture": NV}, stack=("limits", "reach", "posture"), solver="hqp"
    )
    context = sot.CreateDefaultContext()
    limits = BoundedTaskSignal("limits", np.zeros(NV), np.eye(NV), -np.ones(NV), np.ones(NV))
    posture = TaskSignal("posture", np.zeros(NV), np.eye(NV), np.full(NV, 0.2))
    sot.GetInputPort("limits").FixValue(context, limits)
    sot.GetInputPort("posture").FixValue(context, posture)
    previous = None
    binding_ticks, changes = 0, 0
    for k in range(40):
        edot = 4.0 * np.array([np.cos(0.3 * k), np.sin(0.3 * k), np.cos(0.7 * k)])
        sot.GetInputPort("reach").FixValue(context, TaskSignal("reach", np.zeros(3), J, edot))
        qdot, _ = _tick(sot, context)
        cold = solve_hqp([(np.eye(NV), -np.ones(NV), np.ones(NV)), (J, edot), (np.eye(NV), np.full(NV, 0.2))])
        np.testing.assert_allclose(qdot, cold.qdot, rtol=0.0, atol=1e-9)
        # The warm start: the sides of the limit rows at the last tick's q̇ (all free at the first).
        at_upper = cold.qdot >= 1.0 - 1e-9
        at_lower = cold.qdot <= -1.0 + 1e-9
        sides = at_upper.astype(float) - at_lower
        expected = np.zeros(NV) if previous is None else previous
        np.testing.assert_array_equal(warm_starts[-1]["limits"], expected)
        assert set(warm_starts[-1]) == {"limits"}  # the inequality task only
        binding_ticks += bool(sides.any())
        changes += previous is not None and not np.array_equal(sides, previous)
        previous = sides
    assert binding_ticks >= 10 and changes >= 5  # right and wrong guesses both met


ARM = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_yaw", "wrist_pitch")


def reach_past_the_arm(damping: float, duration: float = 1.5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kinematics only: the embedded humanoid on a fixed base, its right arm's six joints; a
    StackOfTasks(solver="hqp") of the arm's position and velocity limits (``taskJL``, margin
    0.02 rad), the hand's position pulled at 5/s toward a point 0.8 m from the shoulder (the
    arm reaches 0.6 m: the elbow, whose upper limit is the straight arm, ends at its bound),
    and the arm's posture (1/s); q̇ applied one tick late, as the ``Device`` does. Returns the
    arm's q̇ (ticks, 6), q (ticks, 6) and its upper bounds less the margin (6,)."""
    plant, info = make_robot_control_model("embedded", fixed_base=True)
    context = plant.CreateDefaultContext()
    joints = [plant.GetJointByName(f"r_{joint}") for joint in ARM]
    columns = [joint.velocity_start() for joint in joints]
    rows = [joint.position_start() for joint in joints]
    limits = JointPositionLimits(plant, period=PERIOD, joints=[j.name() for j in joints], velocity_scale=1.0)
    limits_context = limits.CreateDefaultContext()
    hand = plant.GetFrameByName(info.frames["right_hand"])
    q0 = half_sitting_configuration(plant, info)
    plant.SetPositions(context, q0)
    shoulder = joints[0].frame_on_child().CalcPoseInWorld(context).translation()
    target = shoulder + 0.8 * np.array([0.6, -0.4, -0.6]) / np.linalg.norm([0.6, -0.4, -0.6])
    sot = StackOfTasks(
        len(ARM),
        {"taskJL": len(ARM), "hand": 3, "posture": len(ARM)},
        period=PERIOD,
        stack=("taskJL", "hand", "posture"),
        solver="hqp",
        damping={"hand": damping},
    )
    sot_context = sot.CreateDefaultContext()
    q, committed = q0.copy(), np.zeros(plant.num_velocities())
    qdots, qs = [], []
    for _ in range(int(round(duration / PERIOD))):
        limits.GetInputPort("q").FixValue(limits_context, q)
        limits.GetInputPort("qdot").FixValue(limits_context, committed)
        bounds = task_signal(limits, limits_context)
        plant.SetPositions(context, q)
        p = plant.CalcPointsPositions(context, hand, np.zeros(3), plant.world_frame())[:, 0]
        J = plant.CalcJacobianTranslationalVelocity(
            context, JacobianWrtVariable.kV, hand, np.zeros(3), plant.world_frame(), plant.world_frame()
        )[:, columns]
        signals = {
            "taskJL": BoundedTaskSignal(
                "taskJL", bounds.error, bounds.jacobian[:, columns], bounds.lower, bounds.upper
            ),
            "hand": TaskSignal("hand", p - target, J, -5.0 * (p - target)),
            "posture": TaskSignal("posture", q[rows] - q0[rows], np.eye(len(ARM)), -(q[rows] - q0[rows])),
        }
        for name, signal in signals.items():
            sot.GetInputPort(name).FixValue(sot_context, signal)
        sot_context.SetDiscreteState(sot.EvalUniquePeriodicDiscreteUpdate(sot_context))
        q[rows] += PERIOD * committed[columns]  # the device integrates the q̇ of the tick before
        committed[columns] = sot.GetOutputPort("qdot").Eval(sot_context)
        qdots.append(committed[columns].copy())
        qs.append(q[rows].copy())
    high = np.array([j.position_upper_limits()[0] for j in joints]) - 0.02
    return np.array(qdots), np.array(qs), high


def test_a_hand_pulled_past_its_reach_does_not_chatter_against_the_elbow_limit_when_damped():
    """The elbow held at its bound by ``taskJL`` leaves the hand's reach along the forearm to the
    wrist: the hand level is singular given the level above (its smallest singular value about
    2e-3 m/rad). Its exact least squares asks for the wrist's pitch at the velocity limit, the sign
    flipping about the reach's extremum: measured, the change of q̇ from a tick to the next (RMS
    over the arm) is 2.4 rad/s RMS over the last 0.5 s, up to 4.15 (the wrist's pitch jumping
    between ±5 rad/s, its velocity limit). Damped (μ = 0.1 m/rad on the hand's level only), the
    step along that direction goes to zero with the singular value: the change stays below what
    the hand's target itself changes in a tick through the damped inverse (norm <= 1/(2μ)),
    ``λ T |ė| / (2 μ)`` = 5 · 0.005 · 1 m/s / 0.2 = 0.125 rad/s (|ė| = 5/s times the 0.2 m left
    out of reach), 0.051 RMS over the six joints (measured: 1.2e-4 at most); the elbow stays at
    its bound."""
    qdot, q, high = reach_past_the_arm(damping=0.0)
    last = slice(-int(0.5 / PERIOD), None)
    jumps = np.sqrt(np.mean(np.diff(qdot, axis=0) ** 2, axis=1))
    assert jumps[last].max() > 1.0  # the exact hierarchy chatters: the check below can fail
    qdot, q, high = reach_past_the_arm(damping=0.1)
    jumps = np.sqrt(np.mean(np.diff(qdot, axis=0) ** 2, axis=1))
    assert jumps[last].max() < 0.125 / np.sqrt(len(ARM)), jumps[last].max()
    elbow = ARM.index("elbow")
    assert q[:, elbow].max() <= high[elbow] + 1e-9  # the joint limit held throughout
    np.testing.assert_allclose(q[last, elbow], high[elbow], atol=1e-6)  # the elbow at its bound
