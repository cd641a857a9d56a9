"""``simulate`` raises on a failed run by default: a script does not carry on as if it had finished."""

from __future__ import annotations

import pytest

from drake_sot.diagrams import reach
from drake_sot.diagrams.run import RunFailed, TimedCommand, simulate
from drake_sot.errors import DrakeSotError, UnknownNameError


def _push_unknown(setup):
    sot = setup.built.sot
    return TimedCommand(0.2, "push taskNowhere", lambda context: sot.push(context, "taskNowhere"))


def test_a_command_that_pushes_an_unknown_task_raises_once_the_run_stopped():
    setup = reach.build()
    simulator = setup.built.create_simulator()
    with pytest.raises(
        RunFailed, match=r"the run failed at t = 0\.200 s: Unknown\w*Error: unknown task .taskNowhere."
    ) as caught:
        simulate(simulator, 1.0, [_push_unknown(setup)])
    error = caught.value
    assert isinstance(error, DrakeSotError) and isinstance(error, RuntimeError)
    assert isinstance(error.__cause__, UnknownNameError)  # raised from the command's own error
    assert error.result.failure is error.__cause__ and not error.result.completed
    assert error.result.end_time == pytest.approx(0.2)
    assert simulator.get_context().get_time() == pytest.approx(0.2)  # stopped there: no tick after


def test_check_false_returns_the_failed_result_instead():
    setup = reach.build()
    simulator = setup.built.create_simulator()
    result = simulate(simulator, 1.0, [_push_unknown(setup)], check=False)
    assert isinstance(result.failure, UnknownNameError) and not result.completed
    assert result.end_time == pytest.approx(0.2)


def test_a_completed_run_returns_its_result():
    setup = reach.build()
    result = simulate(setup.built.create_simulator(), 0.3)
    assert result.completed and result.end_time == pytest.approx(0.3)
