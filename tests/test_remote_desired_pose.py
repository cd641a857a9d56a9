"""A remote write of a 6D task's desired position, served in process: it is one of the command
server's declared writables, so it acts at the tick that takes it, as any declared writable does;
each ``run`` line is parsed once; a write out of bounds is refused and changes nothing."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform
from served import FakeNetwork, ticks

from drake_sot import script
from drake_sot.app.serving import Serving
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.run import simulate
from drake_sot.remote.protocol import Request
from drake_sot.validation import REACH_BOUND, WORKSPACE_RADIUS

UNITS = "m, world frame"
STEP = np.array([0.0, 0.0, 0.10])  # [m] the written target: 10 cm above the held one


@pytest.fixture(scope="module")
def built():
    b = HumanoidSoTBuilder()
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_op_point_task("taskRH", "right_hand", gain=2.5)
    b.add_posture_task("taskPosture", gain=1.0)
    gain = b.declare_writable("gain", 1, "1/s", np.ones(1), bound=100.0)
    b.log("gain", gain)
    b.log("error_rh", b.features["taskRH"].GetOutputPort("error"))
    return b.build(stack=("taskLF", "taskRF", "taskRH", "taskPosture"), command_server=True)


@pytest.fixture
def served(built):
    simulator = built.create_simulator()
    network = FakeNetwork()
    serving = Serving(simulator, built.remote, network, realtime=1e9)  # no pacing
    return built, simulator, serving, network


def _target(built, context):
    return built.features["taskRH"].desired(context).translation()


def test_a_written_target_and_a_declared_writable_act_at_the_same_tick(served):
    """Sent in one batch, the target first: both act at the tick after the one that took them (a
    tick's updates all read the state before it), which is when the solver first reads them."""
    built, simulator, serving, network = served
    seen = []  # per tick: what the next tick's updates read (after the host's hook, as served)
    rh = built.features["taskRH"]

    def hook(t, duration, wall):
        serving.after_tick(t, duration, wall)
        context = simulator.get_context()
        if len(seen) == 20:
            target = _target(built, context) + STEP
            network.put(
                Request("write", 1, signal="taskRH.position_des", value=tuple(target)),
                Request("write", 2, signal="remote.gain", value=(7.0,)),
            )
        gain = built.remote.GetOutputPort("gain").Eval(built.remote.GetMyContextFromRoot(context))
        error = rh.GetOutputPort("error").Eval(rh.GetMyContextFromRoot(context))
        seen.append((context.get_time(), _target(built, context).copy(), gain[0], error[:3].copy()))

    simulate(simulator, 30 * serving.period, [], progress=hook, chunk=serving.period)
    assert network.reply(1)["ok"] and network.reply(2)["ok"], network.sent
    times = [t for t, *_ in seen]
    moved = next(i for i, (_, p, _, _) in enumerate(seen) if not np.array_equal(p, seen[0][1]))
    gain_at = times[next(i for i, (_, _, g, _) in enumerate(seen) if g != 1.0)]
    assert times[moved] == pytest.approx(gain_at), (times[moved], gain_at)
    taken_at = built.remote.taken(simulator.get_context()).time
    assert gain_at == pytest.approx(taken_at + serving.period)  # the first tick after the one that took it
    np.testing.assert_array_equal(seen[moved][1], seen[20][1] + STEP)
    # e = p - p*: a step of p* is a step of -STEP in e's position rows (the hand moves < 1 mm a tick)
    np.testing.assert_allclose(seen[moved][3] - seen[moved - 1][3], -STEP, atol=2e-3)


def test_each_run_line_is_parsed_once(served, monkeypatch):
    built, simulator, serving, network = served
    parsed = []
    command = script._Parser.command

    def counted(parser):
        parsed.append(parser.lexer.text)
        return command(parser)

    monkeypatch.setattr(script._Parser, "command", counted)
    network.put(
        Request("run", 1, cmd="taskRH.controlGain 3"),
        Request("run", 2, cmd="sot.rm taskPosture"),
        Request("run", 3, cmd="get featureRH.error"),
    )
    ticks(simulator, serving, 3)
    assert all(network.reply(i)["ok"] for i in (1, 2, 3)), network.sent
    assert sorted(parsed) == sorted(["taskRH.controlGain 3", "sot.rm taskPosture", "get featureRH.error"])


@pytest.mark.parametrize(
    "value, named",
    [
        ((0.3, 0.1, 1e3), f"value[2] = 1000.0: beyond the bound |x| <= {REACH_BOUND:g} (m, world frame)"),
        ((0.3, math.nan, 0.9), "value[1] = nan: not finite"),
        (
            (9.0, 9.0, 0.9),
            f"|value| = {math.hypot(9.0, 9.0, 0.9):g}: beyond the radius {WORKSPACE_RADIUS:g} ({UNITS})",
        ),
        ((0.3, 0.9), "2 values, expected 3"),
    ],
    ids=["1km", "nan", "radius", "size"],
)
def test_a_bad_target_is_refused_naming_the_value_and_the_bound_and_changes_nothing(served, value, named):
    built, simulator, serving, network = served
    ticks(simulator, serving, 2)
    before = RigidTransform(built.features["taskRH"].desired(simulator.get_context()))  # a copy
    network.put(Request("write", 1, signal="taskRH.position_des", value=value))
    ticks(simulator, serving, 3)
    reply = network.reply(1)
    assert not reply["ok"] and reply["error"] == f"taskRH.position_des: {named}"
    after = built.features["taskRH"].desired(simulator.get_context())
    assert after.IsExactlyEqualTo(before)


def test_a_timed_target_acts_at_its_time_and_the_hosts_own_target_keeps_working(served):
    built, simulator, serving, network = served
    ticks(simulator, serving, 2)
    context = simulator.get_mutable_context()
    t, before = context.get_time(), RigidTransform(built.features["taskRH"].desired(context))
    at = t + 10 * serving.period
    network.put(
        Request(
            "write",
            1,
            signal="taskRH.position_des",
            value=tuple(before.translation() + STEP),
            sent_at=t,
            at=at,
        )
    )
    ticks(simulator, serving, 5)
    assert network.reply(1)["ok"]
    assert built.features["taskRH"].desired(context).IsExactlyEqualTo(before)  # not yet
    ticks(simulator, serving, 6)
    after = built.features["taskRH"].desired(context)
    np.testing.assert_array_equal(after.translation(), before.translation() + STEP)
    assert np.array_equal(after.rotation().matrix(), before.rotation().matrix())  # the orientation kept
    built.set_desired(context, "taskRH", before)  # a scenario's own timed target, by the host
    assert built.features["taskRH"].desired(context).IsExactlyEqualTo(before)
    with pytest.raises(ValueError, match="desired position"):
        built.set_desired(context, "taskRH", RigidTransform(before.rotation(), [20.0, 0.0, 0.0]))


def test_a_signal_read_is_published_after_each_tick_before_the_replies(served):
    """Once read, a signal's value at each tick is published for the socket thread (which answers
    later reads of it at once) before that tick's replies go out, with its layout when stacked."""
    built, simulator, serving, network = served
    ticks(simulator, serving, 2)
    assert network.published == {}  # nothing read yet: nothing published
    network.put(Request("read", 1, signal="dyn.com"), Request("read", 2, signal="sot.errors"))
    ticks(simulator, serving, 2)  # taken at the first tick, answered after it; published after both
    assert network.reply(1)["ok"] and network.reply(2)["layout"] == {
        task: [rows.start, rows.stop] for task, rows in built.sot.error_slices().items()
    }
    context = simulator.get_context()
    t, values, beside = network.published["dyn.com"]
    dyn = built.dyn
    assert t == context.get_time() and beside == {}
    np.testing.assert_array_equal(values, dyn.GetOutputPort("com").Eval(dyn.GetMyContextFromRoot(context)))
    assert network.published["sot.errors"][2] == {"layout": network.reply(2)["layout"]}
    network.order.clear()
    network.put(Request("list", 3))
    ticks(simulator, serving, 1)
    assert network.order[0] == "publish" and "send" in network.order  # published, then answered
