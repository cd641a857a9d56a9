"""The ``telecooperation`` scenario's whole walk in physics (Evrard et al. 2009), at 140 ms one
way with the co-operator leading: the tests of ``test_telecooperation_walking.py``, in a file of
their own so that ``--dist loadfile`` can run the two leaders' walks on the two workers."""

import pytest
from test_telecooperation_walking import WalkingChecks

pytestmark = pytest.mark.slow


class TestCooperatorLeading(WalkingChecks):
    LEADER = "cooperator"
