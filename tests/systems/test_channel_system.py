"""The Channel system: a step crosses it one delay later; a loop through it takes the round trip."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.channel import LinkConfig
from drake_sot.systems.channel import Channel

DT = 0.005


def _first_change(simulator, port, context, t_end, level=0.5):
    """Time of the first tick at which ``port`` exceeds ``level`` (stepping one period)."""
    t = simulator.get_context().get_time()
    while t < t_end:
        t += DT
        simulator.AdvanceTo(t)
        if port.Eval(context)[0] > level:
            return t
    return None


def test_a_step_sent_forward_arrives_one_delay_later():
    channel = Channel(1, 2, forward=LinkConfig(delay=0.14), period=DT)
    simulator = Simulator(channel)
    context = simulator.get_mutable_context()
    channel.GetInputPort("forward_in").FixValue(context, [0.0])
    channel.GetInputPort("backward_in").FixValue(context, [0.0, 0.0])
    simulator.AdvanceTo(0.999)
    channel.GetInputPort("forward_in").FixValue(context, [1.0])  # sampled from the tick at 1.0
    t = _first_change(simulator, channel.GetOutputPort("forward_out"), context, 2.0)
    assert t == pytest.approx(1.0 + 0.14, abs=DT)
    assert channel.GetOutputPort("forward_age").Eval(context)[0] == pytest.approx(0.14, abs=DT)
    np.testing.assert_array_equal(channel.GetOutputPort("backward_out").Eval(context), [0.0, 0.0])


def test_a_loop_through_both_directions_takes_the_round_trip():
    builder = DiagramBuilder()
    channel = builder.AddSystem(
        Channel(1, 1, forward=LinkConfig(delay=0.14), backward=LinkConfig(delay=0.14, seed=1), period=DT)
    )
    # The slave echoes what it receives: the outputs depend on the state only, no algebraic loop.
    builder.Connect(channel.GetOutputPort("forward_out"), channel.GetInputPort("backward_in"))
    builder.ExportInput(channel.GetInputPort("forward_in"), "u")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    diagram.GetInputPort("u").FixValue(root, [0.0])
    simulator.AdvanceTo(0.999)
    diagram.GetInputPort("u").FixValue(root, [1.0])
    context = channel.GetMyContextFromRoot(root)
    t = _first_change(simulator, channel.GetOutputPort("backward_out"), context, 2.0)
    # The 280 ms Munich-Tsukuba round trip, plus one period: the echo samples at the tick
    # after the one that delivered.
    assert t == pytest.approx(1.0 + 0.28 + DT, abs=DT)


def test_bad_sizes_are_refused_by_name():
    with pytest.raises(ValueError, match="forward_size"):
        Channel(0, 1)
    with pytest.raises(ValueError, match="backward_initial"):
        Channel(1, 2, backward_initial=[0.0])
