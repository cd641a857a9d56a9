"""The ``drake-sot`` command: ``drake-sot list``, ``drake-sot run SCENARIO``,
``drake-sot script FILE`` (a SoT script, see :mod:`drake_sot.diagrams.script_session`),
``drake-sot serve SCENARIO|FILE`` (the remote command server, :mod:`drake_sot.remote`),
``drake-sot shell`` and ``drake-sot study NAME`` (:mod:`drake_sot.app.study`, its own exit statuses).

Exit status of ``run``, ``script`` and ``serve``: 0 the run completed, 1 it failed (the exception on
stderr), 2 bad arguments, a script that cannot be built or a robot file that is missing or
broken (one line on stderr naming it, nothing simulated), 3 the robot fell (when, on stderr),
4 the run ended but an artefact could not be written (a full disk: one line on stderr naming
the files; every other one was written), 130 interrupted by SIGINT (Ctrl-C), 143 by SIGTERM;
141 (any command) its standard output was closed by its reader (``drake-sot list | head -1``).
Interrupted, failed or fallen, the artefacts of the simulated part are written; a signal that
comes while they are written waits until they all are. ``list --robots`` exits with 2 when a
robot's files are installed but one is missing or broken.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from types import FrameType
from typing import Any, NoReturn, TextIO

from pydrake.systems.analysis import Simulator

from drake_sot.app.live_plot import LivePlot
from drake_sot.app.serving import decision_runner, serve_run
from drake_sot.app.study import EPILOG as STUDY_EPILOG
from drake_sot.app.study import add_arguments as study_arguments
from drake_sot.app.study import describe as describe_study
from drake_sot.app.study import study_command
from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams import PEERS, SCENARIOS, STUDIES
from drake_sot.diagrams.alpha_sweep import StudyScenario
from drake_sot.diagrams.artifacts import output_directory, report_unrendered, report_unwritten
from drake_sot.diagrams.collision_log import collision_report
from drake_sot.diagrams.pushes import MAX_PUSH_FORCE, ExternalPush, check_pushes
from drake_sot.diagrams.run import (
    MAX_DURATION,
    Interrupted,
    RunResult,
    SignalGuard,
    check_duration,
    fall_causes,
)
from drake_sot.diagrams.scenario import (
    ROBOT,
    NotServable,
    Scenario,
    ScenarioParameterError,
    ScenarioSetup,
    build_scenario,
    run_scenario,
)
from drake_sot.diagrams.script_session import ScriptProgram, SessionError, load_script, script_scenario
from drake_sot.diagrams.telecoop_master import PeerScenario
from drake_sot.diagrams.world import loopback_meshcat
from drake_sot.errors import UnknownNameError
from drake_sot.parameters import Parameter
from drake_sot.remote.network import NetworkThread
from drake_sot.remote.peer import PeerError
from drake_sot.remote.shell import DEFAULT_PORT, TOKEN_ENV, shell_main
from drake_sot.robots import ROBOTS, RobotDataMissing, RobotFileError, get_robot
from drake_sot.robots.catalog import INSTALL_HINT
from drake_sot.robots.description import LOGICAL_FRAMES
from drake_sot.robots.draft import draft_description
from drake_sot.script import ScriptError, Statement
from drake_sot.studies.catalog import STUDIES as CATALOG
from drake_sot.validation import bounded, finite, is_number, nonnegative, positive, positive_int

#: Exit status of a run in which the robot fell.
FELL = 3
#: Exit status of a run whose artefacts were not all written (a full disk).
UNWRITTEN = 4
#: Simulated seconds ``serve FILE`` runs a script without ``run SECONDS`` lines (and no --duration).
SERVED_SCRIPT_DURATION = 3600.0


class ProgressBar:
    """A one-line progress bar on a terminal; sparse plain lines otherwise (CI logs)."""

    def __init__(self, stream: TextIO = sys.stderr, width: int = 30, unit: str = "s simulated") -> None:
        self._unit = unit
        self._stream = stream
        self._width = width
        self._tty = stream.isatty()
        self._last_decile = -1
        self.started = False  # called at least once

    def __call__(self, t: float, duration: float, wall: float) -> None:
        self.started = True
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


class _Parser(argparse.ArgumentParser):
    """argparse, with an error as one line (``drake-sot run: error: ...``) and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def _checked(check: Callable[..., float | int], name: str, **kwargs) -> Callable[[str], float | int]:
    """An argparse ``type``: the text as a number (an int when it reads as one), checked by
    ``check(name, number, **kwargs)`` (a drake_sot.validation function) at parse time; its
    ValueError becomes argparse's one-line error, exit status 2."""

    def convert(text: str) -> float | int:
        try:
            number = int(text)
        except ValueError:
            number = None
        if number is None or abs(number) > sys.float_info.max:  # 1e999 or 400 digits: ±inf
            try:
                number = float(text)
            except ValueError:
                raise argparse.ArgumentTypeError(f"{name} = {text!r}: must be a number") from None
        try:
            return check(name, number, **kwargs)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return convert


