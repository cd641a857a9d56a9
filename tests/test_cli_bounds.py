"""The ``drake-sot`` command refuses absurd values of its options with one line naming the
bound (exit status 2), as a user types them: each case runs the real command in a subprocess."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from drake_sot.diagrams.alpha_sweep import MAX_WORKERS
from drake_sot.diagrams.pushes import MAX_PUSH_FORCE, ExternalPush
from drake_sot.diagrams.run import MAX_DURATION
from drake_sot.models.humanoid import FRAMES
from drake_sot.robots.description import LOGICAL_FRAMES

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]
TIMEOUT = 300  # [s] generous: a loaded machine imports Drake slowly


def _refused(argv: list[str], cwd=None) -> str:
    """The one line of stderr of the command ``drake-sot *argv``, which must exit with 2 and
    write nothing on stdout."""
    proc = subprocess.run([*DRAKE_SOT, *argv], capture_output=True, text=True, timeout=TIMEOUT, cwd=cwd)
    lines = [line for line in proc.stderr.splitlines() if not line.startswith("INFO:drake:")]
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    assert len(lines) == 1, proc.stderr
    return lines[0]


def test_the_bounds_are_what_their_documentation_says():
    """One simulated day, four workers per core, 10 kN: the values their comments justify."""
    assert MAX_DURATION == 86400.0
    assert MAX_WORKERS == 4 * os.cpu_count()
    assert MAX_PUSH_FORCE == 1e4


@pytest.mark.parametrize("value", ["1e300", "86400.5", "1" + "0" * 400, "1e999"])
def test_a_duration_beyond_one_simulated_day_is_refused(value):
    line = _refused(["run", "reach", "--duration", value])
    assert line.startswith("drake-sot run: error: argument --duration: duration = ")
    assert "must be" in line and ("86400" in line or "finite" in line)


@pytest.mark.parametrize(
    ("value", "message"), [("inf", "must be finite"), ("nan", "must be finite"), ("-1", "> 0")]
)
def test_a_duration_that_is_not_a_positive_number_is_refused(value, message):
    assert message in _refused(["run", "reach", f"--duration={value}"])


def test_serve_and_script_take_the_same_duration_bound(tmp_path):
    script = tmp_path / "s.sot"
    script.write_text("run 1\n")
    for argv in (["script", str(script)], ["serve", "reach"]):
        line = _refused([*argv, "--duration", "1e300"])
        assert "duration = 1e+300 s: must be in [0, 86400] s" in line


def test_more_workers_than_four_per_core_are_refused_naming_the_cap():
    line = _refused(["run", "alpha_sweep", "--workers", "100000"])
    assert f"workers = 100000: must be an integer in [1, {4 * os.cpu_count()}]" in line


def test_an_empty_out_is_refused_instead_of_writing_into_the_working_directory(tmp_path):
    before = sorted(os.listdir(tmp_path))
    line = _refused(["run", "reach", "--duration", "0.1", "--out", ""], cwd=tmp_path)
    assert "--out: output directory '': empty" in line
    assert sorted(os.listdir(tmp_path)) == before


def test_a_push_with_a_negative_time_is_refused_by_its_field_not_by_argparse():
    """argparse takes ``-1,...`` for an option ("expected one argument"); it reaches the check."""
    line = _refused(["run", "reach", "--push", "-1,pelvis,0,100,0,0.1"])
    assert line == (
        "drake-sot run: error: argument --push: '-1,pelvis,0,100,0,0.1': T = -1.0 s: must be finite and >= 0"
    )


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("1,pelvis,1e300,0,0,0.1", "|force| = 1e+300 N: must be in [0, 10000] N"),
        ("1,pelvis,8000,0,-8000,0.1", "|force| = 11313.7"),  # each component under the bound
        ("1e300,pelvis,0,100,0,0.1", "T = 1e+300 s: must be in [0, 86400] s"),
    ],
)
def test_a_push_beyond_its_bounds_is_refused_naming_the_bound(value, message):
    line = _refused(["run", "reach", "--push", value])
    assert line.startswith(f"drake-sot run: error: argument --push: '{value}': ")
    assert message in line
    assert "ConstantForce" not in line


def test_a_push_after_the_end_of_the_run_is_refused():
    line = _refused(["run", "reach", "--no-record", "--duration", "0.5", "--push", "1,pelvis,0,100,0,0.1"])
    assert "at t = 1 s starts after the run's end (duration = 0.5 s): it would never be applied" in line


def test_the_command_line_and_the_builders_know_the_same_logical_frames():
    """Every logical frame of a robot description, the embedded humanoid's included."""
    assert set(FRAMES) == set(LOGICAL_FRAMES)
    ExternalPush(1.0, "waist", (0.0, 100.0, 0.0), 0.1)


def test_a_push_on_the_waist_is_taken_and_applied(tmp_path):
    proc = subprocess.run(
        [*DRAKE_SOT, "run", "reach", "--no-record", "--duration", "0.3", "--out", str(tmp_path)]
        + ["--push", "0.1,waist,0,100,0,0.1"],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert proc.returncode == 0, proc.stderr
    logs = np.load(tmp_path / "reach.npz")
    (push,) = logs["pushes"]
    assert push["body"] == "waist" and push["time"] == 0.1 and tuple(push["force"]) == (0.0, 100.0, 0.0)
    forces = logs["push_forces"]
    during = (logs["time"] > 0.11) & (logs["time"] < 0.19)
    assert np.any(np.abs(forces[during]) == 100.0)
