"""A broken robot install gives one line naming the file and exit status 2, never a traceback:
a truncated URDF, one Drake cannot parse, a garbage STL, a mesh cache that is a file, a model
missing under an existing data root. Each case copies the G1 of example-robot-data into a data
root of its own (``$DRAKE_SOT_EXAMPLE_ROBOT_DATA``), breaks one file and runs the command."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from robot_data import robot_or_skip

from drake_sot.robots import RobotFileError
from drake_sot.robots.catalog import DATA_ENV
from drake_sot.robots.meshes import CACHE_ENV, converted_mesh

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]
TIMEOUT = 600  # [s] generous: converting the G1's meshes on a loaded machine
MODEL = Path("g1_description") / "urdf" / "g1_29dof_rev_1_0.urdf"


@pytest.fixture
def data_root(tmp_path) -> Path:
    """A copy of the G1's files (meshes linked, the URDF copied) under ``tmp/robots``."""
    g1 = robot_or_skip("g1")
    real = Path(g1.model_file).parents[2]
    root = tmp_path / "robots"
    (root / MODEL).parent.mkdir(parents=True)
    (root / MODEL).write_bytes((real / MODEL).read_bytes())
    meshes = root / "g1_description" / "meshes"
    meshes.mkdir()
    for mesh in (real / "g1_description" / "meshes").iterdir():
        (meshes / mesh.name).symlink_to(mesh)
    for other in real.iterdir():  # the other robots, as installed
        if other.name != "g1_description":
            (root / other.name).symlink_to(other)
    return root


def _command(argv: list[str], root: Path, cache: Path | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, DATA_ENV: str(root)}
    if cache is not None:
        env[CACHE_ENV] = str(cache)
    return subprocess.run([*DRAKE_SOT, *argv], capture_output=True, text=True, timeout=TIMEOUT, env=env)


def _one_line(proc: subprocess.CompletedProcess) -> str:
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    return lines[0]


def _run_g1(root: Path, tmp_path: Path, cache: Path | None = None) -> subprocess.CompletedProcess:
    out = tmp_path / "out"
    argv = ["run", "reach", "--robot", "g1", "--duration", "0.1", "--no-record", "--out", str(out)]
    return _command(argv, root, cache)


def test_a_truncated_urdf_is_named(data_root, tmp_path):
    model = data_root / MODEL
    model.write_bytes(model.read_bytes()[:20000])
    line = _one_line(_run_g1(data_root, tmp_path))
    assert str(model) in line and "not well-formed XML" in line


def test_a_urdf_drake_cannot_parse_is_named_with_drakes_reason(data_root, tmp_path):
    model = data_root / MODEL
    text = model.read_text()
    joint = '<joint name="left_wrist_yaw_joint" type="revolute">'
    assert text.count(joint) == 1
    model.write_text(text.replace(joint, joint.replace("revolute", "bogus")))
    line = _one_line(_run_g1(data_root, tmp_path))
    assert line.startswith(f"drake-sot: error: robot 'g1': model file {model}: Drake: ")
    assert "left_wrist_yaw_joint" in line and "bogus" in line


def test_a_garbage_stl_is_named(data_root, tmp_path):
    mesh = data_root / "g1_description" / "meshes" / "pelvis.STL"  # the model's first visual mesh
    mesh.unlink()
    mesh.write_bytes(bytes(range(256)) * 12)
    line = _one_line(_run_g1(data_root, tmp_path, cache=tmp_path / "cache"))
    assert f"mesh file {mesh}: cannot be read as a mesh" in line


def test_a_mesh_cache_that_is_a_file_is_named(data_root, tmp_path):
    cache = tmp_path / "cache"
    cache.write_text("not a directory")
    line = _one_line(_run_g1(data_root, tmp_path, cache=cache))
    assert f"mesh cache {cache}" in line and "not a directory" in line
    assert cache.read_text() == "not a directory"


def test_list_robots_names_a_model_missing_under_an_existing_data_root(data_root):
    (data_root / MODEL).unlink()
    proc = _command(["list", "--robots"], data_root)
    line = _one_line(proc)
    assert line == f"drake-sot list: error: robot g1: robot model file {data_root / MODEL} does not exist"
    names = [row.split()[0] for row in proc.stdout.splitlines()]
    assert names == ["embedded", "g1", "talos"]  # the listing is still complete


def test_a_mesh_cache_that_cannot_be_written_is_named_and_leaves_no_partial_entry(tmp_path, monkeypatch):
    """ENOSPC while the cache entry is written, in process: the error names the cache."""
    trimesh = pytest.importorskip("trimesh", reason="trimesh (drake_sot[robots]) converts meshes")
    source = tmp_path / "m.stl"
    trimesh.creation.box(extents=(0.1, 0.2, 0.3)).export(source)
    cache = tmp_path / "cache"

    class FullDisk:
        def __init__(self, *args, **kwargs):
            self.name = str(cache / "entry.tmp")
            Path(self.name).write_text("partial")

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, text):
            raise OSError(28, "No space left on device")

    cache.mkdir()
    monkeypatch.setattr(tempfile, "NamedTemporaryFile", FullDisk)
    with pytest.raises(RobotFileError, match=f"mesh cache {cache}: cannot write .*No space left on device"):
        converted_mesh(source, (1.0, -1.0, 1.0), cache)
    assert list(cache.iterdir()) == []


def test_no_home_directory_asks_for_the_mesh_cache_variable(tmp_path, monkeypatch):
    """A container run as a user id without a passwd entry and without ``$HOME``: the mesh a robot
    needs converted cannot go to ``~/.cache``; the error says which variable to set, in one line,
    instead of pathlib's RuntimeError. With the variable set, the mesh is converted."""
    trimesh = pytest.importorskip("trimesh", reason="trimesh (drake_sot[robots]) converts meshes")
    import pwd

    source = tmp_path / "m.stl"
    trimesh.creation.box(extents=(0.1, 0.2, 0.3)).export(source)
    monkeypatch.delenv("HOME", raising=False)
    monkeypatch.delenv(CACHE_ENV, raising=False)

    def no_entry(uid):
        raise KeyError(f"getpwuid(): uid not found: {uid}")

    monkeypatch.setattr(pwd, "getpwuid", no_entry)
    with pytest.raises(RuntimeError):
        Path.home()  # what the default used to raise, unnamed
    with pytest.raises(RobotFileError, match=f"set \\${CACHE_ENV} to a writable directory") as caught:
        converted_mesh(source)
    assert "\n" not in str(caught.value)
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    assert converted_mesh(source).parent == tmp_path / "cache"