#: The fields of ``--push`` and the check of each number (drake_sot.validation, named as the field).
_PUSH_FIELDS: dict[str, Callable[[str, float], float] | None] = {
    "T": lambda name, value: bounded(name, nonnegative(name, value, unit="s"), 0.0, MAX_DURATION, unit="s"),
    "BODY": None,
    "FX": finite,
    "FY": finite,
    "FZ": finite,
    "DURATION": lambda name, value: positive(name, value, unit="s"),
}


def _push(text: str) -> ExternalPush:
    """An argparse ``type``: ``T,BODY,FX,FY,FZ,DURATION`` (s, logical frame, N in the world
    frame, s) as an :class:`ExternalPush`; a bad field is named in argparse's one-line error
    (exit status 2)."""
    fields = [f.strip() for f in text.split(",")]
    if len(fields) != len(_PUSH_FIELDS):
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected {','.join(_PUSH_FIELDS)} ({len(_PUSH_FIELDS)} fields), got {len(fields)}"
        )
    values: dict[str, float] = {}
    for (name, check), field in zip(_PUSH_FIELDS.items(), fields, strict=True):
        if check is None:
            continue
        try:
            values[name] = check(name, float(field))
        except ValueError as exc:
            reason = str(exc) if is_number(field) else f"{name} = {field!r}: must be a number"
            raise argparse.ArgumentTypeError(f"{text!r}: {reason}") from None
    body = fields[1]
    if body not in LOGICAL_FRAMES:
        raise argparse.ArgumentTypeError(
            f"{text!r}: {UnknownNameError('frame', body, LOGICAL_FRAMES, where='BODY')}"
        )
    try:
        return ExternalPush(values["T"], body, (values["FX"], values["FY"], values["FZ"]), values["DURATION"])
    except ValueError as exc:  # a force beyond the bound
        raise argparse.ArgumentTypeError(f"{text!r}: {exc}") from None


def _joined_option_values(argv: Sequence[str], options: Sequence[str] = ("--push",)) -> list[str]:
    """``argv`` with ``OPTION VALUE`` written ``OPTION=VALUE`` when VALUE starts with '-' and
    holds a comma (``--push -1,pelvis,...``): argparse takes such a value for an option and
    says "expected one argument"; joined, the value is checked (and its field named) like any
    other. No option's name holds a comma, so nothing else is joined."""
    joined: list[str] = []
    pending = False
    for token in argv:
        if pending and token.startswith("-") and "," in token:
            joined[-1] = f"{joined[-1]}={token}"
        else:
            joined.append(token)
        pending = token in options
    return joined


# --- two-process mode ---
def _host_port(text: str) -> tuple[str, int]:
    """An argparse ``type``: ``HOST:PORT`` (PORT in 1-65535)."""
    host, colon, port = text.rpartition(":")
    if not colon or not host or not port.isdigit() or not (1 <= int(port) <= 65535):
        raise argparse.ArgumentTypeError(f"{text!r}: expected HOST:PORT, PORT in 1-65535")
    return host, int(port)


def _run_peer(args: argparse.Namespace, run: argparse.ArgumentParser, parameters: dict[str, Any]) -> int:
    """``drake-sot run PEER --connect HOST:PORT``: a scenario run as the client of a served one,
    with its ``parameters`` (checked)."""
    peer = PEERS[args.scenario]
    if args.connect is None:
        run.error(f"{args.scenario} needs --connect HOST:PORT (the address of the served scenario)")
    try:
        output_directory(args.out)
    except OSError as exc:
        run.error(f"--out: {exc}")
    parameters |= {"duration": args.duration} if args.duration is not None else {}
    token = args.token if args.token is not None else os.environ.get(TOKEN_ENV) or None
    progress = ProgressBar()

    def run_it() -> int:
        try:
            output = peer.run(*args.connect, args.out, token=token, progress=progress, **parameters)
        except PeerError as exc:  # could not connect: nothing simulated
            print(f"{args.scenario}: {exc}", file=sys.stderr)
            return 1
        except ValueError as exc:  # a parameter refused (e.g. a delay under one period): nothing simulated
            run.error(f"{args.scenario}: {exc}")
        for path in output.files.values():
            print(f"wrote {path}")
        report_unwritten(output.unwritten)
        if output.result.failure is not None:
            print(
                f"the run failed at t = {output.result.end_time:.3f} s: {output.result.failure}",
                file=sys.stderr,
            )
        return exit_status(output.result, output.unwritten)

    return _interruptible(run_it, progress, args.out)


# --- end two-process mode ---


