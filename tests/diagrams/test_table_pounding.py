"""table_pounding in physics: balance, 30 N presses, and the slow rearrangement beats the fast one."""

import numpy as np
import pytest

from drake_sot.diagrams import table_pounding as tp
from drake_sot.diagrams.scenario import run_scenario


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for transition in (0.6, 0.015):
        output = run_scenario(
            tp.SCENARIO,
            tmp_path_factory.mktemp(f"tp{transition}"),
            record=False,
            parameters={"transition": transition},
        )
        assert output.result.completed, output.result.failure
        out[transition] = output
    return out


def _contact_phases():
    return [
        (p, nxt)
        for p, nxt in zip(tp.DEFAULT_CONFIG.phases, tp.DEFAULT_CONFIG.phases[1:], strict=False)
        if p.name.endswith("contact")
    ]


@pytest.mark.parametrize("transition", [0.6, 0.015])
def test_balance_without_foot_slip(runs, transition):
    output = runs[transition]
    built, q = output.setup.built, output.arrays["q"]
    context = built.plant.CreateDefaultContext()
    soles = []
    for qk in q[::20]:
        built.plant.SetPositions(context, built.info.model_instance, qk)
        soles.append(
            [
                built.plant.GetFrameByName(built.info.frames[f], built.info.model_instance)
                .CalcPoseInWorld(context)
                .translation()[:2]
                for f in ("left_foot", "right_foot")
            ]
        )
    soles = np.array(soles)
    assert np.max(np.linalg.norm(soles - soles[0], axis=2)) < 0.005
    assert q[:, 6].min() > 0.6
    assert np.all(output.arrays["status"] == 0)  # optimal throughout, no task short of its wrench


def test_each_press_reaches_30_newtons(runs):
    output = runs[0.6]
    t, force = output.arrays["time"], output.arrays["table_force"][:, 0]
    for phase, after in _contact_phases():  # the last second of each contact phase: settled
        window = (t >= after.start - 1.0) & (t < after.start)
        assert np.all(np.abs(force[window] - tp.DEFAULT_CONFIG.force) < 3.0), (
            f"{phase.hand} hand force outside 30 ± 3 N"
        )
    idle = t < tp.DEFAULT_CONFIG.phases[1].start
    assert np.all(np.abs(force[idle]) < 0.5)  # nothing presses the table before reaching


def _peak_error_once_reached(output):
    t, force = output.arrays["time"], output.arrays["table_force"][:, 0]
    peaks = []
    for phase, after in _contact_phases():
        f = force[(t >= phase.start) & (t < after.start)]
        reached = int(np.argmax(f >= tp.DEFAULT_CONFIG.force))
        peaks.append(np.max(np.abs(f[reached:] - tp.DEFAULT_CONFIG.force)))
    return np.array(peaks)


def test_slow_rearrangement_gives_smaller_peak_error_and_energy(runs):
    slow, fast = runs[0.6], runs[0.015]
    assert np.all(_peak_error_once_reached(slow) < _peak_error_once_reached(fast))

    def energy(output):
        t, tau = output.arrays["time"], output.arrays["tau"]
        return float(np.trapezoid(np.sum(tau**2, axis=1), t))

    assert energy(slow) < energy(fast)


def test_figures_are_written(runs):
    out_dir = runs[0.6].files["png"].parent
    assert (out_dir / "table_pounding_figures.png").stat().st_size > 1000
