"""``own_context``: a system's context from its own or the root's, the root's found without an
exception (Drake's, translated to Python, cost ~150 µs a call, which a served run's host paid at
every tick), and another system's refused."""

import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_sot.systems._context import own_context
from drake_sot.systems.leaf import SotLeafSystem


class Counted(SotLeafSystem):
    """A system whose ``ValidateContext`` calls are counted, and those that raised."""

    def __init__(self):
        super().__init__()
        self.calls = self.raised = 0

    def ValidateContext(self, context):
        self.calls += 1
        try:
            SotLeafSystem.ValidateContext(self, context)
        except RuntimeError:
            self.raised += 1
            raise


@pytest.fixture
def diagram():
    builder = DiagramBuilder()
    counted = builder.AddSystem(Counted())
    other = builder.AddSystem(ConstantVectorSource([1.0]))
    root = builder.Build().CreateDefaultContext()
    return counted, other, root


def test_the_root_context_gives_the_systems_own_without_an_exception(diagram):
    counted, _, root = diagram
    assert own_context(counted, root) is counted.GetMyMutableContextFromRoot(root)
    assert counted.raised == 0


def test_its_own_context_is_validated_and_returned(diagram):
    counted, _, root = diagram
    own = counted.GetMyMutableContextFromRoot(root)
    assert own_context(counted, own) is own
    assert (counted.calls, counted.raised) == (1, 0)


def test_another_systems_context_is_refused(diagram):
    counted, other, root = diagram
    with pytest.raises(RuntimeError):
        own_context(counted, other.GetMyContextFromRoot(root))
