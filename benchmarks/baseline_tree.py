"""The source tree of an earlier commit, for the benchmarks that run it beside this one."""

from __future__ import annotations

import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def extract(commit: str, into: Path) -> Path:
    """The tree of ``commit`` (``git archive``) written into the directory ``into``; returns ``into``.
    Run it with ``PYTHONPATH`` on it: its ``drake_sot`` is the commit's."""
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", commit], check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive.stdout, check=True)
    return Path(into)
