"""Every scenario builds and simulates on the installed Python and drake.

This module is part of the run ``make test`` repeats on each Python the package claims (its
``compat`` marker): a version of drake or numpy that breaks a system's construction or its
first ticks breaks one of these, whichever scenario holds that system. The case study is run
to its end by ``tests/diagrams/test_walk_then_interact.py`` (also marked ``compat``).
"""

import numpy as np
import pytest

from drake_sot.diagrams import SCENARIOS
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.compat

#: Simulated time of each short run [s]: past the first control ticks (5 ms) and the first
#: samples of every logger, well before any scenario's first command.
SHORT = 0.25


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenario_builds_and_simulates_its_first_ticks(name, tmp_path):
    output = run_scenario(SCENARIOS[name], tmp_path, duration=SHORT, record=False)
    assert output.result.completed, output.result.failure
    t = output.arrays["time"]
    assert t[-1] == pytest.approx(SHORT, abs=0.011)  # logged to the end of the run
    assert np.all(np.isfinite(output.arrays["q"])) and np.all(np.isfinite(output.arrays["v"]))
    assert (tmp_path / f"{name}.npz").is_file()
