"""A served scenario in another process, for the tests that drive ``drake-sot serve`` as a client
does: :func:`start` it (its address read from its first line), :func:`stop` it; or in this one,
for the tests of the serving loop alone: a :class:`FakeNetwork` in place of the socket thread,
and :func:`ticks` run as ``serve_run`` runs them, on a diagram such as :func:`feet_and_posture`'s."""

import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder

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


def feet_and_posture():
    """A small served humanoid: its feet held (``taskLF``, ``taskRF``, writable
    ``TASK.position_des``) above a posture task, with a command server."""
    b = HumanoidSoTBuilder()
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_posture_task("taskPosture", gain=1.0)
    return b.build(stack=("taskLF", "taskRF", "taskPosture"), command_server=True)


class FakeNetwork:
    """What ``Serving`` uses of the network thread: the queue it drains, the replies sent, the
    values published for reads answered at once (kept, not served) and the signals read from
    them (``hits``, set by a test)."""

    def __init__(self):
        self.queued, self.sent, self.published, self.order = [], [], {}, []
        self.hits = set()  # the signals "read from the published values" before the next tick

    def take_hits(self):
        hits, self.hits = self.hits, set()
        return hits

    def publish(self, snapshot):
        self.published = snapshot
        self.order.append("publish")

    def put(self, *requests):
        self.queued += [(0, r) for r in requests]

    def drain(self):
        items, self.queued = self.queued, []
        return items

    def send(self, connection, message):
        self.sent.append(message)
        self.order.append("send")

    def reply(self, request_id):
        return next(m for m in self.sent if m.get("id") == request_id)


def ticks(simulator, serving, n):
    """Run ``n`` more control ticks, the host's hook after each, as ``serve_run`` does."""
    for _ in range(n):
        k = math.floor(simulator.get_context().get_time() / serving.period + 0.5 + 1e-6)
        simulator.AdvanceTo((k + 0.5) * serving.period)  # past the tick at k·period, before the next
        serving.after_tick(simulator.get_context().get_time(), 10.0, 0.0)
