"""A served scenario in another process, for the tests that drive ``drake-sot serve`` as a client
does: :func:`start` it (its address read from its first line), :func:`stop` it."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


def start(*args, target="reach", env=None):
    """``drake-sot serve TARGET ARGS`` running: ``(process, host, port)``; the live view's address
    line is ``process.view``, the live plot's ``process.plot``."""
    proc = subprocess.Popen(
        [*DRAKE_SOT, "serve", target, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        env=env,
    )
    first = proc.stdout.readline()
    match = re.fullmatch(r"serving on (\S+):(\d+)\n", first)
    if match is None:
        proc.kill()
        pytest.fail(f"first line {first!r}; stderr: {proc.stderr.read()}")
    proc.view = proc.stdout.readline()  # the live view's address, second
    proc.plot = proc.stdout.readline()  # the live plot's, third
    return proc, match.group(1), int(match.group(2))


def stop(proc):
    """SIGTERM, then SIGKILL after 20 s."""
    proc.terminate()
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
