"""The events of a served run stay bounded and readable however long a client drives it: the writes
of a stream are one event, the run keeps its last ``MAX_EVENTS``, every request is counted; the
task-error plot marks too many instants without labels. The grouping is checked against a second
way of computing it (the writes of each signal split where the gap exceeds ``STREAM_GAP``)."""

import io
import warnings

import hypothesis.strategies as st
import numpy as np
import pytest
from hypothesis import given, settings
from served import FakeNetwork, feet_and_posture, ticks

from drake_sot.app.served_events import MAX_EVENTS, STREAM_GAP, ServedEvents
from drake_sot.app.serving import Serving, serve_run
from drake_sot.diagrams.scenario import ScenarioSetup
from drake_sot.plots import MAX_MARK_LABELS, plot_task_errors
from drake_sot.remote.protocol import Request

PERIOD = 0.005  # [s] a control period: a client that writes at every tick


def _streams(ops):
    """The reference: ``(first time, signal, count, last time)`` of each stream, in the order the
    streams began, from the writes alone (a new stream where a signal's gap exceeds STREAM_GAP)."""
    last: dict[str, list] = {}
    streams = []
    for t, kind, name in ops:
        if kind != "write":
            continue
        s = last.get(name)
        if s is not None and t - s[3] <= STREAM_GAP:
            s[2] += 1
            s[3] = t
        else:
            last[name] = s = [t, name, 1, t]
            streams.append(s)
    return streams


def _label(first, name, count, end):
    return f"write {name}" if count == 1 else f"write {name} ×{count} to t = {end:.3f} s"


def test_an_hour_of_writes_at_every_tick_is_one_event_and_every_write_is_counted():
    events = ServedEvents()
    n = 3600 * 200
    for k in range(n):
        events.write(k * PERIOD, "taskRH.position_des")
    assert events.events == [(0.0, f"write taskRH.position_des ×{n} to t = {(n - 1) * PERIOD:.3f} s")]
    assert events.applied == n


def test_a_pause_longer_than_the_gap_starts_a_new_stream_and_two_signals_stream_apart():
    events = ServedEvents()
    for t in (0.0, 0.005, 0.01):
        events.write(t, "a")
        events.write(t, "b")
    events.command(0.01, "sot.push taskLH")
    events.write(0.01 + STREAM_GAP, "a")  # at the gap: the same stream
    events.write(0.01 + 2 * STREAM_GAP + 0.001, "a")  # beyond it: a new one
    assert events.events == [
        (0.0, f"write a ×4 to t = {0.01 + STREAM_GAP:.3f} s"),
        (0.0, "write b ×3 to t = 0.010 s"),
        (0.01, "sot.push taskLH"),
        (0.01 + 2 * STREAM_GAP + 0.001, "write a"),
    ]
    assert events.applied == 9


def test_the_run_keeps_its_last_events_and_a_stream_dropped_from_them_starts_again():
    events = ServedEvents()
    events.write(0.0, "a")
    for k in range(3 * MAX_EVENTS):
        events.command(k * PERIOD, f"cmd {k}")
    kept = events.events
    assert len(kept) == MAX_EVENTS
    assert kept[0][1] == f"cmd {2 * MAX_EVENTS}" and kept[-1][1] == f"cmd {3 * MAX_EVENTS - 1}"
    t = 3 * MAX_EVENTS * PERIOD
    events.write(t, "a")  # within the gap of nothing kept: its old stream was dropped
    assert events.events[-1] == (t, "write a")
    assert events.applied == 3 * MAX_EVENTS + 2


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(0.0, 0.3, allow_nan=False),  # the step to the next request [s]
            st.sampled_from(["write", "command"]),
            st.sampled_from(["a", "b", "c"]),
        ),
        max_size=60,
    )
)
def test_streams_match_a_second_grouping_of_the_writes(steps):
    events = ServedEvents()
    ops, t = [], 0.0
    for dt, kind, name in steps:
        t = round(t + dt, 6)
        ops.append((t, kind, name))
        if kind == "write":
            events.write(t, name)
        else:
            events.command(t, f"{name}.cmd")
    streams = iter(_streams(ops))  # the streams begin in the order of their first writes
    expected = []
    started: dict[str, list] = {}
    for t, kind, name in ops:
        if kind == "command":
            expected.append((t, f"{name}.cmd"))
        elif started.get(name) is None or not t - started[name][3] <= STREAM_GAP:
            started[name] = s = next(streams)
            expected.append(s)
        else:
            started[name][3] = t  # the reference's stream already ends there
    got = events.events
    assert got == [(e[0], _label(*e)) if isinstance(e, list) else e for e in expected]
    assert events.applied == len(ops)
    assert [t for t, _ in got] == sorted(t for t, _ in got)


