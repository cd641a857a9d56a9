"""Bounded logs: a run keeps the last window of its logs (and the last changes of its stack), so
that memory stops growing however long it runs; a run shorter than the window keeps every sample."""

from __future__ import annotations

import copy
import sys

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Integrator, LogVectorOutput

from drake_sot.diagrams.artifacts import _aligned
from drake_sot.diagrams.log_window import LogWindow
from drake_sot.diagrams.run import simulate
from drake_sot.systems import stack_history
from drake_sot.systems.stack_history import StackHistory

PERIOD = 0.01  # [s] of the loggers


def _clock(periods=(PERIOD,)):
    """A diagram whose state is the simulated time (an integrator of 1), logged at ``periods``."""
    builder = DiagramBuilder()
    one = builder.AddSystem(ConstantVectorSource([1.0, 2.0]))
    clock = builder.AddSystem(Integrator(2))
    builder.Connect(one.get_output_port(), clock.get_input_port())
    loggers = [LogVectorOutput(clock.get_output_port(), builder, period) for period in periods]
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    return simulator, loggers


@pytest.mark.parametrize("window", [1.0, 2.5])
def test_a_long_run_keeps_the_last_window_of_its_logs(window):
    simulator, (logger,) = _clock()
    duration = 20 * window
    sizes = []
    result = simulate(
        simulator,
        duration,
        log_window=window,
        progress=lambda t, *_: sizes.append(logger.FindLog(simulator.get_context()).num_samples()),
    )
    assert result.completed
    log = logger.FindLog(simulator.get_context())
    times, data = log.sample_times(), log.data()
    assert times[-1] == pytest.approx(duration, abs=1e-9)
    assert window - PERIOD - 1e-9 <= times[-1] - times[0] <= 2 * window  # the last one to two windows
    np.testing.assert_allclose(np.diff(times), PERIOD, atol=1e-9)  # no gap, no duplicate
    # each kept sample is the one logged at its time: the integrated clock reads t and 2t
    np.testing.assert_allclose(data[0], times, atol=1e-9)
    np.testing.assert_allclose(data[1], 2 * times, atol=1e-9)
    # memory stops growing: at most two windows of samples at any step, from the first trim on
    assert max(sizes) <= 2 * window / PERIOD + 2


def test_a_run_shorter_than_its_window_keeps_every_sample():
    simulator, (logger,) = _clock()
    simulate(simulator, 3.0, log_window=300.0)
    assert logger.FindLog(simulator.get_context()).num_samples() == round(3.0 / PERIOD) + 1


def test_no_window_keeps_every_sample():
    simulator, (logger,) = _clock()
    simulate(simulator, 30.0, log_window=None)
    assert logger.FindLog(simulator.get_context()).num_samples() == round(30.0 / PERIOD) + 1


@pytest.mark.parametrize("window", [0.0, -1.0, float("nan"), float("inf")])
def test_a_window_that_is_not_a_positive_duration_is_refused(window):
    simulator, _ = _clock()
    with pytest.raises(ValueError, match="log window"):
        LogWindow(simulator.get_system(), window)


def test_logs_of_other_periods_are_aligned_by_time_after_a_trim():
    """A logger at twice the period, trimmed at another moment, is matched to the main log's
    times sample by sample (NaN where it has none), never by position."""
    simulator, (fine, coarse) = _clock((PERIOD, 2 * PERIOD))
    simulate(simulator, 40.0, log_window=2.0)
    context = simulator.get_context()
    time = fine.FindLog(context).sample_times()
    aligned = _aligned(coarse.FindLog(context), time)
    found = ~np.isnan(aligned[:, 0])
    assert found.sum() >= 0.45 * len(time)
    np.testing.assert_allclose(aligned[found, 0], time[found], atol=1e-9)
    assert np.all(np.isnan(aligned[time < coarse.FindLog(context).sample_times()[0] - 1e-9]))


def test_the_stack_history_keeps_its_last_changes(monkeypatch):
    monkeypatch.setattr(stack_history, "MAX_CHANGES", 5)
    history = StackHistory(period=0.01)
    simulator = Simulator(history)
    context = simulator.get_mutable_context()
    port = history.GetInputPort("stack")
    for k in range(12):
        port.FixValue(context, ("a", "b") if k % 2 == 0 else ("b", "a"))
        simulator.AdvanceTo(0.01 * k + 0.005)
    recorded = history.history(context)
    assert len(recorded) == 5
    assert [t for t, _ in recorded] == pytest.approx([0.07, 0.08, 0.09, 0.10, 0.11], abs=1e-12)
    assert recorded[-1][1] == ("b", "a")


def _deepcopy_calls(simulator, until: float) -> int:
    """Calls of ``copy.deepcopy`` (Drake's copy of Python abstract state) while advancing to ``until``."""
    calls = 0

    def count(frame, event, arg) -> None:
        nonlocal calls
        if event == "call" and frame.f_code is copy.deepcopy.__code__:
            calls += 1

    sys.setprofile(count)
    try:
        simulator.AdvanceTo(until)
    finally:
        sys.setprofile(None)
    return calls


def test_a_long_stack_history_costs_a_tick_what_a_short_one_does():
    """Drake copies a system's abstract state at each of its unrestricted updates, every tick: the
    copy of the history must not walk its records, or a served run whose client changes the stack
    slows down with every change it ever made (85 ms a tick at the cap, 17 control periods)."""
    ticks = 20

    def copies_a_tick_after(changes: int) -> float:
        history = StackHistory(period=0.01)
        simulator = Simulator(history)
        context = simulator.get_mutable_context()
        port = history.GetInputPort("stack")
        for k in range(changes):
            port.FixValue(context, ("a", "b") if k % 2 == 0 else ("b", "a"))
            simulator.AdvanceTo(0.01 * k + 0.005)
        assert len(history.history(context)) == changes
        return _deepcopy_calls(simulator, 0.01 * (changes + ticks)) / ticks

    short, long = copies_a_tick_after(2), copies_a_tick_after(1000)
    assert short >= 1, "no copy of the state was seen: the count does not measure what it should"
    assert long <= short + 1, f"{long:.0f} deepcopy calls a tick with 1000 changes, {short:.0f} with 2"


def test_a_scenario_s_artefacts_cover_the_last_window_of_a_long_run(tmp_path):
    """reach for 4 s with a 1 s window: the replay its first two seconds, the logs written the run's
    last one to two seconds,
    every log aligned on the same ticks (the errors of the feet, always in the stack, are found
    at every kept tick), and the plots are drawn from them."""
    from drake_sot.diagrams import reach
    from drake_sot.diagrams.scenario import run_scenario

    output = run_scenario(reach.SCENARIO, tmp_path, duration=4.0, record=True, log_window=1.0)
    assert output.result.completed
    # the replay recorded the first two windows and stopped at the first step after them
    assert 2.0 < output.result.replay_until <= 2.1 + 1e-9
    assert output.files["html"].stat().st_size > 1000
    time = output.arrays["time"]
    assert time[-1] == pytest.approx(4.0, abs=0.006) and 1.0 - 0.006 <= time[-1] - time[0] <= 2.0
    assert output.arrays["q"].shape[0] == len(time)
    for task in ("taskLF", "taskRF", "taskCom"):
        assert not np.isnan(output.arrays[f"error/{task}"]).any(), task
    logs = np.load(output.files["npz"])
    np.testing.assert_array_equal(logs["time"], time)
    assert output.files["png"].stat().st_size > 1000
