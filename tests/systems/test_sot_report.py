"""StackOfTasks' ``report`` output: the per-task slacks and active rows of each tick, checked
against by-hand cascades (scipy's bounded least squares, a KKT solve) written here."""

import numpy as np
import pytest
import scipy.optimize

from drake_sot.signals import BoundedTaskSignal, TaskSignal
from drake_sot.systems.sot import StackOfTasks

NV = 3


def _tick(sot, context):
    context.SetDiscreteState(sot.EvalUniquePeriodicDiscreteUpdate(context))
    return sot.GetOutputPort("qdot").Eval(context), sot.GetOutputPort("report").Eval(context)


def _limits_reach_posture():
    """Velocity limits |q̇_i| <= 1 on top, a task asking q̇0 = 3 (beyond the limit) and q̇1 = 0.5,
    then a task asking q̇0 + q̇1 + q̇2 = 4 (infeasible within the limits)."""
    limits = BoundedTaskSignal("limits", np.zeros(NV), np.eye(NV), -np.ones(NV), np.ones(NV))
    reach = TaskSignal("reach", np.zeros(2), np.eye(NV)[:2], np.array([3.0, 0.5]))
    posture = TaskSignal("posture", np.zeros(1), np.ones((1, NV)), np.array([4.0]))
    return limits, reach, posture


def test_report_names_the_binding_limit_and_the_slack_of_each_level():
    limits, reach, posture = _limits_reach_posture()
    sot = StackOfTasks(
        NV, {"limits": NV, "reach": 2, "posture": 1, "idle": 1}, solver="hqp", report=True,
        stack=("limits", "reach", "posture"),
    )  # fmt: skip
    context = sot.CreateDefaultContext()
    assert sot.GetOutputPort("report").Eval(context) == ()  # before the first tick
    for signal in (limits, reach, posture):
        sot.GetInputPort(signal.name).FixValue(context, signal)
    qdot, report = _tick(sot, context)
    assert [level.name for level in report] == ["limits", "reach", "posture"]  # not "idle": not in the stack
    by_name = {level.name: level for level in report}
    # The cascade by hand, each level a bounded least squares (scipy) with the levels above held:
    # reach under the limits moves q̇0, q̇1 only (q̇2 is not in its rows) ...
    reach_opt = scipy.optimize.lsq_linear(np.eye(2), reach.edot_des, bounds=(-1.0, 1.0))
    reach_slack = reach_opt.x - reach.edot_des
    # ... and posture, with q̇0 and q̇1 held at reach's optimum, has q̇2 alone, within the limits.
    rest = posture.edot_des[0] - reach_opt.x.sum()
    posture_opt = scipy.optimize.lsq_linear(np.ones((1, 1)), [rest], bounds=(-1.0, 1.0))
    posture_slack = posture_opt.x[0] - rest
    np.testing.assert_allclose(qdot, [*reach_opt.x, *posture_opt.x], atol=1e-9)
    np.testing.assert_allclose(by_name["reach"].slack, reach_slack, atol=1e-9)  # (-2, 0)
    np.testing.assert_allclose(by_name["posture"].slack, [posture_slack], atol=1e-9)  # -1.5
    assert reach_slack[0] == pytest.approx(-2.0) and posture_slack == pytest.approx(-1.5)
    # The limits hold (zero slack); q̇0 and q̇2 sit at their upper bound, q̇1 inside.
    np.testing.assert_array_equal(by_name["limits"].slack, 0.0)
    assert by_name["limits"].active_upper == (0, 2) and by_name["limits"].active_lower == ()
    assert by_name["reach"].active_upper == by_name["reach"].active_lower == ()  # equalities: none


def test_report_of_an_infeasible_lower_equality_task_is_its_constrained_residual():
    """solver='svd': the lower task's slack is ``J₂ q̇ - ė₂`` at the least squares of ``J₂`` under
    ``J₁ q̇ = ė₁``, here from the KKT system solved by numpy (unique in ``J₂ q̇``)."""
    rng = np.random.default_rng(7)
    J1, e1 = rng.normal(size=(2, NV)), rng.normal(size=2)
    J2, e2 = rng.normal(size=(2, NV)), 5.0 * rng.normal(size=2)
    sot = StackOfTasks(NV, {"high": 2, "low": 2}, stack=("high", "low"), report=True)
    context = sot.CreateDefaultContext()
    sot.GetInputPort("high").FixValue(context, TaskSignal("high", np.zeros(2), J1, e1))
    sot.GetInputPort("low").FixValue(context, TaskSignal("low", np.zeros(2), J2, e2))
    _, report = _tick(sot, context)
    kkt = np.block([[J2.T @ J2, J1.T], [J1, np.zeros((2, 2))]])
    x = np.linalg.lstsq(kkt, np.concatenate((J2.T @ e2, e1)), rcond=None)[0][:NV]
    assert [level.name for level in report] == ["high", "low"]
    np.testing.assert_allclose(report[0].slack, 0.0, atol=1e-12)
    np.testing.assert_allclose(report[1].slack, J2 @ x - e2, atol=1e-9)
    assert np.linalg.norm(report[1].slack) > 0.1  # the lower task is infeasible: a real residual


def test_report_holds_the_stack_of_the_tick_and_the_reached_stack_during_a_change():
    limits, reach, posture = _limits_reach_posture()
    sot = StackOfTasks(NV, {"limits": NV, "reach": 2, "posture": 1}, solver="hqp", report=True)
    context = sot.CreateDefaultContext()
    for signal in (limits, reach, posture):
        sot.GetInputPort(signal.name).FixValue(context, signal)
    sot.push(context, "limits")
    sot.push(context, "reach")
    sot.push(context, "posture", transition=0.5)  # at t = 0: weight 0, q̇ is the stack without it
    qdot, report = _tick(sot, context)
    np.testing.assert_allclose(qdot, [1.0, 0.5, 0.0], atol=1e-12)
    assert [level.name for level in report] == ["limits", "reach", "posture"]
    np.testing.assert_allclose(report[2].slack, posture.jacobian @ qdot - posture.edot_des, atol=1e-12)
    sot.rm(context, "reach")  # a command after the tick: the report is still the tick's
    assert [level.name for level in sot.GetOutputPort("report").Eval(context)] == [
        "limits",
        "reach",
        "posture",
    ]


def test_no_report_port_unless_asked():
    sot = StackOfTasks(NV, {"a": 1})
    assert not sot.HasOutputPort("report")
    assert sot.num_discrete_state_groups() == 2  # q̇ and the errors: the tick writes nothing more
    assert StackOfTasks(NV, {"a": 1}, report=True).HasOutputPort("report")
