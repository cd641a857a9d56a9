"""The ``telecooperation`` scenario in physics (Evrard et al. 2009): the lift, then 20 s of walking,
at 0 and 300 ms one way. Each run is simulated once per module."""

import pytest
from telecoop_runs import hand_error

from drake_sot.diagrams import SCENARIOS
from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow


#: [s] the runs across delay: the lift, then 20 s of walking after the follower starts.
ACROSS_DELAY = tc.DEFAULT_CONFIG.walk_at + tc.DEFAULT_CONFIG.lag + 20.0


@pytest.fixture(scope="module", params=[0.0, 0.3], ids=lambda d: f"{1000 * d:.0f}ms")
def walking_across_delay(request, tmp_path_factory):
    return run_scenario(
        SCENARIOS["telecooperation"],
        tmp_path_factory.mktemp(f"walking_{request.param}"),
        duration=ACROSS_DELAY,
        record=False,
        parameters={"leader": "operator", "delay": request.param},
    )


def test_walking_stays_bounded_across_delay(walking_across_delay):
    """At 0 and 300 ms one way, over 20 s of walking: the robot stays up, the hands within 5 cm
    of the operator's, and their error does not grow (the last 5 s no worse than the 10 s
    before)."""
    run = walking_across_delay
    assert run.result.fell is None
    t = run.arrays["time"]
    error = hand_error(run).max(axis=1)
    assert error[t > 1.0].max() <= 0.05
    late = error[t > ACROSS_DELAY - 5.0].max()
    before = error[(t > ACROSS_DELAY - 15.0) & (t <= ACROSS_DELAY - 5.0)].max()
    assert late <= max(before, 0.01)
