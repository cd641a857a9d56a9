"""The pattern generator as a planner fed by the step decider (Evrard et al. 2009, III-C, III-D)."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.footsteps import Footstep, StepTiming
from drake_sot.hand_steps import HandStepRule
from drake_sot.systems.hand_steps import StepDecider
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.walk_planner import FOOTPRINTS_AHEAD

LEFT, RIGHT = Footstep(0.0, 0.095, 0.0, "left"), Footstep(0.0, -0.095, 0.0, "right")
DT = 0.005
RULE = HandStepRule(reference=(0.35, 0.0), threshold=0.05)


def _build():
    builder = DiagramBuilder()
    pg = builder.AddSystem(
        PatternGenerator(LEFT, RIGHT, com_height=0.81, timing=StepTiming(0.7, 0.1, 0.05), horizon=1.6)
    )
    decider = builder.AddSystem(StepDecider(RULE))
    builder.Connect(pg.GetOutputPort("planned_feet"), decider.GetInputPort("planned_feet"))
    builder.Connect(decider.GetOutputPort("next_footprint"), pg.GetInputPort("next_footprint"))
    builder.ExportInput(decider.GetInputPort("hands"), "hands")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    return diagram, pg, decider, simulator


def test_four_footprints_ahead_one_new_per_executed_step_and_a_stop_below_the_threshold():
    diagram, pg, decider, simulator = _build()
    root = simulator.get_mutable_context()
    hands = np.array([1.35, -0.2, 0.9, 1.35, 0.2, 0.9])  # 1 m ahead of the reference
    diagram.GetInputPort("hands").FixValue(root, hands)
    pg_context, decider_context = pg.GetMyContextFromRoot(root), decider.GetMyContextFromRoot(root)
    planned, ahead, errors = [], [], []
    for t in np.arange(1, int(16.0 / DT) + 1) * DT:
        simulator.AdvanceTo(t)
        planner = pg.planner(pg_context)
        planned.append(len(planner.landings))
        ahead.append(len(planner.landings_ahead()))
        errors.append(np.linalg.norm(decider.GetOutputPort("error").Eval(decider_context)))
    planned, ahead, errors = np.array(planned), np.array(ahead), np.array(errors)
    added = np.diff(planned)
    assert set(np.unique(added)) <= {0, 1}  # at most one footprint per tick
    assert ahead.max() == FOOTPRINTS_AHEAD
    # After the first four, a footprint is added only at a tick where a step was executed.
    first_full = int(np.argmax(ahead == FOOTPRINTS_AHEAD))
    for i in np.flatnonzero(added)[1:] + 1:
        if i > first_full:
            assert ahead[i - 1] < FOOTPRINTS_AHEAD
    # Each new footprint reduces the planned stance's error; none is added below the threshold.
    before = errors[np.flatnonzero(added)]
    assert np.all(np.diff(before) < 0)
    assert np.all(before >= RULE.threshold)
    # The walk ends with the error below the threshold and the robot standing.
    assert errors[-1] < RULE.threshold
    assert pg.GetOutputPort("in_process").Eval(pg_context)[0] == 0
    feet = pg.footprints(pg_context)
    mid = 0.5 * (feet["left"].xy + feet["right"].xy)
    assert mid[0] == pytest.approx(1.0, abs=RULE.threshold)


def test_an_error_below_the_threshold_takes_no_step():
    diagram, pg, decider, simulator = _build()
    root = simulator.get_mutable_context()
    diagram.GetInputPort("hands").FixValue(root, [0.38, -0.2, 0.9, 0.38, 0.2, 0.9])  # 3 cm off
    simulator.AdvanceTo(3.0)
    assert len(pg.planner(pg.GetMyContextFromRoot(root)).landings) == 0
