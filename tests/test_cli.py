"""The ``drake-sot`` command and the artefacts of a run: replay, diagram, plot, logs."""

import signal
import subprocess
import sys
import xml.etree.ElementTree as ET

import matplotlib.image
import numpy as np
import pytest
from headless import chromium, screenshot

from drake_sot.app import cli
from drake_sot.diagrams import reach
from drake_sot.diagrams import scenario as scenario_module
from drake_sot.diagrams.run import STOP_SIGNALS, Interrupted, RunResult, SignalGuard, TimedCommand
from drake_sot.diagrams.scenario import Scenario, run_scenario
from drake_sot.systems.fall_monitor import Fall

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


def test_list_names_the_scenarios_then_the_studies():
    out = subprocess.run([*DRAKE_SOT, "list"], capture_output=True, text=True, check=True).stdout
    listed = [
        " ".join(line.split()[:2]) if line.startswith("study ") else line.split()[0]
        for line in out.splitlines()
    ]
    assert listed == [
        "look_and_reach",
        "priority_switching",
        "reach",
        "reach_around",
        "table_pounding",
        "telecoop_slave",
        "telecooperation",
        "walk",
        "walk_long",
        "walk_random",
        "walk_then_interact",
        "alpha_sweep",
        "telecoop_master",
        "study alpha_sweep",
        "study delay_sweep",
        "study gain_sweep",
        "study push_recovery",
    ]
    assert "(24 runs of telecooperation_standing)" in out


def test_a_reader_closing_the_output_early_gets_no_traceback():
    # `drake-sot list | head -1`: the reader is gone before the command writes.
    proc = subprocess.Popen([*DRAKE_SOT, "list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()
    _, err = proc.communicate(timeout=120)
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    assert proc.returncode == cli.EXIT_BROKEN_PIPE == 128 + signal.SIGPIPE


def test_bad_arguments_are_refused(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "no_such_scenario"])
    assert exit_.value.code == 2
    assert "invalid choice: 'no_such_scenario'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "reach", "--transition", "0.6"])
    assert exit_.value.code == 2
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
    for task in reach.STACK + ("taskLH", "taskSelfCollision"):
        assert logs[f"error/{task}"].shape[0] == t.size
    assert list(logs["event_label"]) == ["taskRH target +25 cm x, +20 cm z"]


def test_diagram_svg_shows_the_control_graph(recorded_run):
    out, _ = recorded_run
    root = ET.parse(out / "reach.svg").getroot()
    text = " ".join(t.text or "" for t in root.iter("{http://www.w3.org/2000/svg}text"))
    for system in ("dyn", "sot", "device", "taskRH", "featureRH", "plant"):
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


def _scenario_with(command: TimedCommand) -> Scenario:
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
        _scenario_with(TimedCommand(0.3, "Ctrl-C", _interrupt)), tmp_path, duration=2.0, record=True
    )
    assert output.result.interrupted and not output.result.completed
    assert output.result.interrupted_by == signal.SIGINT  # a KeyboardInterrupt is what Ctrl-C raises
    assert output.arrays["time"][-1] == pytest.approx(0.3, abs=0.006)
    for ext in ("html", "svg", "png", "npz"):
        assert (tmp_path / f"reach.{ext}").exists()