#: The options each kind of ``run`` target takes besides its parameters' (two-process mode: a peer).
_SCENARIO_OPTIONS = ("--duration", "--out", "--no-record", "--fixed-camera", "--push")
_STUDY_OPTIONS = ("--duration", "--out")
_PEER_OPTIONS = ("--connect", "--token", "--duration", "--out")

#: What a runnable is to ``run``: the options it takes besides its parameters, and its parameters.
Takes = tuple[tuple[str, ...], tuple[Parameter, ...]]


def runnables(
    scenarios: Mapping[str, Scenario] | None = None,
    studies: Mapping[str, StudyScenario] | None = None,
    peers: Mapping[str, PeerScenario] | None = None,
) -> dict[str, Takes]:
    """Each target of ``run`` by name (by default :data:`~drake_sot.diagrams.SCENARIOS`,
    ``STUDIES`` and ``PEERS``) with what it takes; the key order is the listing's."""
    tables = (
        (SCENARIOS if scenarios is None else scenarios, _SCENARIO_OPTIONS),
        (STUDIES if studies is None else studies, _STUDY_OPTIONS),
        (PEERS if peers is None else peers, _PEER_OPTIONS),
    )
    return {
        name: (options, tuple(table[name].parameters)) for table, options in tables for name in sorted(table)
    }


def distinct_parameters(owners: Mapping[str, Sequence[Parameter]]) -> dict[str, tuple[Parameter, list[str]]]:
    """Each parameter ``owners`` (name → its parameters) declare, by name, with the owners that
    declare it (in their order).

    Raises:
        ValueError: two owners declare a name differently (one option cannot serve both).
    """
    found: dict[str, tuple[Parameter, list[str]]] = {}
    for owner, parameters in owners.items():
        for parameter in parameters:
            first, takers = found.setdefault(parameter.name, (parameter, []))
            if parameter != first:
                raise ValueError(
                    f"parameter {parameter.name!r}: {owner} declares {parameter}, {takers[0]} {first}: "
                    "one option cannot serve both"
                )
            takers.append(owner)
    return found


def _choice_or_path(parameter: Parameter) -> Callable[[str], str]:
    """An argparse ``type``: one of the ``parameter``'s choices or a path ending with one of its
    ``paths``; anything else is argparse's one-line error naming what is accepted (exit 2)."""

    def convert(text: str) -> str:
        try:
            return str(parameter.check(text))
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return convert


def _parameter_options(parser: argparse.ArgumentParser, owners: Mapping[str, Sequence[Parameter]]) -> None:
    """One option per distinct parameter of ``owners`` (:func:`distinct_parameters`), its value
    ``None`` when not given; its help names the owners, what it accepts and its default. A
    value the declaration refuses is argparse's one-line error naming the option (exit 2)."""
    for name, (parameter, takers) in distinct_parameters(owners).items():
        described = f"{', '.join(takers)}: {parameter.describe()}"
        if parameter.kind == "bool":
            parser.add_argument(
                parameter.option, dest=name, action="store_const", const=not parameter.default, help=described
            )
        elif parameter.kind == "choice" and parameter.paths:  # a name or a path: no argparse choices
            parser.add_argument(
                parameter.option,
                dest=name,
                type=_choice_or_path(parameter),
                metavar="NAME|PATH",
                help=described,
            )
        elif parameter.kind == "choice":
            parser.add_argument(parameter.option, dest=name, choices=parameter.choices, help=described)
        else:
            parser.add_argument(
                parameter.option,
                dest=name,
                type=_checked(lambda _, number, p=parameter: p.check(number), name),
                metavar=name.upper(),
                help=described,
            )


