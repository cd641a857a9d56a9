"""The ``drake-sot`` command: ``drake-sot list`` and ``drake-sot run SCENARIO``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TextIO

from drake_sot.diagrams import SCENARIOS, STUDIES
from drake_sot.diagrams.scenario import run_scenario


class ProgressBar:
    """A one-line progress bar on a terminal; sparse plain lines otherwise (CI logs)."""

    def __init__(self, stream: TextIO = sys.stderr, width: int = 30, unit: str = "s simulated") -> None:
        self._unit = unit
        self._stream = stream
        self._width = width
        self._tty = stream.isatty()
        self._last_decile = -1

    def __call__(self, t: float, duration: float, wall: float) -> None:
        fraction = min(t / duration, 1.0)
        if self._unit == "s simulated":
            rtf = t / wall if wall > 0 else float("nan")
            text = f"{t:6.2f}/{duration:.2f} s simulated, real-time factor {rtf:4.2f}"
        else:
            text = f"{t:g}/{duration:g} {self._unit}, {wall:.0f} s"
        if self._tty:
            filled = int(round(fraction * self._width))
            self._stream.write(f"\r[{'#' * filled}{'.' * (self._width - filled)}] {text}")
            if fraction >= 1.0:
                self._stream.write("\n")
        elif int(fraction * 10) > self._last_decile:
            self._last_decile = int(fraction * 10)
            self._stream.write(f"{100 * fraction:3.0f}% {text}\n")
        self._stream.flush()


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="drake-sot", description="The Stack of Tasks on Drake.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the scenarios")
    run = sub.add_parser("run", help="simulate a scenario and write its artefacts")
    names = sorted(SCENARIOS) + sorted(STUDIES)
    run.add_argument("scenario", choices=names, metavar="SCENARIO", help=f"one of: {', '.join(names)}")
    run.add_argument("--duration", type=float, default=None, metavar="S", help="simulated seconds")
    run.add_argument("--out", default="out", metavar="DIR", help="output directory (default: out/)")
    run.add_argument("--no-record", action="store_true", help="no Meshcat replay (faster)")
    run.add_argument(
        "--workers", type=int, default=2, metavar="N", help="worker processes of a study (default 2)"
    )
    run.add_argument(
        "--transition",
        type=float,
        default=None,
        metavar="S",
        help="priority rearrangement period of table_pounding [s] (default 0.6; the paper also uses 0.015)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "list":
        for name in sorted(SCENARIOS):
            print(f"{name:20s} {SCENARIOS[name].description}")
        for name in sorted(STUDIES):
            print(f"{name:20s} {STUDIES[name].description}")
        return 0
    if args.duration is not None and args.duration <= 0:
        print(f"drake-sot: --duration must be > 0, got {args.duration}", file=sys.stderr)
        return 2
    if args.scenario in STUDIES:
        if args.workers < 1:
            print(f"drake-sot: --workers must be >= 1, got {args.workers}", file=sys.stderr)
            return 2
        kwargs = {"duration": args.duration} if args.duration is not None else {}
        files = STUDIES[args.scenario].run(
            args.out, workers=args.workers, progress=ProgressBar(unit="runs"), **kwargs
        )
        for path in files.values():
            print(f"wrote {path}")
        return 0
    parameters = {}
    if args.transition is not None:
        if args.transition < 0:
            print(f"drake-sot: --transition must be >= 0, got {args.transition}", file=sys.stderr)
            return 2
        parameters["transition"] = args.transition
    scenario = SCENARIOS[args.scenario]
    if set(parameters) - set(scenario.parameters):
        print(f"drake-sot: {args.scenario} takes no --transition", file=sys.stderr)
        return 2
    output = run_scenario(
        scenario,
        args.out,
        duration=args.duration,
        record=not args.no_record,
        progress=ProgressBar(),
        parameters=parameters,
    )
    result = output.result
    for path in output.files.values():
        print(f"wrote {path}")
    print(
        f"simulated {result.end_time:.2f} s in {result.wall_time:.1f} s "
        f"(real-time factor {result.realtime_factor:.2f})"
    )
    if result.interrupted:
        print("interrupted: the artefacts cover the simulated part", file=sys.stderr)
        return 130
    if result.failure is not None:
        print(f"the run failed at t = {result.end_time:.3f} s: {result.failure}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
