"""``RemoteCommandServer`` in a diagram, without a network: what it takes at a tick, the stack
commands the solver applies at that tick, the declared writable signals, and the order of the
commands of the port and of the context."""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, VectorLogSink

from drake_sot.remote.protocol import Request
from drake_sot.signals import TaskSignal
from drake_sot.systems.command_server import DONE, HOST, STACK, RemoteCommandServer
from drake_sot.systems.sot import StackOfTasks

PERIOD = 0.01
NV = 2
# Two tasks on a 2-DoF q̇: each fixes one joint velocity, ė* = (1,) and (2,); q̇ = (1, 2) when
# both act, and the unused joint is 0 when one acts (least norm): q̇ says which are in the stack.
TASKS = {"a": (np.array([[1.0, 0.0]]), 1.0), "b": (np.array([[0.0, 1.0]]), 2.0)}


class Inbox:
    """A stand-in for the network thread's queue: what is put is taken at the next tick."""

    def __init__(self):
        self.items = []

    def put(self, *requests, connection=0):
        self.items += [(connection, r) for r in requests]

    def __call__(self):
        items, self.items = self.items, []
        return items


def _run(cmd, i=0):
    return Request("run", id=i, cmd=cmd)


@pytest.fixture
def served():
    builder = DiagramBuilder()
    sot = builder.AddSystem(StackOfTasks(NV, {"a": 1, "b": 1}, period=PERIOD, commands_input=True))
    for name, (J, edot) in TASKS.items():
        signal = TaskSignal(name, np.zeros(1), J, np.array([edot]))
        source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(signal)))
        builder.Connect(source.get_output_port(), sot.GetInputPort(name))
    server = builder.AddSystem(RemoteCommandServer(PERIOD))
    gain = server.declare_writable("gain", 2, "1/s", np.array([1.0, 1.0]), bound=100.0)
    builder.Connect(server.GetOutputPort("commands"), sot.GetInputPort("commands"))
    log = builder.AddSystem(VectorLogSink(2))
    builder.Connect(gain, log.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.Initialize()
    inbox = Inbox()
    server.attach(inbox)
    return simulator, sot, server, inbox


def _qdot(simulator, sot):
    return sot.GetOutputPort("qdot").Eval(sot.GetMyContextFromRoot(simulator.get_context()))


def _tick(simulator, n=1):
    """Advance to just after ``n`` more ticks (AdvanceTo(t) leaves the events at t for the next call)."""
    simulator.AdvanceTo(simulator.get_context().get_time() + n * PERIOD)


def test_stack_commands_act_at_the_tick_that_takes_them_in_arrival_order(served):
    simulator, sot, server, inbox = served
    _tick(simulator)
    assert np.allclose(_qdot(simulator, sot), 0.0)  # an empty stack
    inbox.put(_run("sot.push a", 1), _run("sot.push b", 2), _run("sot.rm a", 3), _run("sot.push a", 4))
    _tick(simulator)
    context = simulator.get_context()
    taken = server.taken(context)
    assert [r.kind for r in taken.requests] == [STACK] * 4 and [r.index for r in taken.requests] == [
        0,
        1,
        2,
        3,
    ]
    assert taken.time == pytest.approx(PERIOD)  # taken at the tick, not before
    assert sot.list(context) == ("b", "a")  # push a, push b, rm a, push a: in that order
    assert np.allclose(_qdot(simulator, sot), [1.0, 2.0])  # solved at that tick with both tasks
    results = sot.GetOutputPort("command_results").Eval(sot.GetMyContextFromRoot(context))
    assert results.results == ((True, ""),) * 4


def test_a_refused_stack_command_is_reported_and_the_others_act(served):
    simulator, sot, server, inbox = served
    inbox.put(
        _run("sot.push a"), _run("sot.push a"), _run("sot.push nope"), _run("sot.pop"), _run("sot.push b")
    )
    _tick(simulator)
    context = simulator.get_context()
    results = sot.GetOutputPort("command_results").Eval(sot.GetMyContextFromRoot(context)).results
    assert [ok for ok, _ in results] == [True, False, False, True, True]
    assert "'a'" in results[1][1] and "'nope'" in results[2][1]
    assert results[3] == (True, "a")  # pop gives the task it removed
    assert sot.list(context) == ("b",)
    assert np.allclose(_qdot(simulator, sot), [0.0, 2.0])


def test_a_context_command_after_a_batch_acts_after_it(served):
    simulator, sot, server, inbox = served
    inbox.put(_run("sot.push a"))
    _tick(simulator)  # taken and acting; committed into the held stack only at the next tick
    sot.push(simulator.get_mutable_context(), "b")  # the host's command, later than the batch
    assert sot.list(simulator.get_context()) == ("a", "b")
    _tick(simulator, 3)  # the commit at the next tick does not apply the batch again
    assert sot.list(simulator.get_context()) == ("a", "b")
    assert np.allclose(_qdot(simulator, sot), [1.0, 2.0])


def test_a_declared_signal_is_written_at_the_tick_and_refused_when_bad(served):
    simulator, sot, server, inbox = served
    gain = server.writables["remote.gain"]
    assert gain.size == 2 and gain.units == "1/s"
    inbox.put(
        Request("write", 1, signal="remote.gain", value=(2.0, 3.0)),
        Request("write", 2, signal="remote.gain", value=(1.0,)),
        Request("write", 3, signal="remote.gain", value=(1.0, float("nan"))),
        Request("write", 4, signal="remote.other", value=(1.0,)),
        Request("write", 5, signal="taskRH.position_des", value=(1.0, 2.0, 3.0)),
        Request("read", 6, signal="sot.qdot"),
    )
    _tick(simulator)
    taken = server.taken(simulator.get_context()).requests
    assert [r.kind for r in taken] == [DONE] * 5 + [HOST]  # every write is the server's; the read waits
    assert taken[0].error is None
    assert "1 values, expected 2" in taken[1].error
    assert "value[1]" in taken[2].error and "not finite" in taken[2].error
    assert taken[3].error == "unknown writable signal 'remote.other'; known: remote.gain"
    assert taken[4].error.startswith("unknown writable signal 'taskRH.position_des'")  # no pose declared here
    gain = server.GetOutputPort("gain").Eval(server.GetMyContextFromRoot(simulator.get_context()))
    assert np.array_equal(gain, [2.0, 3.0])  # the bad writes after it changed nothing
    log = next(s for s in simulator.get_system().GetSystems() if isinstance(s, VectorLogSink))
    data = log.FindLog(simulator.get_context())
    written = data.sample_times()[np.all(data.data() == [[2.0], [3.0]], axis=0)]
    assert written.min() == pytest.approx(PERIOD)  # seen downstream from the tick that took it


def test_a_wrong_stack_command_is_refused_by_the_server_itself(served):
    simulator, sot, server, inbox = served
    inbox.put(_run("sot.push"), _run("sot.clear a"), _run("sot.list"), _run("featureCom.selec 110"))
    _tick(simulator)
    taken = server.taken(simulator.get_context()).requests
    assert [r.kind for r in taken] == [DONE, DONE, HOST, HOST]
    assert "takes 1 task name" in taken[0].error and "takes 0 task name" in taken[1].error


def test_without_an_inbox_the_server_takes_nothing(served):
    simulator, sot, server, inbox = served
    server.attach(None)
    inbox.put(_run("sot.push a"))
    _tick(simulator, 2)
    assert server.taken(simulator.get_context()).serial == 0 and sot.list(simulator.get_context()) == ()
    with pytest.raises(ValueError, match="declared already"):
        server.declare_writable("gain", 1, "1/s", bound=100.0)


def test_with_a_driven_stack_the_commands_act_on_it_until_its_source_changes(served):
    simulator, sot, server, inbox = served
    context = simulator.get_mutable_context()
    driven = sot.GetInputPort("stack")
    driven.FixValue(sot.GetMyMutableContextFromRoot(context), ("a",))  # a sequencer's decision
    with pytest.raises(ValueError, match="comes from input port 'stack'"):
        sot.push(context, "b")  # the context's commands stay refused
    inbox.put(_run("sot.push b"))
    _tick(simulator)
    assert sot.list(context) == ("a", "b") and np.allclose(_qdot(simulator, sot), [1.0, 2.0])
    _tick(simulator, 3)  # committed: it lasts while the source says the same
    assert sot.list(context) == ("a", "b")
    driven.FixValue(sot.GetMyMutableContextFromRoot(context), ("b",))  # the source's newer decision
    _tick(simulator)
    assert sot.list(context) == ("b",) and np.allclose(_qdot(simulator, sot), [0.0, 2.0])
    driven.FixValue(sot.GetMyMutableContextFromRoot(context), ("a",))  # back: the commands are forgotten
    _tick(simulator)
    assert sot.list(context) == ("a",)


def test_a_task_named_like_the_commands_port_is_refused_by_name():
    with pytest.raises(ValueError, match="'commands' cannot be a task name"):
        StackOfTasks(NV, {"commands": 1}, commands_input=True)
    assert StackOfTasks(NV, {"commands": 1}).task_names == ("commands",)  # no such port without it


def test_what_comes_after_a_change_the_host_applies_waits_for_the_tick_it_acts_at(served):
    """The host applies a parameter change after the tick that took it, so it acts at the next
    tick; the stack command sent after it is taken at that tick, not before it (arrival order)."""
    simulator, sot, server, inbox = served
    inbox.put(_run("sot.push a", 1), _run("taskA.controlGain 2", 2), _run("sot.push b", 3))
    inbox.put(Request("read", 4, signal="sot.qdot"), connection=1)
    _tick(simulator)
    context = simulator.get_context()
    assert [r.request.id for r in server.taken(context).requests] == [1, 2]
    assert [r.id for _, r in server.held(context)] == [3, 4]
    assert sot.list(context) == ("a",)
    inbox.put(_run("sot.list", 5))
    _tick(simulator)
    assert [r.request.id for r in server.taken(context).requests] == [3, 4, 5]  # held ones first
    assert server.held(context) == () and sot.list(context) == ("a", "b")
    inbox.put(_run("get sot.qdot", 6), _run("help", 7), _run("sot.push", 8), _run("sot.rm b", 9))
    _tick(simulator)  # reads, help and refused lines change nothing: nothing waits
    assert [r.request.id for r in server.taken(context).requests] == [6, 7, 8, 9]
    assert sot.list(context) == ("a",)


def test_a_stack_command_with_a_transition_time_blends_qdot_over_it(served):
    """'sot.push b 0.5': q̇ = (1 - h) q̇*(a) + h q̇*(a, b), h eq. 12's raised cosine from the tick that
    took it (written here); q̇*(a) = (1, 0), q̇*(a, b) = (1, 2) (each task fixes one joint)."""
    simulator, sot, server, inbox = served
    inbox.put(_run("sot.push a"))
    _tick(simulator)
    inbox.put(_run("sot.push b 0.5"))
    _tick(simulator)
    start = server.taken(simulator.get_context()).time
    assert server.taken(simulator.get_context()).requests[0].kind == STACK
    assert sot.list(simulator.get_context()) == ("a", "b")  # the stack reached, at once
    previous = None
    first = round(start / PERIOD)
    for k in range(first + 1, first + int(0.6 / PERIOD)):
        simulator.AdvanceTo((k + 0.5) * PERIOD)  # past the tick at k·PERIOD, before the next
        h = 0.5 - 0.5 * np.cos(np.pi * min(max((k * PERIOD - start) / 0.5, 0.0), 1.0))
        qdot = _qdot(simulator, sot)
        np.testing.assert_allclose(qdot, [1.0, 2.0 * h], atol=1e-12)
        if previous is not None:  # a tick moves h by at most π·period / (2 T) of the 2 rad/s gap
            assert abs(qdot[1] - previous[1]) <= np.pi * PERIOD / (2 * 0.5) * 2.0 + 1e-12
        previous = qdot
    np.testing.assert_allclose(_qdot(simulator, sot), [1.0, 2.0], atol=1e-12)
