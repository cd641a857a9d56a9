"""RemoteLink against Channel: fed the same signals (the peer's messages stamped with the sender's
clock, one per period), both deliver the same values at the same ticks, jitter and loss included."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Sine

from drake_sot.channel import LinkConfig
from drake_sot.systems.channel import Channel
from drake_sot.systems.remote_link import RemoteLink

DT = 0.005
FORWARD = LinkConfig(delay=0.04, jitter=0.012, loss=0.2, seed=3)
BACKWARD = LinkConfig(delay=0.03, jitter=0.01, loss=0.1, seed=4)


def _sine(frequencies, phases) -> Sine:
    n = len(frequencies)
    return Sine(np.ones(n), np.array(frequencies), np.array(phases), is_time_based=True)


FORWARD_SINE = ((7.0, 3.0), (0.0, 0.5))  # frequencies [rad/s], phases [rad]
BACKWARD_SINE = ((5.0,), (math.pi / 2,))


def backward_signal(t: float) -> np.ndarray:
    (w,), (phi,) = BACKWARD_SINE
    return np.array([math.sin(w * t + phi)])


class FakePeer:
    """The other side: at each tick of the receiver, one message of its own tick (the k-th call
    of ``take`` gives the signal at ``k DT`` stamped ``k DT``, as a peer on the same clock
    sends); records what it is posted."""

    def __init__(self, first_tick: int = 0) -> None:
        self.posted: list[np.ndarray] = []
        self.tick = first_tick

    def take(self):
        t = self.tick * DT
        self.tick += 1
        return [(t, tuple(backward_signal(t)))]

    def post(self, value) -> None:
        self.posted.append(np.array(value))


def _run(system, *, feed_backward: bool, ticks: int = 80):
    """Each output after each tick, the inputs sines of time."""
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


def test_remote_link_delivers_what_a_channel_delivers_both_ways():
    channel = Channel(2, 1, forward=FORWARD, backward=BACKWARD, period=DT, backward_initial=[9.0])
    peer = FakePeer()
    link = RemoteLink(
        peer,
        2,
        1,
        forward=FORWARD,
        backward=BACKWARD,
        period=DT,
        forward_initial=np.zeros(2),
        backward_initial=[9.0],
    )
    expected = _run(channel, feed_backward=True)
    got = _run(link, feed_backward=False)
    for (f_ch, b_ch), (f_rl, b_rl) in zip(expected, got, strict=True):
        np.testing.assert_array_equal(f_rl, f_ch)
        np.testing.assert_array_equal(b_rl, b_ch)
    # what was posted to the peer: each newer value the channel delivered, once, in order
    delivered = [
        f for k, (f, _) in enumerate(expected) if k == 0 or not np.array_equal(f, expected[k - 1][0])
    ]
    delivered = [f for f in delivered if not np.array_equal(f, np.zeros(2))]
    assert len(delivered) > 10
    assert len(peer.posted) == len(delivered)
    for posted, value in zip(peer.posted, delivered, strict=True):
        np.testing.assert_array_equal(posted, value)


def test_unattached_it_holds_its_initial_values_and_attach_connects_it():
    link = RemoteLink(
        None,
        2,
        1,
        forward=LinkConfig(delay=0.01),
        backward=LinkConfig(delay=0.01),
        period=DT,
        forward_initial=[0.0, 0.0],
        backward_initial=[5.0],
    )
    builder = DiagramBuilder()
    builder.AddSystem(link)
    forward = builder.AddSystem(_sine(*FORWARD_SINE))
    builder.Connect(forward.get_output_port(0), link.GetInputPort("forward_in"))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.1)
    context = link.GetMyContextFromRoot(simulator.get_context())
    assert link.GetOutputPort("backward_out").Eval(context)[0] == 5.0
    peer = FakePeer(first_tick=20)
    link.attach(peer)
    simulator.AdvanceTo(0.2)
    assert len(peer.posted) >= 15  # one a tick, from the first delivery on
    received = link.GetOutputPort("backward_out").Eval(context)[0]
    assert received in [backward_signal(k * DT)[0] for k in range(20, 41)]


def test_a_bad_size_is_refused_with_its_name():
    with pytest.raises(ValueError, match="backward_initial"):
        RemoteLink(
            None,
            1,
            2,
            forward=LinkConfig(),
            backward=LinkConfig(),
            period=DT,
            forward_initial=[0.0],
            backward_initial=[0.0],
        )
