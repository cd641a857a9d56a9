"""``drake-sot script FILE``: the paper's script end to end, its artefacts, its physics, and
the refusals of a bad script."""

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from drake_sot.app import cli
from drake_sot.models import half_sitting_configuration, make_control_model

REPO = Path(__file__).resolve().parents[1]
PAPER_SCRIPT = REPO / "examples" / "paper_III_B.sot"
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("script")
    proc = subprocess.run(
        [*DRAKE_SOT, "script", str(PAPER_SCRIPT), "--out", str(out)], capture_output=True, text=True, cwd=REPO
    )
    assert proc.returncode == 0, proc.stderr
    return out, proc


def test_the_script_writes_every_artefact(paper_run):
    out, proc = paper_run
    for ext in ("svg", "npz", "png", "html"):
        path = out / f"paper_III_B.{ext}"
        assert path.stat().st_size > 1000, ext
        assert f"wrote {path}" in proc.stdout
    assert matplotlib.image.imread(out / "paper_III_B.png").ndim == 3
    svg = ET.parse(out / "paper_III_B.svg").getroot()
    text = " ".join(t.text or "" for t in svg.iter("{http://www.w3.org/2000/svg}text"))
    for name in ("featureCom", "featureComDes", "taskCom", "featureTwofeet", "dyn", "sot", "pg"):
        assert name in text, name
    assert (out / "paper_III_B.html").read_text().rstrip().endswith("</html>")
    # the build-phase output: the operational points the paper's createOpPoint lines made
    assert (
        "paper_III_B.sot, line 31: dyn2.createOpPoint rleg 6\n  rleg: frame 'r_ankle_roll_link'"
        in proc.stdout
    )


def test_the_scripts_run_time_lines_are_the_runs_events(paper_run):
    out, _ = paper_run
    logs = np.load(out / "paper_III_B.npz")
    assert list(logs["event_label"]) == [
        "sot.push taskLeftFoot",
        "sot.push taskTwofeet",
        "sot.push taskCom",
        "pg.parsecmd :singlesupporttime 0.780",
    ]
    np.testing.assert_allclose(logs["event_time"], [0.0, 0.0, 0.4, 0.4])
    assert logs["time"][-1] == pytest.approx(2.5, abs=0.006)  # the script's run lines: 0.4 + 2.1
    assert list(logs["stack"]) == ["taskLeftFoot > taskTwofeet", "taskLeftFoot > taskTwofeet > taskCom"]


def test_the_paper_stack_keeps_the_robot_upright_with_its_com_on_target(paper_run):
    """Measured on the simulated plant's logged configuration, with a model of our own."""
    out, _ = paper_run
    _check_upright_with_the_com_on_target(np.load(out / "paper_III_B.npz"))