def _parser(
    targets: Mapping[str, Takes] | None = None, served: Mapping[str, Sequence[Parameter]] | None = None
) -> tuple[argparse.ArgumentParser, argparse.ArgumentParser, argparse.ArgumentParser]:
    """The command's parser and its ``run`` and ``script`` subparsers; ``run`` takes ``targets``
    (default :func:`runnables`), ``serve`` the parameters of ``served`` (default
    :func:`_served_parameters`)."""
    targets = runnables() if targets is None else targets
    parser = _Parser(prog="drake-sot", description="The Stack of Tasks on Drake.")
    sub = parser.add_subparsers(dest="command", required=True)
    listing = sub.add_parser(
        "list",
        help="list the scenarios, then the studies of 'drake-sot study' (or, with --robots, the robots)",
    )
    listing.add_argument("--robots", action="store_true", help="list the robots --robot takes")
    run = sub.add_parser(
        "run",
        help="simulate a scenario and write its artefacts",
        epilog="exit status: 0 completed, 1 failed, 2 bad arguments or robot files, 3 the robot fell, "
        "4 an artefact not written (a full disk), 130 interrupted (Ctrl-C), 143 SIGTERM",
    )
    names = list(targets)
    run.add_argument("scenario", choices=names, metavar="SCENARIO", help=f"one of: {', '.join(names)}")
    _simulation_options(
        run, f"simulated seconds (of each run of a study), finite, > 0 and at most {MAX_DURATION:g}"
    )
    _parameter_options(run, {name: parameters for name, (_, parameters) in targets.items()})
    peers = [name for name, (options, _) in targets.items() if "--connect" in options]
    # --- two-process mode: a scenario run as the client of a served one ---
    run.add_argument(
        "--connect",
        type=_host_port,
        default=None,
        metavar="HOST:PORT",
        help=f"{', '.join(peers)}: the address of the served scenario to connect to (required)",
    )
    run.add_argument(
        "--token",
        default=None,
        metavar="T",
        help=f"with --connect: the server's shared secret; give it in ${TOKEN_ENV} instead (the "
        "default): a --token value shows in `ps` to every user of the machine",
    )
    # --- end two-process mode ---
    run.add_argument(
        "--push",
        type=_push,
        action="append",
        default=[],
        metavar="T,BODY,FX,FY,FZ,DURATION",
        help="push the robot (repeatable): from T [s] for DURATION [s], a force (FX, FY, FZ) [N] in the "
        f"world frame on the origin of BODY, one of: {', '.join(LOGICAL_FRAMES)}; |F| at most "
        f"{MAX_PUSH_FORCE:g} N; T before the end of the run",
    )
    script = sub.add_parser(
        "script",
        help="run a SoT script (new, plug, set, sot.push, run SECONDS, ...) and write its artefacts",
        epilog="exit status: 0 completed, 1 failed, 2 bad arguments or script, 130 interrupted, 143 SIGTERM",
    )
    script.add_argument("file", metavar="FILE", help="the script (e.g. examples/paper_III_B.sot)")
    _parameter_options(script, {"script": (ROBOT,)})
    _simulation_options(
        script, "simulated seconds (default: what the script's 'run SECONDS' lines add up to)"
    )
    _remote_parsers(sub, _served_parameters() if served is None else served)
    robot = sub.add_parser(
        "robot", help="your own robot: 'robot draft MODEL > MODEL.toml' drafts its description"
    )
    actions = robot.add_subparsers(dest="action", required=True)
    draft = actions.add_parser(
        "draft",
        help="print a description file drafted from a URDF, SDF or MJCF model (frames, sole, sensors, "
        "half-sitting, gains)",
        epilog="write it beside the model under the model's name with .toml, check what its first lines "
        "say it could not guess, then: drake-sot run walk --robot MODEL.toml; exit status 2: a model "
        "file that is missing or cannot be read",
    )
    draft.add_argument(
        "model",
        metavar="MODEL",
        help="the robot's model file: a URDF (.urdf), an SDF (.sdf) or an MJCF (.xml)",
    )
    study_arguments(sub.add_parser("study", help="run a study (many runs) on Dask", epilog=STUDY_EPILOG))
    return parser, run, script


#: What ``serve`` calls a script file among the scenarios it serves.
SCRIPT_FILE = "a script FILE"


def _served_parameters() -> dict[str, tuple[Parameter, ...]]:
    """The parameters of what ``serve`` serves, by name: each servable scenario's, and a script
    file's (its robot)."""
    servable = {
        name: scenario.parameters for name, scenario in sorted(SCENARIOS.items()) if scenario.servable
    }
    return servable | {SCRIPT_FILE: (ROBOT,)}


def _remote_parsers(sub: argparse._SubParsersAction, served: Mapping[str, Sequence[Parameter]]) -> None:
    """``serve SCENARIO`` (taking the parameters of ``served``, by name) and ``shell``: the command
    server and its interactive client."""
    names = [name for name in served if name != SCRIPT_FILE]
    serve = sub.add_parser(
        "serve",
        help="run a scenario paced at R x real time while serving the remote command protocol",
        epilog=f"the first line on stdout is 'serving on HOST:PORT'; a token may also come from ${TOKEN_ENV}",
    )
    serve.add_argument(
        "target",
        metavar="SCENARIO|FILE",
        help=f"a scenario (one of: {', '.join(names)}) or a SoT script file (its run lines through 'run')",
    )
    serve.add_argument(
        "--duration",
        type=_checked(check_duration, "duration"),
        default=None,
        metavar="S",
        help=f"simulated seconds, at most {MAX_DURATION:g} (default: the scenario's, the script's run "
        f"lines, else {SERVED_SCRIPT_DURATION:g})",
    )
    serve.add_argument(
        "--realtime",
        type=_checked(positive, "realtime"),
        default=1.0,
        metavar="R",
        help="pace: R x real time (default 1.0)",
    )
    serve.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="write the usual artefacts in DIR (logs .npz, replay .html, plots, signal graph .svg); a served "
        "script's pool.writegraph writes there too, else into a fresh temporary directory (on stderr)",
    )
    _parameter_options(serve, served)
    _address_options(serve, "address to bind (default 127.0.0.1; any other needs a token)")
    shell = sub.add_parser("shell", help="the interactive coshell of a 'drake-sot serve' server")
    _address_options(shell, "server address (default 127.0.0.1)")


