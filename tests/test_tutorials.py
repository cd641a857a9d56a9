"""Every tutorial runs as a plain script, and tutorial 01 shows the outcomes it claims.

Each ``tutorials/*.py`` runs in a subprocess with this interpreter, from the repository
root, writing its artefacts into a temporary ``DRAKE_SOT_OUT``. New tutorials are
picked up automatically.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((REPO / "tutorials").glob("*.py"))
TIMEOUT = 300.0  # [s] per tutorial; tutorial 01 takes a few seconds

pytestmark = pytest.mark.slow


@pytest.fixture(scope="session")
def run_tutorial(tmp_path_factory):
    """Run a tutorial once per session; returns (completed process, its output directory)."""
    runs: dict[Path, tuple[subprocess.CompletedProcess, Path]] = {}

    def run(path: Path) -> tuple[subprocess.CompletedProcess, Path]:
        if path not in runs:
            out = tmp_path_factory.mktemp(path.stem)
            env = dict(os.environ, DRAKE_SOT_OUT=str(out), MPLBACKEND="Agg")
            proc = subprocess.run(
                [sys.executable, str(path)],
                cwd=REPO,
                env=env,
                capture_output=True,
                text=True,
                timeout=TIMEOUT,
            )
            runs[path] = (proc, out)
        return runs[path]

    return run


def _report(proc: subprocess.CompletedProcess) -> str:
    return f"exit code {proc.returncode}\n--- stdout ---\n{proc.stdout}\n--- stderr ---\n{proc.stderr}"


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.name for p in TUTORIALS])
def test_tutorial_runs(path: Path, run_tutorial) -> None:
    proc, _ = run_tutorial(path)
    assert proc.returncode == 0, _report(proc)


# --- tutorial 01: the paper's script lines on the standing humanoid ------------------

TUTORIAL_01 = REPO / "tutorials" / "01_stack_of_tasks.py"


@pytest.fixture(scope="module")
def tutorial_01(run_tutorial) -> tuple[str, Path]:
    proc, out = run_tutorial(TUTORIAL_01)
    assert proc.returncode == 0, _report(proc)
    return proc.stdout, out


def _number(stdout: str, label: str) -> float:
    """The number printed on the line ``<label>: <number>[ unit]``."""
    match = re.search(rf"^{re.escape(label)}: ([-+0-9.eE]+)", stdout, re.MULTILINE)
    assert match, f"no line {label!r} in the output:\n{stdout}"
    return float(match.group(1))


def _stacks(stdout: str) -> dict[str, list[tuple[str, ...]]]:
    """Command -> stacks printed after it (``t = ... s  <command> -> stack = (...)``)."""
    stacks: dict[str, list[tuple[str, ...]]] = {}
    for match in re.finditer(r"^t = [0-9.]+ s  (.+?)\s+-> stack = \(([^)]*)\)", stdout, re.MULTILINE):
        names = tuple(re.findall(r"'([^']+)'", match.group(2)))
        stacks.setdefault(match.group(1), []).append(names)
    return stacks


def test_tutorial_01_commands_change_the_stack(tutorial_01) -> None:
    stdout, _ = tutorial_01
    stacks = _stacks(stdout)
    assert stacks["(initial)"] == [()]
    assert stacks["push taskTwofeet"] == [("taskLeftFoot", "taskTwofeet")]
    assert stacks["push taskCom"] == [("taskLeftFoot", "taskTwofeet", "taskCom")] * 2
    assert stacks["up taskCom"] == [("taskLeftFoot", "taskCom", "taskTwofeet")]
    assert stacks["down taskCom"] == [("taskLeftFoot", "taskTwofeet", "taskCom")]
    assert stacks["rm taskCom"] == [("taskLeftFoot", "taskTwofeet")]
    assert "final stack (highest priority first): taskLeftFoot > taskTwofeet > taskCom" in stdout


def test_tutorial_01_robot_stands_and_tracks(tutorial_01) -> None:
    stdout, _ = tutorial_01
    # Half-sitting pelvis height from the leg geometry, computed here independently.
    from drake_sot.models import half_sitting_configuration, make_control_model

    plant, info = make_control_model()
    pelvis_z0 = half_sitting_configuration(plant, info)[6]  # q = [quaternion, x, y, z, joints]
    assert 0.6 < pelvis_z0 < 0.7
    pelvis = _number(stdout, "pelvis height")
    assert abs(pelvis - pelvis_z0) < 0.02, "the robot fell or crouched"
    # The CoM ground projection reached the last target (3 cm to the left of the start).
    assert _number(stdout, "CoM xy error") < 0.005
    # The two feet stayed where they were, for the controller and on the simulated robot.
    assert _number(stdout, "featureTwofeet error norm") < 1e-4
    assert _number(stdout, "measured feet relative position error") < 0.005
    assert _number(stdout, "measured left foot drift") < 0.005


def test_tutorial_01_writes_the_graph(tutorial_01) -> None:
    stdout, out = tutorial_01
    assert "digraph" in stdout
    svg = out / "tutorial_01.svg"  # graphviz-pure, a dependency, renders it
    assert svg.is_file(), stdout
    text = svg.read_text()
    assert "<svg" in text and "featureTwofeet" in text and "taskCom" in text


def test_tutorial_01_plays_the_papers_script_into_the_same_diagram(tutorial_01):
    """The script section: the paper's lines beside their Python, every plug of the script a
    connection of the hand-wired diagram, and the script's robot where the script says."""
    stdout, _ = tutorial_01
    assert re.search(r"^set featureCom\.sdes featureComDes +\| builder\.Connect\(", stdout, re.MULTILINE)
    assert "script plugs that are connections of the hand-wired diagram: 8 of 8" in stdout
    assert "script stack at t = 4.0 s: taskLeftFoot taskTwofeet taskCom" in stdout
    assert _number(stdout, "script CoM xy error") < 0.005
