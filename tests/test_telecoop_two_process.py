"""The tele-cooperation in two processes (issue 12, point 4): ``drake-sot serve telecoop_slave``
and ``drake-sot run telecoop_master --connect HOST:PORT`` on loopback for 10 s, against the
one-process ``telecooperation`` run at the same delay (140 ms one way).

What is compared, and why the bound holds only up to the walk's first landing jump:

- the backward direction (slave → master) is emulated on the master's side with the slave's
  time stamps: the master receives the slave's own hands (its log) one delay earlier, to a tick;
- the forward direction (master → slave) crosses the protocol's ``write``, which acts at the
  slave's tick after it arrives: a write is mostly one tick late (compensated by one period,
  ``telecoop_master.FORWARD_LATENCY``), sometimes 0 or 2-7 ticks (measured in two runs: 0: 15-21 %,
  1: 68-73 %, 2: 9-10 %, 3-7: 1-2 %), so the slave's received forces are those of the one-process run give or
  take a tick;
- the hands then follow the one-process run's within 1 cm while standing and lifting the board,
  up to the walk's first lift-off (t ≈ 6.5 s), which is what is asserted. Once the robot walks, a
  tick of difference in the steps' timing changes the landings, and how far the runs part is
  down to the two processes' scheduling (measured: 0.5-3.9 mm up to 7.53 s, then 3.7-35 cm by
  10 s in four runs; in a fifth, 10.3 mm at most over the whole 10 s; the one-process run itself
  parts by 35 cm by 10 s from its own copy run with a delay one tick longer, 145 ms, after
  matching it within 2 mm up to 7.25 s). The issue's 1 cm over the 10 s is therefore printed,
  not asserted.
"""

import re
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
DRAKE_SOT = [sys.executable, "-m", "drake_sot.cli"]
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


def _lags(received: np.ndarray, sent: np.ndarray, start: int, lags: range) -> list[int | None]:
    """Per sample from ``start``: the smallest lag k in ``lags`` with received[i] == sent[i - k]."""
    found = []
    for i in range(start, min(len(received), len(sent))):
        match = [k for k in lags if 0 <= i - k < len(sent) and np.array_equal(received[i], sent[i - k])]
        found.append(match[0] if match else None)
    return found


def test_the_master_receives_the_slaves_hands_one_delay_late_on_the_slaves_clock(runs):
    # received_by_master at t: the packet delivered at the master's tick before, sent by the slave
    # `DELAY` before that: its hands at t - DELAY - PERIOD (the slave's own log), to a tick
    ticks = round((DELAY + PERIOD) / PERIOD)
    lags = _lags(
        runs["master"]["received_by_master"],
        runs["slave"]["robot_hands"],
        ticks + 10,
        range(ticks - 2, ticks + 3),
    )
    counts = {k: lags.count(k) for k in sorted(set(lags), key=lambda k: (k is None, k))}
    print(f"backward: samples by delay [ticks of {PERIOD} s]: {counts}")
    assert None not in counts
    assert set(counts) <= {ticks - 1, ticks}  # the delay, or one tick less (the stream's stamp)


def test_the_slave_applies_each_write_mostly_a_tick_after_the_master_sent_it(runs):
    # the master's sent_to_slave already went through the emulated delay (less one period)
    lags = _lags(runs["slave"]["received_by_slave"], runs["master"]["sent_to_slave"], 40, range(0, 11))
    counts = {k: lags.count(k) for k in sorted(set(lags), key=lambda k: (k is None, k))}
    print(f"forward: writes by latency [ticks of {PERIOD} s]: {counts}")
    assert None not in counts
    assert max(counts, key=counts.get) == 1  # mostly the one period compensated for
    # a tail of later writes under load (measured up to 7 ticks, 0.1-0.2 % of them, with the one-process
    # run beside on 2 busy cores); every value the slave held came from the master within 50 ms
    assert max(counts) <= 10


def test_the_hands_match_the_one_process_run_within_1_cm_up_to_the_first_lift_off(runs):
    one, slave = runs["one"], runs["slave"]
    n = min(len(one["time"]), len(slave["time"]))
    t = one["time"][:n]
    np.testing.assert_allclose(slave["time"][:n], t)
    hands_one, hands_two = one["robot_hands"][:n], slave["robot_hands"][:n]
    distance = np.linalg.norm((hands_two - hands_one).reshape(n, 2, 3), axis=2).max(axis=1)
    # the walk's first lift-off in the one-process run (the generator leaves double support)
    walking = np.flatnonzero(one["phase"][:n, 0] != 0)
    cut = t[walking[0]] if len(walking) else t[-1] + 1.0
    moved = np.linalg.norm((hands_one[t < cut] - hands_one[0]).reshape(-1, 2, 3), axis=2).max()
    print(
        f"hands: two-process vs one-process, max {1000 * distance[t < cut].max():.1f} mm before the first "
        f"lift-off at {cut:.3f} s, {1000 * distance.max():.0f} mm over {t[-1]:.2f} s "
        f"(at {t[np.argmax(distance)]:.3f} s); the hands moved up to {1000 * moved:.0f} mm before it"
    )
    assert moved > 0.01  # the comparison covers a motion of the hands, not a standstill
    assert cut > 4.0  # the interaction before the walk is inside the compared part
    assert distance[t < cut].max() < 0.01
