"""A task gain's range at the control period: the SoT law ``ė* = -λ e`` integrated once per period
dt is explicit Euler's ``e_{k+1} = (1 - λ dt) e_k`` (Mansard, Stasse, Evrard, Kheddar 2009, eq. 3,
at the device's period), which overshoots for ``λ dt > 1`` and diverges for ``λ dt >= 2``: a gain
beyond ``λ dt = 1`` is refused wherever the period is known, naming the gain, the period and the
product."""

import numpy as np
import pytest

from drake_sot.gains import AdaptiveGain, validate_gain
from drake_sot.signals import FeatureSignal
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task

DT = 0.005  # [s] the control period (HRP-2's)
BOUND = 1.0 / DT  # [1/s] λ·dt <= 1


def _euler(gain: float, steps: int, e0: float = 1.0) -> np.ndarray:
    """The paper's law in discrete time, written here: e_{k+1} = (1 - λ dt) e_k."""
    e = [e0]
    for _ in range(steps):
        e.append((1.0 - gain * DT) * e[-1])
    return np.array(e)


def _closed_loop(task: Task, sot: StackOfTasks, steps: int, e0: float = 1.0) -> np.ndarray:
    """The error of the 1-D task ``task`` (s = q, J = 1, s* = 0) ticked by ``sot``, q integrated by
    hand over the period as the device does: q_{k+1} = q_k + dt q̇_k."""
    task_context, sot_context = task.CreateDefaultContext(), sot.CreateDefaultContext()
    q, errors = e0, [e0]
    for _ in range(steps):
        task.GetInputPort("f").FixValue(task_context, FeatureSignal(np.array([q]), np.eye(1), np.zeros(1)))
        sot.GetInputPort("t").FixValue(sot_context, task.GetOutputPort("task").Eval(task_context))
        sot_context.SetDiscreteState(sot.EvalUniquePeriodicDiscreteUpdate(sot_context))
        q += DT * float(sot.GetOutputPort("qdot").Eval(sot_context)[0])
        errors.append(q)
    return np.array(errors)


class _OneFeature:
    """What ``Task.add`` reads of a feature: its name, dimension and units (a 1-D feature "f")."""

    dimension = 1
    units = ("",)

    def get_name(self) -> str:
        return "f"


def _task(gain):
    task = Task("t", gain=gain)
    task.add(_OneFeature())
    return task


def test_a_gain_just_below_the_bound_converges_as_the_discrete_law_says():
    gain = 0.95 * BOUND
    reference = _euler(gain, 20)
    assert np.all(np.diff(np.sign(reference[:-1])) == 0)  # no overshoot: the sign never changes
    assert abs(reference[-1]) < 1e-20  # (0.05)^20
    task = _task(gain)
    sot = StackOfTasks(1, [task], period=DT, stack=("t",))  # accepted
    assert task.period == DT
    np.testing.assert_allclose(_closed_loop(task, sot, 20), reference, rtol=1e-9, atol=1e-300)


def test_past_the_bound_the_discrete_law_overshoots_and_past_twice_it_diverges():
    """Why the bound: the independent recursion, not the code under test."""
    over = _euler(1.5 * BOUND, 10)
    assert np.all(over[1:] * over[:-1] < 0) and abs(over[-1]) < 1e-2  # overshoots, converges
    assert abs(_euler(2.1 * BOUND, 50)[-1]) > 1.0  # |1 - 2.1| > 1: diverges


@pytest.mark.parametrize("gain", [1.01 * BOUND, 1e4, 1e150, 1e300])
def test_the_solver_refuses_a_task_whose_gain_is_past_the_bound_naming_gain_period_and_product(gain):
    with pytest.raises(ValueError) as raised:
        StackOfTasks(1, [_task(gain)], period=DT)
    message = str(raised.value)
    assert "task 't'" in message
    assert f"λ = {gain:g} 1/s" in message and f"period {DT:g} s" in message
    assert f"λ·period = {gain * DT:g} must be <= 1" in message


def test_an_adaptive_gain_is_bounded_by_its_largest_value_at_zero_error():
    below = AdaptiveGain.from_limits(at_zero=0.9 * BOUND, at_infinity=1.0, slope_at_zero=10.0)
    StackOfTasks(1, [_task(below)], period=DT)
    above = AdaptiveGain.from_limits(at_zero=1.1 * BOUND, at_infinity=1.0, slope_at_zero=1000.0)
    assert above(0.0) * DT > 1.0 and above(1.0) * DT < 1.0  # only near the goal is it too large
    with pytest.raises(ValueError, match=r"adaptive gain's λ\(0\) = 220 1/s .* λ·period = 1.1 must be <= 1"):
        StackOfTasks(1, [_task(above)], period=DT)
    with pytest.raises(ValueError, match="λ·period = inf"):  # a + c overflows: refused, not let through
        validate_gain(AdaptiveGain(a=1.7e308, b=0.0, c=1.7e308), name="t", period=DT)


def test_a_task_that_knows_its_period_refuses_a_run_time_gain_past_the_bound():
    task = _task(2.0)
    StackOfTasks(1, [task], period=DT)
    context = task.CreateDefaultContext()
    task.set_gain(context, BOUND)  # λ·dt = 1: the goal in one period, accepted
    with pytest.raises(ValueError, match=r"task 't': gain λ = 10000 1/s at the control period 0.005 s"):
        task.set_gain(context, 1e4)
    assert task.gain(context) == BOUND  # the refused gain changed nothing
    with pytest.raises(
        ValueError, match="task 't': control period 0.01 s, but the task is integrated at 0.005"
    ):
        StackOfTasks(1, [task], period=0.01)  # one task, one period


def test_a_gain_input_past_the_bound_is_refused_at_evaluation_naming_the_task():
    task = _task(2.0)
    StackOfTasks(1, [task], period=DT)
    context = task.CreateDefaultContext()
    task.GetInputPort("f").FixValue(context, FeatureSignal(np.ones(1), np.eye(1), np.zeros(1)))
    task.GetInputPort("gain").FixValue(context, [0.5 * BOUND])
    np.testing.assert_allclose(task.GetOutputPort("task").Eval(context).edot_des, [-0.5 * BOUND])
    task.GetInputPort("gain").FixValue(context, [3.0 * BOUND])
    with pytest.raises(
        RuntimeError,
        match=r"task 't': gain λ = 600 1/s .* λ·period = 3 must be <= 1 .*\(on input port 'gain'\)",
    ):
        task.GetOutputPort("task").Eval(context)


def test_a_task_given_its_period_refuses_the_gain_at_construction():
    with pytest.raises(ValueError, match=r"λ·period = 50 must be <= 1"):
        Task("t", gain=1e4, period=DT)
    assert Task("t", gain=1e4).period is None  # no period, no product to check (until a solver)
