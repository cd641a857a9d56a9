"""The Makefile's interpreter: ``make demo PYTHON=python3.X``, the README's way to pick another
Python, finds pyenv's 3.X when it is not on PATH, and an interpreter that does not run is named
before anything is created or installed (no apt-get for a Python that is not there)."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(
    shutil.which("make") is None, reason="no make on PATH: the Makefile is not run"
)


def _script(path: pathlib.Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    path.chmod(0o755)


@pytest.fixture
def machine(tmp_path: pathlib.Path) -> dict:
    """A PATH whose ``python3.97`` fails as pyenv's shim does for a version it does not enable,
    whose ``pyenv root`` is a directory of ours, and whose ``apt-get`` and ``sudo`` only record
    that they were called."""
    bin_dir, root = tmp_path / "bin", tmp_path / "pyenv"
    calls = tmp_path / "apt-calls"
    _script(bin_dir / "python3.97", "#!/bin/sh\necho 'pyenv: python3.97: command not found' >&2\nexit 127\n")
    _script(bin_dir / "pyenv", f'#!/bin/sh\n[ "$1" = root ] && echo {root}\n')
    for name in ("apt-get", "sudo"):
        _script(bin_dir / name, f'#!/bin/sh\necho {name} "$@" >> {calls}\n')
    root.mkdir()
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}"}
    return {"env": env, "root": root, "calls": calls, "venv": tmp_path / "venv"}


def _make(machine: dict, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["make", "--no-print-directory", "-C", str(ROOT), *args, f"VENV={machine['venv']}"],
        env=machine["env"],
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_a_python_that_pyenv_has_but_does_not_enable_is_found_there(machine: dict) -> None:
    found = machine["root"] / "versions" / "3.97.2" / "bin" / "python3.97"
    _script(found, f'#!/bin/sh\nexec {sys.executable} "$@"\n')
    plan = _make(machine, "-n", "demo", "PYTHON=python3.97")
    assert plan.returncode == 0, plan.stderr
    assert f"{found} -m venv {machine['venv']}" in plan.stdout


def test_a_python_that_runs_is_taken_as_given(machine: dict) -> None:
    plan = _make(machine, "-n", "demo", f"PYTHON={sys.executable}")
    assert plan.returncode == 0, plan.stderr
    assert f"{sys.executable} -m venv {machine['venv']}" in plan.stdout


def test_a_python_that_does_not_run_is_named_and_nothing_is_installed(machine: dict) -> None:
    result = _make(machine, "demo", "PYTHON=python3.97")
    assert result.returncode != 0
    assert "PYTHON=python3.97 does not run" in result.stderr
    assert not machine["calls"].exists(), machine["calls"].read_text()  # no apt-get for a missing Python
    assert not machine["venv"].exists()