def test_a_plot_with_too_many_marks_draws_them_unlabelled_and_counts_them():
    time = np.linspace(0.0, 10.0, 101)
    errors = {"taskRH": np.full((101, 3), 0.1)}
    few = plot_task_errors(time, errors, [(1.0, "a"), (2.0, "b"), (2.0, "c")])
    assert sorted(t.get_text().strip() for t in few.axes[0].texts) == ["a", "b; c"]
    many = [(0.2 * k, f"cmd {k}") for k in range(MAX_MARK_LABELS + 1)]  # 2 % of the span apart
    fig = plot_task_errors(time, errors, many)
    assert len(fig.axes[0].texts) == 0 and len(fig.axes[0].lines) == 1 + len(many)
    assert f"{len(many)} commands marked, unlabelled" in fig.axes[0].get_title()


def test_marks_a_few_ticks_apart_share_one_label_and_a_long_label_stays_inside_the_axes():
    """A served tele-cooperation slave for 300 s: the master's four streams of writes begin a tick
    apart, each labelled ``write remote.… ×60000 to t = 299.860 s``. Drawn one by one, the labels
    covered each other, ran out under the axes and broke the figure's layout (a warning, the axes
    squeezed)."""
    time = np.linspace(0.0, 300.0, 3001)
    errors = {"taskRH": np.full((3001, 3), 0.1)}
    signals = ("right_hand_force", "left_hand_force", "head", "gripper")
    streams = [
        (0.005 * (k + 1), f"write remote.{name} ×60000 to t = 299.860 s") for k, name in enumerate(signals)
    ]
    fig = plot_task_errors(time, errors, [*streams, (150.0, "rm taskRH")])
    texts = sorted(t.get_text().strip() for t in fig.axes[0].texts)
    assert texts == ["rm taskRH", "; ".join(label for _, label in streams)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # matplotlib warns when the layout cannot hold the labels
        fig.savefig(io.BytesIO(), format="png")
    position = fig.axes[0].get_position()
    assert position.height > 0.6 and position.y0 > 0.05, position


@pytest.fixture(scope="module")
def built():
    return feet_and_posture()


def test_a_served_client_writing_at_every_tick_makes_one_event_and_a_command_its_own(built):
    simulator = built.create_simulator()
    network = FakeNetwork()
    serving = Serving(simulator, built.remote, network, realtime=1e9)  # no pacing
    ticks(simulator, serving, 1)
    held = tuple(built.features["taskLF"].desired(simulator.get_context()).translation())
    n = 150
    for k in range(n):
        network.put(Request("write", k, signal="taskLF.position_des", value=held))
        if k == 50:
            network.put(Request("run", 10_000, cmd="taskLF.controlGain 4"))
        ticks(simulator, serving, 1)
    assert all(m["ok"] for m in network.sent), [m for m in network.sent if not m["ok"]]
    events = serving.events.events
    assert [label for _, label in events] == [
        f"write taskLF.position_des ×{n} to t = {events[0][0] + (n - 1) * serving.period:.3f} s",
        "taskLF.controlGain 4",
    ]
    assert serving.events.applied == n + 1


def test_serve_run_counts_the_requests_and_returns_the_kept_events(built):
    """``serve_run``'s result: ``events`` the kept ones, ``requests_applied`` all of them (writes
    queued before the run: all taken, and applied, at its first tick)."""
    network = FakeNetwork()
    network.start = network.close = lambda: None
    network.address = ("127.0.0.1", 0)
    simulator = built.create_simulator()
    held = tuple(built.features["taskLF"].desired(simulator.get_context()).translation())
    for k in range(40):
        network.put(Request("write", k, signal="taskLF.position_des", value=held))
    setup = ScenarioSetup(built=built, commands=[], duration=0.1)
    result = serve_run(setup, simulator, network, 0.1, realtime=1e9)
    assert result.requests_applied == 40
    assert result.events == [(0.0, "write taskLF.position_des ×40 to t = 0.000 s")]
