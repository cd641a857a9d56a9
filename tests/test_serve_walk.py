"""``drake-sot serve walk`` for 30 s, driven by a client in another process: the walk's plan ends
near 13 s and the pattern generator stands on past the samples it keeps (20 s), served."""

import numpy as np
import pytest
from landings import landing_errors
from served import start, stop

from drake_sot.diagrams import walk, walking
from drake_sot.diagrams.scenario import build_scenario
from drake_sot.remote import Client

pytestmark = pytest.mark.slow

DURATION = 30.0  # [s] simulated: past the 20 s of executed samples the pattern generator keeps


@pytest.fixture(scope="module")
def served_walk(tmp_path_factory):
    """The served run's logs, the CoM the client read at 25 s or later, the scenario (built here,
    not simulated: the planned footprints), the logs measured on its plant, and the run's stdout."""
    out = tmp_path_factory.mktemp("served_walk")
    proc, host, port = start(
        "--port", "0", "--duration", str(DURATION), "--realtime", "1000", "--out", str(out), target="walk"
    )
    try:
        with Client(host, port, timeout=120.0) as client:
            com = client.read("dyn.com")
            while client.t < 25.0:  # the client is answered past the samples the generator keeps
                com = client.read("dyn.com")
            read_at = client.t
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        stop(proc)
    assert proc.returncode == 0, stderr
    with np.load(out / "walk.npz") as npz:
        arrays = {key: npz[key] for key in npz.files}
    setup = build_scenario(walk.SCENARIO, None)
    return arrays, (read_at, np.array(com)), setup, walking.analyse(setup.built, arrays), stdout


def test_a_served_walk_of_30_s_completes_upright(served_walk):
    arrays, _, _, _, stdout = served_walk
    assert f"served up to t = {DURATION:.3f} s" in stdout
    assert arrays["time"][-1] == pytest.approx(DURATION, abs=0.006)
    assert arrays["q"][:, 6].min() > 0.6, "pelvis dropped below 0.6 m"


def test_the_served_walk_lands_on_its_footprints_and_stands_on_the_last_two(served_walk):
    arrays, _, setup, analysis, _ = served_walk
    steps = setup.extras.steps
    soles = analysis.soles
    for side, off, yaw_error in landing_errors(arrays, soles, steps):
        assert off < 0.02, f"{side} foot landed {off:.3f} m off"
        assert yaw_error < 3.0
    last = {step.side: step for step in steps}
    standing = arrays["time"] > 20.0  # the samples the generator keeps, passed
    for side, step in last.items():
        assert np.abs(soles[side][standing, :2] - step.xy).max() < 0.02, side
    assert np.all(arrays["contacts"][standing] > 0.5)  # both feet down


def test_the_served_robot_stands_with_its_com_over_its_feet(served_walk):
    """The CoM the client read at 25 s or later, and the logged one from 20 s on, over the midpoint of
    the last two footprints (the CoM task's reference once the walk has stopped)."""
    arrays, (read_at, com), setup, analysis, _ = served_walk
    last = {step.side: step for step in setup.extras.steps}
    midpoint = 0.5 * (last["left"].xy + last["right"].xy)
    assert read_at >= 25.0 and np.linalg.norm(com[:2] - midpoint) < 0.03
    assert np.linalg.norm(analysis.com[arrays["time"] > 20.0, :2] - midpoint, axis=1).max() < 0.03
