"""A solver whose levels are all solved may leave a task far from its goal (a target out of reach):
``StackOfTasks.task_errors`` names it and says by how much."""

import numpy as np
import pytest

from drake_sot.signals import TaskSignal
from drake_sot.systems.sot import StackOfTasks

DT = 0.005
GAIN = 20.0  # [1/s] λ·dt = 0.1
# reach: s = (q0, 0) against s* = (1, 5): no joint moves its second coordinate, a target out of
# reach; posture: s = q1 against 0.3.
J_REACH, TARGET = np.array([[1.0, 0.0], [0.0, 0.0]]), np.array([1.0, 5.0])
J_POSTURE, POSTURE = np.array([[0.0, 1.0]]), np.array([0.3])


def _signals(q: np.ndarray) -> tuple[TaskSignal, TaskSignal]:
    e_reach = np.array([q[0], 0.0]) - TARGET
    e_posture = np.array([q[1]]) - POSTURE
    return (
        TaskSignal("reach", e_reach, J_REACH, -GAIN * e_reach),
        TaskSignal("posture", e_posture, J_POSTURE, -GAIN * e_posture),
    )


def _tick(sot: StackOfTasks, context, q: np.ndarray) -> np.ndarray:
    for signal in _signals(q):
        sot.GetInputPort(signal.name).FixValue(context, signal)
    context.SetDiscreteState(sot.EvalUniquePeriodicDiscreteUpdate(context))
    context.SetTime(context.get_time() + DT)
    return q + DT * sot.GetOutputPort("qdot").Eval(context)


@pytest.mark.parametrize("solver", ["svd", "hqp"])
def test_a_target_out_of_reach_is_named_with_how_far_it_stays(solver):
    sot = StackOfTasks(
        2, {"reach": 2, "posture": 1, "idle": 1}, period=DT, stack=("reach", "posture"), solver=solver
    )
    context = sot.CreateDefaultContext()
    assert sot.task_errors(context) == ()  # before the first tick
    q = np.zeros(2)
    for _ in range(300):  # 1.5 s: (1 - λ dt)^300 = 0.9^300 ~ 2e-14 of the reachable errors is left
        q = _tick(sot, context, q)
    errors = sot.task_errors(context)
    assert [name for name, _ in errors] == ["reach", "posture"]  # largest first; "idle" is not in the stack
    # the errors of the last tick (its q is one period before the final q), from the law by hand:
    reachable = 0.9**299
    assert errors[0][1] == pytest.approx(np.hypot(reachable, TARGET[1]), abs=1e-9)  # 5 m out of reach
    assert errors[1][1] == pytest.approx(reachable * POSTURE[0], abs=1e-9)  # converged
