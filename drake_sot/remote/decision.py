"""A decision layer as a separate client process (the case study of Mansard et al. 2009, IV-B:
the DecisionServer drove the SoT through the coshell).

``python -m drake_sot.remote.decision --port P --signal pg.in_process --run "sot.rm taskRHwaist"
... --write remote.force_active=1`` polls ``--signal`` every ``--period`` simulated seconds (a
subscription); once it has seen it above 0.5 (the walk under way) and then below 0.5 (the
walk over), it sends each ``--run`` line, then each ``--write``, all at once (applied at one
control tick), and exits 0. Standard library
and :class:`~drake_sot.remote.client.Client` only: no Drake in this process.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from drake_sot.remote.client import Client, RemoteError


def decide(client: Client, signal: str, period: float, lines: Sequence[str], writes: Sequence[str]) -> float:
    """Wait for ``signal`` to rise above 0.5 and fall below it, then act; the simulated time of
    the poll that decided [s]."""
    walking, decided_at = False, float("nan")
    stream = client.subscribe(signal, period)
    for t, value in stream:
        if value[0] > 0.5:
            walking = True
        elif walking:
            decided_at = t
            break
    stream.close()
    requests = [{"op": "run", "cmd": line} for line in lines]
    for write in writes:
        name, _, values = write.partition("=")
        requests.append({"op": "write", "signal": name, "value": [float(x) for x in values.split(",")]})
    client.batch(requests)  # sent at once: applied at one tick, as the sequencer's entry actions
    return decided_at


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m drake_sot.remote.decision", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--token", default=None)
    parser.add_argument("--signal", default="pg.in_process")
    parser.add_argument("--period", type=float, default=1.0, help="poll period [s simulated]")
    parser.add_argument("--run", action="append", default=[], metavar="LINE")
    parser.add_argument("--write", action="append", default=[], metavar="SIGNAL=V1,V2")
    args = parser.parse_args(argv)
    try:
        with Client(args.host, args.port, token=args.token) as client:
            t = decide(client, args.signal, args.period, args.run, args.write)
    except (OSError, RemoteError) as exc:
        print(f"decision: {exc}", file=sys.stderr)
        return 1
    print(f"decision: {args.signal} fell at t = {t:.3f} s; sent {len(args.run)} commands", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
