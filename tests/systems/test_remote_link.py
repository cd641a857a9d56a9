"""RemoteLink against Channel: fed the same signals (the peer's packets stamped with the sender's
clock, one per period, by name), this side and the other side's receiving end (a
``Link`` carrying the arrival times posted) deliver the same values at the same ticks as a
``Channel``, jitter and loss included; and what it refuses, by name."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Sine

from drake_sot.channel import Link, LinkConfig
from drake_sot.systems.channel import Channel
from drake_sot.systems.remote_link import RemoteLink

DT = 0.005
FORWARD = LinkConfig(delay=0.04, jitter=0.012, loss=0.2, seed=3)
BACKWARD = LinkConfig(delay=0.03, jitter=0.01, loss=0.1, seed=4)
FORWARD_SIGNALS = (("remote.a", 1), ("remote.b", 1))
BACKWARD_SIGNALS = (("hands.x", 1),)


def _sine(frequencies, phases) -> Sine:
    n = len(frequencies)
    return Sine(np.ones(n), np.array(frequencies), np.array(phases), is_time_based=True)


FORWARD_SINE = ((7.0, 3.0), (0.0, 0.5))  # frequencies [rad/s], phases [rad]
BACKWARD_SINE = ((5.0,), (math.pi / 2,))


def backward_signal(t: float) -> np.ndarray:
    (w,), (phi,) = BACKWARD_SINE
    return np.array([math.sin(w * t + phi)])


class FakePeer:
    """The other side, on the same clock: the k-th call of ``take`` gives its packet of the tick
    ``k DT`` (its stream starts after its tick 0), by name; records what it is posted."""

    def __init__(self, first_tick: int = 1, name: str = "hands.x", gap_at: int | None = None) -> None:
        self.posted: list[tuple[float, float, float, dict]] = []
        self.tick = first_tick
        self.name = name
        self.gap_at = gap_at

    def take(self):
        if self.tick == self.gap_at:
            self.tick += 1
        t = self.tick * DT
        self.tick += 1
        return [(t, {self.name: tuple(backward_signal(t))})]

    def post(self, t, at, horizon, values) -> None:
        self.posted.append((t, at, horizon, {k: np.array(v) for k, v in values.items()}))

    def wait_beyond(self, t, timeout) -> bool:
        return False


def _run(system, *, feed_backward: bool, ticks: int = 80):
    """Each output after each tick (the values at ticks 0 .. ticks-1), the inputs sines of time."""
    builder = DiagramBuilder()
    builder.AddSystem(system)
    forward = builder.AddSystem(_sine(*FORWARD_SINE))
    builder.Connect(forward.get_output_port(0), system.GetInputPort("forward_in"))
    if feed_backward:
        backward = builder.AddSystem(_sine(*BACKWARD_SINE))
        builder.Connect(backward.get_output_port(0), system.GetInputPort("backward_in"))
    simulator = Simulator(builder.Build())
    outputs = []
    for k in range(1, ticks + 1):
        simulator.AdvanceTo(k * DT)
        context = system.GetMyContextFromRoot(simulator.get_context())
        outputs.append(
            (
                system.GetOutputPort("forward_out").Eval(context).copy(),
                system.GetOutputPort("backward_out").Eval(context).copy(),
            )
        )
    return outputs


def _link(peer, **kw) -> RemoteLink:
    args = dict(
        forward=FORWARD,
        backward=BACKWARD,
        period=DT,
        forward_initial=np.zeros(2),
        backward_initial=backward_signal(0.0),  # the other side's value at t = 0
    )
    return RemoteLink(peer, FORWARD_SIGNALS, BACKWARD_SIGNALS, **{**args, **kw})


def test_both_ends_deliver_what_a_channel_delivers_at_the_same_ticks():
    channel = Channel(
        2, 1, forward=FORWARD, backward=BACKWARD, period=DT, backward_initial=backward_signal(0.0)
    )
    peer = FakePeer()
    expected = _run(channel, feed_backward=True)
    got = _run(_link(peer), feed_backward=False)
    for (f_ch, b_ch), (f_rl, b_rl) in zip(expected, got, strict=True):
        np.testing.assert_array_equal(f_rl, f_ch)
        np.testing.assert_array_equal(b_rl, b_ch)
    # the other side: one packet a tick, by name, stamped with its tick; carried with the posted
    # arrival times by a receiving end, it holds what the channel delivers, tick by tick
    assert [t for t, *_ in peer.posted] == pytest.approx([k * DT for k in range(len(expected))])
    receiver = Link.start(None, np.zeros(2))
    lost = 0
    for k, ((t, at, horizon, values), (f_ch, _)) in enumerate(zip(peer.posted, expected, strict=True)):
        assert set(values) == {"remote.a", "remote.b"}
        np.testing.assert_allclose(
            np.concatenate([values["remote.a"], values["remote.b"]]), _sine_at(t), atol=1e-12
        )
        lost += math.isinf(at)
        assert math.isinf(at) or FORWARD.min_delay - 1e-12 <= at - t <= FORWARD.delay + FORWARD.jitter + 1e-12
        # the horizon: the next packet (sent one period later) cannot be due before it
        assert horizon == pytest.approx(t + DT + FORWARD.min_delay)
        receiver = receiver.carry(t, at, np.concatenate(list(values.values()))).receive(k * DT)
        np.testing.assert_array_equal(receiver.value, f_ch)
    assert 0 < lost < len(peer.posted)  # the loss was exercised
    assert len({tuple(f) for f, _ in expected}) > 20  # and the values moved


def _sine_at(t: float) -> np.ndarray:
    (w1, w2), (p1, p2) = FORWARD_SINE
    return np.array([math.sin(w1 * t + p1), math.sin(w2 * t + p2)])


def test_unattached_it_holds_its_initial_values_and_attach_connects_it():
    link = _link(None, backward_initial=[5.0])
    builder = DiagramBuilder()
    builder.AddSystem(link)
    forward = builder.AddSystem(_sine(*FORWARD_SINE))
    builder.Connect(forward.get_output_port(0), link.GetInputPort("forward_in"))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.02)
    context = link.GetMyContextFromRoot(simulator.get_context())
    assert link.GetOutputPort("backward_out").Eval(context)[0] == 5.0


@pytest.mark.parametrize(
    ("config", "named"),
    [
        (LinkConfig(delay=0.003), "forward: delay - jitter = 0.003 - 0 = 0.003 s"),
        (LinkConfig(delay=0.0), "forward: delay - jitter = 0 - 0 = 0 s"),
        (LinkConfig(delay=0.02, jitter=0.018), "forward: delay - jitter = 0.02 - 0.018 = 0.002 s"),
    ],
)
def test_a_delay_under_one_period_is_refused_with_its_value(config, named):
    with pytest.raises(ValueError, match="at least one period") as error:
        _link(None, forward=config)
    assert named in str(error.value)


def test_a_packet_of_another_name_or_a_gap_in_the_stamps_fails_naming_it():
    for peer, message in (
        (FakePeer(name="hands.y"), "expected 'hands.x' \\(1\\), got \\{'hands.y': 1\\}"),
        (FakePeer(gap_at=3), "packet of t = 0.015000 s is missing"),
    ):
        with pytest.raises(Exception, match=message):
            _run(_link(peer), feed_backward=False, ticks=10)


def test_await_peer_waits_only_for_packets_that_can_arrive_and_times_out_naming_them():
    link = _link(FakePeer())
    # before BACKWARD's shortest delay plus a period, the packet of t = 0 is all it can need
    link.await_peer(BACKWARD.min_delay, timeout=0.0)
    with pytest.raises(TimeoutError, match=r"sent after t = 0\.005000 s .* tick of t = 0\.030000 s"):
        link.await_peer(0.03, timeout=0.01)


def test_bad_signals_are_refused_by_name():
    with pytest.raises(ValueError, match="backward_initial"):
        _link(None, backward_initial=[0.0, 1.0])
    with pytest.raises(ValueError, match="each name once"):
        RemoteLink(
            None,
            (("a", 1), ("a", 1)),
            BACKWARD_SIGNALS,
            forward=FORWARD,
            backward=BACKWARD,
            period=DT,
            forward_initial=[0.0, 0.0],
            backward_initial=[0.0],
        )
