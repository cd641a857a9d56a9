"""The ``drake-sot`` command and the artefacts of a run: replay, diagram, plot, logs."""

import signal
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from headless import chromium, screenshot

from drake_sot import cli
from drake_sot.diagrams import reach
from drake_sot.diagrams.run import Command
from drake_sot.diagrams.scenario import Scenario, run_scenario

DRAKE_SOT = [sys.executable, "-m", "drake_sot.cli"]


def test_list_names_the_scenarios():
    out = subprocess.run([*DRAKE_SOT, "list"], capture_output=True, text=True, check=True).stdout
    listed = [line.split()[0] for line in out.splitlines()]
    assert listed == [
        "priority_switching",
        "reach",
        "table_pounding",
        "walk",
        "walk_then_interact",
        "alpha_sweep",
    ]


def test_bad_arguments_are_refused(capsys):
    with pytest.raises(SystemExit):
        cli.main(["run", "no_such_scenario"])
    assert "invalid choice: 'no_such_scenario'" in capsys.readouterr().err
    assert cli.main(["run", "reach", "--duration", "-1"]) == 2
    assert "--duration must be > 0, got -1.0" in capsys.readouterr().err
    assert cli.main(["run", "reach", "--transition", "0.6"]) == 2
    assert "reach takes no --transition" in capsys.readouterr().err


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli")
    proc = subprocess.run(
        [*DRAKE_SOT, "run", "reach", "--duration", "1.2", "--out", str(out)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    return out, proc


def test_run_writes_every_artefact(recorded_run):
    out, proc = recorded_run
    for ext in ("html", "svg", "png", "npz"):
        assert (out / f"reach.{ext}").stat().st_size > 1000, ext
        assert f"reach.{ext}" in proc.stdout
    logs = np.load(out / "reach.npz")
    t = logs["time"]
    assert t[0] == 0.0 and t[-1] == pytest.approx(1.2, abs=0.01)
    assert logs["q"].shape == (t.size, 37)
    for task in reach.STACK + ("taskLH",):
        assert logs[f"error/{task}"].shape[0] == t.size
    assert list(logs["event_label"]) == ["taskRH target +25 cm x, +20 cm z"]


def test_diagram_svg_shows_the_control_graph(recorded_run):
    out, _ = recorded_run
    root = ET.parse(out / "reach.svg").getroot()
    text = " ".join(t.text or "" for t in root.iter("{http://www.w3.org/2000/svg}text"))
    for system in ("dyn", "sot", "device", "taskRH", "feature_taskRH", "plant"):
        assert system in text, system


def test_replay_is_standalone_and_renders(recorded_run, tmp_path):
    out, _ = recorded_run
    html = (out / "reach.html").read_text()
    assert '<script src="http' not in html and "<link" not in html  # no external resources
    if chromium() is None:
        pytest.skip("chromium is not installed (make test installs it with apt)")
    pixels = screenshot(out / "reach.html", tmp_path / "shot.png").reshape(-1, 3)
    colours = np.unique(np.round(pixels * 255).astype(int), axis=0)
    assert len(colours) > 50, "the replay rendered as a blank page"


def _scenario_with(command: Command) -> Scenario:
    def build(meshcat):
        setup = reach.build(meshcat)
        setup.commands.append(command)
        return setup

    return Scenario(name="reach", description="reach with an injected command", build=build)


def _interrupt(context):
    raise KeyboardInterrupt


def _fail(context):
    raise RuntimeError("sensor exploded")


def test_interrupted_run_keeps_what_was_simulated(tmp_path):
    output = run_scenario(
        _scenario_with(Command(0.3, "Ctrl-C", _interrupt)), tmp_path, duration=2.0, record=True
    )
    assert output.result.interrupted and not output.result.completed
    assert output.arrays["time"][-1] == pytest.approx(0.3, abs=0.006)
    for ext in ("html", "svg", "png", "npz"):
        assert (tmp_path / f"reach.{ext}").exists()


def test_failed_run_reports_and_keeps_artefacts(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(cli.SCENARIOS, "reach", _scenario_with(Command(0.2, "boom", _fail)))
    code = cli.main(["run", "reach", "--duration", "1", "--no-record", "--out", str(tmp_path)])
    assert code == 1
    assert "the run failed at t = 0.200 s: sensor exploded" in capsys.readouterr().err
    assert np.load(tmp_path / "reach.npz")["time"][-1] == pytest.approx(0.2, abs=0.006)
    assert not (tmp_path / "reach.html").exists()  # --no-record


def test_ctrl_c_on_the_command_line(tmp_path):
    """A real SIGINT mid-run: exit code 130 and the artefacts of the simulated part."""
    proc = subprocess.Popen(
        [*DRAKE_SOT, "run", "reach", "--no-record", "--out", str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # a shell may have ignored it
    )
    for line in proc.stdout:
        if "simulated, real-time factor" in line and not line.startswith("  0%"):
            proc.send_signal(signal.SIGINT)
            break
    rest, _ = proc.communicate(timeout=120)
    assert proc.returncode == 130, rest
    assert "interrupted" in rest
    t_end = np.load(tmp_path / "reach.npz")["time"][-1]
    assert 0.0 < t_end < 7.0
