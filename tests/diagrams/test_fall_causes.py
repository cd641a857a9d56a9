"""A fall names what the controller was failing to do: a stance foot's target lifted 1.5 m (out of
the robot's reach while it stands on that foot) throws the standing robot down, and the run's
result says which command came last and which task errors were large just before the fall."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform

from drake_sot.diagrams import reach
from drake_sot.diagrams.run import RunFailed, RunResult, TimedCommand, fall_causes, simulate
from drake_sot.diagrams.tasks import SELF_COLLISION_TASK
from drake_sot.systems.fall_monitor import Fall

LIFT = 1.5  # [m] up, from the left foot's target (a stance foot)


@pytest.fixture(scope="module")
def lifted():
    setup = reach.build()
    foot = setup.built.features["taskLF"]

    def lift(context):
        X = foot.desired(context)
        foot.set_desired(context, RigidTransform(X.rotation(), X.translation() + [0.0, 0.0, LIFT]))

    simulator = setup.built.create_simulator()
    result = simulate(simulator, 3.0, [TimedCommand(0.5, "lift taskLF 1.5 m", lift)], check=False)
    return setup, simulator, result


def test_lifting_a_stance_foot_s_target_throws_the_robot_down(lifted):
    _, _, result = lifted
    assert result.fell is not None, "the robot stood on a foot whose target was lifted 1.5 m"
    assert 0.5 < result.fell.time < 3.0


def test_the_fall_keeps_the_task_errors_of_the_step_before_it(lifted):
    setup, simulator, result = lifted
    when, errors = result.errors_before_fall
    assert result.fell.time - 0.1 - 1e-9 <= when <= result.fell.time  # one step of the run before (0.1 s)
    names = [task for task, _ in errors]
    # the stack before the left hand's push at 3 s, the self-collision task on by default
    assert sorted(names) == sorted((*reach.STACK, SELF_COLLISION_TASK))
    assert [norm for _, norm in errors] == sorted((norm for _, norm in errors), reverse=True)
    # against the errors logged by the diagram's own logger at the last tick at or before `when`
    context = simulator.get_context()
    log = setup.built.loggers["errors"].FindLog(context)
    times, data = log.sample_times(), log.data().T
    tick = int(np.searchsorted(times, when + 1e-9)) - 1
    slices = setup.built.error_slices()
    for task, norm in errors:
        assert norm == pytest.approx(float(np.linalg.norm(data[tick, slices[task]])), rel=1e-6, abs=1e-9), (
            task
        )
    # the lifted foot is far from its target: its position error alone (target 1.5 m up, the foot
    # on or near the ground) is more than the 0.2 m the foot could have climbed by then
    assert dict(errors)["taskLF"] > 0.2


def test_the_causes_name_the_last_command_and_the_largest_errors(lifted):
    _, _, result = lifted
    lines = fall_causes(result)
    assert lines[0] == "the last command before the fall: 'lift taskLF 1.5 m' at t = 0.500 s"
    largest = result.errors_before_fall[1][:3]
    for task, norm in largest:
        assert f"{task} {norm:.3g}" in lines[1]


def test_no_causes_without_a_fall():
    assert fall_causes(RunResult(end_time=1.0, events=[(0.5, "x")])) == []
    fell = RunResult(fell=Fall(time=0.2, pelvis_height=0.3, tilt=1.0), events=[(0.5, "after")])
    assert fall_causes(fell) == []  # a command after the fall is not its cause, no errors kept


def test_a_checked_run_that_fell_raises_naming_the_fall_and_its_causes(lifted):
    """What ``simulate`` (``check=True``, the default) raises for this run: the fall, when the run
    stopped, and the causes, in one message."""
    _, _, result = lifted
    message = str(RunFailed(result))
    assert message.startswith(f"the robot {result.fell} (the run stopped at t = {result.end_time:.3f} s)")
    for line in fall_causes(result):
        assert line in message
