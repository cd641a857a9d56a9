"""Round-trip time of the remote command server, beside the control period.

    python benchmarks/bench_remote.py

Starts ``drake-sot serve reach`` (controller at 200 Hz, paced at 1 x real time) and, from
this process:

1. ``read sot.errors`` one at a time: round-trip time (median, p99) against the 5 ms control
   period. A request waits for the next tick, which applies it; the reply leaves after that
   tick, so a round trip is expected to take up to one period plus a tick's computation.
2. ``run sot.list`` pipelined (64 requests in flight): sustained commands per second applied,
   and refused by the per-connection rate limit, against the 200 ticks per second (every
   request queued before a tick is applied at that tick).
3. The simulated time the server advanced during the measurements, over the wall time: the
   pacing held (1.0) or not (< 1) while it served.
"""

from __future__ import annotations

import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

from drake_sot.remote import Client
from drake_sot.remote.network import NetworkThread
from drake_sot.remote.protocol import encode

REPO = Path(__file__).resolve().parents[1]
PERIOD = 0.005
RATE = NetworkThread.__init__.__kwdefaults__["rate"]


def main() -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "drake_sot.app.cli", "serve", "reach", "--port", "0", "--duration", "600"],
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )
    try:
        host, port = re.fullmatch(r"serving on (\S+):(\d+)\n", proc.stdout.readline()).groups()
        with Client(host, int(port)) as client:
            client.read("sot.errors")
            t0, wall0 = client.t, time.perf_counter()
            rtt = []
            for _ in range(1000):
                start = time.perf_counter()
                client.read("sot.errors")
                rtt.append(time.perf_counter() - start)
            rtt.sort()
            print(
                f"read sot.errors round trip: median {1e3 * statistics.median(rtt):.2f} ms, "
                f"p99 {1e3 * rtt[int(0.99 * len(rtt))]:.2f} ms; control period {1e3 * PERIOD:.1f} ms"
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
            print(f"simulated / wall time while serving: {rtf:.2f} (paced at 1.0)")
    finally:
        proc.terminate()
        proc.wait()


if __name__ == "__main__":
    main()