def _check_robot(parser: argparse.ArgumentParser, name: str | None) -> None:
    """Refuse (exit 2) a robot whose models are not installed, saying how to install them, or
    whose files are missing or broken, naming the file."""
    if name is not None:
        try:
            get_robot(name)
        except (RobotDataMissing, RobotFileError) as exc:
            parser.error(f"--robot {name}: {exc}")


def _draft(model: str, parser: argparse.ArgumentParser) -> int:
    """``robot draft MODEL``: the drafted description on stdout, how many things it could not
    guess on stderr; a model that is missing or cannot be read is one line on stderr, exit 2."""
    try:
        drafted = draft_description(model)
    except RobotFileError as exc:
        parser.exit(2, f"drake-sot robot draft: error: {exc}\n")
    sys.stdout.write(drafted.text)
    print(
        f"drafted; {len(drafted.unguessed)} things not guessed, listed at the top: check them",
        file=sys.stderr,
    )
    return 0


def _list_robots() -> int:
    """The robots and their titles on stdout; 2 when a robot's files are installed but one is
    missing or broken (one line on stderr naming it), else 0."""
    status = 0
    for name in sorted(ROBOTS):
        try:
            title = get_robot(name).title
        except RobotDataMissing:
            title = f"(not installed: {INSTALL_HINT})"
        except RobotFileError as exc:
            title = "(installed, but a file is missing or broken: see stderr)"
            print(f"drake-sot list: error: robot {name}: {exc}", file=sys.stderr)
            status = 2
        print(f"{name:20s} {title}")
    return status


def _address_options(parser: argparse.ArgumentParser, host_help: str) -> None:
    parser.add_argument("--host", default="127.0.0.1", help=host_help)
    parser.add_argument(
        "--port",
        type=_checked(positive_int, "port", minimum=0),
        default=DEFAULT_PORT,
        metavar="P",
        help=f"TCP port (default {DEFAULT_PORT}; 0 for a free one when serving)",
    )
    parser.add_argument(
        "--token",
        default=None,
        metavar="T",
        help=f"shared secret; give it in ${TOKEN_ENV} instead (the default): a --token value shows in "
        "`ps` to every user of the machine",
    )


def _simulation_options(parser: argparse.ArgumentParser, duration_help: str) -> None:
    """``--duration S``, ``--out DIR``, ``--no-record`` and ``--fixed-camera``."""
    parser.add_argument(
        "--duration",
        type=_checked(check_duration, "duration"),
        default=None,
        metavar="S",
        help=duration_help,
    )
    parser.add_argument(
        "--out", default="out", metavar="DIR", help="output directory, not empty (default: out/)"
    )
    parser.add_argument("--no-record", action="store_true", help="no Meshcat replay (faster)")
    parser.add_argument(
        "--fixed-camera",
        action="store_true",
        help="the replay's camera stays put instead of following the robot's pelvis",
    )


def exit_status(result: RunResult, unwritten: Mapping[str, str] | None = None) -> int:
    """0 completed, 1 failed, 3 fell, 4 (:data:`UNWRITTEN`) some of the ``unwritten`` files,
    128 + the signal's number when interrupted (130 SIGINT, 143 SIGTERM); a signal, then a
    failure, then unwritten files take precedence over a fall."""
    if result.interrupted_by is not None:
        return 128 + result.interrupted_by
    if result.failure is not None:
        return 1
    if unwritten:
        return UNWRITTEN
    return FELL if result.fell is not None else 0


#: The one line a ``--token`` on the command line gets on stderr: argv is not a secret.
TOKEN_IN_ARGV = (
    f"drake-sot: warning: --token shows in /proc/PID/cmdline (`ps`) to every user of this machine; "
    f"give it in ${TOKEN_ENV} instead"
)

#: The exit status of a command whose standard output's reader went away (``drake-sot list | head``),
#: as for a process ended by SIGPIPE (128 + 13).
EXIT_BROKEN_PIPE = 141


def main(argv: Sequence[str] | None = None) -> int:
    """The ``drake-sot`` command; its exit status (documented in the module docstring)."""
    try:
        status = _main(argv)
        sys.stdout.flush()  # here, not at the interpreter's exit, where a broken pipe is a traceback
        return status
    except BrokenPipeError:
        # No traceback for a closed reader; stdout to /dev/null so that the final flush is quiet.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE


