"""The package's systems derive from ``SotLeafSystem``: on drake 1.51 the simulator's query of
their witness functions after every step of a plant (an unrestricted update) looks up a Python
attribute at most once, where a plain Python ``LeafSystem`` is looked up at every step (its
pybind11; drake 1.58's would call the marker, so it gets none); a subclass that has witness
functions still has them, on either."""

import numpy as np
import pytest
from pydrake.common.value import Value
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import (
    DiagramBuilder,
    EventStatus,
    LeafSystem,
    PublishEvent,
    WitnessFunctionDirection,
)
from pydrake.systems.primitives import ConstantValueSource, ZeroOrderHold

from drake_sot.systems.features import Feature
from drake_sot.systems.leaf import MARKER_TAKEN, SotLeafSystem
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task

STEP = 1e-3  # [s] the hold's unrestricted update, as the plant's step
STEPS = 200


def _lookups(base: type) -> int:
    """How many times the simulator looked up ``DoGetWitnessFunctions`` on a system of a subclass
    of ``base``, over STEPS unrestricted updates of a hold beside it."""

    class Counted(base):
        lookups = 0

        def __getattribute__(self, name):
            if name == "DoGetWitnessFunctions":
                type(self).lookups += 1
            return super().__getattribute__(name)

    _beside_a_hold(Counted()).AdvanceTo(STEPS * STEP)
    return Counted.lookups


def _beside_a_hold(system) -> Simulator:
    """A simulator of ``system`` beside an abstract zero-order hold, whose step every STEP is an
    unrestricted update, as the discrete plant's."""
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantValueSource(Value[object](0)))
    hold = builder.AddSystem(ZeroOrderHold(STEP, Value[object](0)))
    builder.Connect(source.get_output_port(), hold.get_input_port())
    builder.AddSystem(system)
    return Simulator(builder.Build())


def test_where_the_marker_is_set_the_query_looks_up_python_once_not_at_every_step():
    """Drake 1.51's pybind11: a plain Python system is looked up at every step (the control),
    one on ``SotLeafSystem`` at most once."""
    if not MARKER_TAKEN:
        pytest.skip("this pydrake's pybind11 calls the marker as an override: it is not set here")
    assert _lookups(LeafSystem) >= STEPS
    assert _lookups(SotLeafSystem) <= 1


def test_the_marker_is_set_where_pybind11_takes_it_and_never_called():
    """Set: the per-step query runs Drake's default without a Python call (none of the marker's
    TypeErrors); not set: the class has no such attribute and pybind11's own lookup runs."""
    assert ("DoGetWitnessFunctions" in vars(SotLeafSystem)) == MARKER_TAKEN
    system = StackHistoryLike()
    assert system.GetWitnessFunctions(system.CreateDefaultContext()) == []
    assert _lookups(SotLeafSystem) >= 0  # STEPS steps of a plant-like hold beside it: no TypeError


class StackHistoryLike(SotLeafSystem):
    """A system of the package's kind: no witness function of its own."""


@pytest.mark.parametrize("system", [StackOfTasks, Task, Feature])
def test_the_systems_of_the_stack_derive_from_it(system):
    assert issubclass(system, SotLeafSystem)


def test_a_subclass_with_a_witness_function_still_triggers_it():
    """A witness on time crossing 0.1 s publishes once, near 0.1 s."""

    class Timed(SotLeafSystem):
        def __init__(self):
            super().__init__()
            self.fired = []
            self.witness = self.MakeWitnessFunction(
                "t = 0.1 s",
                WitnessFunctionDirection.kNegativeThenNonNegative,
                lambda context: context.get_time() - 0.1,
                PublishEvent(self._fire),
            )

        def DoGetWitnessFunctions(self, context):
            return [self.witness]

        def _fire(self, context, event):
            self.fired.append(context.get_time())
            return EventStatus.Succeeded()

    timed = Timed()
    simulator = _beside_a_hold(timed)
    simulator.get_mutable_context().SetAccuracy(1e-6)  # the witness is isolated to this accuracy
    simulator.AdvanceTo(0.2)
    assert len(timed.fired) == 1 and np.isclose(timed.fired[0], 0.1, atol=STEP), timed.fired
