"""The torque-level controller tells the truth, in physics.

- Contacts and bounds that cannot hold the robot are refused when the diagram is built,
  naming the bound (0.01 N·m effort limits on a CoM + posture stack; 1 kN per sole corner).
- Bounds that hold the robot at q0 but cannot follow a demanding CoM target: the status
  names the short task within 50 ms, the run's logs carry it, and no commanded torque
  leaves its bound on any tick.
- A posture bend that the minimum normal forces cannot support: the fallback is saturated
  at the bounds and says which joints it cut.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable

from drake_sot.diagrams.artifacts import log_arrays
from drake_sot.diagrams.run import TimedCommand, simulate
from drake_sot.diagrams.torque_humanoid import TorqueHumanoidBuilder
from drake_sot.models import sole_corner_points
from drake_sot.quasistatic import SolveStatus
from drake_sot.systems.generalized_controller import (
    SHORTFALL_THRESHOLD,
)
from drake_sot.systems.priority_schedule import PrioritySchedule
from drake_sot.transitions import AlphaSchedule

pytestmark = pytest.mark.slow


def _com_and_posture(**kwargs):
    """CoM (xy) above a whole-body posture, on the floating-base robot; returns (builder, built)."""
    b = TorqueHumanoidBuilder()
    b.add_com_task("taskCom")
    b.add_posture_task("taskPosture")
    names = ("taskCom", "taskPosture")
    schedule = b.builder.AddSystem(PrioritySchedule(AlphaSchedule(names, [[0.0, 0.0], [1.0, 0.0]])))
    built = b.build(
        motion=[("taskCom", 100.0, 20.0), ("taskPosture", 16.0, 8.0)],
        priorities=schedule.GetOutputPort("priorities"),
        **kwargs,
    )
    return b, built


def _static_torques(b: TorqueHumanoidBuilder) -> dict[str, float]:
    """Joint torques [N·m] that hold the robot still at q0 with the weight shared by the 8 sole
    corners by least squares on the base rows (computed here, not by the controller)."""
    plant = b.control_plant
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, b.q0)
    g = -plant.CalcGravityGeneralizedForces(context)
    world = plant.world_frame()
    J = np.vstack(
        [
            plant.CalcJacobianTranslationalVelocity(
                context,
                JacobianWrtVariable.kV,
                plant.GetFrameByName(b.control_info.frames[foot]),
                sole_corner_points().T,
                world,
                world,
            )
            for foot in ("left_foot", "right_foot")
        ]
    )
    f = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
    tau = g - J.T @ f
    return {j: float(tau[plant.GetJointByName(j).velocity_start()]) for j in b.control_info.actuated_joints}


def _limits(built, joints) -> np.ndarray:
    return np.array([built.control_plant.GetJointActuatorByName(j).effort_limit() for j in joints])


# --------------------------------------------------------------------------- refused at build time
def test_effort_limits_of_a_hundredth_of_a_newton_metre_are_refused_at_build_time():
    b = TorqueHumanoidBuilder()
    weight = b.control_plant.CalcTotalMass(b.control_plant.CreateDefaultContext()) * 9.81
    with pytest.raises(ValueError) as refused:
        _com_and_posture(effort_limits=dict.fromkeys(b.control_info.actuated_joints, 0.01))
    message = str(refused.value)
    assert message.startswith(f"effort limits cannot hold the robot's weight ({weight:.0f} N) at q_posture")
    # The knees carry the upper body (the statics computed here say so too): named with their bound.
    static = _static_torques(b)
    assert abs(static["r_knee"]) > 10.0
    assert "r_knee (needs ~" in message and "limit 0.01 N·m)" in message


def test_a_kilonewton_minimum_normal_force_is_refused_at_build_time():
    b = TorqueHumanoidBuilder()
    weight = b.control_plant.CalcTotalMass(b.control_plant.CreateDefaultContext()) * 9.81
    with pytest.raises(
        ValueError, match=r"min_normal_force per point \(l_sole: 1000 N, r_sole: 1000 N\)"
    ) as e:
        _com_and_posture(min_normal_force=1000.0)
    assert f"exceeds the robot's weight ({weight:.0f} N)" in str(e.value)


def test_a_schedule_over_other_tasks_is_refused_at_build_time():
    b = TorqueHumanoidBuilder()
    b.add_com_task("taskCom")
    b.add_posture_task("taskPosture")
    schedule = b.builder.AddSystem(PrioritySchedule(AlphaSchedule(("taskCom", "taskHead"), np.zeros((2, 2)))))
    with pytest.raises(
        ValueError,
        match=r"names unknown task\(s\) \['taskHead'\] and has no priority for \['taskPosture'\]; "
        r"known tasks: taskCom, taskPosture",
    ):
        b.build(
            motion=[("taskCom", 100.0, 20.0), ("taskPosture", 16.0, 8.0)],
            priorities=schedule.GetOutputPort("priorities"),
        )


def test_unknown_names_and_bad_limits_are_refused():
    b = TorqueHumanoidBuilder()
    b.add_posture_task("taskPosture")
    schedule = b.builder.AddSystem(PrioritySchedule(AlphaSchedule(("taskPosture",), np.zeros((1, 1)))))
    port = schedule.GetOutputPort("priorities")
    with pytest.raises(ValueError, match=r"unknown task\(s\) \['taskCom'\]; known tasks: taskPosture"):
        b.build(motion=[("taskCom", 1.0, 1.0)], priorities=port)
    with pytest.raises(ValueError, match=r"force_inputs for \['taskPosture'\], which are not force tasks"):
        b.build(
            motion=[("taskPosture", 1.0, 1.0)], priorities=port, force_inputs={"taskPosture": (port, port)}
        )
    with pytest.raises(ValueError, match=r"effort_limits: unknown joint 'knee'"):
        b.build(motion=[("taskPosture", 1.0, 1.0)], priorities=port, effort_limits={"knee": 1.0})
    with pytest.raises(ValueError, match=r"effort_limits\['r_knee'\] = nan N·m: must be finite and > 0"):
        b.build(motion=[("taskPosture", 1.0, 1.0)], priorities=port, effort_limits={"r_knee": np.nan})
    with pytest.raises(ValueError, match=r"ContactPoints\('l_sole'\).min_normal_force = -1.0 N"):
        b.build(motion=[("taskPosture", 1.0, 1.0)], priorities=port, min_normal_force=-1.0)
    with pytest.raises(ValueError, match=r"MotionTask\('taskPosture'\).kp = inf 1/s²"):
        b.build(motion=[("taskPosture", np.inf, 1.0)], priorities=port)


# --------------------------------------------------------------------------- short, in physics
SHIFT_AT = 0.3  # [s] when the CoM target jumps 8 cm forward


@pytest.fixture(scope="module")
def short_run():
    """Effort limits 10 % above the static torques at q0 (+0.5 N·m): the robot stands, then
    its CoM target jumps 8 cm forward, which those bounds cannot follow."""
    b = TorqueHumanoidBuilder()
    limits = {j: 1.1 * abs(tau) + 0.5 for j, tau in _static_torques(b).items()}
    b, built = _com_and_posture(effort_limits=limits)
    com0 = b.initial_com()
    shift = TimedCommand(
        SHIFT_AT, "CoM +8 cm", lambda c: built.features["taskCom"].set_desired(c, com0 + [0.08, 0.0, 0.0])
    )
    simulator = built.create_simulator()
    result = simulate(simulator, 0.8, [shift])
    assert result.completed, result.failure
    return built, limits, simulator.get_context(), result


def test_the_status_names_the_short_task_within_50_ms(short_run):
    built, _, context, _ = short_run
    log = built.loggers["status"].FindLog(context)
    t, status = log.sample_times(), log.data()[0]
    assert np.all(status[t < SHIFT_AT] == SolveStatus.OPTIMAL.code)  # standing: the bounds suffice
    column = built.controller.task_names.index("taskCom")
    shortfall = built.loggers["shortfall"].FindLog(context).data()[column]
    named = (t >= SHIFT_AT) & (status == SolveStatus.SHORT.code) & (shortfall > SHORTFALL_THRESHOLD)
    assert named.any()
    assert t[named][0] - SHIFT_AT <= 0.05
    # The same, by name, in the stack history the run's plot marks.
    first = next(time for time, stack in built.stack_history.history(context) if "short:taskCom" in stack)
    assert SHIFT_AT <= first <= SHIFT_AT + 0.05 + 1e-9


def test_no_commanded_torque_exceeds_its_bound_on_any_tick(short_run):
    built, limits, context, _ = short_run
    joints = built.controller.actuated_joints
    tau = built.loggers["tau"].FindLog(context).data().T
    bound = np.array([limits[j] for j in joints])
    assert tau.shape[0] >= 0.8 / 0.005
    assert np.all(np.abs(tau) <= bound)
    assert np.any(np.isclose(np.abs(tau), bound))  # the bounds do bind: the test is not vacuous


def test_the_run_logs_carry_the_status_and_the_short_task_by_name(short_run):
    built, _, context, result = short_run
    arrays = log_arrays(built, context, result)
    assert arrays["status"].shape == (arrays["time"].size, 1)
    assert set(np.unique(arrays["status"])) <= {s.code for s in SolveStatus}
    assert arrays["shortfall"].shape == (arrays["time"].size, len(built.controller.task_names))
    # The names of the short tasks, with the time they fell short (within 50 ms of the shift).
    short = [
        t for t, stack in zip(arrays["stack_time"], arrays["stack"], strict=True) if "short:taskCom" in stack
    ]
    assert short and SHIFT_AT <= short[0] <= SHIFT_AT + 0.05 + 1e-9
    np.testing.assert_array_equal(arrays["error/taskCom"].shape, (arrays["time"].size, 2))


# --------------------------------------------------------------------------- fallback, in physics
def test_the_fallback_in_physics_is_saturated_and_reported():
    """65 N per sole corner (520 of the 567 N weight) keeps the centre of pressure near the
    middle of the feet; bending the chest 1.2 rad forward moves the CoM beyond what those
    forces allow: the QP becomes infeasible and the fallback, held to 60 N·m at the legs and
    chest, says what it cut. No torque exceeds its bound on any tick."""
    b = TorqueHumanoidBuilder()
    b.add_posture_task("taskPosture")
    schedule = b.builder.AddSystem(PrioritySchedule(AlphaSchedule(("taskPosture",), np.zeros((1, 1)))))
    strong = {
        j: 60.0
        for j in b.control_info.actuated_joints
        if any(k in j for k in ("hip", "knee", "ankle", "chest"))
    }
    built = b.build(
        motion=[("taskPosture", 16.0, 8.0)],
        priorities=schedule.GetOutputPort("priorities"),
        min_normal_force=65.0,
        effort_limits=strong,
    )
    bent = b.q0.copy()
    bent[b.control_plant.GetJointByName("chest_pitch").position_start()] += 1.2
    bend = TimedCommand(0.2, "bend", lambda c: built.features["taskPosture"].set_desired(c, bent))
    simulator = built.create_simulator()
    assert simulate(simulator, 1.0, [bend]).completed
    context = simulator.get_context()
    joints = built.controller.actuated_joints
    status = built.loggers["status"].FindLog(context).data()[0]
    tau = built.loggers["tau"].FindLog(context).data().T
    saturation = built.loggers["saturation"].FindLog(context).data().T
    fallback = status == SolveStatus.INFEASIBLE.code
    assert fallback.any()
    bound = np.array([strong.get(j, lim) for j, lim in zip(joints, _limits(built, joints), strict=True)])
    assert np.all(np.abs(tau) <= bound)
    chest = joints.index("chest_pitch")
    assert np.abs(saturation[fallback, chest]).max() > 1.0  # the chest was cut, and said so
    np.testing.assert_array_equal(saturation[~fallback], 0.0)
    np.testing.assert_allclose(np.abs(tau[fallback & (saturation[:, chest] != 0), chest]), 60.0)
    stacks = [stack for _, stack in built.stack_history.history(context)]
    assert any("fallback:infeasible" in s and "saturated:chest_pitch" in s for s in stacks)
