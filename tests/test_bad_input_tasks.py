"""Tasks and scripts refused whole: ``run`` lines that add up beyond the longest run, a task name
too long to key the logs (refused when the task is made, so no run ends without its artefacts),
and a task call refused at construction, which leaves the builder as it was (the corrected line
then adds the task and the diagram builds)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from drake_sot.diagrams.artifacts import MAX_ARRAY_NAME, Artefacts, write_npz
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.run import MAX_DURATION
from drake_sot.diagrams.script_session import load_script
from drake_sot.errors import UnknownNameError
from drake_sot.stack import MAX_TASK_NAME, StackError
from drake_sot.systems.task import Task

REPO = Path(__file__).resolve().parents[1]
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]
HUGE = "t" * 100_000


def _script(tmp_path: Path, text: str) -> subprocess.CompletedProcess:
    path = tmp_path / "bad.sot"
    path.write_text(text)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    argv = [*DRAKE_SOT, "script", str(path), "--out", str(tmp_path / "out"), "--no-record"]
    return subprocess.run(argv, capture_output=True, text=True, timeout=300, env=env, cwd=REPO)


def _refused(proc: subprocess.CompletedProcess, *names: str) -> str:
    """The one error line of a refused command (exit 2, no traceback, short), naming ``names``."""
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    (line,) = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert len(line) < 500, line[:600]
    for name in names:
        assert name in line, (name, line)
    return line


# --- run DURATION --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "names"),
    [
        ("run 1e308\n", ["bad.sot, line 1", "run 1e308", "1e+308 s", f"at most {MAX_DURATION:g} s"]),
        ("run 86000\nrun 1000\n", ["bad.sot, line 2", "run 1000", "87000 s"]),
    ],
)
def test_run_lines_beyond_the_longest_run_exit_2_naming_the_line(tmp_path, text, names):
    _refused(_script(tmp_path, text), *names)
    assert not (tmp_path / "out").exists()  # nothing simulated


def test_run_lines_within_the_longest_run_load():
    program = load_script(REPO / "examples" / "paper_III_B.sot")
    assert 0.0 < program.scripted_duration <= MAX_DURATION


# --- task names ---------------------------------------------------------------------------------


def test_a_huge_task_name_is_refused_when_the_task_is_made_naming_its_length():
    started = time.monotonic()
    with pytest.raises(StackError, match=f"has 100000 characters: at most {MAX_TASK_NAME}") as caught:
        Task(HUGE)
    assert len(str(caught.value)) < 200
    assert time.monotonic() - started < 1.0
    assert Task("t" * MAX_TASK_NAME).get_name() == "t" * MAX_TASK_NAME


def test_a_huge_task_name_in_a_script_exits_2_with_a_short_line(tmp_path):
    _refused(_script(tmp_path, f"new Task {HUGE}\nrun 0.05\n"), "bad.sot, line 1", "at most 128 characters")
    assert not (tmp_path / "out").exists()


def test_an_npz_name_beyond_the_zip_format_loses_that_file_only(tmp_path):
    """The write refuses the name before it writes anything, as an OSError: the artefacts after
    it are still written (before, the zip writer's struct.error ended the run's writing)."""
    artefacts = Artefacts()
    npz, png = tmp_path / "run.npz", tmp_path / "run.png"
    artefacts.write("npz", npz, lambda path: write_npz({"x" * (MAX_ARRAY_NAME + 1): np.zeros(2)}, path))
    artefacts.write("png", png, lambda path: path.write_bytes(b"picture"))
    assert str(npz) in artefacts.unwritten and "at most" in artefacts.unwritten[str(npz)]
    assert not npz.exists() and not list(tmp_path.glob("*.tmp*"))
    assert artefacts.files == {"png": png}
    write_npz({"x" * MAX_TASK_NAME: np.arange(3.0)}, npz)  # the longest task name keys an array
    assert np.load(npz)["x" * MAX_TASK_NAME].tolist() == [0.0, 1.0, 2.0]


# --- a refused call leaves the builder as it was -------------------------------------------------


def _state(b: HumanoidSoTBuilder) -> tuple:
    """What a task call may change: the systems, the connections, the tasks, features, op points."""
    return (
        sorted(s.get_name() for s in b.builder.GetSystems()),
        len(b.builder.connection_map()),
        tuple(b.tasks),
        tuple(b.features),
        tuple(b.dyn.operational_points),
    )


@pytest.fixture(scope="module")
def builder() -> HumanoidSoTBuilder:
    b = HumanoidSoTBuilder()
    b.add_com_task("taskCom")
    return b


REFUSED = [
    (lambda b: b.add_op_point_task("taskRH", "right_hand", selection="11100"), ValueError, "6 characters"),
    (
        lambda b: b.add_op_point_task("taskRH", "right_hand", selection=[1, 1, 1, 2, 0, 0]),
        ValueError,
        "flag 2",
    ),
    (lambda b: b.add_op_point_task(HUGE, "right_hand"), StackError, "100000 characters"),
    (lambda b: b.add_op_point_task("taskRH", "right_hand", gain=float("nan")), ValueError, "nan"),
    (lambda b: b.add_op_point_task("taskNose", "nose"), UnknownNameError, "unknown frame 'nose'"),
    (lambda b: b.add_relative_task("taskTwofeet", "right_foot", "left_fot"), UnknownNameError, "'left_fot'"),
    (lambda b: b.add_visual_point_task("taskGaze", None, camera="eye"), UnknownNameError, "'eye'"),
    (lambda b: b.add_com_task("taskCom"), ValueError, "exists already"),
    (
        lambda b: b.add_admittance_task("taskForce", "right", mass=1.0, damping=10.0, selection="111"),
        ValueError,
        "6 characters",
    ),
    (
        lambda b: b.add_admittance_task("taskForce", "right", mass=-1.0, damping=10.0),
        ValueError,
        "mass",
    ),
    (lambda b: b.add_above_plane_task("taskAbove", "nose"), UnknownNameError, "'nose'"),
    (
        lambda b: b.add_distance_task("taskApart", "right_hand", "nose", minimum=0.1),
        UnknownNameError,
        "'nose'",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), REFUSED)
def test_a_refused_task_call_leaves_the_builder_as_it_was(builder, call, error, message):
    before = _state(builder)
    with pytest.raises(error, match=message):
        call(builder)
    assert _state(builder) == before


def test_the_corrected_line_then_adds_the_task_and_the_diagram_builds():
    """The report's case: a bad selection, then the same line corrected: no "exists already",
    and the task has the 3 rows selected (the build checks every task's dimension)."""
    b = HumanoidSoTBuilder()
    with pytest.raises(ValueError, match="6 characters"):
        b.add_op_point_task("taskRH", "right_hand", selection="11100")
    task = b.add_op_point_task("taskRH", "right_hand", selection="111000")
    assert task.dimension == 3
    b.add_com_task("taskCom")
    built = b.build(stack=["taskCom", "taskRH"])
    assert set(built.tasks) == {"taskCom", "taskRH"}
