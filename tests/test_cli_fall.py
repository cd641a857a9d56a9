"""A run in which the robot fell ends as a fall (exit status 3) with every artefact written,
whatever raises after the fall is detected: the walk is pushed over, and its stabilizer, which
needs a support polygon, raises while the run settles after the fall."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from drake_sot.app.cli import FELL
from drake_sot.systems.fall_monitor import FallCriteria

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


@pytest.fixture(scope="module")
def pushed_over(tmp_path_factory):
    out = tmp_path_factory.mktemp("fell")
    argv = ["run", "walk_then_interact", "--duration", "4", "--no-record", "--out", str(out)]
    argv += ["--push", "1.0,torso,0,700,0,0.2"]
    proc = subprocess.run([*DRAKE_SOT, *argv], capture_output=True, text=True, timeout=1200)
    return proc, out


def test_a_push_that_throws_the_walker_down_ends_the_run_as_a_fall(pushed_over):
    proc, _ = pushed_over
    assert proc.returncode == FELL == 3, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "the run failed" not in proc.stderr
    assert "the robot fell at t = " in proc.stderr


def test_the_fallen_run_writes_every_artefact_of_what_was_simulated(pushed_over):
    proc, out = pushed_over
    names = ("walk_then_interact.svg", "walk_then_interact.npz", "walk_then_interact.png")
    for name in names:
        assert (out / name).stat().st_size > 0, name
        assert f"wrote {out / name}" in proc.stdout
    logs = np.load(out / "walk_then_interact.npz")
    fall_time, pelvis_height, tilt = logs["fall"]
    time = logs["time"]
    assert 1.0 < fall_time < time[-1] < 4.0  # after the push, and the run stopped before its end
    # the fall as the logged state shows it, against the monitor's thresholds
    criteria = FallCriteria()
    at_fall = int(np.argmin(np.abs(time - fall_time)))
    base_z = logs["q"][at_fall, 6]  # q = [quaternion, x, y, z, joints]; the base is the pelvis
    assert base_z == pytest.approx(pelvis_height, abs=0.02)
    assert pelvis_height < criteria.min_pelvis_height or tilt > criteria.max_tilt
    assert np.all(logs["fallen"][time >= fall_time + 0.01] == 1.0)


def test_the_fall_names_the_task_errors_before_it(pushed_over):
    proc, out = pushed_over
    line = next(x for x in proc.stderr.splitlines() if x.startswith("the largest task errors ‖e‖ at t = "))
    when = float(line.split("t = ")[1].split(" s")[0])
    logs = np.load(out / "walk_then_interact.npz")
    time = logs["time"]
    assert when < logs["fall"][0] <= when + 0.1 + 1e-9  # the last step of the run before the fall
    tick = int(np.searchsorted(time, when + 1e-9)) - 1
    named = [pair.rsplit(" ", 1) for pair in line.split("before the fall: ")[1].split(", ")]
    assert len(named) == 3
    for task, norm in named:  # as logged at that tick, against the printed 3 digits
        assert float(norm) == pytest.approx(np.linalg.norm(logs[f"error/{task}"][tick]), rel=6e-3, abs=1e-6)