def _main(argv: Sequence[str] | None) -> int:
    parser, run, script = _parser()
    args = parser.parse_args(_joined_option_values(sys.argv[1:] if argv is None else argv))
    if getattr(args, "token", None) is not None:  # serve, shell, run --connect
        print(TOKEN_IN_ARGV, file=sys.stderr, flush=True)
    limit_blas_threads(1)  # small matrices: one BLAS thread (drake_sot.blas says why)
    if args.command == "script":
        return _script(args, script)
    if args.command == "study":
        return study_command(args)
    if args.command in ("serve", "shell"):
        args.token = args.token if args.token is not None else os.environ.get(TOKEN_ENV) or None
        return (
            _serve(args, parser) if args.command == "serve" else shell_main(args.host, args.port, args.token)
        )
    if args.command == "robot":
        return _draft(args.model, parser)
    if args.command == "list" and args.robots:
        return _list_robots()
    if args.command == "list":
        for name in sorted(SCENARIOS):
            print(f"{name:20s} {SCENARIOS[name].description}")
        for name in sorted(STUDIES):
            print(f"{name:20s} {STUDIES[name].description}")
        for name in sorted(PEERS):  # two-process mode
            print(f"{name:20s} {PEERS[name].description}")
        for name, study in sorted(CATALOG.items()):  # drake-sot study NAME
            print(f"{'study ' + name:20s} {describe_study(study)}")
        return 0
    targets = runnables()
    options, declared = targets[args.scenario]
    _refuse_untaken(run, args, args.scenario, (*options, *(p.option for p in declared)), targets)
    parameters = {p.name: getattr(args, p.name) for p in declared if getattr(args, p.name) is not None}
    if args.scenario in PEERS:  # two-process mode
        return _run_peer(args, run, parameters)
    _check_robot(run, args.robot)
    try:
        check_pushes(args.push, LOGICAL_FRAMES)
    except ValueError as exc:
        run.error(f"--push: {exc}")
    try:
        output_directory(args.out)
    except OSError as exc:
        run.error(f"--out: {exc}")
    if args.scenario in STUDIES:
        progress = ProgressBar(unit="runs")
        return _interruptible(lambda: _run_study(args, parameters, progress), progress, args.out, study=True)
    return _run_scenario(SCENARIOS[args.scenario], args, parameters)


def _refuse_untaken(
    parser: argparse.ArgumentParser,
    args: argparse.Namespace,
    target: str,
    takes: Sequence[str],
    targets: Mapping[str, Takes],
) -> None:
    """Exit 2 (one line: "``target`` takes no --X (it takes ...)") when ``args`` gives an
    option of ``run`` that ``target`` does not take (``takes``); an option of ``targets`` is
    given when its value is not None, False or empty."""
    fixed = {option for options, _ in targets.values() for option in options}
    given = [option for option in sorted(fixed) if getattr(args, option[2:].replace("-", "_"), None)]
    declared = distinct_parameters({name: parameters for name, (_, parameters) in targets.items()})
    given += [
        parameter.option for name, (parameter, _) in declared.items() if getattr(args, name) is not None
    ]
    refused = [option for option in given if option not in takes]
    if refused:
        parser.error(f"{target} takes no {refused[0]} (it takes {', '.join(takes)})")