def test_failed_run_reports_and_keeps_artefacts(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(cli.SCENARIOS, "reach", _scenario_with(TimedCommand(0.2, "boom", _fail)))
    code = cli.main(["run", "reach", "--duration", "1", "--no-record", "--out", str(tmp_path)])
    assert code == 1
    assert "the run failed at t = 0.200 s: sensor exploded" in capsys.readouterr().err
    assert np.load(tmp_path / "reach.npz")["time"][-1] == pytest.approx(0.2, abs=0.006)
    assert not (tmp_path / "reach.html").exists()  # --no-record


def _artefacts_load(out, name: str = "reach", *, html: bool = True) -> np.ndarray:
    """Every artefact of a run exists, is whole and opens; returns the logged times."""
    ET.parse(out / f"{name}.svg")
    assert matplotlib.image.imread(out / f"{name}.png").ndim == 3
    if html:
        page = (out / f"{name}.html").read_text()
        assert "meshcat" in page and page.rstrip().endswith("</html>")
    assert not [p.name for p in out.iterdir() if ".partial" in p.name]  # no temporary left
    return np.load(out / f"{name}.npz")["time"]


def _signalled(out, duration: float, signals, *, when: str, record: bool = True):
    """Run ``drake-sot run reach``, send ``signals`` once stderr shows ``when`` (the first
    progress line, or the 100 % line that ends the simulation); (exit status, stderr)."""
    proc = subprocess.Popen(
        [*DRAKE_SOT, "run", "reach", "--duration", str(duration), "--out", str(out)]
        + ([] if record else ["--no-record"]),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # a shell may have ignored them for its background jobs
        preexec_fn=lambda: [signal.signal(s, signal.SIG_DFL) for s in (signal.SIGINT, signal.SIGTERM)],
    )
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if "s simulated, real-time factor" in line and (when == "started" or line.startswith("100%")):
            for signum in signals:
                proc.send_signal(signum)
            break
    _, rest = proc.communicate(timeout=300)
    return proc.returncode, "".join(seen) + rest


@pytest.mark.parametrize(
    ("signals", "status"),
    [
        ([signal.SIGINT], 130),
        ([signal.SIGTERM], 143),
        ([signal.SIGINT, signal.SIGINT], 130),  # a second Ctrl-C as the run stops
    ],
    ids=["ctrl-c", "sigterm", "ctrl-c-twice"],
)
def test_a_signal_mid_run_keeps_every_artefact_of_the_simulated_part(tmp_path, signals, status):
    code, err = _signalled(tmp_path, 3.0, signals, when="started")
    assert code == status, err
    assert f"interrupted by {signals[0].name}: the artefacts cover the simulated part" in err
    t = _artefacts_load(tmp_path)
    assert 0.0 < t[-1] < 3.0


def test_two_ctrl_c_as_the_run_ends_wait_for_every_artefact(tmp_path):
    """Sent as soon as the simulation reports its end, both land while the files are written
    (the replay is written in about a second): they wait, then the command exits with 130."""
    code, err = _signalled(tmp_path, 0.5, [signal.SIGINT, signal.SIGINT], when="ended")
    assert code == 130, err
    assert "interrupted by SIGINT" in err
    assert _artefacts_load(tmp_path)[-1] == pytest.approx(0.5, abs=0.006)


def _sigterm(context):
    signal.raise_signal(signal.SIGTERM)


def test_sigterm_in_process_stops_the_run_like_ctrl_c(tmp_path, monkeypatch, capsys):
    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setitem(cli.SCENARIOS, "reach", _scenario_with(TimedCommand(0.2, "SIGTERM", _sigterm)))
    code = cli.main(["run", "reach", "--duration", "1", "--no-record", "--out", str(tmp_path)])
    assert code == 143
    assert "interrupted by SIGTERM" in capsys.readouterr().err
    assert _artefacts_load(tmp_path, html=False)[-1] == pytest.approx(0.2, abs=0.006)
    assert signal.getsignal(signal.SIGTERM) is before


def test_ctrl_c_while_writing_waits_until_every_file_is_written(tmp_path, monkeypatch, capsys):
    """Deterministic twin of the subprocess test: the SIGINT arrives as the first file is written."""
    write_npz = scenario_module.write_npz

    def interrupted_write(arrays, path):
        signal.raise_signal(signal.SIGINT)
        write_npz(arrays, path)

    monkeypatch.setattr(scenario_module, "write_npz", interrupted_write)
    code = cli.main(["run", "reach", "--duration", "0.3", "--out", str(tmp_path)])
    assert code == 130
    assert f"interrupted by SIGINT while the artefacts were written: they all were, in {tmp_path}" in (
        capsys.readouterr().err
    )
    assert _artefacts_load(tmp_path)[-1] == pytest.approx(0.3, abs=0.006)


def test_sigterm_while_a_served_run_writes_its_artefacts_says_so_and_waits_for_them(
    tmp_path, monkeypatch, capsys
):
    """The serve twin of the test above: the served run is over when SIGTERM comes, as its first
    file is written; the message says so (it said "before the simulation started")."""
    write_npz = scenario_module.write_npz

    def interrupted_write(arrays, path):
        signal.raise_signal(signal.SIGTERM)
        write_npz(arrays, path)

    monkeypatch.setattr(scenario_module, "write_npz", interrupted_write)
    code = cli.main(
        ["serve", "reach", "--port", "0", "--duration", "0.3", "--realtime", "100", "--out", str(tmp_path)]
    )
    assert code == 143
    assert f"interrupted by SIGTERM while the artefacts were written: they all were, in {tmp_path}" in (
        capsys.readouterr().err
    )
    assert _artefacts_load(tmp_path)[-1] == pytest.approx(0.3, abs=0.006)


def test_signal_guard_stops_once_then_holds():
    before = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    with SignalGuard() as guard:
        with pytest.raises(Interrupted) as stop:
            signal.raise_signal(signal.SIGTERM)
        assert stop.value.signum == signal.SIGTERM and isinstance(stop.value, KeyboardInterrupt)
        signal.raise_signal(signal.SIGTERM)  # held, then absorbed: the stop it asks for is under way
        assert guard.held == [signal.SIGTERM]
        finished = True
    assert finished
    assert {s: signal.getsignal(s) for s in STOP_SIGNALS} == before


def test_signal_guard_delivers_another_signal_once_the_block_is_done():
    finished = False
    with pytest.raises(KeyboardInterrupt) as late, SignalGuard():
        with pytest.raises(Interrupted):
            signal.raise_signal(signal.SIGTERM)
        signal.raise_signal(signal.SIGINT)  # held until the block is done, then delivered
        finished = True
    assert finished and not isinstance(late.value, Interrupted)  # Python's own Ctrl-C handler raised it


def test_signal_guard_delivers_a_held_signal_on_exit():
    finished = False
    with pytest.raises(KeyboardInterrupt), SignalGuard() as guard:
        guard.hold()
        signal.raise_signal(signal.SIGINT)
        finished = True
    assert finished


def test_signal_guard_leaves_an_ignored_signal_ignored():
    before = signal.signal(signal.SIGTERM, signal.SIG_IGN)
    try:
        with SignalGuard():
            signal.raise_signal(signal.SIGTERM)  # would raise Interrupted had the guard taken it
            assert signal.getsignal(signal.SIGTERM) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGTERM, before)


