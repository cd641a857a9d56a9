"""``drake-sot script FILE`` with a finite but absurd value on a line: refused with one message naming
the line, the value and the bound, before Drake sees it (a Drake assertion ends the interpreter
with only the graph written). Subprocesses, as a user runs the command."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]
TIMEOUT = 600  # [s] generous: a loaded machine


def _script(tmp_path: Path, text: str) -> tuple[subprocess.CompletedProcess, Path]:
    script = tmp_path / "bounds.sot"
    script.write_text(text)
    out = tmp_path / "out"
    proc = subprocess.run(
        [*DRAKE_SOT, "script", str(script), "--out", str(out), "--no-record"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=TIMEOUT,
    )
    return proc, out


TASK = "new FeatureCoM f\nnew Task t\nt.add f\n"


@pytest.mark.parametrize("gain", ["1e300", "1e150", "1e4"])
def test_a_build_time_gain_past_the_bound_of_the_period_is_refused_on_its_line(tmp_path, gain):
    """λ·dt <= 1 at the script's 5 ms period: λ <= 200 1/s."""
    proc, out = _script(tmp_path, f"{TASK}t.controlGain {gain}\nsot.push t\nrun 0.1\n")
    assert proc.returncode == 2, proc.stderr
    assert f"bounds.sot, line 4: t.controlGain {gain}: task 't': gain λ = {float(gain):g} 1/s" in proc.stderr
    assert f"λ·period = {float(gain) * 0.005:g} must be <= 1" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (out / "bounds.svg").exists()  # refused before the build


def test_a_run_time_gain_past_the_bound_fails_the_run_naming_it_and_keeps_the_artefacts(tmp_path):
    proc, out = _script(
        tmp_path, f"{TASK}t.controlGain 200\nsot.push t\nrun 0.1\nt.controlGain 1e4\nrun 0.1\n"
    )
    assert proc.returncode == 1, proc.stderr
    assert (
        "the run failed at t = 0.100 s: bounds.sot, line 7: t.controlGain 1e4: task 't': "
        "gain λ = 10000 1/s at the control period 0.005 s: λ·period = 50 must be <= 1"
    ) in proc.stderr
    assert "Traceback" not in proc.stderr
    assert np.load(out / "bounds.npz")["time"][-1] == pytest.approx(0.1, abs=0.006)


PAPER_SCRIPT = REPO / "examples" / "paper_III_B.sot"


def test_the_papers_com_target_set_to_1e300_is_refused_on_its_line(tmp_path):
    """``set featureComDes.errorIN [3](1e300,0,0.64)`` in the paper's script (a generic feature: no
    unit known, the bound of every value a script sets, 1e4)."""
    paper = PAPER_SCRIPT.read_text()
    line = "set featureComDes.errorIN [3](0,-0,0.64)"
    assert paper.count(line) == 1
    number = 1 + paper[: paper.index(line)].count("\n")
    proc, out = _script(tmp_path, paper.replace(line, "set featureComDes.errorIN [3](1e300,0,0.64)"))
    assert proc.returncode == 2, proc.stderr
    assert (
        f"bounds.sot, line {number}: set featureComDes.errorIN [3](1e300,0,0.64): featureComDes.errorIN = "
        "[1e+300, 0, 0.64]: entry [0] = 1e+300: every entry must be within ±10000"
    ) in proc.stderr
    assert "Traceback" not in proc.stderr and not (out / "bounds.svg").exists()


def test_a_com_target_1_km_away_taken_from_another_feature_is_refused_in_either_order(tmp_path):
    """A CoM feature's desired value from a generic feature's value: the value is checked as a CoM
    (10 m), whether it was set before or after the link."""
    value = "set d.errorIN [3](1000,0,0.8)\n"
    link = "set f.sdes d\n"
    head = "new FeatureCoM f\nnew FeatureGeneric d\n"
    tail = "new Task t\nt.add f\nsot.push t\nrun 0.1\n"
    for first, second, line in ((value, link, 4), (link, value, 4)):
        proc, _ = _script(tmp_path, head + first + second + tail)
        assert proc.returncode == 2, proc.stderr
        assert f"bounds.sot, line {line}: " in proc.stderr
        assert (
            "'f': desired CoM = [1000, 0, 0.8] m: 1000 m from the world origin; must be within 10 m"
            in proc.stderr
        )


def test_a_run_time_hand_target_1_km_away_fails_the_run_naming_it(tmp_path):
    script = (
        "dyn.createOpPoint rh right_hand\nnew FeaturePoint6d h\nplug dyn.rh_frame h.frame\n"
        "new Task t\nt.add h\nsot.push t\nrun 0.1\nset h.position_des [3](1000,0,1)\nrun 0.1\n"
    )
    proc, out = _script(tmp_path, script)
    assert proc.returncode == 1, proc.stderr
    assert (
        "the run failed at t = 0.100 s: bounds.sot, line 8: set h.position_des [3](1000,0,1): "
        "'h': desired position = [1000, 0, 1] m: 1000 m from the world origin; must be within 10 m of it"
    ) in proc.stderr
    assert np.load(out / "bounds.npz")["time"][-1] == pytest.approx(0.1, abs=0.006)
