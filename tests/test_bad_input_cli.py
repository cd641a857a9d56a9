"""Bad input to the ``drake-sot`` command, to ``simulate`` and to ``run_scenario`` is refused
before anything is built or simulated, with one line (exit status 2) or a ValueError naming
the value; and importing the scenarios leaves a notebook's matplotlib backend alone."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.primitives import ConstantVectorSource

from drake_sot.app import cli
from drake_sot.diagrams.artifacts import atomic_path
from drake_sot.diagrams.run import simulate
from drake_sot.diagrams.scenario import Scenario, run_scenario
from drake_sot.robots.description import LOGICAL_FRAMES

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


def _refused(capsys, argv: list[str]) -> str:
    """The one line of stderr of ``drake-sot *argv``, which must exit with status 2."""
    with pytest.raises(SystemExit) as exit_:
        cli.main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    return err


@pytest.fixture
def nothing_runs(monkeypatch):
    """Fails the test if the command gets as far as building a scenario or a study."""

    def forbidden(*args, **kwargs):
        raise AssertionError("a refused command must not build anything")

    monkeypatch.setattr(cli, "run_scenario", forbidden)
    for name in cli.STUDIES:
        monkeypatch.setitem(cli.STUDIES, name, dataclasses.replace(cli.STUDIES[name], run=forbidden))


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("nan", "duration = nan s: must be finite and > 0"),
        ("inf", "duration = inf s: must be finite and > 0"),
        ("-inf", "duration = -inf s: must be finite and > 0"),
        ("0", "duration = 0 s: must be finite and > 0"),
        ("-1", "duration = -1 s: must be finite and > 0"),
        ("abc", "duration = 'abc': must be a number"),
    ],
)
def test_duration_is_checked_at_parse_time(capsys, nothing_runs, value, message):
    err = _refused(capsys, ["run", "reach", f"--duration={value}"])
    assert err == f"drake-sot run: error: argument --duration: {message}\n"


@pytest.mark.parametrize("value", ["nan", "inf", "-0.1"])
def test_transition_is_checked_at_parse_time(capsys, nothing_runs, value):
    err = _refused(capsys, ["run", "table_pounding", f"--transition={value}"])
    assert "--transition" in err and f" {value} s" in err


def test_a_nan_duration_on_the_real_command_simulates_nothing():
    """It used to exit 0 having simulated nothing (every comparison with NaN is False)."""
    proc = subprocess.run([*DRAKE_SOT, "run", "reach", "--duration", "nan"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert (
        proc.stderr.strip()
        == "drake-sot run: error: argument --duration: duration = nan s: must be finite and > 0"
    )


@pytest.mark.parametrize("value", ["0", "-2", "2.5", "nan"])
def test_workers_must_be_a_positive_integer(capsys, nothing_runs, value):
    err = _refused(capsys, ["run", "alpha_sweep", f"--workers={value}"])
    assert f"workers = {value}" in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "reach", "--workers", "2"], "reach takes no --workers"),
        (["run", "reach", "--transition", "0.6"], "reach takes no --transition"),
        (["run", "alpha_sweep", "--transition", "0.6"], "alpha_sweep takes no --transition"),
        (["run", "alpha_sweep", "--no-record"], "alpha_sweep takes no --no-record"),
    ],
)
def test_an_option_the_scenario_does_not_take_is_refused(capsys, nothing_runs, argv, message):
    assert message in _refused(capsys, argv)


def test_out_that_is_a_file_is_refused(capsys, nothing_runs, tmp_path):
    existing = tmp_path / "notes.txt"
    existing.write_text("keep me")
    assert f"'{existing}' is a file, not a directory" in _refused(
        capsys, ["run", "reach", "--out", str(existing)]
    )
    under = existing / "out"
    assert f"cannot write into '{under}': Not a directory" in _refused(
        capsys, ["run", "reach", "--out", str(under)]
    )
    assert existing.read_text() == "keep me"


def test_out_in_a_directory_not_even_root_can_write_is_refused(capsys, nothing_runs):
    """/sys is a directory the kernel refuses files in, to root too: the check creates a file,
    it does not trust permission bits."""
    if not Path("/sys").is_dir() or _can_create_in("/sys"):
        pytest.skip("needs Linux's /sys, where no file can be created")
    assert "cannot write into '/sys'" in _refused(capsys, ["run", "reach", "--out", "/sys"])


def _can_create_in(directory: str) -> bool:
    try:
        with open(Path(directory) / ".drake_sot_probe", "x"):
            pass
    except OSError:
        return False
    os.remove(Path(directory) / ".drake_sot_probe")
    return True


def test_out_in_a_read_only_directory_is_refused(capsys, nothing_runs, tmp_path):
    if os.geteuid() == 0:
        pytest.skip("running as root, who may write into a read-only directory (see the /sys test)")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        err = _refused(capsys, ["run", "reach", "--out", str(locked / "out")])
    finally:
        locked.chmod(0o755)
    assert f"cannot write into '{locked / 'out'}': Permission denied" in err


BAD_DURATIONS = [math.nan, math.inf, -math.inf, 0.0, -1.0]


@pytest.mark.parametrize("duration", BAD_DURATIONS)
def test_simulate_refuses_a_bad_duration_before_drake_sees_it(duration):
    simulator = Simulator(ConstantVectorSource([0.0]))
    with pytest.raises(ValueError, match=f"duration = {duration!r} s: must be finite and > 0"):
        simulate(simulator, duration)
    assert simulator.get_context().get_time() == 0.0


@pytest.mark.parametrize("chunk", [math.nan, 0.0, -0.1])
def test_simulate_refuses_a_bad_chunk(chunk):
    with pytest.raises(ValueError, match="chunk = "):
        simulate(Simulator(ConstantVectorSource([0.0])), 1.0, chunk=chunk)


def _never_built(meshcat):
    raise AssertionError("refused before the scenario is built")


@pytest.mark.parametrize("duration", BAD_DURATIONS)
def test_run_scenario_refuses_a_bad_duration_before_building(tmp_path, duration):
    scenario = Scenario(name="probe", description="", build=_never_built)
    with pytest.raises(ValueError, match=f"duration = {duration!r} s"):
        run_scenario(scenario, tmp_path, duration=duration, record=False)


def test_run_scenario_refuses_an_unwritable_out_dir_before_building(tmp_path):
    scenario = Scenario(name="probe", description="", build=_never_built)
    (tmp_path / "file").write_text("")
    with pytest.raises(NotADirectoryError, match="is a file, not a directory"):
        run_scenario(scenario, tmp_path / "file", record=False)


def test_an_interrupted_writer_leaves_the_previous_file_and_no_temporary(tmp_path):
    path = tmp_path / "logs.npz"
    path.write_bytes(b"previous")
    with pytest.raises(KeyboardInterrupt), atomic_path(path) as temporary:
        temporary.write_bytes(b"half of the new")
        raise KeyboardInterrupt
    assert path.read_bytes() == b"previous"
    assert [p.name for p in tmp_path.iterdir()] == ["logs.npz"]
    with atomic_path(path) as temporary:
        assert temporary.parent == tmp_path and temporary.suffix == ".npz"
        temporary.write_bytes(b"new")
    assert path.read_bytes() == b"new"
    assert [p.name for p in tmp_path.iterdir()] == ["logs.npz"]


def test_importing_the_scenarios_leaves_the_matplotlib_backend_alone():
    """A notebook's backend (inline, widget...) must survive ``import drake_sot.diagrams``:
    plots use ``matplotlib.figure.Figure`` and never pyplot."""
    code = (
        "import sys, matplotlib\n"
        "before = matplotlib.rcParams['backend']\n"
        "import drake_sot.diagrams, drake_sot.plots, drake_sot.app.cli\n"
        "assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'\n"
        "print(before, matplotlib.get_backend())\n"
    )
    env = {**os.environ, "MPLBACKEND": "pdf"}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["pdf", "pdf"]


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("1,pelvis,0,300,0", "'1,pelvis,0,300,0': expected T,BODY,FX,FY,FZ,DURATION (6 fields), got 5"),
        ("abc,pelvis,0,300,0,0.1", "T = 'abc': must be a number"),
        ("-1,pelvis,0,300,0,0.1", "T = -1.0 s: must be finite and >= 0"),
        ("nan,pelvis,0,300,0,0.1", "T = nan s: must be finite and >= 0"),
        (
            "1,elbow,0,300,0,0.1",
            f"BODY: unknown frame 'elbow'; known: {', '.join(sorted(LOGICAL_FRAMES))}",
        ),
        ("1,pelvis,inf,300,0,0.1", "FX = inf: must be a finite number"),
        ("1,pelvis,0,N,0,0.1", "FY = 'N': must be a number"),
        ("1,pelvis,0,300,nan,0.1", "FZ = nan: must be a finite number"),
        ("1,pelvis,0,300,0,0", "DURATION = 0.0 s: must be finite and > 0"),
        ("1,pelvis,0,300,0,-0.1", "DURATION = -0.1 s: must be finite and > 0"),
    ],
)
def test_push_is_checked_at_parse_time(capsys, nothing_runs, value, message):
    err = _refused(capsys, ["run", "reach", f"--push={value}"])
    assert err.startswith(f"drake-sot run: error: argument --push: '{value}': ")
    assert message in err


def test_overlapping_pushes_on_one_frame_are_refused_at_parse_time(capsys, nothing_runs):
    err = _refused(
        capsys, ["run", "walk", "--push", "1,pelvis,0,300,0,0.5", "--push", "1.2,pelvis,0,-300,0,0.1"]
    )
    assert "--push: pushes on 'pelvis' overlap" in err


def test_a_study_takes_no_push(capsys, nothing_runs):
    err = _refused(capsys, ["run", "alpha_sweep", "--push", "1,pelvis,0,300,0,0.1"])
    assert "alpha_sweep takes no --push" in err