def test_sigterm_on_a_study_stops_it_and_writes_the_runs_done(tmp_path):
    """A study's SIGTERM cancels the runs not started, terminates the workers and writes what
    was done, at once (it used to wait for every queued run, then write nothing)."""
    proc = subprocess.Popen(
        [*DRAKE_SOT, "run", "alpha_sweep", "--duration", "0.3", "--workers", "1", "--out", str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL),
    )
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if " runs, " in line:  # the first progress line: one run is done
            proc.send_signal(signal.SIGTERM)
            break
    _, rest = proc.communicate(timeout=120)
    err = "".join(seen) + rest
    assert proc.returncode == 143, err
    assert "interrupted by SIGTERM" in err
    done = np.load(tmp_path / "alpha_sweep.npz")["done"]
    assert 1 <= done.sum() < done.size
    assert matplotlib.image.imread(tmp_path / "alpha_sweep.png").ndim == 3


def test_exit_status_of_a_fall_is_3_unless_a_signal_or_a_failure_came_too():
    fall = Fall(1.0, 0.3, 1.2)
    assert cli.exit_status(RunResult(fell=fall)) == 3
    assert not RunResult(fell=fall).completed
    assert cli.exit_status(RunResult(fell=fall, failure=RuntimeError("x"))) == 1
    assert cli.exit_status(RunResult(fell=fall, interrupted_by=signal.SIGINT)) == 130
    assert cli.exit_status(RunResult()) == 0
