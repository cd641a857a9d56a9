"""The pattern generator's and the step decider's abstract ports, built on the installed drake.

drake 1.58 (nanobind) refuses ``None`` in a ``Value[object]``, which drake 1.51 (pybind11)
accepted: every abstract port of the walking systems is built, fixed and evaluated here with
both an empty and a full value, whatever the version, and the version is printed.
"""

import pytest
from pydrake.common.value import Value
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.footsteps import Footstep, StepTiming
from drake_sot.hand_steps import HandStepRule
from drake_sot.systems.hand_steps import StepDecider
from drake_sot.systems.pattern_generator import PatternGenerator

LEFT, RIGHT = Footstep(0.0, 0.095, 0.0, "left"), Footstep(0.0, -0.095, 0.0, "right")
TIMING = StepTiming(0.7, 0.1, 0.05)


def _pg() -> PatternGenerator:
    return PatternGenerator(LEFT, RIGHT, com_height=0.81, timing=TIMING, horizon=1.6)


def _tick(pg: PatternGenerator, context) -> None:
    """One control tick of ``pg`` (its periodic event at t = 0), in ``context``."""
    k = pg.planner(context).k
    Simulator(pg, context).AdvanceTo(0.5 * pg.planner(context).dt)
    assert pg.planner(context).k == k + 1  # exactly one tick ran


def test_pattern_generator_builds_and_reports_its_stance_on_the_planned_feet_port():
    pg = _pg()
    context = pg.CreateDefaultContext()
    left, right, last = pg.GetOutputPort("planned_feet").Eval(context)
    assert (left, right, last) == (LEFT, RIGHT, None)  # no step planned yet: no last side


@pytest.mark.parametrize("fixed", ["unconnected", "empty"])
def test_no_footprint_on_the_input_plans_no_step(fixed):
    pg = _pg()
    context = pg.CreateDefaultContext()
    if fixed == "empty":
        pg.GetInputPort("next_footprint").FixValue(context, Value[object](()))
    _tick(pg, context)
    assert len(pg.planner(context).landings) == 0


def test_one_footprint_on_the_input_is_planned_at_the_next_tick():
    pg = _pg()
    context = pg.CreateDefaultContext()
    step = Footstep(0.2, 0.095, 0.0, "left")
    pg.GetInputPort("next_footprint").FixValue(context, Value[object]((step,)))
    _tick(pg, context)
    landings = pg.planner(context).landings
    assert len(landings) == 1
    assert landings[0][1] == step


def test_two_footprints_in_one_tick_are_refused_by_name():
    pg = _pg()
    context = pg.CreateDefaultContext()
    steps = (Footstep(0.2, 0.095, 0.0, "left"), Footstep(0.4, -0.095, 0.0, "right"))
    pg.GetInputPort("next_footprint").FixValue(context, Value[object](steps))
    with pytest.raises(ValueError, match="next_footprint: at most one footprint per tick, got 2"):
        _tick(pg, context)


@pytest.mark.parametrize(("hands_x", "steps"), [(0.38, 0), (1.35, 1)])
def test_the_step_decider_outputs_an_empty_or_a_one_footprint_tuple(hands_x, steps):
    builder = DiagramBuilder()
    pg = builder.AddSystem(_pg())
    decider = builder.AddSystem(StepDecider(HandStepRule(reference=(0.35, 0.0), threshold=0.05)))
    builder.Connect(pg.GetOutputPort("planned_feet"), decider.GetInputPort("planned_feet"))
    builder.Connect(decider.GetOutputPort("next_footprint"), pg.GetInputPort("next_footprint"))
    diagram = builder.Build()
    root = diagram.CreateDefaultContext()
    decider_context = decider.GetMyContextFromRoot(root)
    decider.GetInputPort("hands").FixValue(decider_context, [hands_x, -0.2, 0.9, hands_x, 0.2, 0.9])
    value = decider.GetOutputPort("next_footprint").Eval(decider_context)
    assert isinstance(value, tuple) and len(value) == steps
    if steps:
        # 1 m ahead of the reference: the step goes forward, by at most the step limit.
        assert value[0].x > max(LEFT.x, RIGHT.x)
