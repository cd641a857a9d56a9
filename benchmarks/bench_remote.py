"""Round-trip time of the remote command server, beside the control period.

    python benchmarks/bench_remote.py [--scenario reach]
    python benchmarks/bench_remote.py --baseline 8074b69
    python benchmarks/bench_remote.py --baseline abdad51 --socket-thread


Starts ``drake-sot serve reach`` (or ``--scenario``'s; controller at 200 Hz, paced at 1 x real
time) and, from this process:

1. ``read sot.errors`` one at a time: round-trip time (median, p99) against the 5 ms control
   period, back to back and spaced by 0-2 periods of wall time. A read of a value the socket
   thread holds (the last tick's, of a signal read lately) is answered at once, once per tick
   and connection; another waits for the next tick, and its reply leaves after that tick (up to
   one period plus a tick's computation). Back to back, every other read asks again for the
   value it just got.
2. ``run sot.list`` pipelined (64 requests in flight): sustained commands per second applied,
   and refused by the per-connection rate limit, against the 200 ticks per second (every
   request queued before a tick is applied at that tick).
3. The simulated time the server advanced during the measurements, over the wall time: the
   pacing held (1.0) or not (< 1) while it served.

With ``--baseline COMMIT``: an A/B of the round trip of 1. instead. ``serve reach`` is started
from this tree and from ``COMMIT``'s tree (``git archive`` into a temporary directory, run with
``PYTHONPATH`` on it: ``drake_sot.app.cli``, or ``drake_sot.cli`` in a tree from before the
front-ends had their own package), one client each; blocks of ``read sot.errors`` alternate
between the two (the order swapped every block), so that both see the same machine load. Prints
each side's median and p99 and the median of the per-block ratios of medians (this tree /
baseline).

With ``--baseline COMMIT --socket-thread``: the same A/B of the socket thread alone, in this
process, without a simulation (whose pace, on a loaded machine, hides a change of the socket
thread): this tree's :class:`~drake_sot.remote.network.NetworkThread` and ``COMMIT``'s (its
``network.py`` loaded from the extracted tree; the protocol module is this tree's), each with a
token and one authenticated client, answer ``read`` from values published before each read (32
signals, as the serving loop publishes them after a tick), in blocks that alternate as above.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import os
import random
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

from baseline_tree import extract

from drake_sot.remote import Client
from drake_sot.remote.network import NetworkThread
from drake_sot.remote.protocol import encode

REPO = Path(__file__).resolve().parents[1]
PERIOD = 0.005
RATE = NetworkThread.__init__.__kwdefaults__["rate"]


def serve(
    tree: Path,
    realtime: str = "1",
    scenario: str = "reach",
    *,
    duration: str = "600",
    extra: Sequence[str] = (),
    log: Path | None = None,
) -> tuple[subprocess.Popen, str, int]:
    """``serve SCENARIO`` (free port, ``duration`` simulated s, paced at ``realtime`` x real time,
    ``extra`` arguments) from the ``drake_sot`` of ``tree``, run with ``PYTHONPATH`` on it and
    ``tree`` as working directory, its output into ``log`` (a temporary file when None: a pipe
    nobody reads would stop the server once full); returns the process and the address it serves
    on, read from its first line."""
    module = "drake_sot.app.cli" if (tree / "drake_sot" / "app" / "cli.py").exists() else "drake_sot.cli"
    temporary = log is None
    if log is None:  # unlinked once read: the server writes on into its open file
        log = Path(tempfile.mkstemp(prefix="serve-", suffix=".log")[1])
    with log.open("w") as stream:
        proc = subprocess.Popen(
            [sys.executable, "-m", module, "serve", scenario, "--port", "0", "--duration", duration]
            + ["--realtime", realtime, *extra],
            stdout=stream,
            stderr=subprocess.STDOUT,
            cwd=tree,
            env={**os.environ, "PYTHONPATH": str(tree)},
        )
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None:
            match = re.search(r"^serving on (\S+):(\d+)$", log.read_text(), re.MULTILINE)
            if match:
                return proc, match[1], int(match[2])
            time.sleep(0.1)
        proc.kill()
        proc.wait()
        raise RuntimeError(
            f"serve {scenario} from {tree} did not start; its output: {log.read_text()[-2000:]}"
        )
    finally:
        if temporary:
            log.unlink()


def round_trips(client: Client, count: int, spaced: bool = False) -> list[float]:
    """``count`` round trips of ``read sot.errors``, one at a time [s]; ``spaced``: each after a
    wait of 0 to 2 control periods of wall time (uniform, seeded), as a client that reads the
    state about once a tick (back to back, every other read asks again for the value it just
    got, which waits for the next tick)."""
    rtt = []
    waits = random.Random(0)
    for _ in range(count):
        if spaced:
            time.sleep(waits.uniform(0.0, 2.0 * PERIOD))
        start = time.perf_counter()
        client.read("sot.errors")
        rtt.append(time.perf_counter() - start)
    return rtt


def p99(samples: list[float]) -> float:
    """The 99th percentile of ``samples`` (the sample at rank ⌊0.99 n⌋ of the sorted list)."""
    return sorted(samples)[int(0.99 * len(samples))]


@contextlib.contextmanager
def stopped(proc: subprocess.Popen) -> Iterator[subprocess.Popen]:
    """``proc``, terminated and waited for on leaving the ``with`` block."""
    try:
        yield proc
    finally:
        proc.terminate()
        proc.wait()


def against_baseline(
    commit: str, blocks: int, block: int, realtime: str, settle: float, spaced: bool = False
) -> None:
    """The A/B of the module docstring: ``blocks`` alternations of ``block`` reads against a server
    of this tree and one of ``commit``'s tree, both paced at ``realtime`` x real time, once both
    have simulated ``settle`` seconds (the scenario's script done: both run the same stack)."""
    with tempfile.TemporaryDirectory() as baseline, contextlib.ExitStack() as stack:
        extract(commit, Path(baseline))
        clients = {}
        for name, tree in (("baseline", Path(baseline)), ("tree", REPO)):
            proc, host, port = serve(tree, realtime)
            stack.enter_context(stopped(proc))
            clients[name] = stack.enter_context(Client(host, port))
        for client in clients.values():
            while not client.t >= settle:
                client.read("sot.errors")
        start = {}
        for name, client in clients.items():  # client.t is its last read's: one read each, now
            client.read("sot.errors")
            start[name] = (client.t, time.perf_counter())
        samples: dict[str, list[float]] = {"baseline": [], "tree": []}
        ratios = []
        for k in range(blocks):
            order = ("baseline", "tree") if k % 2 == 0 else ("tree", "baseline")
            got = {name: round_trips(clients[name], block, spaced) for name in order}
            for name, rtt in got.items():
                samples[name] += rtt
            ratios.append(statistics.median(got["tree"]) / statistics.median(got["baseline"]))
        pace = {
            name: (client.t - start[name][0]) / (time.perf_counter() - start[name][1])
            for name, client in clients.items()
        }
    for name, label in (("tree", "this tree"), ("baseline", f"commit {commit}")):
        rtt = samples[name]
        print(
            f"read sot.errors round trip, {label}: median {1e3 * statistics.median(rtt):.2f} ms, "
            f"p99 {1e3 * p99(rtt):.2f} ms ({len(rtt)} reads); simulated / wall time {pace[name]:.2f}"
        )
    print(
        f"this tree / baseline: {statistics.median(ratios):.3f} (median of {blocks} per-block ratios of "
        f"medians, {block} reads a block); of all reads: "
        f"{statistics.median(samples['tree']) / statistics.median(samples['baseline']):.3f}; "
        f"control period {1e3 * PERIOD:.1f} ms"
    )


def socket_thread_against_baseline(commit: str, blocks: int, block: int) -> None:
    """The socket-thread A/B of the module docstring: ``blocks`` alternations of ``block`` reads."""
    with tempfile.TemporaryDirectory() as baseline:
        extract(commit, Path(baseline))
        spec = importlib.util.spec_from_file_location(
            "baseline_network", Path(baseline) / "drake_sot" / "remote" / "network.py"
        )
        module = sys.modules["baseline_network"] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    token = "bench-token"
    signals = [f"system{k}.port" for k in range(32)]
    # two ticks' values, in turn for each round of the signals: a read is answered once per tick
    ticks = [{signal: (float(t), [0.1, 0.2, 0.3], {}) for signal in signals} for t in (0, 1)]
    threads = {"baseline": module.NetworkThread, "tree": NetworkThread}
    with contextlib.ExitStack() as stack:
        clients = {}
        for name, kind in threads.items():
            thread = threads[name] = kind("127.0.0.1", 0, token=token)
            thread.start()
            stack.callback(thread.close)
            clients[name] = stack.enter_context(Client(*thread.address, token=token))
        samples: dict[str, list[float]] = {"baseline": [], "tree": []}
        ratios = []
        for k in range(blocks):
            order = ("baseline", "tree") if k % 2 == 0 else ("tree", "baseline")
            got = {}
            for name in order:
                rtt = got[name] = []
                for i in range(len(samples[name]), len(samples[name]) + block):
                    threads[name].publish(ticks[(i // len(signals)) % 2])
                    start = time.perf_counter()
                    clients[name].read(signals[i % len(signals)])
                    rtt.append(time.perf_counter() - start)
                samples[name] += rtt
            ratios.append(statistics.median(got["tree"]) / statistics.median(got["baseline"]))
    for name, label in (("tree", "this tree"), ("baseline", f"commit {commit}")):
        rtt = samples[name]
        print(
            f"socket thread alone, read round trip, {label}: median {1e6 * statistics.median(rtt):.0f} us, "
            f"p99 {1e6 * p99(rtt):.0f} us ({len(rtt)} reads)"
        )
    print(
        f"this tree / baseline: {statistics.median(ratios):.3f} (median of {blocks} per-block ratios of "
        f"medians, {block} reads a block); of all reads: "
        f"{statistics.median(samples['tree']) / statistics.median(samples['baseline']):.3f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--baseline", metavar="COMMIT", help="A/B the round trip against COMMIT's tree")
    parser.add_argument("--blocks", type=int, default=40, help="A/B blocks (default 40)")
    parser.add_argument("--block", type=int, default=25, help="reads per A/B block and side (default 25)")
    parser.add_argument(
        "--realtime",
        default="1",
        metavar="R",
        help="A/B: serve at R x real time (default 1; 1000: as fast as the machine goes)",
    )
    parser.add_argument(
        "--settle",
        type=float,
        default=8.0,
        metavar="S",
        help="A/B: measure once both servers have simulated S seconds (default 8: reach's script is done)",
    )
    parser.add_argument(
        "--spaced", action="store_true", help="A/B: reads spaced by 0-2 control periods (see round_trips)"
    )
    parser.add_argument(
        "--scenario", default="reach", metavar="NAME", help="the scenario served (default reach)"
    )
    parser.add_argument(
        "--socket-thread",
        action="store_true",
        help="A/B: the socket thread alone, in this process, no simulation (see the docstring)",
    )
    args = parser.parse_args()
    if args.baseline and args.socket_thread:
        socket_thread_against_baseline(args.baseline, args.blocks, args.block)
        return
    if args.baseline:
        against_baseline(args.baseline, args.blocks, args.block, args.realtime, args.settle, args.spaced)
        return
    proc, host, port = serve(REPO, scenario=args.scenario)
    with stopped(proc):
        with Client(host, port) as client:
            client.read("sot.errors")
            t0, wall0 = client.t, time.perf_counter()
            for spaced in (False, True):
                rtt = round_trips(client, 1000 if not spaced else 400, spaced)
                print(
                    f"read sot.errors round trip, {'spaced by 0-2 periods' if spaced else 'back to back'}: "
                    f"median {1e3 * statistics.median(rtt):.2f} ms, p99 {1e3 * p99(rtt):.2f} ms; "
                    f"control period {1e3 * PERIOD:.1f} ms"
                )
            sent = received = refused = 0
            start = time.perf_counter()
            while time.perf_counter() - start < 3.0:
                while sent - received < 64:
                    sent += 1
                    client.send_raw(encode({"id": sent, "op": "run", "cmd": "sot.list"}))
                message = client.receive()
                received += 1
                refused += not message["ok"]
            elapsed = time.perf_counter() - start
            while received < sent:
                client.receive()
                received += 1
            print(
                f"run sot.list pipelined: {(received - refused) / elapsed:.0f} commands/s applied, "
                f"{refused / elapsed:.0f}/s refused by the rate limit ({RATE:g}/s per connection); "
                f"ticks per second {1 / PERIOD:.0f}"
            )
            client.read("sot.errors")
            rtf = (client.t - t0) / (time.perf_counter() - wall0)
            print(f"simulated / wall time while serving {args.scenario}: {rtf:.2f} (paced at 1.0)")


if __name__ == "__main__":
    main()
