"""The package's systems derive from ``SotLeafSystem``: the simulator's query of their witness
functions after every step of a plant (an unrestricted update) looks up no Python attribute,
where a plain Python ``LeafSystem`` is looked up at every step; a subclass that has witness
functions still has them."""

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
from drake_sot.systems.leaf import SotLeafSystem
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

    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantValueSource(Value[object](0)))
    hold = builder.AddSystem(ZeroOrderHold(STEP, Value[object](0)))
    builder.Connect(source.get_output_port(), hold.get_input_port())
    builder.AddSystem(Counted())
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(STEPS * STEP)
    return Counted.lookups


def test_a_plain_python_leaf_system_is_looked_up_at_every_step():
    assert _lookups(LeafSystem) >= STEPS  # what SotLeafSystem saves: this test's control


def test_a_sot_leaf_system_is_looked_up_at_most_once():
    assert _lookups(SotLeafSystem) <= 1


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

    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantValueSource(Value[object](0)))
    hold = builder.AddSystem(ZeroOrderHold(STEP, Value[object](0)))
    builder.Connect(source.get_output_port(), hold.get_input_port())
    timed = builder.AddSystem(Timed())
    simulator = Simulator(builder.Build())
    simulator.get_mutable_context().SetAccuracy(1e-6)  # the witness is isolated to this accuracy
    simulator.AdvanceTo(0.2)
    assert len(timed.fired) == 1 and np.isclose(timed.fired[0], 0.1, atol=STEP), timed.fired