def _script(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``drake-sot script FILE``: the script read and checked, then run as a scenario."""
    try:
        program: ScriptProgram = load_script(args.file)
    except (ScriptError, SessionError) as exc:
        parser.error(str(exc))
    duration = args.duration if args.duration is not None else program.scripted_duration
    if not (duration > 0):
        parser.error(f"{args.file} simulates nothing: give --duration S or add 'run SECONDS' lines")
    try:
        output_directory(args.out)
    except OSError as exc:
        parser.error(f"--out: {exc}")
    args.duration = duration
    _check_robot(parser, args.robot)
    scenario = script_scenario(program, output_dir=args.out, echo=_echo, robot=args.robot or "embedded")
    try:
        return _run_scenario(scenario, args, {})
    except SessionError as exc:  # raised while the script built its diagram: nothing simulated
        parser.error(str(exc))


def _serve(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``drake-sot serve``: bind (refused before anything is built when unsafe), build, serve."""
    if args.port > 65535:
        parser.error(f"port = {args.port}: at most 65535")
    _check_robot(parser, args.robot)
    served, duration = _served(args.target, parser)
    args.duration = duration if args.duration is None else args.duration
    declared = SCENARIOS[args.target].parameters if args.target in SCENARIOS else (ROBOT,)
    targets = {name: ((), parameters) for name, parameters in _served_parameters().items()}
    _refuse_untaken(parser, args, f"serve: {args.target}", [p.option for p in declared], targets)
    # (an option serve has not, of a scenario it cannot serve: never given)
    parameters = {p.name: getattr(args, p.name, None) for p in declared}
    parameters = {name: value for name, value in parameters.items() if value is not None}
    if args.target not in SCENARIOS:  # a script: its robot went to script_scenario
        parameters = {}
    if args.out is not None:
        try:
            output_directory(args.out)
        except OSError as exc:
            parser.error(f"--out: {exc}")
    try:
        network = NetworkThread(args.host, args.port, token=args.token)
    except (ValueError, OSError) as exc:
        parser.error(f"serve: {exc}")
    # bound: only now is a script's fresh directory made (a refusal before leaves nothing behind)
    fresh = None
    if isinstance(served, Scenario):
        scenario = served
    else:
        scenario, fresh = _served_script(served, args.out, args.robot)

    bar = ProgressBar()  # not drawn: it says when a signal came (before the run, or after it)

    def runner(setup: ScenarioSetup, simulator: Simulator, duration: float, **kwargs) -> RunResult:
        bar.started = True
        plot = LivePlot()

        def ready(address: tuple[str, int]) -> None:
            print(f"serving on {address[0]}:{address[1]}", flush=True)
            view = setup.built.meshcat.web_url()
            print(f"live view (stack and task errors in the controls): {view}", flush=True)
            print(f"live plot (task errors over time, the stack): {plot.url}", flush=True)
            # --- two-process mode: one half of a run starts with its peer ---
            if setup.extras.wait_for_client:
                print("waiting for the first client before the run starts", flush=True)
                network.connected.wait()
            # --- end two-process mode ---

        try:
            result = serve_run(
                setup,
                simulator,
                network,
                duration,
                realtime=args.realtime,
                on_ready=ready,
                live_plot=plot,
                **kwargs,
            )
        finally:
            plot.close()
        print(
            f"served up to t = {result.end_time:.3f} s; {result.requests_applied} requests applied; "
            f"{result.wall_time:.1f} s of wall time (real-time factor {result.realtime_factor:.2f}, "
            f"paced at {args.realtime:g})",
            flush=True,
        )
        return result

    def serve() -> int:
        try:
            if args.out is not None:  # the usual artefacts
                output = run_scenario(
                    scenario,
                    args.out,
                    duration=args.duration,
                    runner=runner,
                    parameters=parameters,
                    command_server=True,
                )
                for path in output.files.values():
                    print(f"wrote {path}", flush=True)
                report_unwritten(output.unwritten)
                report_unrendered(output.unrendered)
                for line in collision_report(output.arrays):
                    print(line, flush=True)
                unwritten = output.unwritten
                result = output.result
            else:
                unwritten = {}
                setup = build_scenario(
                    scenario, loopback_meshcat(), parameters=parameters, command_server=True
                )
                simulator = setup.built.create_simulator()
                duration = setup.duration if args.duration is None else args.duration
                with SignalGuard() as guard:
                    result = runner(setup, simulator, duration, guard=guard)
        except (SessionError, NotServable, ScenarioParameterError, RobotFileError) as exc:  # nothing served
            network.close()
            parser.error(f"serve {args.target}: {exc}")
        if result.failure is not None:
            print(f"the run failed at t = {result.end_time:.3f} s: {result.failure}", file=sys.stderr)
        return exit_status(result, unwritten)

    try:
        return _interruptible(serve, bar, args.out or "no output directory")
    finally:
        if fresh is not None:  # what the clients wrote there lived as long as the server
            shutil.rmtree(fresh, ignore_errors=True)


def _served(target: str, parser: argparse.ArgumentParser) -> tuple[Scenario | ScriptProgram, float | None]:
    """The scenario named ``target``, or the script loaded from the file ``target``; and its
    default duration (None: the scenario's own)."""
    if target in SCENARIOS:
        return SCENARIOS[target], None
    if not os.path.isfile(target):
        parser.error(f"serve: {target!r} is neither a scenario ({', '.join(sorted(SCENARIOS))}) nor a file")
    try:
        program = load_script(target)
    except (ScriptError, SessionError) as exc:
        parser.error(str(exc))
    return program, program.scripted_duration if program.scripted_duration > 0 else SERVED_SCRIPT_DURATION


def _served_script(program: ScriptProgram, out: str | None, robot: str | None) -> tuple[Scenario, str | None]:
    """The scenario of a served script driving ``robot`` (None: the embedded one), its files in
    ``out`` or, when None, in a fresh directory (never the working one), named on stderr, which the
    server removes when it stops; and that fresh directory (None: ``out`` was given)."""
    fresh = None
    if out is None:
        out = fresh = tempfile.mkdtemp(prefix=f"drake_sot_{program.path.stem}_")
        print(
            f"the script writes its files (pool.writegraph) into {out} (removed when the server stops)",
            file=sys.stderr,
            flush=True,
        )
    scenario = script_scenario(program, output_dir=out, echo=_echo_stderr, robot=robot or "embedded")
    return scenario, fresh


def _echo(statement: Statement, time: float, output: str, stream: TextIO | None = None) -> None:
    """A script command's output on stdout (or ``stream``), under its time and line."""
    print(f"t = {time:.3f} s  {statement.where}: {statement.text}", file=stream)
    print("\n".join(f"  {line}" for line in output.splitlines()), file=stream, flush=True)


def _echo_stderr(statement: Statement, time: float, output: str) -> None:
    """:func:`_echo` on stderr (a server's stdout starts with its address)."""
    _echo(statement, time, output, sys.stderr)


def _interruptible(run: Callable[[], int], progress: ProgressBar, out: str, *, study: bool = False) -> int:
    """``run()``, with SIGTERM as Ctrl-C; an interruption outside the simulation is reported and
    gives 128 + the signal's number."""
    try:
        with _sigterm_as_interrupt():
            return run()
    except KeyboardInterrupt as exc:  # before the simulation, or held while its artefacts were written
        signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
        if study:
            when = f": the runs done (and which, 'done') are in {out}"
        elif progress.started:
            when = f" while the artefacts were written: they all were, in {out}"
        else:
            when = " before the simulation started"
        print(f"interrupted by {signum.name}{when}", file=sys.stderr)
        return 128 + signum


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM raises :class:`Interrupted` as Ctrl-C raises KeyboardInterrupt, so that the command
    always ends by its own exit status (143) instead of being killed mid-way. Main thread only,
    and only when SIGTERM has its default action."""
    if threading.current_thread() is not threading.main_thread() or (
        signal.getsignal(signal.SIGTERM) != signal.SIG_DFL
    ):
        yield
        return
    signal.signal(signal.SIGTERM, _raise_interrupted)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _raise_interrupted(signum: int, frame: FrameType | None) -> NoReturn:
    raise Interrupted(signum)


def _run_study(args: argparse.Namespace, parameters: dict[str, Any], progress: ProgressBar) -> int:
    kwargs = {"duration": args.duration} if args.duration is not None else {}
    artefacts = STUDIES[args.scenario].run(args.out, progress=progress, **parameters, **kwargs)
    for path in artefacts.files.values():
        print(f"wrote {path}")
    report_unwritten(artefacts.unwritten)
    return UNWRITTEN if artefacts.unwritten else 0


def _run_scenario(scenario: Scenario, args: argparse.Namespace, parameters: dict) -> int:
    progress = ProgressBar()
    return _interruptible(lambda: _simulate(scenario, args, parameters, progress), progress, args.out)


def _simulate(scenario: Scenario, args: argparse.Namespace, parameters: dict, progress: ProgressBar) -> int:
    try:
        output = run_scenario(
            scenario,
            args.out,
            duration=args.duration,
            record=not args.no_record,
            fixed_camera=args.fixed_camera,
            progress=progress,
            parameters=parameters,
            pushes=getattr(args, "push", None) or (),  # `script` takes no --push
            runner=decision_runner() if parameters.get("decision") == "remote" else None,
        )
    except (
        ScenarioParameterError,
        RobotFileError,
    ) as exc:  # a usage error, a broken robot: nothing simulated
        print(f"drake-sot: error: {exc}", file=sys.stderr)
        return 2
    result = output.result
    for path in output.files.values():
        print(f"wrote {path}")
    report_unwritten(output.unwritten)
    report_unrendered(output.unrendered)
    print(
        f"simulated {result.end_time:.2f} s in {result.wall_time:.1f} s "
        f"(real-time factor {result.realtime_factor:.2f})"
    )
    for line in collision_report(output.arrays):
        print(line)
    time = output.arrays.get("time")
    if time is not None and len(time) and time[0] > 0.0:
        print(f"the logs cover the run's last {time[-1] - time[0]:.1f} s (from t = {time[0]:.1f} s)")
    if result.replay_until is not None:
        print(f"the replay covers the run's first {result.replay_until:.1f} s")
    if result.interrupted_by is not None:
        print(
            f"interrupted by {result.interrupted_by.name}: the artefacts cover the simulated part",
            file=sys.stderr,
        )
    elif result.failure is not None:
        print(f"the run failed at t = {result.end_time:.3f} s: {result.failure}", file=sys.stderr)
    elif result.fell is not None:
        after = "" if result.after_fall is None else f" (ended by, after the fall: {result.after_fall})"
        print(
            f"the robot {result.fell}; the run stopped at t = {result.end_time:.3f} s{after} and the "
            "artefacts cover the simulated part",
            file=sys.stderr,
        )
        for line in fall_causes(result):
            print(line, file=sys.stderr)
    elif result.not_reached:
        later = ", ".join(f"{label!r} at {t:g} s" for t, label in result.not_reached)
        print(f"after the end of the run, not applied: {later}", file=sys.stderr)
    return exit_status(result, output.unwritten)


if __name__ == "__main__":
    sys.exit(main())
