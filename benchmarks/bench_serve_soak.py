"""Soak of the command server: ``drake-sot serve`` driven by its clients for minutes.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_serve_soak.py [--scenario walk_random]
        [--minutes 10] [--realtime 1] [--restack SECONDS] [--baseline COMMIT]

The server runs ``serve SCENARIO`` (paced at ``--realtime``, its artefacts into a temporary
``--out``; ``bench_remote.serve``), its output to a file; with ``--baseline``, the server is
``COMMIT``'s tree (``git archive``), the clients this tree's. Six clients, each
its own connection and thread, all the while:

- **reader**: ``read sot.errors``, each after a wait of 0-2 control periods (a program that
  follows the state about once a tick); its round trips, minute by minute;
- **writer** (where the scenario declares a 6D task's ``TASK.position_des``, as ``reach`` does,
  and its feature's ``error`` is readable; a hand's, ``…H.position_des``, where there is one): a
  teleoperated hand, writing the target at every
  control period of wall time, 1 cm around where the hand was when it started (found from the
  feature's error after one write), so that every write is applied and the run's events must
  stay bounded (``drake_sot.app.served_events``);
- **churn**: every 20 s, a new connection subscribes to ``sot.errors`` every 0.05 simulated s,
  takes 10 messages, unsubscribes and closes (a client that comes and goes);
- **rotation**: from the readable vector signals of ``list``, a new group of 4 every 15 s, each
  read about every 20 ms during its 15 s (the server publishes the signals read lately, at most
  ``WATCHED``, for at most ``WATCH_EXPIRY`` = 10 s after their last read);
- **restack** (with ``--restack``, every that many seconds of wall time): ``sot.rm taskPosture``,
  then ``sot.push taskPosture`` (the lowest task, back where it was), so that the stack changes
  two times a period for the whole run (an operator who toggles a task, a program that switches
  stacks): each change is a record of the stack's history
  (:class:`~drake_sot.systems.stack_history.StackHistory`), which must not slow the ticks down
  as the records pile up;
- **probes**: at the start of each group, one connection reads a signal of the group just ended
  (read < 0.1 s ago: published, answered at once) and another a signal of the group before it
  (last read > 15 s ago: expired, so the read waits for the next tick). The two round-trip
  medians over the run show whether the expiry works: the same medians mean a signal read no more
  is still published.

Every minute one row: simulated time, the pace over the minute (simulated / wall), the server's
resident memory (``VmRSS``) and CPU share, the reader's round trip (median, p99) and the errors
seen. At the end the server gets SIGTERM: it must exit with 143 and have written its logs.
Exits 1 when a client saw an error, the server did not end as it should or counted fewer requests
applied than the writes it acknowledged.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import signal
import statistics
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from baseline_tree import extract
from bench_remote import REPO, serve
from bench_soak import rss_mb

from drake_sot.app.serving import WATCH_EXPIRY
from drake_sot.remote import Client

PERIOD = 0.005  # [s] the control period
GROUP = 4  # signals a rotation group reads
PHASE = 15.0  # [s] of wall time a group is read: more than WATCH_EXPIRY
CHURN = 20.0  # [s] between two subscribing connections
RESTACKED = "taskPosture"  # the task the restack client removes and pushes back


def proc_stats(pid: int) -> tuple[float, float]:
    """Resident memory [MB] and CPU time (user + system) [s] of process ``pid``."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return rss_mb(pid), (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Soak:
    """The clients' threads and what they measured (each list appended by one thread)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.stop = threading.Event()
        self.errors: list[str] = []
        self.reads: list[tuple[float, float]] = []  # (wall time, round trip) of the reader
        self.t = 0.0  # the reader's last simulated time
        self.subscriptions = 0
        self.writes = 0
        self.restacks = 0  # stack changes applied by the restack client
        self.probes: dict[str, list[float]] = {"published": [], "expired": []}

    def thread(self, name: str, body: Callable[[], None]) -> threading.Thread:
        def guarded() -> None:
            try:
                body()
            except Exception as err:  # noqa: BLE001 (every failure is a finding of the soak)
                self.errors.append(f"{name}: {type(err).__name__}: {err}")
                self.stop.set()

        thread = threading.Thread(target=guarded, name=name, daemon=True)
        thread.start()
        return thread

    def reader(self) -> None:
        waits = random.Random(0)
        with Client(port=self.port) as client:
            while not self.stop.is_set():
                time.sleep(waits.uniform(0.0, 2.0 * PERIOD))
                start = time.perf_counter()
                client.read("sot.errors")
                self.reads.append((time.monotonic(), time.perf_counter() - start))
                self.t = client.t

    def writer(self) -> None:
        with Client(port=self.port) as client:
            writable = [name for name in client.list()["writable"] if name.endswith(".position_des")]
            writable.sort(key=lambda name: not name.endswith("H.position_des"))  # a hand's first
            if not writable:
                print("writer: the scenario declares no TASK.position_des: no writer")
                return
            signal_ = writable[0]
            feature = "feature" + signal_.removeprefix("task").removesuffix(".position_des") + ".error"
            guess = np.array(client.read("dyn.com")) + [0.3, -0.2, 0.2]
            client.write(signal_, guess)
            client.read("dyn.com")  # a tick later: the write acted
            held = guess + np.array(client.read(feature))[:3]  # error = p - p*: the hand's position
            start = time.monotonic()
            while not self.stop.is_set():
                phase = 2 * np.pi * 0.2 * (time.monotonic() - start)
                client.write(signal_, held + 0.01 * np.array([np.sin(phase), np.cos(phase), 0.0]))
                self.writes += 1
                time.sleep(PERIOD)

    def restack(self, every: float) -> None:
        with Client(port=self.port) as client:
            while not self.stop.wait(every):
                client.run(f"sot.rm {RESTACKED}")
                client.run(f"sot.push {RESTACKED}")
                self.restacks += 2

    def churn(self) -> None:
        while not self.stop.wait(CHURN):
            with Client(port=self.port) as client:
                stream = client.subscribe("sot.errors", 0.05)
                times = [next(stream)[0] for _ in range(10)]
                stream.close()
                if not all(b > a for a, b in zip(times, times[1:], strict=False)):
                    raise AssertionError(f"subscription times not increasing: {times}")
                self.subscriptions += 1

    def rotation(self) -> None:
        with Client(port=self.port) as client, Client(port=self.port) as near, Client(port=self.port) as far:
            listed = client.list()
            pool = [
                name
                for name, size in sorted(listed["readable"].items())
                if isinstance(size, int) and size > 0
            ]
            if len(pool) < 3 * GROUP:
                raise AssertionError(f"only {len(pool)} readable vector signals: {pool}")
            groups: list[list[str]] = []
            for k in range(10**9):
                if self.stop.is_set():
                    return
                group = [pool[(k * GROUP + i) % len(pool)] for i in range(GROUP)]
                if len(groups) >= 2:
                    for probe, kind, signal_ in (
                        (near, "published", groups[-1][0]),
                        (far, "expired", groups[-2][0]),
                    ):
                        start = time.perf_counter()
                        probe.read(signal_)
                        self.probes[kind].append(time.perf_counter() - start)
                groups.append(group)
                end = time.monotonic() + PHASE
                while time.monotonic() < end and not self.stop.is_set():
                    for name in group:
                        client.read(name)
                    time.sleep(0.02)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="walk_random")
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--realtime", default="1")
    ap.add_argument("--restack", type=float, help="[s] of wall time between two rm/push of the posture task")
    ap.add_argument("--baseline", help="serve from this commit's tree")
    args = ap.parse_args()
    if args.restack is not None and not args.restack > 0:
        sys.exit(f"--restack must be > 0 s, got {args.restack}")
    if not PHASE > WATCH_EXPIRY + 1.0:
        sys.exit(f"PHASE {PHASE} s must exceed WATCH_EXPIRY {WATCH_EXPIRY} s by a margin")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        log = out / "serve.log"
        extra = ["--out", str(out / "artefacts")]
        tree = REPO if args.baseline is None else extract(args.baseline, out / "tree")
        proc, _, port = serve(tree, args.realtime, args.scenario, duration="86400", extra=extra, log=log)
        soak = Soak(port)
        threads = [
            soak.thread(name, getattr(soak, name)) for name in ("reader", "writer", "churn", "rotation")
        ]
        if args.restack is not None:
            threads.append(soak.thread("restack", lambda: soak.restack(args.restack)))
        load = os.getloadavg()[0]
        served_tree = "this tree" if args.baseline is None else args.baseline
        print(
            f"serve {args.scenario} --realtime {args.realtime} ({served_tree}), {args.minutes:g} min, "
            f"restack every {args.restack} s, load {load:.1f}"
        )
        print(
            "| minute | simulated [s] | pace | server RSS [MB] | server CPU | read median / p99 [ms] |",
            end="",
        )
        print(" errors |")
        print("|---|---|---|---|---|---|---|")
        wall0, t0 = time.monotonic(), soak.t
        _, cpu0 = proc_stats(proc.pid)
        minute = 0
        while minute < args.minutes and not soak.stop.wait(min(60.0, 60.0 * (args.minutes - minute))):
            minute += 1
            now, t = time.monotonic(), soak.t
            rss, cpu = proc_stats(proc.pid)
            rtt = [r for w, r in soak.reads if w > now - 60.0]
            print(
                f"| {minute} | {t:.1f} | {(t - t0) / (now - wall0):.2f} | {rss:.0f} "
                f"| {(cpu - cpu0) / (now - wall0):.2f} "
                f"| {1e3 * statistics.median(rtt):.2f} / {1e3 * sorted(rtt)[int(0.99 * len(rtt))]:.2f} "
                f"| {len(soak.errors)} |",
                flush=True,
            )
            wall0, t0, cpu0 = now, t, cpu
        soak.stop.set()
        for thread in threads:
            thread.join(timeout=30)
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=120)
        logs = sorted(p.name for p in (out / "artefacts").glob("*.npz"))
        for kind, samples in soak.probes.items():
            if samples:
                median = 1e3 * statistics.median(samples)
                print(f"probe of a signal {kind}: median {median:.2f} ms over {len(samples)}")
        print(f"subscriptions that came and went: {soak.subscriptions}; server exit {code} on SIGTERM")
        served = re.search(r"served up to t = \S+ s; (\d+) requests applied", log.read_text())
        print(f"writes sent: {soak.writes}; stack changes: {soak.restacks}")
        print(f"the server's count of requests applied: {served and served[1]}")
        if logs:
            with np.load(out / "artefacts" / logs[0]) as arrays:
                print(f"events in the logs: {len(arrays['event_label'])}: {list(arrays['event_label'])[:4]}")
        print(f"logs written: {logs}")
        for error in soak.errors:
            print("error:", error)
        if soak.errors or code != 128 + signal.SIGTERM or not logs or served is None:
            print(log.read_text()[-3000:])
            sys.exit(1)
        sent = soak.writes + soak.restacks  # every one was answered ok: all of them were applied
        if int(served[1]) < sent:
            print(f"the server counted {served[1]} requests applied, fewer than the {sent} sent")
            sys.exit(1)


if __name__ == "__main__":
    main()
