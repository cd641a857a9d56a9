"""The SoT script on a Drake diagram: a build phase, then a run phase (Mansard, Stasse,
Evrard, Kheddar 2009, III-B).

In the original Stack of Tasks the graph of entities can change at any time. A Drake
diagram is fixed once built, so a :class:`ScriptSession` has two phases:

* **build phase**: ``new``, ``destroy``, ``plug``, ``set``, ``dyn.createOpPoint``,
  ``task.add`` and the other *build-time* commands describe the diagram. Nothing is made
  yet: entities are recorded with their settings, so that the order of the lines does
  not matter as long as a name is created before it is used (a ``FeatureGeneric`` learns
  its size from what is plugged into ``errorIN``, a task its features from ``add``).
* the **first run-time command** (``get``, ``sot.push``, ``pg.parsecmd``, ``run
  DURATION``, ``pool.writegraph``…) builds the diagram through
  :class:`~drake_sot.diagrams.humanoid.HumanoidSoTBuilder` — the embedded humanoid on
  the ground, ``dyn``, the entities, every task wired into the solver, the device and the
  torque feed-forward — and acts on a context of it. From then on only run-time commands
  act; a build-time command gets a :class:`SessionError` saying why.
* ``set`` acts in both phases: before the build it gives the value the diagram starts
  with; after, it changes that value in the context. ``help``, ``pool.list`` and the
  other introspection commands work in both and build nothing.

The session starts with ``dyn`` (the robot model: ``com``, ``Jcom`` and the operational
points created with ``dyn.createOpPoint``; the paper's ``dyn2`` is another name for
it) and ``pool``. The solver is ``new SOT NAME``; when the script declares none, the
build adds one named ``sot`` (so ``sot.push taskCom`` works as printed in the paper). It solves
the stack by strict priority with SVDs (equality tasks, the paper's eq. 8), or, once the script
makes an inequality task (``new TaskSelfCollision``), by the hierarchical QP
(:func:`~drake_sot.hqp.solve_hqp`, equalities and inequalities at any level).

Classes for ``new`` and the script's signals (the paper's names where it gives them):

================================ ========================================================
class                            signals (in → out), commands
================================ ========================================================
``FeatureGeneric``               errorIN, jacobianIN, sdes, sdes_dot → feature, error; selec
``FeatureCoM``                   com, Jcom (dyn's unless plugged), sdes, sdes_dot → feature, error; selec
``FeaturePoint6d``               position, Jq (or frame: both), position_des, velocity_des → feature, error;
                                 selec
``FeaturePoint6dRelative``       position, Jq (or frame), positionRef, JqRef (or frameRef), position_des →
                                 feature, error; selec
``FeaturePosture``               q (the reference q unless plugged), sdes → feature, error; selec
``FeatureJointLimits``           q (idem) → feature, error; ``margin``
``Task``                         gain → task; ``add``, ``controlGain``, ``controlGainAdaptive``
``TaskSelfCollision``            → task, closest_pairs, distances, pair_indices; ``d_s``, ``d_i``, ``xi``,
                                 ``maxPairs``, ``legPairs`` (``set`` before the build); ``pairs``. Not
                                 an entity of the SoT: the inequality task of self-collision avoidance
                                 (``SelfCollisionAvoidance``), which makes the solver the HQP
``SOT``                          stack → qdot, errors, stack; ``push``, ``pop``, ``rm``, ``up``,
                                 ``down``, ``clear`` (each with an optional time [s]), ``list``
``PatternGenerator``             → com, com_vel, left_foot, right_foot, waist, zmp_ref, …,
                                 in_process; ``parsecmd``, ``velocity``
``AdmittanceController``         wrench_ref, active → position_des, velocity_des, wrench_external,
                                 saturated, fault; ``hand``, ``mass``, ``damping``, …
``TaskSequencer``                <guard inputs> → stack, smooth_stack, state, transitions, <outputs>;
                                 ``addState``, ``addEntry``, ``addTransition``, ``transitionTime``, …
================================ ========================================================

``E.help`` lists an entity's signals and commands with their phase; ``pool.help``,
``pool.list``, ``pool.listFeature``, ``pool.listTask``, ``pool.listClass`` and ``pool.writegraph
FILE`` are the pool's.

Values: ``set`` on a vector input before the build puts a constant source on it (named
``E.SIG`` in the diagram), whose value a later ``set`` changes in the context. The
desired value of a feature (``sdes``, ``position_des``) and a task's ``controlGain`` are
parameters. ``set A.sdes B``, with B a feature, feeds A's desired value from whatever feeds
B's value (``errorIN``, ``com``, ``position`` or ``q``): the paper's ``set featureCom.sdes
featureComDes``. Pose values are ``[4,4]`` homogeneous matrices, or a ``[3]`` position that
keeps the current orientation. A feature whose desired value is neither set nor plugged
holds where it starts (the CoM at q0, or the pose at q0 of the ``dyn`` operational points
plugged into it), except ``FeatureGeneric``, whose s* is 0 as in the SoT. A feature's
``selec`` is written ``110``, or quoted when it starts with 0 (``"000111"``: a number
loses its leading zeros).

Wiring the build does itself: ``dyn.q`` and, unless plugged, the ``q`` of the posture and
joint-limit features are the reference configuration the loop integrates; a ``FeatureCoM``
reads ``dyn.com`` and ``dyn.Jcom`` unless plugged; every task goes into the solver; an
``AdmittanceController``'s wrist sensor and poses follow from ``hand right|left``. Once a
``PatternGenerator``'s CoM, feet or waist references are plugged, its ``load`` splits the
torque feed-forward between the feet (``examples/walk_two_steps.sot``).

The solver's outputs (``qdot``, ``errors``, ``stack``) plug into other entities like any
output (``plug sot.errors decision.errors``: a sequencer's guard on the task errors); they are
connected when the build makes the solver, which is last. An entity cannot take its size from
``sot.errors`` (``FeatureGeneric.errorIN``): it is known only then.

Files: ``run FILE`` reads a regular file inside the session's script directory (a path that
resolves outside it is refused). A client of a served session was not given those files, so its
``run FILE`` (``execute(..., served=True)``) runs only a ``.sot`` file that reads and parses, and
its errors show nothing the file holds: whether the name is not a ``.sot``, missing, unreadable or
not a script, the reply is the same line (only a script that runs tells that it exists); a command
of it that is refused is named by its rank, and why is logged on the server's side alone.
``pool.writegraph FILE`` writes a plain file name (no directory part, not
``.`` or ``..``) into the session's output directory, creates no directory, never replaces
a file that this session did not write itself (the script, another user's file), and writes at
most :data:`MAX_OUTPUT_FILES` files (writing one of them again is always allowed): a client of a
served session cannot fill a disk by naming new files. Without an output directory the session
makes a fresh temporary one, never the working directory (``drake-sot serve`` removes its own
when the server stops).

The run-time entry point, for a command server or a shell, is
:meth:`ScriptSession.execute`: ``session.execute("sot.push taskCom", root_context)`` returns
the command's output text (``get`` writes the value in the script's syntax, which
:func:`drake_sot.script.parse_value` reads back when it is finite). Call it from the thread
that owns the context, between simulation steps; it is not thread-safe.
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, InputPort, OutputPort, PortDataType, System
from pydrake.systems.primitives import ConstantVectorSource

from drake_sot import validation
from drake_sot.diagrams.humanoid import HumanoidSoT, HumanoidSoTBuilder
from drake_sot.diagrams.run import MAX_DURATION, TimedCommand, check_duration
from drake_sot.diagrams.scenario import Scenario, ScenarioHandles, ScenarioSetup
from drake_sot.diagrams.script_entities import (
    AT_MOST_ONE,
    CLASSES,
    DynamicEntity,
    Entity,
    FeatureEntity,
    Feed,
    FromFeature,
    PatternGeneratorEntity,
    Phase,
    Plugged,
    PoolEntity,
    SessionError,
    SotEntity,
    TaskEntity,
    UnknownScriptName,
    Valued,
    format_signal_value,
    vector_value,
)
from drake_sot.errors import UnknownNameError, prefixed
from drake_sot.script import (
    COMMAND_SOURCE,
    Call,
    Destroy,
    Get,
    Name,
    New,
    Plug,
    Run,
    RunFor,
    ScriptCommand,
    ScriptError,
    Set,
    Signal,
    Statement,
    Value,
    format_value,
    parse_script,
)
from drake_sot.systems.sot import StackOfTasks

_log = logging.getLogger(__name__)

#: The files a session may write into its output directory (``pool.writegraph``): one more is refused.
MAX_OUTPUT_FILES = 64

#: The suffix of the script files a client of a served session may run.
SCRIPT_SUFFIX = ".sot"

__all__ = [
    "Phase",
    "ScriptProgram",
    "ScriptSession",
    "SessionError",
    "load_script",
    "schedule",
    "script_scenario",
]

#: The solver's name when the script declares none (``new SOT NAME``).
DEFAULT_SOT = "sot"
#: Names the build gives to systems of its own (an entity may not take them).
RESERVED_NAMES = (
    "pool",
    "dyn",
    "dyn2",
    "plant",
    "scene_graph",
    "device",
    "torque_feedforward",
    "stack_history",
    "left_wrist_sensor",
    "right_wrist_sensor",
    "remote",
)

# ---------------------------------------------------------------------------------------
# The session
# ---------------------------------------------------------------------------------------


class ScriptSession:
    """Runs SoT script commands: records the diagram, builds it, then acts on its context.

    Args:
        meshcat: a Meshcat to draw in (e.g. ``loopback_meshcat()`` to record a replay), or None.
        control_period: the controller's period [s] (5 ms, as on HRP-2).
        script_dir: where ``run FILE`` reads scripts (a file must resolve inside it).
        output_dir: an existing directory where ``pool.writegraph FILE`` writes; None for a
            fresh temporary directory of this session's, made on first use.
        robot: the robot, a name of ``drake_sot.robots.ROBOTS`` (its logical frames are the
            operational points the script can name).
        command_server: build the diagram with a
            :class:`~drake_sot.systems.command_server.RemoteCommandServer`, to serve the session
            (its stack commands then name the script's solver).

    Attributes:
        builder: the :class:`~drake_sot.diagrams.humanoid.HumanoidSoTBuilder` the build uses.
        built: the built diagram and its parts (None before the build).

    Example::

        session = ScriptSession()
        session.execute("new FeatureCoM featureCom")
        ...
        session.execute("sot.push taskCom")   # builds the diagram, then pushes (own simulator)
        session.execute("run 1.0")            # simulates one second
        print(session.execute("get dyn.com"))
    """

    def __init__(
        self,
        *,
        meshcat: Meshcat | None = None,
        control_period: float = 0.005,
        script_dir: str | Path = ".",
        output_dir: str | Path | None = None,
        robot: str = "embedded",
        command_server: bool = False,
    ) -> None:
        self.builder = HumanoidSoTBuilder(control_period=control_period, meshcat=meshcat, robot=robot)
        self._command_server = command_server
        self.script_dir = Path(script_dir)
        self._output_dir = None if output_dir is None else Path(output_dir)
        self._written: set[Path] = set()  # the files this session wrote (it may replace them)
        self.built: HumanoidSoT | None = None
        self._built_by: str = ""
        self._entities: dict[str, Entity] = {}
        self._feeds: dict[tuple[str, str], Feed] = {}
        self._sources: dict[tuple[str, str], ConstantVectorSource] = {}
        self._simulator: Simulator | None = None
        self._failed = ""  # why the build failed, if it did
        self._statement: Statement | None = None
        self._probe = self.builder.control_plant.CreateDefaultContext()
        self.builder.control_plant.SetPositions(self._probe, self.builder.q0)
        self._add(PoolEntity(self, "pool", None))
        self._add(DynamicEntity(self, "dyn", None))

    # --- the pool -------------------------------------------------------------------------
    def _add(self, entity: Entity) -> Entity:
        self._entities[entity.name] = entity
        return entity

    def _has(self, kind: type[Entity]) -> bool:
        return any(isinstance(e, kind) for e in self._entities.values())

    def entities(self) -> list[Entity]:
        """Every entity, in the order they were created (the pool first)."""
        return list(self._entities.values())

    def entity(self, name: str) -> Entity:
        """The entity ``name`` (``dyn2`` is ``dyn``); SessionError listing the entities if unknown.

        ``sot``, while the script has declared no solver, declares the default one.
        """
        entity = self._entities.get("dyn" if name == "dyn2" else name)
        if entity is None and name == DEFAULT_SOT and not self._has(SotEntity) and not self.is_built:
            entity = self._add(SotEntity(self, DEFAULT_SOT, None))
        if entity is None:
            raise UnknownScriptName("entity", name, self._entities)
        return entity

    def system(self, name: str) -> System:
        """The Drake system of an entity (after the build)."""
        entity = self.entity(name)
        if entity.system is None:
            raise SessionError(f"{entity.describe()} has no system yet: the diagram is not built")
        return entity.system

    def feed(self, entity: str, signal: str) -> Feed | None:
        """What feeds an entity's input before the build (a plug, a value, another feature)."""
        return self._feeds.get((entity, signal))

    def joints_by_rank(self) -> list:
        """Joint indices by rank in the state vector: the free flyer (rank 0), then the
        one-DoF joints in the order of q."""
        plant = self.builder.control_plant
        joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
        floating = [j.index() for j in joints if j.num_positions() == 7]
        singles = sorted((j for j in joints if j.num_positions() == 1), key=lambda j: j.position_start())
        return floating + [j.index() for j in singles]

    def initial_frame_pose(self, frame_name: str) -> RigidTransform:
        """Pose in world of a frame of the controller's model at q0."""
        return self.builder.control_plant.GetFrameByName(frame_name).CalcPoseInWorld(self._probe)

    def output_size(self, signal: Signal) -> int:
        """Size of an output signal (its entity is made first); SessionError if not a vector."""
        entity = self.entity(signal.entity)
        if isinstance(entity, SotEntity):  # made last, when the build closes the loop
            if signal.name == "qdot":
                return self.builder.control_plant.num_velocities()
            raise SessionError(f"{signal}: its size is known only once the diagram is built")
        self._construct(entity, ())
        port = entity.output_port(signal.name)
        if port.get_data_type() != PortDataType.kVectorValued:
            raise SessionError(f"{signal} is not a vector signal")
        return port.size()

    @property
    def output_dir(self) -> Path:
        """Where ``pool.writegraph`` writes: the directory given, else a fresh temporary
        directory made for this session on first use."""
        if self._output_dir is None:
            self._output_dir = Path(tempfile.mkdtemp(prefix="drake_sot_script_"))
        return self._output_dir

    def claim_output(self, name: str) -> Path:
        """The file ``name`` of the output directory, which this session may now write.

        Raises:
            SessionError: ``name`` is not a plain file name (empty, ``.``, ``..``, a separator,
                a NUL), or names a file (or link) that exists and that this session did not write,
                or a new file when the session wrote :data:`MAX_OUTPUT_FILES` already.
        """
        if name in ("", ".", "..") or any(c in name for c in ("/", "\\", os.sep, "\0")):
            raise SessionError(
                f"file name {name!r}: must be a plain file name (no directory part, not '.' or '..'), "
                f"written into the output directory {str(self.output_dir)!r}"
            )
        path = self.output_dir / name
        if path in self._written:
            return path
        if path.exists() or path.is_symlink():
            raise SessionError(
                f"{name!r}: {str(path)!r} exists and this session did not write it: not replaced"
            )
        if len(self._written) >= MAX_OUTPUT_FILES:
            raise SessionError(
                f"{name!r}: this session wrote {MAX_OUTPUT_FILES} files already, the most it writes "
                f"(write one of those again instead)"
            )
        self._written.add(path)
        return path

    # --- phases -----------------------------------------------------------------------------
    @property
    def is_built(self) -> bool:
        return self.built is not None

    def phase(self, command: ScriptCommand) -> Phase:
        """When ``command`` acts (SessionError for an unknown entity or command)."""
        match command:
            case New() | Destroy() | Plug():
                return Phase.BUILD
            case Set(signal):
                entity = self.entity(signal.entity)
                return entity.set_phase(entity.check_signal(signal.name, "ip"))
            case Get() | RunFor():
                return Phase.RUN
            case Run():
                return Phase.INFO  # its commands have their own phases
            case Call(entity, name):
                return self.entity(entity).command_spec(name).phase
        raise TypeError(f"{command!r} is not a script command")

    # --- executing --------------------------------------------------------------------------
    def execute(
        self,
        command: str | ScriptCommand | Statement,
        context: Context | None = None,
        *,
        served: bool = False,
    ) -> str:
        """Run one script command; return its output text ("" when it writes nothing).

        Build-time commands record the diagram; the first run-time command builds it and
        acts on ``context`` — the root context of the built diagram (e.g. a simulator's),
        or, when None, the context of the session's own simulator (made at the build).
        ``get`` writes the value in the script's syntax (see :func:`format_signal_value`).
        ``run DURATION`` advances the session's own simulator. ``run FILE`` runs the file's
        commands in order; ``served``: the command came from a client of the server, whose ``run
        FILE`` is a ``.sot`` file and whose errors tell nothing of the file (module docstring).

        Raises:
            ScriptError: a line out of the grammar (with its line and column).
            SessionError: a command that cannot act (unknown entity, signal or command, a
                build-time command after the build, a bad value...), saying why; the
                message starts with the script line when the command came from one.
        """
        if isinstance(command, str):
            statements = parse_script(command, source=COMMAND_SOURCE)
            if len(statements) > 1:
                raise SessionError(f"one command at a time, got {len(statements)} lines")
            if not statements:
                return ""
            command = statements[0]
        statement = command if isinstance(command, Statement) else None
        command = statement.command if statement else command
        previous, self._statement = self._statement, statement
        try:
            if served and isinstance(command, Run):
                return self._run_for_client(command.path, context)
            return self._dispatch(command, context)
        except ScriptError:
            raise  # a line of an included script: it says where
        except SessionError as error:
            if error.located:
                raise
            raise _located(error, statement, command) from error.__cause__
        except (ValueError, KeyError, RuntimeError) as error:
            raise _located(error, statement, command) from error
        finally:
            self._statement = previous

    def run_script(self, text: str, *, source: str = "<script>") -> list[str]:
        """Execute every line of ``text`` (its ``run DURATION`` on the own simulator); the outputs."""
        return [self.execute(statement) for statement in parse_script(text, source=source)]

    def _dispatch(self, command: ScriptCommand, context: Context | None) -> str:
        if isinstance(command, Run):
            return "\n".join(out for st in self._included(command.path) if (out := self.execute(st, context)))
        phase = self.phase(command)
        if phase == Phase.BUILD:
            self._require_build_phase(command)
        elif isinstance(command, RunFor) and context is not None:
            raise SessionError(
                "run DURATION advances the session's own simulator; the caller owns this context"
            )
        elif phase == Phase.RUN or (phase == Phase.BOTH and self.is_built):
            self.build()
            context = self._context(context)
        match command:
            case New(cls, name):
                return self._new(cls, name)
            case Destroy(name):
                return self._destroy(name)
            case Plug(source, target):
                return self._plug(source, target)
            case Set(signal, value):
                return self._set(signal, value, context if self.is_built else None)
            case Get(signal):
                entity = self.entity(signal.entity)
                return format_signal_value(entity.get(entity.check_signal(signal.name, "iop"), context))
            case RunFor(duration):
                return self._advance(duration, context)
            case Call(entity, name):
                return self.entity(entity).run_command(name, command.args, context if self.is_built else None)
        raise TypeError(f"{command!r} is not a script command")

    def _require_build_phase(self, command: ScriptCommand) -> None:
        if self.is_built:
            raise SessionError(
                f"the diagram is built (by {self._built_by}) and a Drake diagram is fixed once built: "
                f"{_keyword(command)} is a build-time command; put it before the first run-time command"
            )

    def _context(self, context: Context | None) -> Context:
        if context is not None:
            try:
                self.built.diagram.ValidateContext(context)
            except RuntimeError:
                raise SessionError(
                    "the context given is not a root context of this session's diagram"
                ) from None
            return context
        return self.simulator.get_mutable_context()

    @property
    def simulator(self) -> Simulator:
        """The session's own simulator (made, and the diagram built, on first use)."""
        self.build()
        if self._simulator is None:
            self._simulator = self.built.create_simulator()
        return self._simulator

    def _advance(self, duration: float, context: Context) -> str:
        duration = check_duration("run DURATION", duration)
        self.simulator.AdvanceTo(context.get_time() + duration)
        return f"t = {context.get_time():.3f} s"

    def _included(self, name: str) -> tuple[Statement, ...]:
        path = _inside(self.script_dir, name, "the script directory")
        return _expand(path, self.script_dir, ())

    def _run_for_client(self, name: str, context: Context | None) -> str:
        """``run FILE`` from a client of the server: a ``.sot`` file of the script directory, run
        command by command; no error says what the file holds (module docstring)."""
        try:
            if not name.endswith(SCRIPT_SUFFIX):
                raise SessionError(f"not a {SCRIPT_SUFFIX} file")
            statements = self._included(name)
        except (SessionError, ScriptError, ValueError, OSError) as error:
            _log.warning("a client's run %r: %s", name, error)
            raise SessionError(
                f"{name!r}: no script to run by that name (a client runs a {SCRIPT_SUFFIX} file of the "
                "served script's directory that reads and parses; which of these it is not, is not told)"
            ) from None
        outputs = []
        for k, statement in enumerate(statements, 1):
            try:
                output = self.execute(statement, context)
            except Exception as error:  # noqa: BLE001 - any message may quote the file: none is shown
                _log.warning("a client's run %r: %s", name, error)
                raise SessionError(
                    f"{name!r}: its command {k} of {len(statements)} was refused, after {k - 1} acted "
                    "(why is in the server's log: a client is not shown what the file holds)"
                ) from None
            if output:
                outputs.append(output)
        return "\n".join(outputs)

    # --- build-phase commands -------------------------------------------------------------
    def _new(self, cls: str, name: str) -> str:
        klass = CLASSES.get(cls)
        if klass is None:
            raise UnknownScriptName("class", cls, CLASSES)
        if name in self._entities or name in RESERVED_NAMES or name.startswith("log_"):
            raise SessionError(f"the name {name!r} is taken (entities: {', '.join(self._entities)})")
        if klass in AT_MOST_ONE:
            other = [e.name for e in self._entities.values() if isinstance(e, klass)]
            if other:
                raise SessionError(f"the diagram has one {cls}, {other[0]!r}, already")
        self._add(klass(self, name, self._statement))
        return ""

    def _destroy(self, name: str) -> str:
        entity = self.entity(name)
        if isinstance(entity, (PoolEntity, DynamicEntity)):
            raise SessionError(f"{entity.describe()} cannot be destroyed")
        del self._entities[entity.name]
        removed = []
        for key, feed in list(self._feeds.items()):
            how = feed.how
            if (
                key[0] == entity.name
                or (isinstance(how, Plugged) and how.source.entity == entity.name)
                or (isinstance(how, FromFeature) and how.feature == entity.name)
            ):
                del self._feeds[key]
                if key[0] != entity.name:
                    removed.append(f"{key[0]}.{key[1]} ({feed.describe()})")
        for task in self._entities.values():
            if isinstance(task, TaskEntity) and entity.name in task.features:
                task.features.remove(entity.name)
                removed.append(f"{task.name}.add {entity.name}")
        return f"removed with it: {'; '.join(removed)}" if removed else ""

    def _plug(self, source: Signal, target: Signal) -> str:
        out_entity = self.entity(source.entity)
        out_entity.check_signal(source.name, "o")
        in_entity = self.entity(target.entity)
        in_entity.check_signal(target.name, "i")
        wired = in_entity.wired().get(target.name)
        if wired is not None:
            raise SessionError(f"{target} is fed by the build: {wired}")
        return self._feed(in_entity, target.name, Plugged(Signal(out_entity.name, source.name)))

    def _feed(self, entity: Entity, signal: str, how: Plugged | Valued | FromFeature) -> str:
        key = (entity.name, signal)
        before = self._feeds.get(key)
        self._feeds[key] = Feed(how, self._statement)
        return f"{entity.name}.{signal} was {before.describe()}: replaced" if before else ""

    def _set(self, signal: Signal, value: Value, context: Context | None) -> str:
        entity = self.entity(signal.entity)
        name = entity.check_signal(signal.name, "ip")
        if context is None:  # the build phase: what the diagram starts with
            if name == "selec" or (name in entity.parameters() and not isinstance(entity, FeatureEntity)):
                entity.set_parameter(name, value, None)
                return ""
            if isinstance(value, Name):
                return self._set_from_feature(entity, name, value.text)
            if name in entity.wired() or isinstance(entity, SotEntity):
                why = entity.wired().get(name, "plug a sequencer's stack into it; push tasks at run time")
                raise SessionError(f"{signal} takes no value: {why}")
            if isinstance(entity, FeatureEntity) and name == entity.DESIRED:
                entity.check_desired(value)
            else:
                vector_value(value, str(signal))  # a vector input: a constant source at the build
                self._check_as_desired(entity, name, value)
            return self._feed(entity, name, Valued(value))
        self._check_as_desired(entity, name, value)
        return self._set_at_run_time(entity, name, value, context)

    def _check_as_desired(self, entity: Entity, signal: str, value: Value) -> None:
        """A value set on a feature's value input (``featureComDes.errorIN``) that other features take
        as their desired value (``set featureCom.sdes featureComDes``) is checked as theirs too."""
        if not isinstance(entity, FeatureEntity) or signal != entity.VALUE:
            return
        for (taker, taken), feed in self._feeds.items():
            if isinstance(feed.how, FromFeature) and feed.how.feature == entity.name:
                target = self.entity(taker)
                if isinstance(target, FeatureEntity) and taken == target.DESIRED:
                    target.check_desired(value)

    def _set_from_feature(self, entity: Entity, signal: str, feature: str) -> str:
        if not (isinstance(entity, FeatureEntity) and signal == entity.DESIRED):
            raise SessionError(
                f"{entity.name}.{signal} takes a value; only a feature's desired value "
                "takes another feature's name"
            )
        other = self.entity(feature)
        if not isinstance(other, FeatureEntity):
            raise SessionError(f"{other.describe()} is not a feature")
        value_feed = self._feeds.get((other.name, other.VALUE))
        if value_feed is not None and isinstance(value_feed.how, Valued):  # its value is set already
            entity.check_desired(value_feed.how.value)
        return self._feed(entity, signal, FromFeature(other.name))

    def _set_at_run_time(self, entity: Entity, signal: str, value: Value, context: Context) -> str:
        feed = self._feeds.get((entity.name, signal))
        if feed is not None and not isinstance(feed.how, Valued):
            raise SessionError(
                f"{entity.name}.{signal} is {feed.describe()}; "
                "the diagram is built: change its source instead"
            )
        if signal in entity.parameters():
            entity.set_parameter(signal, value, context)
            return ""
        source = self._sources.get((entity.name, signal))
        if source is None:
            raise SessionError(
                f"{entity.name}.{signal}: nothing feeds this input; set it before the build "
                "(a constant source is made for it) to change it at run time"
            )
        own = source.GetMyMutableContextFromRoot(context)
        vector = source.get_mutable_source_value(own)
        vector.SetFromVector(
            validation.vector(f"{entity.name}.{signal}", vector_value(value, signal), vector.size())
        )
        return ""

    # --- the build ----------------------------------------------------------------------------
    def build(self, by: Statement | None = None) -> HumanoidSoT:
        """Build the diagram (once; later calls return it) and close the loop.

        Every entity is made (in the order their inputs need), the plugs and values are
        wired, every task goes into the solver and the builder closes the loop. When a
        ``PatternGenerator``'s references (CoM, feet, waist) are plugged, its ``load`` splits the
        torque feed-forward between the feet and the feed-forward follows the reference's
        dynamics, as in the walk scenario (a generator that drives nothing leaves the static
        feed-forward, equal shares, alone).

        Args:
            by: the statement that asks for the build (named when a later build-time
                command is refused); default: the one being executed.

        Raises:
            SessionError: naming the entity and the line that made it, for anything that
                cannot be built (a size that does not match, a missing setting...). The
                session cannot be built after that (a Drake builder cannot take back the
                systems it was given): every later run-time command says so.
        """
        if self.built is not None:
            return self.built
        if self._failed:
            raise SessionError(f"the build failed ({self._failed}); a diagram half made cannot be finished")
        by = by or self._statement
        self._built_by = _label(by) if by else "build()"
        try:
            self.built = self._build()
        except SessionError as error:
            self._failed = str(error)
            raise
        return self.built

    def _build(self) -> HumanoidSoT:
        if not self._has(SotEntity):
            self._add(SotEntity(self, DEFAULT_SOT, None))
        for entity in list(self._entities.values()):
            self._construct(entity, ())
        from_solver = []  # the plugs of the solver's outputs: connected once the builder made it
        for (name, signal), feed in self._feeds.items():
            if isinstance(self._entities[name], SotEntity):
                continue  # its stack input: the builder connects it
            if isinstance(feed.how, Plugged) and isinstance(
                self._entities[feed.how.source.entity], SotEntity
            ):
                from_solver.append((self._entities[name], signal, feed))
                continue
            with self._building(self._entities[name], feed.statement):
                self._connect(self._entities[name], signal, feed)
        for entity in self._entities.values():
            with self._building(entity, entity.statement):
                entity.connect()
        sot = next(e for e in self._entities.values() if isinstance(e, SotEntity))
        pg = next((e for e in self._entities.values() if isinstance(e, PatternGeneratorEntity)), None)
        if pg is not None and not self._drives_the_robot(pg):
            pg = None
        stack_feed = self._feeds.get((sot.name, "stack"))

        def wire_solver(solver: StackOfTasks) -> None:
            solver.set_name(sot.name)
            sot.system = solver
            for entity, signal, feed in from_solver:
                with self._building(entity, feed.statement):
                    self._connect(entity, signal, feed)

        with self._building(sot, sot.statement):
            built = self.builder.build(
                stack=(),
                load=pg.system.GetOutputPort("load") if pg else None,
                dynamic_feedforward=pg is not None,
                stack_source=self._port(stack_feed.how.source) if stack_feed else None,
                solver=sot.solver(),
                wire_solver=wire_solver,
                command_server=self._command_server,
            )
        if built.remote is not None:  # served: the stack commands of its clients name this solver
            built.remote.sot_name = sot.name
        return built

    def _drives_the_robot(self, pg: Entity) -> bool:
        """True when a reference of the pattern generator (CoM, feet, waist) is plugged somewhere."""
        return any(
            isinstance(feed.how, Plugged)
            and feed.how.source.entity == pg.name
            and feed.how.source.name in PatternGeneratorEntity.REFERENCES
            for feed in self._feeds.values()
        )

    @contextmanager
    def _building(self, entity: Entity, statement: Statement | None) -> Iterator[None]:
        """Errors raised while building ``entity`` name it and the line that asked for it."""
        try:
            yield
        except (ValueError, KeyError, RuntimeError) as error:
            if isinstance(error, SessionError) and error.building:
                raise
            where = f" ({_label(statement)})" if statement else ""
            raise SessionError(f"building {entity.describe()}{where}: {error}", building=True) from error

    def _construct(self, entity: Entity, chain: tuple[str, ...]) -> None:
        if entity.system is not None or isinstance(entity, (PoolEntity, SotEntity)):
            return
        if entity.name in chain:
            raise SessionError(f"a cycle: {' -> '.join((*chain, entity.name))}")
        for dependency in entity.dependencies():
            self._construct(self.entity(dependency), (*chain, entity.name))
        with self._building(entity, entity.statement):
            entity.system = entity.construct()

    def _port(self, signal: Signal) -> OutputPort:
        return self.entity(signal.entity).output_port(signal.name)

    def _source(self, entity: Entity, signal: str, value: Value) -> OutputPort:
        """The constant source made for a value set on a vector input (once)."""
        key = (entity.name, signal)
        if key not in self._sources:
            source = self.builder.builder.AddSystem(
                ConstantVectorSource(vector_value(value, f"{entity.name}.{signal}"))
            )
            source.set_name(f"{entity.name}.{signal}")
            self._sources[key] = source
        return self._sources[key].get_output_port()

    def _connect(self, entity: Entity, signal: str, feed: Feed) -> None:
        how = feed.how
        if isinstance(how, Valued) and signal in entity.parameters():
            return  # made with it (a desired value)
        target = entity.input_port(signal)
        if isinstance(how, Plugged):
            source = self._port(how.source)
            what = f"plug {how.source} {entity.name}.{signal}"
        elif isinstance(how, Valued):
            source = self._source(entity, signal, how.value)
            what = f"set {entity.name}.{signal} {format_value(how.value)}"
        else:  # the value of another feature: what feeds its value input
            other = self._entities[how.feature]
            value_feed = self._feeds.get((other.name, other.VALUE))
            if value_feed is None or isinstance(value_feed.how, FromFeature):
                raise SessionError(
                    f"{entity.name}.{signal} takes the value of {other.name}, "
                    f"whose {other.VALUE} is neither plugged nor set"
                )
            if isinstance(value_feed.how, Plugged):
                source = self._port(value_feed.how.source)
            else:
                source = self._source(other, other.VALUE, value_feed.how.value)
            what = f"set {entity.name}.{signal} {other.name}"
        _check_kinds(what, source, target)
        self.builder.builder.Connect(source, target)


def _check_kinds(what: str, source: OutputPort, target: InputPort) -> None:
    """A vector into a vector of its size, an abstract value into an abstract input."""
    kinds = (source.get_data_type(), target.get_data_type())
    vector = PortDataType.kVectorValued
    if kinds[0] != kinds[1]:

        def kind(port, k):
            return f"a vector of size {port.size()}" if k == vector else "an abstract value"

        raise SessionError(
            f"{what}: the output is {kind(source, kinds[0])}, the input takes {kind(target, kinds[1])}"
        )
    if kinds[0] == vector and source.size() != target.size():
        raise SessionError(f"{what}: the output has size {source.size()}, the input size {target.size()}")
    if kinds[0] != vector:
        have = type(source.Allocate().get_value()).__name__
        want = type(target.Allocate().get_value()).__name__
        if have != want:
            raise SessionError(f"{what}: the output is a {have}, the input takes a {want}")


def _label(statement: Statement) -> str:
    """``<source>, line <n>: <text>``, or the text alone for a command given as a string."""
    return statement.text if statement.source == COMMAND_SOURCE else f"{statement.where}: {statement.text}"


def _located(error: Exception, statement: Statement | None, command: ScriptCommand) -> SessionError:
    """``error`` prefixed with the script line (or the command) that raised it; an unknown name
    stays one (:class:`UnknownScriptName`)."""
    prefix = _label(statement) if statement else str(command)
    if isinstance(error, UnknownNameError):
        where = prefixed(error, prefix).where
        return UnknownScriptName(error.kind, error.name, error.known, where=where, located=True)
    return SessionError(f"{prefix}: {error}", located=True)


def _keyword(command: ScriptCommand) -> str:
    match command:
        case Call(entity, name):
            return f"{entity}.{name}"
        case Set(signal):
            return f"set {signal}"
    return str(command).split()[0]


# ---------------------------------------------------------------------------------------
# Script files
# ---------------------------------------------------------------------------------------


def _inside(root: Path, name: str, what: str) -> Path:
    """``root / name``, refused when it resolves outside ``root``."""
    path = (root / name).resolve()
    if not path.is_relative_to(root.resolve()):
        raise SessionError(f"{name!r} resolves outside {what} {str(root)!r}")
    return path


#: How deep ``run FILE`` lines may nest (a script that runs one that runs one...).
MAX_INCLUDE_DEPTH = 16


class _IncludeError(SessionError):
    """A ``run FILE`` line that failed: ``inner`` names the innermost such line (where, its text,
    why), ``outer`` the line of the outermost script that ran it (None: the same), each once."""

    def __init__(self, inner: str, outer: str | None = None) -> None:
        super().__init__(inner if outer is None else f"{inner} (run from {outer})")
        self.inner = inner


def _expand(path: Path, root: Path, chain: tuple[Path, ...]) -> tuple[Statement, ...]:
    """The statements of a script file with its ``run FILE`` lines replaced by the files'
    statements (read relative to the including file, inside ``root``), nested at most
    :data:`MAX_INCLUDE_DEPTH` deep.

    Raises:
        SessionError: a file that cannot be read, an include outside ``root``, a cycle, too deep a
            nesting: the message names the innermost ``run FILE`` line that failed and, when it is
            in an included script, the outermost script's line that ran it.
    """
    if path in chain:
        raise SessionError(f"{path.name} runs itself: {' -> '.join(p.name for p in (*chain, path))}")
    if len(chain) > MAX_INCLUDE_DEPTH:
        raise SessionError(
            f"run {path.name}: scripts nested {len(chain)} deep ({chain[0].name} -> ... -> "
            f"{chain[-1].name}); at most {MAX_INCLUDE_DEPTH}"
        )
    try:
        if not path.is_file():  # a directory, a FIFO (whose read waits forever), a device
            raise OSError(f"{str(path)!r} is not a regular file")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise SessionError(f"cannot read the script {str(path)!r}: {error}") from None
    out: list[Statement] = []
    for statement in parse_script(text, source=path.name):
        if isinstance(statement.command, Run):
            try:
                included = _inside(path.parent, statement.command.path, "the including script's directory")
                if not included.is_relative_to(root.resolve()):
                    raise SessionError(f"{statement.command.path!r} resolves outside {str(root)!r}")
                out.extend(_expand(included, root, (*chain, path)))
            except _IncludeError as error:
                raise _IncludeError(error.inner, statement.where) from None
            except SessionError as error:
                raise _IncludeError(f"{statement.where}: {statement.text}: {error}") from None
        else:
            out.append(statement)
    return tuple(out)


@dataclass(frozen=True)
class ScriptProgram:
    """A script file read and parsed, its ``run FILE`` lines replaced by the files' statements.

    Attributes:
        path: the script file.
        statements: its statements, in order.
    """

    path: Path
    statements: tuple[Statement, ...]

    def __post_init__(self) -> None:
        t = 0.0
        for statement in self.statements:
            if isinstance(statement.command, RunFor):
                t += statement.command.duration
                if not t <= MAX_DURATION:
                    raise SessionError(
                        f"{statement.where}: {statement.text}: the script's run lines add up to {t:g} s; "
                        f"a run lasts at most {MAX_DURATION:g} s"
                    )

    @property
    def scripted_duration(self) -> float:
        """The simulated time its ``run DURATION`` lines add up to [s]."""
        return sum(s.command.duration for s in self.statements if isinstance(s.command, RunFor))


def load_script(path: str | Path) -> ScriptProgram:
    """Read and parse a script file (its includes inside its directory).

    Raises:
        ScriptError: a line out of the grammar (file, line, column).
        SessionError: a file that cannot be read, an include outside the directory or a cycle,
            ``run DURATION`` lines that add up to more than the longest run
            (:data:`~drake_sot.diagrams.run.MAX_DURATION`), naming the line.
    """
    path = Path(path).resolve()
    return ScriptProgram(path, _expand(path, path.parent, ()))


Echo = Callable[[Statement, float, str], None]
"""Called with a command's statement, the simulated time and its (non-empty) output."""


def schedule(
    session: ScriptSession, program: ScriptProgram, echo: Echo | None = None
) -> tuple[list[TimedCommand], float]:
    """Run the build phase of ``program`` on ``session`` and turn its run phase into timed commands.

    Statements before the first run-time command (or ``run DURATION``) execute now; the
    session is then built. Each later statement becomes a command applied at the simulated
    time its preceding ``run DURATION`` lines add up to; a build-time command among them is
    refused now, with its line.

    Returns:
        the timed commands and the scripted duration [s].

    Raises:
        SessionError: a build-phase command that cannot act, or a build-time command after the build.
    """
    t = 0.0
    commands: list[TimedCommand] = []
    for statement in program.statements:
        try:
            phase = session.phase(statement.command)
        except SessionError as error:
            raise SessionError(f"{statement.where}: {statement.text}: {error}") from None
        if not session.is_built and phase in (Phase.BUILD, Phase.BOTH, Phase.INFO):
            output = session.execute(statement)
            if output and echo:
                echo(statement, t, output)
            continue
        if phase == Phase.BUILD:
            session.execute(statement)  # refused, saying why
        session.build(statement)
        if isinstance(statement.command, RunFor):
            t += validation.positive(f"{statement.where}: run", statement.command.duration, unit="s")
            continue

        def apply(context: Context, statement: Statement = statement) -> None:
            output = session.execute(statement, context)
            if output and echo:
                echo(statement, context.get_time(), output)

        commands.append(TimedCommand(t, statement.text, apply))
    return commands, t


def script_scenario(
    program: ScriptProgram,
    *,
    output_dir: str | Path | None,
    echo: Echo | None = None,
    robot: str = "embedded",
) -> Scenario:
    """The script as a scenario of :func:`~drake_sot.diagrams.scenario.run_scenario`: its name is
    the file's stem, its duration the scripted one; ``extras.session`` is the session.
    ``pool.writegraph`` writes into ``output_dir`` (None: a fresh temporary directory, see
    :class:`ScriptSession`); the script drives ``robot``."""

    def build(meshcat: Meshcat | None, command_server: bool = False) -> ScenarioSetup:
        session = ScriptSession(
            meshcat=meshcat,
            script_dir=program.path.parent,
            output_dir=output_dir,
            robot=robot,
            command_server=command_server,
        )
        commands, duration = schedule(session, program, echo)
        session.build()
        return ScenarioSetup(
            built=session.built, commands=commands, duration=duration, extras=ScenarioHandles(session=session)
        )

    return Scenario(
        name=program.path.stem, description=f"the script {program.path.name}", build=build, servable=True
    )
