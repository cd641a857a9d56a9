"""The tele-cooperation in two processes: ``drake-sot serve telecoop_slave``
and ``drake-sot run telecoop_master --connect HOST:PORT`` on loopback for 10 s, against the
one-process ``telecooperation`` run at the same delay (140 ms one way).

The two processes run in conservative lookahead (each waits only for the packets that can
arrive by its next tick, ``telecoop_master``'s docstring), so they compute what one diagram
computes: every packet is delivered at the tick a ``Channel`` delivers it (asserted on what each
side received, by name), and the hands follow the one-process run's over the whole 10 s, the
walk's landings included (the bound is 1 cm; measured: 0 m, bitwise equal, in three
runs). Before this lockstep the writes acted when they reached the slave's wall clock, and the
runs parted by 10-349 mm after the walk's first lift-off.
"""

import json
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drake_sot.diagrams import SCENARIOS
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.diagrams.telecoop_master import PERIOD

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]
DURATION = 10.0
DELAY = 0.14
TIMEOUT = 900.0  # [s] of wall time for each process (the slave runs at ~0.3 x real time here)


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [*DRAKE_SOT, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO
    )


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("two_process")
    slave = _start(
        "serve", "telecoop_slave", "--port", "0", "--duration", str(DURATION), "--out", str(out / "slave")
    )
    try:
        first = slave.stdout.readline()
        match = re.fullmatch(r"serving on (\S+:\d+)\n", first)
        assert match is not None, (first, slave.stderr.read() if slave.poll() is not None else "")
        master = _start(
            "run",
            "telecoop_master",
            "--connect",
            match.group(1),
            "--duration",
            str(DURATION),
            "--delay",
            str(DELAY),
            "--out",
            str(out / "master"),
        )
        # the one-process run meanwhile, in this process
        one = run_scenario(
            SCENARIOS["telecooperation"],
            out / "one",
            duration=DURATION,
            record=False,
            parameters={"delay": DELAY},
        )
        master_out, master_err = master.communicate(timeout=TIMEOUT)
        slave_out, slave_err = slave.communicate(timeout=TIMEOUT)
    finally:
        for proc in (slave, *([master] if "master" in locals() else [])):
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    return {
        "one": one.arrays,
        "slave": dict(np.load(out / "slave" / "telecoop_slave.npz")),
        "master": dict(np.load(out / "master" / "telecoop_master.npz")),
        "codes": (slave.returncode, master.returncode),
        "text": (first + slave_out, slave_err, master_out, master_err),
    }


def test_both_processes_run_the_10_s_and_exit_0(runs):
    assert runs["codes"] == (0, 0), runs["text"]
    assert "served up to t = 10.000 s" in runs["text"][0]
    assert runs["slave"]["time"][-1] == pytest.approx(DURATION, abs=PERIOD)
    assert runs["master"]["time"][-1] == pytest.approx(DURATION, abs=PERIOD)


def _common(one: dict, two: dict) -> tuple[int, np.ndarray]:
    n = min(len(one["time"]), len(two["time"]))
    np.testing.assert_allclose(two["time"][:n], one["time"][:n], atol=1e-9)
    assert one["time"][n - 1] >= DURATION - PERIOD
    return n, one["time"][:n]


def test_each_side_receives_what_a_channel_delivers_at_the_same_ticks(runs):
    one = runs["one"]
    names = sorted(k for k in one if k.startswith("received_by_slave/"))
    assert len(names) == 4  # the master's four named signals
    n, _ = _common(one, runs["slave"])
    for name in names:
        # the operator's forces move all along: a packet applied a tick early or late would show
        np.testing.assert_array_equal(runs["slave"][name][:n], one[name][:n], err_msg=name)
    assert np.ptp(one["received_by_slave/right_hand_force"][:n], axis=0).max() > 1.0  # [N]
    n, _ = _common(one, runs["master"])
    for name in ("received_by_master", "delay_backward", "delay_forward"):
        np.testing.assert_allclose(runs["master"][name][:n], one[name][:n], atol=1e-9, err_msg=name)


def test_the_hands_match_the_one_process_run_within_1_cm_over_the_10_s(runs):
    one, slave = runs["one"], runs["slave"]
    n, t = _common(one, slave)
    hands_one, hands_two = one["robot_hands"][:n], slave["robot_hands"][:n]
    distance = np.linalg.norm((hands_two - hands_one).reshape(n, 2, 3), axis=2).max(axis=1)
    walking = np.flatnonzero(one["phase"][:n, 0] != 0)
    moved = np.linalg.norm((hands_one - hands_one[0]).reshape(-1, 2, 3), axis=2).max()
    print(
        f"hands: two-process vs one-process, max {distance.max():.3g} m over {t[-1]:.2f} s "
        f"(the hands moved up to {1000 * moved:.0f} mm; the walk's first lift-off at "
        f"{t[walking[0]] if len(walking) else float('nan'):.3f} s)"
    )
    assert len(walking) and t[walking[0]] < t[-1] - 2.0  # steps are inside the compared run
    assert moved > 0.05  # a motion of the hands is compared, not a standstill
    assert distance.max() < 0.01


def _serve_slave(out: Path) -> tuple[subprocess.Popen, tuple[str, int]]:
    slave = _start("serve", "telecoop_slave", "--port", "0", "--duration", str(DURATION), "--out", str(out))
    first = slave.stdout.readline()
    match = re.fullmatch(r"serving on (\S+):(\d+)\n", first)
    assert match is not None, (first, slave.stderr.read() if slave.poll() is not None else "")
    return slave, (match.group(1), int(match.group(2)))


def _timed_write(horizon: float) -> bytes:
    message = {"op": "write", "signal": "remote.head", "value": [0.0, 0.0], "t": 0.0, "at": 0.14}
    return json.dumps({**message, "horizon": horizon}).encode() + b"\n"


def test_a_slave_waiting_for_its_masters_horizon_stops_on_sigterm_or_when_the_master_leaves(tmp_path):
    # SIGTERM while it waits: the run stops there, writes its artefacts and exits 143
    slave, address = _serve_slave(tmp_path / "sigterm")
    try:
        with socket.create_connection(address) as sock:
            sock.sendall(_timed_write(0.05))  # the slave may simulate the ticks before 0.05 s
            with pytest.raises(subprocess.TimeoutExpired):
                slave.wait(timeout=5.0)  # it waits for the next horizon (for 60 s)
            slave.send_signal(signal.SIGTERM)
            out, err = slave.communicate(timeout=60.0)
        assert slave.returncode == 128 + signal.SIGTERM, (out, err)
        assert "served up to t = 0.050 s" in out
    finally:
        if slave.poll() is None:
            slave.kill()
            slave.wait()
    # the master leaves before its horizon passed the next tick: the run fails at once, saying so
    slave, address = _serve_slave(tmp_path / "left")
    try:
        with socket.create_connection(address) as sock:
            sock.sendall(_timed_write(0.05))
        out, err = slave.communicate(timeout=60.0)
        assert slave.returncode == 1, (out, err)
        assert (
            "the client pacing the run disconnected with its horizon at 0.050000 s, before the tick of "
            "t = 0.050000 s"
        ) in err
    finally:
        if slave.poll() is None:
            slave.kill()
            slave.wait()
