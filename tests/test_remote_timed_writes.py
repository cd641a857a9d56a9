"""Timed writes (the two-process tele-cooperation's lockstep): the protocol's ``t``/``at``/``horizon``,
the server applying each write at the tick of its ``at`` (newest by sending time), refusing a late
one and a wrong name or size by name, and the network thread's horizon."""

import json
import math
import socket
import threading
import time

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.remote.network import NetworkThread
from drake_sot.remote.protocol import ProtocolError, Request, parse_request
from drake_sot.systems.command_server import DONE, RemoteCommandServer
from drake_sot.systems.telecoop import MASTER_BOUNDS, MASTER_SIGNALS

PERIOD = 0.01


def _line(**message) -> bytes:
    return json.dumps({"op": "write", "signal": "remote.head", "value": [1, 2], **message}).encode()


def test_a_timed_write_parses_with_at_null_as_never():
    request = parse_request(_line(t=0.1, at=0.24, horizon=0.255))
    assert (request.sent_at, request.at, request.horizon, request.timed) == (0.1, 0.24, 0.255, True)
    lost = parse_request(_line(t=0.1, at=None, horizon=0.255))
    assert lost.at == math.inf and lost.timed
    plain = parse_request(_line())
    assert (plain.sent_at, plain.at, plain.horizon, plain.timed) == (None, None, None, False)


@pytest.mark.parametrize(
    ("fields", "named"),
    [
        ({"t": 0.1}, "both 't'"),
        ({"at": 0.2}, "both 't'"),
        ({"t": 0.1, "at": 0.05}, "at = 0.05: before t = 0.1"),
        ({"t": "x", "at": 0.2}, 't: a finite number [s], got "x"'),
        ({"horizon": float("nan")}, "horizon: a finite number [s], got NaN"),
    ],
)
def test_a_bad_timing_is_refused_naming_the_field(fields, named):
    with pytest.raises(ProtocolError) as error:
        parse_request(_line(**fields))
    assert named in str(error.value)


class Inbox:
    def __init__(self):
        self.items = []

    def put(self, *requests):
        self.items += [(0, r) for r in requests]

    def __call__(self):
        items, self.items = self.items, []
        return items


@pytest.fixture
def slave_like():
    """A command server declaring the tele-cooperation slave's writable signals, by name."""
    builder = DiagramBuilder()
    server = builder.AddSystem(RemoteCommandServer(PERIOD))
    for name, (size, units) in MASTER_SIGNALS.items():
        server.declare_writable(name, size, units, bound=MASTER_BOUNDS[name])
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    inbox = Inbox()
    server.attach(inbox)
    return simulator, server, inbox


def _write(signal, value, sent_at=None, at=None):
    return Request("write", id=signal, signal=signal, value=tuple(value), sent_at=sent_at, at=at)


def _tick(simulator):
    """Simulate the tick at the current time (AdvanceTo leaves the events at its end for the next call)."""
    simulator.AdvanceTo(simulator.get_context().get_time() + PERIOD)


def _value(simulator, server, name):
    return server.GetOutputPort(name).Eval(server.GetMyContextFromRoot(simulator.get_context())).tolist()


def _errors(simulator, server):
    return [r.error for r in server.taken(simulator.get_context()).requests]


def test_a_timed_write_acts_at_the_first_tick_at_or_after_its_at_the_newest_sent_winning(slave_like):
    simulator, server, inbox = slave_like
    inbox.put(
        _write("remote.head", (0.1, 0.2), sent_at=0.0, at=0.025),  # angles [rad], within ±π
        _write("remote.head", (0.3, 0.4), sent_at=0.005, at=0.022),  # sent later, arrives first
        _write("remote.head", (0.5, 0.6), sent_at=0.001, at=0.021),
        _write("remote.gripper", (0.7,), sent_at=0.0, at=math.inf),  # lost on the emulated link
    )
    seen = []
    for _ in range(6):  # the ticks of t = 0, 0.01, ... 0.05
        _tick(simulator)
        if not seen:
            assert _errors(simulator, server) == [None] * 4  # all accepted at tick 0
        seen.append((_value(simulator, server, "head"), _value(simulator, server, "gripper")))
    # due at 0.021-0.025: none by the tick of 0.02; at the tick of 0.03 all are, and the newest
    # by sending time (0.005) is held, whatever the order they came or arrive in
    assert [h for h, _ in seen] == [[0.0, 0.0]] * 3 + [[0.3, 0.4]] * 3
    assert all(g == [0.0] for _, g in seen)  # a lost write never acts


def test_a_timed_write_coming_after_its_tick_is_refused_naming_both_times(slave_like):
    simulator, server, inbox = slave_like
    for _ in range(4):  # ticks 0 .. 0.03
        _tick(simulator)
    inbox.put(
        _write("remote.head", (1.0, 2.0), sent_at=0.0, at=0.025),  # was due at the tick of 0.03
        _write("remote.left_hand_force", (1.0, 2.0, 3.0), sent_at=0.0, at=0.035),  # due now: on time
    )
    _tick(simulator)  # the tick of 0.04
    late, on_time = _errors(simulator, server)
    assert late == (
        "remote.head: a write due at t = 0.025000 s (sent at 0.000000 s) came at the tick of "
        "t = 0.040000 s, after it"
    )
    assert on_time is None
    assert _value(simulator, server, "head") == [0.0, 0.0]
    assert _value(simulator, server, "left_hand_force") == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("timed", [False, True])
def test_a_write_of_a_wrong_name_or_size_is_refused_naming_it(slave_like, timed):
    simulator, server, inbox = slave_like
    stamp = {"sent_at": 0.0, "at": 0.0} if timed else {}
    inbox.put(
        _write("remote.master", [0.0] * 9, **stamp),  # the former 9-vector: positions, not names
        _write("remote.head", (1.0, 2.0, 3.0), **stamp),
        _write("remote.right_hand_force", (1.0, math.nan, 0.0), **stamp),
    )
    _tick(simulator)
    taken = server.taken(simulator.get_context()).requests
    assert [r.kind for r in taken] == [DONE] * 3
    declared = ", ".join(
        sorted(f"remote.{n}" for n in ("right_hand_force", "left_hand_force", "head", "gripper"))
    )
    assert [r.error for r in taken] == [
        f"unknown writable signal 'remote.master'; known: {declared}",
        "remote.head: 3 values, expected 2",
        "remote.right_hand_force: value[1] = nan: not finite",
    ]
    assert _value(simulator, server, "head") == [0.0, 0.0]


def test_the_network_thread_keeps_the_horizon_and_says_when_its_client_left():
    network = NetworkThread("127.0.0.1", 0)
    network.start()
    try:
        assert network.wait_horizon(0.0, 0.01) == (-math.inf, False)
        with socket.create_connection(network.address) as sock:
            sock.sendall(_line(t=0.0, at=0.14, horizon=0.145) + b"\n")
            horizon, left = network.wait_horizon(0.1, 5.0)
            assert (horizon, left) == (0.145, False)
            queued = network.drain()
            assert [r.at for _, r in queued] == [0.14]  # queued before the horizon was known
            started = time.monotonic()
            assert network.wait_horizon(0.145, 0.2) == (0.145, False)  # not beyond: waited
            assert time.monotonic() - started >= 0.2
            waiter = {}
            thread = threading.Thread(target=lambda: waiter.update(r=network.wait_horizon(1.0, 5.0)))
            thread.start()
        thread.join(5.0)
        assert waiter["r"] == (0.145, True)  # woken by the disconnection, not the timeout
    finally:
        network.close()