@pytest.mark.slow
def test_the_paper_script_run_for_25_s_stands_with_its_com_on_target(tmp_path):
    """The script's ``new PatternGenerator`` stands (none of its outputs is plugged, but it ticks)
    past the 20 s of executed samples a generator keeps, and the run completes as the short one
    does: upright, the feet where they started, the CoM on target."""
    proc = subprocess.run(
        [*DRAKE_SOT, "script", str(PAPER_SCRIPT), "--duration", "25", "--out", str(tmp_path), "--no-record"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    logs = np.load(tmp_path / "paper_III_B.npz")
    assert logs["time"][-1] == pytest.approx(25.0, abs=0.006)
    _check_upright_with_the_com_on_target(logs)
    settled = logs["time"] > 5.0
    assert np.linalg.norm(logs["error/taskCom"][settled], axis=1).max() < 1e-3  # and stays there


def _check_upright_with_the_com_on_target(logs) -> None:
    """The pelvis at its starting height, the CoM's ground projection on the script's target
    (0, -0), the left foot where it started and the feet's relative pose unchanged, at the end of
    the run; taskCom out of the stack until its ``sot.push`` at 0.4 s, converged at the end."""
    plant, info = make_control_model()
    context = plant.CreateDefaultContext()
    q0 = half_sitting_configuration(plant, info)
    plant.SetPositions(context, q0)
    left0 = plant.GetFrameByName(info.frames["left_foot"]).CalcPoseInWorld(context).translation()
    gap0 = left0 - plant.GetFrameByName(info.frames["right_foot"]).CalcPoseInWorld(context).translation()
    com0 = plant.CalcCenterOfMassPositionInWorld(context)
    plant.SetPositions(context, logs["q"][-1])
    com = plant.CalcCenterOfMassPositionInWorld(context)
    assert abs(logs["q"][:, 6].min() - q0[6]) < 0.02, "the pelvis dropped: the robot fell or crouched"
    assert abs(com0[0]) > 0.01  # the target (0, -0) is not where the CoM started...
    assert np.linalg.norm(com[:2] - [0.0, -0.0]) < 0.005  # ...but where it is now
    left = plant.GetFrameByName(info.frames["left_foot"]).CalcPoseInWorld(context).translation()
    gap = left - plant.GetFrameByName(info.frames["right_foot"]).CalcPoseInWorld(context).translation()
    assert np.linalg.norm(left - left0) < 0.005 and np.linalg.norm(gap - gap0) < 0.005
    error = logs["error/taskCom"]
    assert np.all(np.isnan(error[logs["time"] < 0.4 - 1e-9]))  # out of the stack until sot.push
    assert np.linalg.norm(error[-1]) < 1e-3


def _main(argv, capsys) -> tuple[int, str, str]:
    try:
        code = cli.main(argv)
    except SystemExit as exit_:
        code = exit_.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_a_bad_script_is_refused_with_one_line_before_anything_runs(tmp_path, capsys):
    bad = tmp_path / "bad.sot"
    bad.write_text("new FeatureGeneric featureCom\nset featureComDes.errorIN [3](0,-0)\n")
    code, _, err = _main(["script", str(bad), "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    assert err.strip().endswith(
        "bad.sot, line 2, column 35: expected ',' and 1 more number(s): the vector [3] has 3, found ')'"
    )
    assert len(err.strip().splitlines()) == 1

    code, _, err = _main(["script", str(tmp_path / "missing.sot")], capsys)
    assert code == 2 and "cannot read the script" in err

    idle = tmp_path / "idle.sot"
    idle.write_text("new FeatureCoM f\n")
    code, _, err = _main(["script", str(idle), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "idle.sot simulates nothing: give --duration S or add 'run SECONDS' lines" in err

    unknown = tmp_path / "unknown.sot"
    unknown.write_text("new FeatureCoM f\nplug dyn.com g.com\nrun 1\n")
    code, _, err = _main(["script", str(unknown), "--out", str(tmp_path / "o"), "--no-record"], capsys)
    assert code == 2
    assert "unknown.sot, line 2: plug dyn.com g.com: unknown entity 'g'; known: dyn, f, pool" in err
    assert not (tmp_path / "o" / "unknown.svg").exists()  # refused before anything was built


def test_a_failing_run_time_command_fails_the_run_and_keeps_its_artefacts(tmp_path, capsys):
    script = tmp_path / "fails.sot"
    script.write_text(
        "new FeatureCoM f\nnew Task t\nt.add f\nsot.push t\nrun 0.1\nget dyn.com\nsot.push nothing\nrun 0.2\n"
    )
    code, out, err = _main(["script", str(script), "--out", str(tmp_path), "--no-record"], capsys)
    assert code == 1
    assert "the run failed at t = 0.100 s: fails.sot, line 7: sot.push nothing: unknown task 'nothing'" in err
    assert "t = 0.100 s  fails.sot, line 6: get dyn.com\n  [3](" in out
    assert np.load(tmp_path / "fails.npz")["time"][-1] == pytest.approx(0.1, abs=0.006)


def test_duration_extends_or_cuts_the_scripted_time(tmp_path, capsys):
    script = tmp_path / "short.sot"
    script.write_text("new FeatureCoM f\nnew Task t\nt.add f\nsot.push t\n")
    code, _, err = _main(
        ["script", str(script), "--duration", "0.2", "--out", str(tmp_path), "--no-record"], capsys
    )
    assert code == 0, err
    assert np.load(tmp_path / "short.npz")["time"][-1] == pytest.approx(0.2, abs=0.006)


def test_lines_after_a_shorter_duration_are_said_not_applied(tmp_path, capsys):
    script = tmp_path / "long.sot"
    script.write_text("new FeatureCoM f\nnew Task t\nt.add f\nrun 0.3\nsot.push t\n")
    code, _, err = _main(
        ["script", str(script), "--duration", "0.1", "--out", str(tmp_path), "--no-record"], capsys
    )
    assert code == 0, err
    assert "after the end of the run, not applied: 'sot.push t' at 0.3 s" in err
