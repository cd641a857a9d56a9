"""Scenarios: a named diagram with its timed commands, and the run that writes its artefacts."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context

from drake_sot.diagrams.artifacts import (
    Artefacts,
    log_arrays,
    output_directory,
    write_figure,
    write_npz,
    write_replay,
    write_svg,
)
from drake_sot.diagrams.log_window import LOG_WINDOW
from drake_sot.diagrams.pushes import ExternalPush, check_push_times
from drake_sot.diagrams.run import Progress, RunResult, SignalGuard, TimedCommand, check_duration, simulate
from drake_sot.diagrams.signal_graph import write_graph
from drake_sot.diagrams.world import BuiltHumanoid, loopback_meshcat
from drake_sot.errors import DrakeSotError
from drake_sot.footsteps import Footstep
from drake_sot.hand_steps import HandStepRule
from drake_sot.parameters import Parameter, UndeclaredParameter, check_parameters
from drake_sot.plots import plot_task_errors
from drake_sot.robots import ROBOTS
from drake_sot.robots.description_file import ROBOT_PATH_SUFFIXES
from drake_sot.systems.admittance import AdmittanceController
from drake_sot.systems.channel import Channel
from drake_sot.systems.hand_steps import StepDecider
from drake_sot.systems.master import MasterSite, Operator
from drake_sot.systems.moving_point import MovingPoint
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.systems.priority_schedule import PrioritySchedule
from drake_sot.systems.replay_view import FollowCamera
from drake_sot.systems.search import systems_of_type
from drake_sot.systems.sequencer import TaskSequencer
from drake_sot.systems.stack_history import stack_changes

if TYPE_CHECKING:  # script_session builds on this module
    from drake_sot.diagrams.script_session import ScriptSession


@dataclass(frozen=True)
class RemoteDecision:
    """What a remote decision client (``python -m drake_sot.remote.decision``) is started with.

    Attributes:
        signal: the signal it polls (``entity.signal``).
        period: [s] simulated time between two polls.
        run: the script lines it sends when the signal falls.
        write: the ``server.signal=value`` items it writes then.
    """

    signal: str
    period: float
    run: tuple[str, ...]
    write: tuple[str, ...]


@dataclass(frozen=True)
class ScenarioHandles:
    """The parts a scenario exposes besides its diagram, for its runner, its plots and its tests;
    a field a scenario does not have is None (False for the flags).

    Attributes:
        session: a script's session (``drake-sot script``/``serve FILE``).
        wait_for_client: a served run starts when its first client connects (two-process mode).
        paced_by_client: a served run is paced by its client, not by the wall clock.
        decision: the remote decision client to start (``walk_then_interact --decision remote``).
        pattern_generator: the walking pattern generator.
        steps: the footsteps the script gives the pattern generator.
        admittances: the hands' admittance controllers, by task name.
        hands: the bodies the partner holds (the hands), by name.
        sequencer: the task sequencer (the decision server, or the altitude tasks' switch).
        schedule: the priority schedule (α) of a torque-level scenario.
        transition: [s] the priority rearrangement period.
        desired_force: [N] the force a hand presses with (``table_pounding``).
        leader: who leads the tele-cooperation, ``"operator"`` or ``"cooperator"``.
        delay: [s] the tele-cooperation link's one-way delay.
        admittance: the tele-cooperation hands' admittance, ``"plain"`` or ``"weighted"``.
        object: the moving object looked at and reached.
        operator: the tele-cooperation's operator (one-process mode).
        master: the tele-cooperation's master site (one-process mode).
        channel: the tele-cooperation's link (one-process mode).
        decider: the step decider of the walk driven by the hands.
        rule: the step rule of ``decider``.
        grippers: the gripper joints the master's aperture drives.
    """

    session: ScriptSession | None = None
    wait_for_client: bool = False
    paced_by_client: bool = False
    decision: RemoteDecision | None = None
    pattern_generator: PatternGenerator | None = None
    steps: list[Footstep] | None = None
    admittances: dict[str, AdmittanceController] | None = None
    hands: list[str] | None = None
    sequencer: TaskSequencer | None = None
    schedule: PrioritySchedule | None = None
    transition: float | None = None
    desired_force: float | None = None
    leader: str | None = None
    delay: float | None = None
    admittance: str | None = None
    object: MovingPoint | None = None
    operator: Operator | None = None
    master: MasterSite | None = None
    channel: Channel | None = None
    decider: StepDecider | None = None
    rule: HandStepRule | None = None
    grippers: tuple[str, ...] | None = None


@dataclass
class ScenarioSetup:
    """A built scenario, ready to simulate.

    Attributes:
        built: the diagram and its parts.
        commands: the timed commands of the scenario's script.
        duration: default simulated duration [s].
        targets: named target poses, for checks and plots.
        extras: the other parts a scenario exposes (e.g. its pattern generator, its footsteps).
    """

    built: BuiltHumanoid
    commands: list[TimedCommand]
    duration: float
    targets: dict[str, RigidTransform] = field(default_factory=dict)
    extras: ScenarioHandles = field(default_factory=ScenarioHandles)


ExtraPlots = Callable[[ScenarioSetup, dict[str, np.ndarray], Path], dict[str, Path]]
"""Writes a scenario's own plots from its setup and logs into a directory; returns name → file."""


@dataclass(frozen=True)
class Scenario:
    """A scenario of the ``drake-sot`` command: a name, a one-line description, a builder,
    and optionally its own plots beside the task-error plot. ``build(meshcat, **parameters)``
    also takes ``pushes=`` (a sequence of :class:`~drake_sot.diagrams.pushes.ExternalPush`)
    when :func:`run_scenario` is given some, and, when the scenario is ``servable``,
    ``command_server=True`` to add a
    :class:`~drake_sot.systems.command_server.RemoteCommandServer` to the diagram (``built.remote``)
    for a front-end to serve it. :func:`build_scenario` is the one call of ``build``."""

    name: str
    description: str
    build: Callable[..., ScenarioSetup]
    extra_plots: ExtraPlots | None = None
    parameters: tuple[Parameter, ...] = ()  # keyword arguments ``build`` accepts besides the Meshcat
    servable: bool = False  # ``build`` takes ``command_server``


#: The robot a scenario drives (its builder's ``robot=``), by name or by the path of its
#: description file (or of its model, the description beside it).
ROBOT = Parameter(
    "robot",
    "choice",
    "embedded",
    "the robot (see 'drake-sot list --robots'; your own: a description .toml, or a URDF, SDF or "
    "MJCF .xml model with its description beside it, see 'drake-sot robot draft')",
    choices=tuple(sorted(ROBOTS)),
    paths=ROBOT_PATH_SUFFIXES,
)

#: The self-collision avoidance task just below the joint limits of a kinematic scenario
#: (:meth:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder.below_joint_limits`), on unless
#: switched off.
SELF_COLLISION = Parameter(
    "self_collision", "bool", True, "the self-collision avoidance task, just below the joint limits"
)

Runner = Callable[..., RunResult]
"""Runs a built scenario: ``runner(setup, simulator, duration, progress=, guard=)`` -> RunResult."""


@dataclass
class ScenarioOutput:
    """What :func:`run_scenario` produced: how the run ended, the logs, the files written,
    those that could not be (a full disk: file → why), the pictures written as Graphviz source
    for want of a renderer, and the scenario with its final context (to inspect the stack or
    the plant)."""

    result: RunResult
    arrays: dict[str, np.ndarray]
    files: dict[str, Path]
    setup: ScenarioSetup
    context: Context
    unwritten: dict[str, str] = field(default_factory=dict)
    unrendered: list[Path] = field(default_factory=list)


class ScenarioParameterError(DrakeSotError, ValueError):
    """A scenario's ``build`` refused the value of one of its parameters: nothing was simulated."""


class NotServable(DrakeSotError, ValueError):
    """A command server was asked of a scenario whose diagram cannot have one (nothing built)."""


def _check_parameters(scenario: Scenario, parameters: dict[str, Any] | None) -> dict[str, Any]:
    """``parameters`` checked against ``scenario.parameters``: undeclared names raise
    :class:`~drake_sot.parameters.UndeclaredParameter`, a refused value
    :class:`ScenarioParameterError`."""
    try:
        return check_parameters(scenario.name, scenario.parameters, parameters)
    except UndeclaredParameter:
        raise
    except ValueError as exc:
        raise ScenarioParameterError(f"{scenario.name}: {exc}") from exc


def build_scenario(
    scenario: Scenario,
    meshcat: Meshcat | None,
    *,
    parameters: dict[str, Any] | None = None,
    pushes: Sequence[ExternalPush] = (),
    command_server: bool = False,
) -> ScenarioSetup:
    """``scenario.build`` with its declared ``parameters``, the ``pushes`` (when there are some)
    and, with ``command_server``, a :class:`~drake_sot.systems.command_server.RemoteCommandServer`.

    Raises:
        ValueError: an undeclared parameter (nothing built).
        NotServable: ``command_server`` for a scenario that is not ``servable`` (nothing built).
        ScenarioParameterError: its declaration (nothing built) or ``build`` refused a
            parameter's value.
    """
    parameters = _check_parameters(scenario, parameters)
    if command_server and not scenario.servable:
        raise NotServable(
            f"{scenario.name} cannot be served: its diagram has no place for a RemoteCommandServer "
            "(a kinematic SoT built by HumanoidSoTBuilder has one)"
        )
    extra: dict[str, Any] = {"pushes": tuple(pushes)} if pushes else {}
    if command_server:
        extra["command_server"] = True
    try:
        return scenario.build(meshcat, **parameters, **extra)
    except ValueError as exc:
        raise ScenarioParameterError(f"{scenario.name}: {exc}") from exc


def run_scenario(
    scenario: Scenario,
    out_dir: str | Path,
    *,
    duration: float | None = None,
    record: bool = True,
    progress: Progress | None = None,
    parameters: dict[str, Any] | None = None,
    pushes: Sequence[ExternalPush] = (),
    runner: Runner | None = None,
    command_server: bool = False,
    log_window: float | None = LOG_WINDOW,
    fixed_camera: bool = False,
) -> ScenarioOutput:
    """Build, simulate and write ``<name>.npz`` (logs), ``<name>.html`` (replay, when ``record``),
    ``<name>.png`` (task errors), the scenario's own plots, ``<name>.svg`` (the signal graph, see
    :mod:`~drake_sot.diagrams.signal_graph`) and ``<name>_drake.svg`` (Drake's picture of every
    system; both written before the run) into ``out_dir``. Without a Graphviz renderer the two
    pictures are written as ``.dot`` source instead and listed in the output's ``unrendered``.
    The replay draws the forces as arrows and the pairs of collision shapes a self-collision task
    holds apart as lines, with a legend, and its camera follows the robot's pelvis (see
    :mod:`~drake_sot.systems.replay_view`) unless ``fixed_camera``.

    Artefacts are written even when the run is interrupted (SIGINT, SIGTERM), fails or the
    robot falls, covering what was simulated; ``result`` says how it ended. A file that cannot
    be written (a full disk) is listed in the output's ``unwritten`` and the next one is still
    attempted. The task-error plot
    marks the commands, the stack changes, the pushes and the fall. While they are written, SIGINT and SIGTERM
    are held and delivered once every file is written (see :class:`SignalGuard`); each file is
    written atomically (see :mod:`drake_sot.diagrams.artifacts`).

    Args:
        scenario: what to run.
        out_dir: the output directory, created if needed.
        duration: simulated time [s], finite, > 0 and at most
            :data:`~drake_sot.diagrams.run.MAX_DURATION`; None for the scenario's own.
        record: record the Meshcat replay.
        progress: called as the simulation advances (see :func:`simulate`).
        parameters: keyword arguments of the scenario's ``build`` (only those it declares).
        pushes: disturbances applied to the robot (passed to ``build`` when there are some).
        runner: runs the simulation instead of :func:`simulate` (e.g. while serving remote
            commands), called as ``runner(setup, simulator, duration, progress=, guard=)``.
        command_server: build the diagram with a command server (see :func:`build_scenario`).
        log_window: [s] the logs keep the run's last ``log_window`` seconds (up to twice that),
            None every sample (see :mod:`drake_sot.diagrams.log_window`); the artefacts cover
            what the logs kept. With ``runner``, the runner decides.
        fixed_camera: the replay's camera stays where Meshcat puts it (the live view's too)
            instead of following the pelvis.

    Raises:
        ValueError: a bad ``duration`` or an undeclared parameter (before anything is built);
            :class:`ScenarioParameterError` when a parameter's declaration (before anything is
            built) or ``build`` refuses its value or a push starts after the run's end (before
            anything is simulated).
        OSError: ``out_dir`` cannot be written (before anything is built).
    """
    if duration is not None:
        duration = check_duration("duration", duration)
    parameters = _check_parameters(scenario, parameters)  # before the output directory is made
    out = output_directory(out_dir)
    setup = build_scenario(
        scenario,
        loopback_meshcat() if record else None,
        parameters=parameters,
        pushes=pushes,
        command_server=command_server,
    )
    built = setup.built
    duration = setup.duration if duration is None else duration
    try:
        check_push_times(built.pushes, duration)
    except ValueError as exc:
        raise ScenarioParameterError(f"{scenario.name}: {exc}") from exc
    artefacts = Artefacts()
    artefacts.write("svg", out / f"{scenario.name}.svg", lambda path: write_graph(built.diagram, path))
    artefacts.write(
        "drake_svg", out / f"{scenario.name}_drake.svg", lambda path: write_svg(built.diagram, path)
    )
    simulator = built.create_simulator()
    if fixed_camera:
        for camera in systems_of_type(built.diagram, FollowCamera):
            camera.set_follow(camera.GetMyMutableContextFromRoot(simulator.get_mutable_context()), False)
    if built.visualizer is not None:
        # the live view moves while the replay is recorded (a frozen robot at t = 0 otherwise)
        built.visualizer.StartRecording(set_transforms_while_recording=True)
    with SignalGuard() as guard:
        if runner is None:
            result = simulate(
                simulator,
                duration,
                setup.commands,
                progress=progress,
                guard=guard,
                log_window=log_window,
                check=False,
            )
        else:
            result = runner(setup, simulator, duration, progress=progress, guard=guard)
        context = simulator.get_context()
        arrays = log_arrays(built, context, result)
        artefacts.write("npz", out / f"{scenario.name}.npz", lambda path: write_npz(arrays, path))
        if record:
            artefacts.write(
                "html",
                out / f"{scenario.name}.html",
                lambda path: write_replay(built, path, scenario=scenario.name),
            )
        errors = {k.removeprefix("error/"): v for k, v in arrays.items() if k.startswith("error/")}
        command_times = {round(t, 6) for t, _ in result.events}
        history = built.stack_history.history(context) if built.stack_history is not None else []
        changes = stack_changes(history)
        marks = result.events + [(t, label) for t, label in changes if round(t, 6) not in command_times]
        marks += [(p.time, p.label) for p in built.pushes if p.time <= result.end_time]
        if result.fell is not None:
            marks.append((result.fell.time, str(result.fell)))
        title = f"{scenario.name}: task errors"
        figure = plot_task_errors(arrays["time"], errors, marks, title=title)
        artefacts.write("png", out / f"{scenario.name}.png", lambda path: write_figure(figure, path))
        if scenario.extra_plots is not None:
            extra_plots = scenario.extra_plots
            artefacts.write_several(f"{out / scenario.name}_*.png", lambda: extra_plots(setup, arrays, out))
    return ScenarioOutput(
        result=result,
        arrays=arrays,
        files=artefacts.files,
        setup=setup,
        context=context,
        unwritten=artefacts.unwritten,
        unrendered=artefacts.unrendered,
    )
