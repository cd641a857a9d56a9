"""Every scenario builds and simulates on the installed Python and drake.

This module is part of the run ``make test`` repeats on each Python the package claims (its
``compat`` marker): a version of drake or numpy that breaks a system's construction or its
first ticks breaks one of these, whichever scenario holds that system. The case study is run
to its end by ``tests/diagrams/test_walk_then_interact.py`` (also marked ``compat``).
"""

import dataclasses

import numpy as np
import pytest

from drake_sot.diagrams import SCENARIOS
from drake_sot.diagrams.scenario import NotServable, build_scenario, run_scenario

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


def _has_server(setup) -> bool:
    return getattr(setup.built, "remote", None) is not None


@pytest.mark.parametrize("name", sorted(n for n, s in SCENARIOS.items() if s.servable))
def test_a_servable_scenario_has_a_command_server_when_asked_and_only_then(name):
    scenario = SCENARIOS[name]
    served = build_scenario(scenario, None, command_server=True)
    assert _has_server(served)
    # The server drives the solver's stack commands: its output is wired into the solver.
    sot = served.built.sot
    assert sot.GetInputPort("commands").HasValue(
        sot.GetMyContextFromRoot(served.built.diagram.CreateDefaultContext())
    )
    plain = build_scenario(scenario, None)
    assert _has_server(plain) == (name == "telecoop_slave")  # the slave side is served by nature


@pytest.mark.parametrize("name", sorted(n for n, s in SCENARIOS.items() if not s.servable))
def test_a_scenario_that_cannot_be_served_is_refused_before_it_is_built(name):
    scenario = dataclasses.replace(SCENARIOS[name], build=lambda *a, **k: pytest.fail("built"))
    with pytest.raises(NotServable, match=f"{name} cannot be served"):
        build_scenario(scenario, None, command_server=True)
