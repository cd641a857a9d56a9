"""The entities of the SoT script: what each class of ``new`` is on a Drake diagram.

An :class:`Entity` is a script name for a Drake system that is made when the diagram is
built (see :mod:`drake_sot.diagrams.script_session`, which runs the commands). Each class
says which signals the script sees (``inputs``, ``outputs``, ``parameters``), which commands
it has and in which :class:`Phase` they act (methods marked with ``@_command``), what it
needs made first (``dependencies``), and how its system is made (``construct``) and wired
(``connect``). :data:`CLASSES` lists the classes ``new`` makes.
"""

from __future__ import annotations

import enum
import inspect
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, InputPort, OutputPort, System

from drake_sot import validation
from drake_sot.diagrams.artifacts import WRITE_ERRORS
from drake_sot.diagrams.signal_graph import write_graph
from drake_sot.diagrams.tasks import HumanoidTaskBuilder
from drake_sot.diagrams.walking import add_pattern_generator
from drake_sot.errors import DrakeSotError, UnknownNameError
from drake_sot.gains import AdaptiveGain, Gain, validate_gain
from drake_sot.script import (
    Call,
    Matrix,
    Name,
    Signal,
    Statement,
    Value,
    Vector,
    Verb,
    format_value,
    stack_command,
)
from drake_sot.sequencing import (
    Above,
    Below,
    Flag,
    SetValue,
    State,
    Timeout,
    Transition,
)
from drake_sot.signals import FeatureSignal, TaskSignal
from drake_sot.stack import VERBS, Pop, StackError, find_verb
from drake_sot.systems.features import (
    FeatureCoM,
    FeatureGeneric,
    FeatureJointLimits,
    FeaturePoint6d,
    FeaturePoint6dRelative,
    FeaturePosture,
    check_desired_com,
    check_desired_pose,
)
from drake_sot.systems.kinematics import FRAME_SUFFIX
from drake_sot.systems.self_collision import ClosestPair
from drake_sot.systems.sequencer import TaskSequencer
from drake_sot.systems.task import Task

if TYPE_CHECKING:
    from drake_sot.diagrams.script_session import ScriptSession

__all__ = [
    "AT_MOST_ONE",
    "CLASSES",
    "Entity",
    "Phase",
    "SessionError",
    "UnknownScriptName",
    "format_signal_value",
    "vector_value",
]


class SessionError(DrakeSotError, ValueError):
    """A command that cannot act here: the message names the entity, signal, command or
    value at fault, says why, and starts with ``<source>, line <n>: <the line>:`` when the
    command came from a script (``located`` is then True)."""

    def __init__(self, message: str, *, located: bool = False, building: bool = False) -> None:
        super().__init__(message)
        self.located = located
        self.building = building


class UnknownScriptName(SessionError, UnknownNameError):
    """An entity, signal, command, class or task that a script names and the session does not
    know: a :class:`SessionError` (a ValueError) and an
    :class:`~drake_sot.errors.UnknownNameError` (a KeyError) listing the known names."""

    def __init__(
        self, kind: str, name: object, known: Iterable[str], *, where: str = "", located: bool = False
    ) -> None:
        UnknownNameError.__init__(self, kind, name, known, where=where)
        self.located = located
        self.building = False


class Phase(enum.Enum):
    """When a command may act."""

    BUILD = "build"  #: before the diagram is built, to describe it
    RUN = "run"  #: on a context of the built diagram (the first one builds it)
    BOTH = "both"  #: before the build, the value the diagram starts with; after, on a context
    INFO = "info"  #: any time, builds nothing (help, lists)


# ---------------------------------------------------------------------------------------
# Arguments
# ---------------------------------------------------------------------------------------


def _arity(args: tuple[Value, ...], usage: str, low: int, high: int | None = None) -> None:
    high = low if high is None else high
    if not (low <= len(args) <= high):
        want = f"{low}" if low == high else (f"{low} to {high}" if high < 99 else f"at least {low}")
        raise SessionError(f"takes {want} argument(s) ({usage}), got {len(args)}")


def _text(value: Value, what: str) -> str:
    """A name or a string argument as text."""
    if isinstance(value, Name):
        return value.text
    if isinstance(value, str):
        return value
    raise SessionError(f"{what} must be a name, got {format_value(value)}")


# Values from the parser are finite; a command value made in Python may not be: every
# number is checked here (validation.finite / validation.vector) before it goes further.


def _number(value: Value, what: str) -> float:
    """A finite number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SessionError(f"{what} must be a number, got {format_value(value)}")
    return validation.finite(what, value)


def _numbers(args: Iterable[Value], what: str) -> np.ndarray:
    """Finite numbers, or one vector, as a float array."""
    args = tuple(args)
    if len(args) == 1 and isinstance(args[0], Vector):
        return validation.vector(what, args[0].array)
    return np.array([_number(a, what) for a in args], dtype=float)


#: The bound of every number a script gives a signal (``set``, a sequencer's output values), in the
#: signal's own unit (m, rad, m/s, N, …): a humanoid's controller takes no quantity beyond 10⁴ in SI
#: units (10 km, 10⁴ rad, 10 kN), and a finite value past it (1e300) would reach Drake as a target,
#: a q̇ or a force of that size. The features whose unit is known bound their desired value further
#: (a position within 10 m: :mod:`drake_sot.systems.features`).
SIGNAL_VALUE_LIMIT = 1e4


def vector_value(value: Value, what: str) -> np.ndarray:
    """A finite vector value (a number is a vector of size 1), every entry within
    ±:data:`SIGNAL_VALUE_LIMIT`."""
    if isinstance(value, Vector):
        array = value.array
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        array = np.array([_number(value, what)])
    else:
        raise SessionError(f"{what} takes a vector [n](…) or a number, got {format_value(value)}")
    return validation.magnitude(what, array, SIGNAL_VALUE_LIMIT)


def _pose(value: Value, what: str, rotation: RotationMatrix | None) -> RigidTransform:
    """A ``[4,4]`` homogeneous matrix, or a ``[3]`` position with ``rotation`` kept."""
    if isinstance(value, Vector) and len(value.values) == 3:
        if rotation is None:
            raise SessionError(f"{what}: a [3] position needs an orientation to keep; give a [4,4] matrix")
        return RigidTransform(rotation, value.array)
    if not (isinstance(value, Matrix) and value.array.shape == (4, 4)):
        raise SessionError(
            f"{what} takes a [4,4] homogeneous matrix or a [3] position, got {format_value(value)}"
        )
    X = value.array
    R = X[:3, :3]
    if not (
        np.allclose(X[3], (0.0, 0.0, 0.0, 1.0), atol=1e-9)
        and np.allclose(R.T @ R, np.eye(3), atol=1e-6)
        and np.linalg.det(R) > 0.0
    ):
        raise SessionError(f"{what}: {value} is not a rigid transform (rotation block, last row 0 0 0 1)")
    return RigidTransform(RotationMatrix(R), X[:3, 3])


def _flags(value: Value, what: str) -> str:
    """A selection: '0'/'1' flags written as a number (``110``) or a string (``"011"``, for a
    leading 0)."""
    flags = str(value) if isinstance(value, int) and not isinstance(value, bool) else value
    if not isinstance(flags, str) or not flags or set(flags) - {"0", "1"}:
        raise SessionError(
            f'{what} takes 0/1 flags (110, or "011" with a leading 0), got {format_value(value)}'
        )
    return flags


def format_signal_value(value: object) -> str:
    """A signal's value as ``get`` writes it: the script's syntax for numbers, vectors and
    matrices (a pose as its ``[4,4]`` homogeneous matrix), names separated by spaces, one
    ``field value`` line per field of a feature or task signal, and one line per pair of
    shapes of a self-collision task's ``closest_pairs`` (``A (body) and B (body): d m``)."""
    if isinstance(value, np.ndarray):
        if value.ndim == 1:
            return str(Vector(tuple(float(x) for x in value)))
        if value.ndim == 2 and value.size:
            return str(Matrix(tuple(tuple(float(x) for x in row) for row in value)))
        return f"array of shape {value.shape}"
    if isinstance(value, RigidTransform):
        return format_signal_value(value.GetAsMatrix4())
    if isinstance(value, (FeatureSignal, TaskSignal)):
        fields = [f for f in ("name", "error", "jacobian", "feedforward", "edot_des") if hasattr(value, f)]
        return "\n".join(f"{f} {format_signal_value(getattr(value, f))}" for f in fields)
    if isinstance(value, tuple) and value and all(isinstance(v, ClosestPair) for v in value):
        return "\n".join(
            f"{p.shape_a} ({p.body_a}) and {p.shape_b} ({p.body_b}): {format_value(p.distance)} m"
            for p in value
        )
    if isinstance(value, tuple) and all(isinstance(v, str) for v in value):
        return " ".join(value)
    if isinstance(value, str):
        return value
    if isinstance(value, (int, float, np.floating)) and not isinstance(value, bool):
        return format_value(float(value))
    if isinstance(value, AdaptiveGain):
        return f"adaptive a={value.a!r} b={value.b!r} c={value.c!r}"
    return repr(value)


# ---------------------------------------------------------------------------------------
# Entities
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CommandSpec:
    name: str
    phase: Phase
    usage: str
    doc: str


def _command(phase: Phase, usage: str, doc: str) -> Callable:
    """Mark an entity method as a script command ``E.<name>`` (``usage`` shows its arguments)."""

    def mark(method: Callable) -> Callable:
        method._script_command = (phase, usage, doc)
        return method

    return mark


@dataclass(frozen=True)
class Plugged:
    """An input fed by ``plug source.signal``."""

    source: Signal


@dataclass(frozen=True)
class Valued:
    """An input (or parameter) given a value by ``set`` before the build."""

    value: Value


@dataclass(frozen=True)
class FromFeature:
    """A desired value fed from another feature's value (``set A.sdes B``)."""

    feature: str


@dataclass(frozen=True)
class Feed:
    how: Plugged | Valued | FromFeature
    statement: Statement | None

    def describe(self) -> str:
        where = f" ({self.statement.where})" if self.statement else ""
        match self.how:
            case Plugged(source):
                return f"plugged from {source}{where}"
            case Valued(value):
                return f"set to {format_value(value)}{where}"
            case FromFeature(feature):
                return f"set to the value of {feature}{where}"
        raise AssertionError(self.how)


class Entity:
    """An entity of the pool: a name for a Drake system made when the diagram is built.

    Subclasses give the script class (``CLASS``), the signals (:meth:`inputs`,
    :meth:`outputs`, :meth:`parameters`), the commands (methods marked with
    ``@_command``) and how the system is made (:meth:`construct`).
    """

    CLASS: ClassVar[str] = ""
    DOC: ClassVar[str] = ""
    #: Inputs the build feeds itself: signal -> by what (a plug into them is refused).
    WIRED: ClassVar[dict[str, str]] = {}
    _commands: ClassVar[dict[str, CommandSpec]] = {}

    def __init_subclass__(cls) -> None:
        super().__init_subclass__()
        commands = {}
        for klass in reversed(cls.__mro__):
            for attr, member in vars(klass).items():
                marked = getattr(member, "_script_command", None)
                if marked is not None:
                    phase, usage, doc = marked
                    commands[attr] = CommandSpec(attr, phase, usage, doc)
        cls._commands = {**commands, **cls._table_commands()}

    @classmethod
    def _table_commands(cls) -> dict[str, CommandSpec]:
        """Commands a class takes from a table rather than from its marked methods (by name);
        :meth:`run_command` runs them."""
        return {}

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        self.session = session
        self.name = name
        self.statement = statement
        self.system: System | None = None

    # --- what the script sees ---------------------------------------------------------
    def inputs(self) -> tuple[str, ...]:
        return ()

    def outputs(self) -> tuple[str, ...]:
        return ()

    def parameters(self) -> dict[str, str]:
        """Signals that are values of the entity, not ports: name -> what they hold."""
        return {}

    def wired(self) -> dict[str, str]:
        """Inputs the build feeds itself: signal -> by what (a plug or a value on them is refused)."""
        return dict(self.WIRED)

    def set_phase(self, signal: str) -> Phase:
        return Phase.BOTH

    def command_spec(self, command: str) -> CommandSpec:
        spec = self._commands.get(command)
        if spec is None:
            raise UnknownScriptName("command", command, self._commands, where=self.describe())
        return spec

    def run_command(self, name: str, args: tuple[Value, ...], context: Context | None) -> str:
        """Run the script command ``E.<name> ARG…`` (``context`` None before the build); its output."""
        return getattr(self, self.command_spec(name).name)(args, context)

    def describe(self) -> str:
        return f"{self.name!r} ({self.CLASS})"

    def signal_names(self) -> tuple[str, ...]:
        return (*self.inputs(), *self.outputs(), *self.parameters())

    def check_signal(self, signal: str, kinds: str = "io") -> str:
        """``signal`` if the entity has it (as an input ``i``, output ``o`` or parameter ``p``)."""
        known = {
            "i": self.inputs(),
            "o": self.outputs(),
            "p": tuple(self.parameters()),
        }
        if any(signal in known[k] for k in kinds):
            return signal
        for kind, names in known.items():
            if signal in names:
                what = {"i": "an input", "o": "an output", "p": "a parameter"}[kind]
                allowed = " or ".join(
                    {"i": "an input", "o": "an output", "p": "a parameter"}[k] for k in kinds
                )
                raise SessionError(f"{self.name}.{signal} is {what} signal; {allowed} signal is needed here")
        raise UnknownScriptName("signal", signal, self.signal_names(), where=self.describe())

    @_command(Phase.INFO, "help", "this text")
    def help(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "help", 0)
        lines = [f"{self.name} ({self.CLASS}): {self.DOC}"]
        for label, names in (("inputs", self.inputs()), ("outputs", self.outputs())):
            if names:
                lines.append(f"  {label}: {', '.join(names)}")
        for name, doc in self.parameters().items():
            lines.append(f"  parameter {name}: {doc}")
        for name, why in self.wired().items():
            lines.append(f"  {name} is fed by the build: {why}")
        lines.append("  commands:")
        for spec in self._commands.values():
            lines.append(f"    {spec.usage:40s} [{spec.phase.value}] {spec.doc}")
        return "\n".join(lines)

    # --- the build ----------------------------------------------------------------------
    def dependencies(self) -> Iterable[str]:
        """Entities that must be made before this one."""
        return ()

    def construct(self) -> System | None:
        """Make the system (in the session's builder); None for one the build makes itself."""
        raise NotImplementedError

    def connect(self) -> None:
        """Wire what the build feeds itself, once every entity is made (default: nothing)."""

    def own_context(self, context: Context) -> Context:
        return self.system.GetMyMutableContextFromRoot(context)

    def input_port(self, signal: str) -> InputPort:
        return self.system.GetInputPort(signal)

    def output_port(self, signal: str) -> OutputPort:
        return self.system.GetOutputPort(signal)

    # --- values -------------------------------------------------------------------------
    def set_parameter(self, signal: str, value: Value, context: Context | None) -> None:
        """Set one of :meth:`parameters` (``context`` None before the build)."""
        raise NotImplementedError

    def get_parameter(self, signal: str, context: Context) -> object:
        """Read one of :meth:`parameters` in ``context``."""
        raise NotImplementedError

    def get(self, signal: str, context: Context) -> object:
        """The signal's value in ``context`` (the root context)."""
        if signal in self.parameters():
            return self.get_parameter(signal, context)
        if signal in self.outputs():
            return self.output_port(signal).Eval(self.own_context(context))
        port = self.input_port(signal)
        own = self.own_context(context)
        if not port.HasValue(own):
            raise SessionError(f"{self.name}.{signal}: nothing feeds this input")
        return port.Eval(own)


class PoolEntity(Entity):
    CLASS = "Pool"
    DOC = "the factory of entities"

    @_command(Phase.INFO, "help", "the pool's commands")
    def help(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "help", 0)
        return "Pool:\n- list\n- listFeature\n- listTask\n- writegraph FileName\n- listClass\n- help"

    @_command(Phase.INFO, "list", "every entity, with its class")
    def list(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "list", 0)
        return "\n".join(f"{e.name} ({e.CLASS})" for e in self.session.entities())

    @_command(Phase.INFO, "listFeature", "the features")
    def listFeature(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "listFeature", 0)
        return "\n".join(e.name for e in self.session.entities() if isinstance(e, FeatureEntity))

    @_command(Phase.INFO, "listTask", "the tasks")
    def listTask(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "listTask", 0)
        return "\n".join(e.name for e in self.session.entities() if isinstance(e, StackedEntity))

    @_command(Phase.INFO, "listClass", "the classes `new` makes")
    def listClass(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "listClass", 0)
        return "\n".join(f"{name}: {cls.DOC}" for name, cls in CLASSES.items())

    @_command(
        Phase.RUN,
        "writegraph FILE",
        "the signal graph of the entities (Graphviz source, SVG for *.svg) as FILE, a plain name, in the "
        "output directory",
    )
    def writegraph(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "writegraph FILE", 1)
        name = _text(args[0], "the file name")
        if name.endswith(".svg"):  # without a renderer, the source is written beside it as .dot
            self.session.claim_output(name.removesuffix(".svg") + ".dot")
        path = self.session.claim_output(name)
        try:
            write_graph(self.session.built.diagram, path)
        except WRITE_ERRORS as exc:
            raise SessionError(f"pool.writegraph: cannot write {str(path)!r}: {exc}") from None
        return f"wrote {path}"


class DynamicEntity(Entity):
    CLASS = "Dynamic"
    DOC = "the robot model (com, Jcom, inertia, the operational points); the paper's dyn and dyn2"
    WIRED = {"q": "the reference configuration the loop integrates (the device's q)"}

    def inputs(self) -> tuple[str, ...]:
        return ("q",)

    def outputs(self) -> tuple[str, ...]:
        ops = self.session.builder.dyn.operational_points
        return ("com", "Jcom", "inertia", *(x for op in ops for x in (op, "J" + op, op + FRAME_SUFFIX)))

    @_command(
        Phase.BUILD,
        "createOpPoint NAME RANK|FRAME",
        "outputs NAME (pose), JNAME (Jacobian) and NAME_frame (both, for a feature's frame input)",
    )
    def createOpPoint(self, args: tuple[Value, ...], context: Context | None) -> str:
        """The paper's ``dyn2.createOpPoint rleg 6``: RANK is the joint's rank in the robot's
        state vector as in the SoT's dynamic entity — the free flyer is rank 0, the one-DoF
        joints follow in the order of q (here as on HRP-2: 1-6 the right leg, 7-12 the left
        leg) — and the point is the frame of the body that joint moves. A name instead gives
        a frame: a logical one (``right_foot``) or one of the model (``r_sole``)."""
        _arity(args, "createOpPoint NAME RANK|FRAME", 2)
        name = _text(args[0], "the operational point's name")
        b = self.session.builder
        taken = set(self.outputs()) | {"q"}
        if taken & {name, "J" + name, name + FRAME_SUFFIX}:
            raise SessionError(
                f"dyn already has a signal {name!r} (or {'J' + name!r}, or {name + FRAME_SUFFIX!r})"
            )
        where = args[1]
        if isinstance(where, int) and not isinstance(where, bool):
            frame = self._rank_frame(where)
        else:
            key = _text(where, "the joint rank or frame")
            frame = b.control_info.frames.get(key, key)
        b.op_point(name, frame)
        return f"{name}: frame {frame!r}"

    def _rank_frame(self, rank: int) -> str:
        plant = self.session.builder.control_plant
        joints = self.session.joints_by_rank()
        if not (0 <= rank < len(joints)):
            raise SessionError(f"joint rank {rank}: must be 0 (the free flyer) to {len(joints) - 1}")
        return plant.get_joint(joints[rank]).child_body().body_frame().name()

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self.system = session.builder.dyn  # the builder's, made with it


class FeatureEntity(Entity):
    """A feature: its selection, its desired value, and the input that carries its value s."""

    FEATURE: ClassVar[type] = FeatureGeneric
    VALUE: ClassVar[str] = "errorIN"  # the input carrying s
    DESIRED: ClassVar[str] = "sdes"  # the desired-value input (a parameter when nothing feeds it)

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self.selection: str | None = None
        self._selection_was_a_number = False

    def parameters(self) -> dict[str, str]:
        return {
            self.DESIRED: "s*: a value, or another feature's name (its value) before the build",
            "selec": "the selected components, '0'/'1' flags (before the build)",
        }

    def outputs(self) -> tuple[str, ...]:
        return ("feature", "error")

    def set_phase(self, signal: str) -> Phase:
        return Phase.BUILD if signal == "selec" else Phase.BOTH

    def set_parameter(self, signal: str, value: Value, context: Context | None) -> None:
        """``selec`` (before the build), or s* in ``context`` (after; before, the session
        records s* as the value the feature is made with)."""
        if signal == "selec":
            self.selection = _flags(value, f"{self.name}.selec")
            self._selection_was_a_number = isinstance(value, int)
        else:
            self.system.set_desired(context, self.desired_value(value, self.system.desired(context)))

    def desired_value(self, value: Value, current: object) -> object:
        """A script value as this feature's s* (``current``: the s* it replaces, or its default)."""
        return vector_value(value, f"{self.name}.{self.DESIRED}")

    def check_desired(self, value: Value) -> None:
        """Refuse, before the build, a value that cannot be an s* whatever the sizes."""
        self.desired_value(value, None)

    def get_parameter(self, signal: str, context: Context) -> object:
        if signal == "selec":
            return self.selection or "1" * self.system.dimension
        return self.system.desired(context)

    def initial_desired(self) -> object | None:
        """s* when neither set nor plugged (None: the feature's own default)."""
        return None

    def desired_default(self) -> object | None:
        """The desired value the feature is made with."""
        feed = self.session.feed(self.name, self.DESIRED)
        if feed is not None and isinstance(feed.how, Valued):
            return self.desired_value(feed.how.value, self.initial_desired())
        return self.initial_desired()

    def make(self, desired: object | None) -> System:
        return self.FEATURE(selection=self.selection, name=self.name, desired=desired)

    def construct(self) -> System:
        try:
            feature = self.make(self.desired_default())
        except ValueError as error:
            if self._selection_was_a_number and "selection" in str(error):
                raise SessionError(
                    f'{error} (selec written as a number loses its leading zeros: quote it, "0…")'
                ) from error
            raise
        return self.session.builder.builder.AddSystem(feature)


class FeatureGenericEntity(FeatureEntity):
    CLASS = "FeatureGeneric"
    DOC = "e = s - s*, s and its Jacobian from input signals (SoT FeatureGeneric)"

    def inputs(self) -> tuple[str, ...]:
        return ("errorIN", "jacobianIN", "sdes", "sdes_dot")

    def dependencies(self) -> Iterable[str]:
        feed = self.session.feed(self.name, "errorIN")
        if feed is not None and isinstance(feed.how, Plugged):
            yield feed.how.source.entity

    def make(self, desired: object | None) -> System:
        feed = self.session.feed(self.name, "errorIN")
        if feed is None:
            raise SessionError(f"{self.name}: its size comes from errorIN, which is neither plugged nor set")
        if isinstance(feed.how, Plugged):
            size = self.session.output_size(feed.how.source)
        else:
            size = vector_value(feed.how.value, f"{self.name}.errorIN").size
        return FeatureGeneric(size, selection=self.selection, name=self.name, desired=desired)


class FeatureCoMEntity(FeatureEntity):
    CLASS = "FeatureCoM"
    DOC = "the centre of mass against s* (3,) [m]; holds the CoM at q0 unless set"
    FEATURE = FeatureCoM
    VALUE = "com"

    def inputs(self) -> tuple[str, ...]:
        return ("com", "Jcom", "sdes", "sdes_dot")

    def initial_desired(self) -> object:
        return self.session.builder.initial_com()

    def desired_value(self, value: Value, current: object) -> object:
        return check_desired_com(self.name, super().desired_value(value, current))

    def connect(self) -> None:
        """``com`` and ``Jcom`` from dyn's unless plugged."""
        for signal in ("com", "Jcom"):
            if self.session.feed(self.name, signal) is None:
                dyn = self.session.builder.dyn
                self.session.builder.builder.Connect(
                    dyn.GetOutputPort(signal), self.system.GetInputPort(signal)
                )


class PoseFeatureEntity(FeatureEntity):
    VALUE = "position"
    DESIRED = "position_des"

    def desired_value(self, value: Value, current: object) -> object:
        rotation = current.rotation() if isinstance(current, RigidTransform) else None
        pose = _pose(value, f"{self.name}.{self.DESIRED}", rotation)
        return check_desired_pose(self.name, pose, origin=self.FEATURE.ORIGIN)

    def check_desired(self, value: Value) -> None:
        self.desired_value(value, RigidTransform())

    def op_pose(self, suffix: str = "") -> RigidTransform | None:
        """The pose at q0 of the ``dyn`` operational point plugged into ``position<suffix>`` (its
        pose) or ``frame<suffix>`` (its pose and Jacobian), if one is."""
        ops = self.session.builder.dyn.operational_points
        for signal, ending in (("position" + suffix, ""), ("frame" + suffix, FRAME_SUFFIX)):
            feed = self.session.feed(self.name, signal)
            if feed is None or not isinstance(feed.how, Plugged):
                continue
            source, name = self.session.entity(feed.how.source.entity), feed.how.source.name
            op = name[: len(name) - len(ending)] if name.endswith(ending) else None
            if isinstance(source, DynamicEntity) and op in ops:
                return self.session.initial_frame_pose(ops[op])
        return None

    def desired_default(self) -> object:
        desired = super().desired_default()
        if desired is None and self.session.feed(self.name, self.DESIRED) is None:
            raise SessionError(
                f"{self.name}: {self.DESIRED} is neither set nor plugged, and neither {self.VALUE} nor frame "
                "comes from a dyn operational point whose pose at q0 it could hold"
            )
        return desired


class Point6dEntity(PoseFeatureEntity):
    CLASS = "FeaturePoint6d"
    DOC = "the pose of an operational point against a desired pose (SoT FeaturePoint6d)"
    FEATURE = FeaturePoint6d

    def inputs(self) -> tuple[str, ...]:
        return ("position", "Jq", "frame", "position_des", "velocity_des")

    def initial_desired(self) -> RigidTransform | None:
        return self.op_pose()


class Relative6dEntity(PoseFeatureEntity):
    CLASS = "FeaturePoint6dRelative"
    DOC = "the pose of one operational point in another's frame (SoT FeaturePoint6dRelative)"
    FEATURE = FeaturePoint6dRelative

    def inputs(self) -> tuple[str, ...]:
        return ("position", "Jq", "frame", "positionRef", "JqRef", "frameRef", "position_des")

    def initial_desired(self) -> RigidTransform | None:
        X, X_ref = self.op_pose(), self.op_pose("Ref")
        return None if X is None or X_ref is None else X_ref.InvertAndCompose(X)


class JointFeatureEntity(FeatureEntity):
    """A feature on the configuration: its q is the reference configuration unless plugged."""

    VALUE = "q"

    def connect(self) -> None:
        if self.session.feed(self.name, "q") is None:
            self.session.builder.use_reference_q(self.system.GetInputPort("q"))


class PostureEntity(JointFeatureEntity):
    CLASS = "FeaturePosture"
    DOC = "every actuated joint against a posture (nq,), q0 unless set"

    def inputs(self) -> tuple[str, ...]:
        return ("q", "sdes")

    def make(self, desired: object | None) -> System:
        b = self.session.builder
        joints = list(b.control_info.actuated_joints)
        return FeaturePosture(
            b.control_plant, joints, selection=self.selection, name=self.name, desired=desired
        )

    def initial_desired(self) -> np.ndarray:
        return self.session.builder.q0


class JointLimitsEntity(JointFeatureEntity):
    CLASS = "FeatureJointLimits"
    DOC = "every actuated joint pushed back inside its limits less a margin (top of the stack)"

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self._margin = 0.02

    def inputs(self) -> tuple[str, ...]:
        return ("q",)

    def parameters(self) -> dict[str, str]:
        return {}

    @_command(Phase.BUILD, "margin RAD", "distance from each limit where a joint is pushed back (0.02)")
    def margin(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "margin RAD", 1)
        self._margin = validation.nonnegative(f"{self.name}.margin", _number(args[0], "margin"), unit="rad")
        return ""

    def make(self, desired: object | None) -> System:
        b = self.session.builder
        return FeatureJointLimits(
            b.control_plant, list(b.control_info.actuated_joints), margin=self._margin, name=self.name
        )


class StackedEntity(Entity):
    """An entity the solver stacks: its ``task`` output is wired into the solver (``sot.push``
    takes its name)."""

    #: True for an inequality task: the solver is then the HQP (:meth:`SotEntity.solver`).
    INEQUALITY: ClassVar[bool] = False


class TaskEntity(StackedEntity):
    CLASS = "Task"
    DOC = "the features it adds, e = [e1; e2; …], ė* = -λ e (Mansard et al. 2009, eq. 3 and 10)"

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self.features: list[str] = []
        self.gain: Gain = 1.0

    def inputs(self) -> tuple[str, ...]:
        return ("gain", *self.features)

    def wired(self) -> dict[str, str]:
        return {f: "added with add" for f in self.features}

    def outputs(self) -> tuple[str, ...]:
        return ("task",)

    def parameters(self) -> dict[str, str]:
        return {"controlGain": "λ [1/s] (a parameter unless the gain input is fed)"}

    @_command(Phase.BUILD, "add FEATURE", "add a feature (its rows follow those added before)")
    def add(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "add FEATURE", 1)
        feature = _text(args[0], "the feature")
        entity = self.session.entity(feature)
        if not isinstance(entity, FeatureEntity):
            raise SessionError(f"{entity.describe()} is not a feature")
        if feature in self.features:
            raise SessionError(f"{self.name} has {feature} already")
        self.features.append(feature)
        return ""

    def _gain(self, gain: Gain, context: Context | None) -> str:
        if context is None:  # the solver will integrate the task at the builder's period
            self.gain = validate_gain(gain, name=self.name, period=self.session.builder.control_period)
        else:
            self.system.set_gain(context, gain)
        return ""

    @_command(Phase.BOTH, "controlGain LAMBDA", "a constant gain λ [1/s]")
    def controlGain(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "controlGain LAMBDA", 1)
        return self._gain(_number(args[0], "the gain"), context)

    @_command(
        Phase.BOTH,
        "controlGainAdaptive AT_ZERO AT_INFINITY SLOPE",
        "λ(‖e‖) = a·exp(-b‖e‖) + c from λ(0), λ(∞) and the slope at 0",
    )
    def controlGainAdaptive(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "controlGainAdaptive AT_ZERO AT_INFINITY SLOPE", 3)
        at_zero, at_infinity, slope = (_number(a, "a gain coefficient") for a in args)
        return self._gain(AdaptiveGain.from_limits(at_zero, at_infinity, slope), context)

    def set_parameter(self, signal: str, value: Value, context: Context | None) -> None:
        self._gain(_number(value, f"{self.name}.controlGain"), context)

    def get_parameter(self, signal: str, context: Context) -> object:
        return self.system.gain(context)

    def dependencies(self) -> Iterable[str]:
        return tuple(self.features)

    def construct(self) -> System:
        b = self.session.builder
        task = b.add_task(Task(self.name, gain=self.gain))
        for feature in self.features:
            system = self.session.entity(feature).system
            b.builder.Connect(system.GetOutputPort("feature"), task.add(system))
        return task


#: The bounds of the self-collision task's settings (finite ones past them reach Drake's query and
#: the solver as nonsense): distances [m] within a humanoid's reach of one body from another, the
#: approach speed [m/s] of a hand's fastest motion and the rows a tick's solve takes.
MAX_COLLISION_DISTANCE = 1.0
MAX_APPROACH_SPEED = 10.0
MAX_COLLISION_PAIRS = 1000


class SelfCollisionEntity(StackedEntity):
    CLASS = "TaskSelfCollision"
    DOC = (
        "every pair of the robot's collision shapes closer than d_i kept d_s apart, an inequality task"
        " (SelfCollisionAvoidance; the SoT has no such entity); the solver is then the HQP"
    )
    INEQUALITY = True
    WIRED = {"q": "the reference configuration the loop integrates (the device's q)"}
    #: The settings: script name -> (``add_self_collision_task``'s argument, what it is).
    SETTINGS = {
        "d_s": ("d_s", f"the safety margin [m], in [0, {MAX_COLLISION_DISTANCE:g}]"),
        "d_i": ("d_i", f"the activation distance [m], > d_s and <= {MAX_COLLISION_DISTANCE:g}"),
        "xi": ("xi", f"ξ, the approach speed allowed at d_i [m/s], in (0, {MAX_APPROACH_SPEED:g}]"),
        "maxPairs": ("max_pairs", f"the number of rows, an integer in [1, {MAX_COLLISION_PAIRS}]"),
        "legPairs": ("leg_pairs", "1: rows between one leg's shapes and the other's; 0: none"),
    }
    #: The settings' values when not set: ``add_self_collision_task``'s defaults.
    DEFAULTS = {
        argument: inspect.signature(HumanoidTaskBuilder.add_self_collision_task).parameters[argument].default
        for argument, _ in SETTINGS.values()
    }

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self.settings: dict[str, float | int | bool] = dict(self.DEFAULTS)

    def inputs(self) -> tuple[str, ...]:
        return ("q",)

    def outputs(self) -> tuple[str, ...]:
        return ("task", "closest_pairs", "distances", "pair_indices")

    def parameters(self) -> dict[str, str]:
        return {
            name: f"{doc} ({float(self.DEFAULTS[argument]):g} unless set before the build)"
            for name, (argument, doc) in self.SETTINGS.items()
        }

    def set_phase(self, signal: str) -> Phase:
        return Phase.BUILD if signal in self.SETTINGS else Phase.BOTH

    def set_parameter(self, signal: str, value: Value, context: Context | None) -> None:
        """A setting, before the build (the session refuses ``set`` on one after it).

        Raises:
            ValueError: a value out of its range (NaN, ±inf, negative, past its bound, not a
                number), naming the setting and the value.
        """
        what = f"{self.name}.{signal}"
        if signal == "maxPairs":
            count = validation.positive_int(what, value)
            if not count <= MAX_COLLISION_PAIRS:
                raise SessionError(
                    f"{what} = {validation.shown(value)}: must be an integer in [1, {MAX_COLLISION_PAIRS}]"
                )
            setting: float | int | bool = count
        elif signal == "legPairs":
            if isinstance(value, bool) or value not in (0, 1):
                raise SessionError(f"{what} = {format_value(value)}: must be 1 (rows between the legs) or 0")
            setting = value == 1
        else:
            number = _number(value, what)
            if signal == "xi":
                setting = validation.positive(what, number, unit="m/s")
                limit, unit = MAX_APPROACH_SPEED, "m/s"
            else:
                setting = validation.nonnegative(what, number, unit="m")
                limit, unit = MAX_COLLISION_DISTANCE, "m"
            if not setting <= limit:
                raise SessionError(f"{what} = {format_value(value)} {unit}: must be at most {limit:g} {unit}")
        self.settings[self.SETTINGS[signal][0]] = setting

    def get_parameter(self, signal: str, context: Context) -> object:
        value = self.settings[self.SETTINGS[signal][0]]
        return int(value) if isinstance(value, bool) else value

    @_command(Phase.RUN, "pairs", "the rows' pairs of shapes (bodies) closest first, with their distance [m]")
    def pairs(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "pairs", 0)
        pairs = self.get("closest_pairs", context)
        if not pairs:
            return f"no pair closer than d_i = {format_value(self.settings['d_i'])} m"
        return format_signal_value(pairs)

    def construct(self) -> System:
        return self.session.builder.add_self_collision_task(self.name, **self.settings)


class SotEntity(Entity):
    CLASS = "SOT"
    DOC = "the solver: its stack of tasks, in strict priority (eq. 8); every task is wired into it"

    def _tasks(self) -> list[str]:
        return [e.name for e in self.session.entities() if isinstance(e, StackedEntity)]

    def solver(self) -> str:
        """The ``StackOfTasks`` solver: ``"hqp"`` when an inequality task
        (``TaskSelfCollision``) exists, else ``"svd"`` (equality tasks)."""
        inequality = any(isinstance(e, StackedEntity) and e.INEQUALITY for e in self.session.entities())
        return "hqp" if inequality else "svd"

    def inputs(self) -> tuple[str, ...]:
        return ("stack", *self._tasks())

    def wired(self) -> dict[str, str]:
        return {task: "every task is wired into the solver" for task in self._tasks()}

    def outputs(self) -> tuple[str, ...]:
        return ("qdot", "errors", "stack")

    def construct(self) -> None:
        return None  # made by the builder when it closes the loop

    @classmethod
    def _table_commands(cls) -> dict[str, CommandSpec]:
        # The stack commands, from the one vocabulary (SECONDS, optional, is this dialect's: the
        # change is blended over that time, StackOfTasks' transition).
        return {v.name: CommandSpec(v.name, Phase.RUN, v.usage, v.doc) for v in VERBS.values()}

    def command_spec(self, command: str) -> CommandSpec:
        if command not in self._commands:
            try:
                find_verb(command)
            except StackError as error:
                others = ", ".join(name for name in self._commands if name not in VERBS)
                raise SessionError(f"{error}; {self.describe()} also has: {others}") from error
        return super().command_spec(command)

    def run_command(self, name: str, args: tuple[Value, ...], context: Context | None) -> str:
        """A stack command made by the vocabulary's parser and applied with ``StackOfTasks.apply``
        (``pop`` writes the task it removed); the other commands as any entity's."""
        if name not in VERBS:
            return super().run_command(name, args, context)
        command = stack_command(Call(self.name, name, args))
        before = self.system.apply(context, command)
        return before.active[-1] if isinstance(command, Pop) else ""

    @_command(Phase.RUN, "list", "the stack, highest priority first")
    def list(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "list", 0)
        return " ".join(self.system.list(context))


class PatternGeneratorEntity(Entity):
    CLASS = "PatternGenerator"
    DOC = "walking references by ZMP preview control (the paper's pg); at most one"
    #: The references that move the robot: once one is plugged, the generator's ``load`` splits
    #: the torque feed-forward between the feet and the feed-forward follows the reference's dynamics.
    REFERENCES = ("com", "com_vel", "left_foot", "right_foot", "left_foot_vel", "right_foot_vel", "waist")

    def inputs(self) -> tuple[str, ...]:
        return ("next_footprint",)  # the step decider of the tele-cooperation (Evrard et al. 2009)

    def outputs(self) -> tuple[str, ...]:
        return (
            *self.REFERENCES,
            "zmp_ref",
            "zmp",
            "phase",
            "contacts",
            "load",
            "in_process",
            "planned_feet",
        )

    def construct(self) -> System:
        pg, _, _ = add_pattern_generator(self.session.builder, self.name)
        return pg

    @_command(Phase.RUN, "parsecmd :VERB ARG…", "the generator's commands (:stepseq, :singlesupporttime, …)")
    def parsecmd(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "parsecmd :VERB ARG…", 1, 999)
        if not isinstance(args[0], Verb):
            raise SessionError(f"parsecmd starts with a :verb, got {format_value(args[0])}")
        numbers = [format_value(_number(a, f"{args[0]} argument")) for a in args[1:]]
        self.system.parsecmd(context, " ".join([str(args[0]), *numbers]))
        return ""

    @_command(Phase.RUN, "velocity VX VY WZ", "walk at (vx, vy) [m/s], turning at wz [rad/s]; 0 0 0 stops")
    def velocity(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "velocity VX VY WZ", 3)
        vx, vy, wz = (_number(a, "a velocity") for a in args)
        self.system.set_velocity(context, vx, vy, wz)
        return ""


class AdmittanceEntity(Entity):
    CLASS = "AdmittanceController"
    DOC = "a hand's compliant reference from its wrist sensor (Mansard et al. 2009, IV-C)"
    WIRED = {
        "wrench": "the hand's wrist sensor",
        "sensor_pose": "dyn's <side>_wrist_sensor point",
        "hand_pose": "dyn's <side>_hand point",
    }

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self.side: str | None = None
        self.dynamics: dict[str, np.ndarray] = {}
        self.max_velocity: np.ndarray = np.array([0.5, 1.0])

    def inputs(self) -> tuple[str, ...]:
        return ("wrench", "sensor_pose", "hand_pose", "wrench_ref", "active")

    def outputs(self) -> tuple[str, ...]:
        return ("position_des", "velocity_des", "wrench_external", "saturated", "fault", "virtual_mass")

    @_command(Phase.BUILD, "hand right|left", "the hand (its wrist sensor and poses are wired)")
    def hand(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "hand right|left", 1)
        side = _text(args[0], "the hand")
        if side not in ("right", "left"):
            raise SessionError(f"hand {side!r}: must be right or left")
        self.side = side
        return ""

    def _per_axis(self, key: str, args: tuple[Value, ...], usage: str) -> str:
        _arity(args, usage, 1, 6)
        self.dynamics[key] = _numbers(args, key)
        return ""

    @_command(Phase.BUILD, "mass M… (1, 2 or 6 values)", "virtual mass [kg, kg·m²]")
    def mass(self, args: tuple[Value, ...], context: Context | None) -> str:
        return self._per_axis("mass", args, "mass M…")

    @_command(Phase.BUILD, "damping B… (1, 2 or 6 values)", "virtual damping [N·s/m, N·m·s/rad]")
    def damping(self, args: tuple[Value, ...], context: Context | None) -> str:
        return self._per_axis("damping", args, "damping B…")

    @_command(Phase.BUILD, "stiffness K… (1, 2 or 6 values)", "virtual stiffness (0: mass-damper)")
    def stiffness(self, args: tuple[Value, ...], context: Context | None) -> str:
        return self._per_axis("stiffness", args, "stiffness K…")

    @_command(Phase.BUILD, "maxVelocity LINEAR ANGULAR", "velocity saturation [m/s, rad/s]")
    def maxVelocity(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "maxVelocity LINEAR ANGULAR", 2)
        self.max_velocity = _numbers(args, "maxVelocity")
        return ""

    def construct(self) -> System:
        missing = [what for what in ("mass", "damping") if what not in self.dynamics]
        if self.side is None:
            missing.insert(0, "hand")
        if missing:
            raise SessionError(f"{self.name}: give its {', '.join(missing)} before the build")
        return self.session.builder.add_admittance_controller(
            self.name, self.side, max_velocity=self.max_velocity, **self.dynamics
        )


#: A state's stack actions, from the vocabulary (their change is blended by ``transitionTime``).
_ENTRY_ACTIONS = " | ".join(v.name + " TASK" * v.tasks for v in VERBS.values())


class SequencerEntity(Entity):
    CLASS = "TaskSequencer"
    DOC = (
        "a state machine over the stack (the paper's DecisionServer); plug its stack (or smooth_stack,"
        " with transitionTime) into the SOT's"
    )

    def __init__(self, session: ScriptSession, name: str, statement: Statement | None) -> None:
        super().__init__(session, name, statement)
        self.states: dict[str, tuple[list, list]] = {}  # name -> (entry actions, transitions)
        self.values: dict[str, object] = {}
        self._period = 0.005
        self._transition_time = 0.0
        self.initial_stack: tuple[str, ...] = ()

    def _guard_ports(self) -> list[str]:
        ports = []
        for _, transitions in self.states.values():
            for transition in transitions:
                port = getattr(transition.guard, "port", None)
                if port is not None and port not in ports:
                    ports.append(port)
        return ports

    def inputs(self) -> tuple[str, ...]:
        return tuple(self._guard_ports())

    def outputs(self) -> tuple[str, ...]:
        return ("stack", "smooth_stack", "state", "transitions", *self.values)

    def _state(self, value: Value) -> tuple[list, list]:
        name = _text(value, "the state")
        if name not in self.states:
            raise SessionError(
                f"{self.name} has no state {name!r}; states: {', '.join(self.states) or '(none)'}"
            )
        return self.states[name]

    @_command(Phase.BUILD, "addState NAME", "a state (the first is the initial one)")
    def addState(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "addState NAME", 1)
        name = _text(args[0], "the state")
        if name in self.states:
            raise SessionError(f"{self.name} has a state {name!r} already")
        self.states[name] = ([], [])
        return ""

    @_command(Phase.BUILD, "addOutput NAME INITIAL", "an output (a number or a vector) that entries set")
    def addOutput(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "addOutput NAME INITIAL", 2)
        name = _text(args[0], "the output")
        if name in ("stack", "state", "transitions") or name in self.values:
            raise SessionError(f"{self.name} has an output {name!r} already")
        self.values[name] = vector_value(args[1], f"output {name}")
        return ""

    @_command(
        Phase.BUILD,
        f"addEntry STATE {_ENTRY_ACTIONS} | set OUTPUT VALUE",
        "an action run on entering STATE",
    )
    def addEntry(self, args: tuple[Value, ...], context: Context | None) -> str:
        usage = "addEntry STATE ACTION [ARG…]"
        _arity(args, usage, 2, 4)
        entry, _ = self._state(args[0])
        action = _text(args[1], "the action")
        rest = args[2:]
        if action == "set":
            _arity(rest, "set OUTPUT VALUE", 2)
            entry.append(SetValue(_text(rest[0], "the output"), vector_value(rest[1], "the value")))
        else:
            try:
                command = stack_command(Call(self.name, action, rest))
            except StackError as error:
                hint = "" if action in VERBS else "; or set OUTPUT VALUE"
                raise SessionError(f"{error}{hint}") from error
            if command.transition:
                raise SessionError(
                    f"addEntry {command}: an entry action has no transition time of its own; the "
                    f"state's change of the stack is blended over {self.name}.transitionTime"
                )
            entry.append(command)
        return ""

    @_command(
        Phase.BUILD,
        "addTransition FROM TO below|above PORT THRESHOLD [SIZE] | signal PORT | timeout S",
        "go from FROM to TO when the guard holds (checked in order)",
    )
    def addTransition(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "addTransition FROM TO GUARD …", 3, 6)
        _, transitions = self._state(args[0])
        target = _text(args[1], "the target state")
        kind = _text(args[2], "the guard")
        rest = args[3:]
        if kind in ("below", "above"):
            _arity(rest, f"{kind} PORT THRESHOLD [SIZE]", 2, 3)
            size = validation.positive_int("SIZE", _number(rest[2], "SIZE")) if len(rest) == 3 else 1
            guard = (Below if kind == "below" else Above)(
                _text(rest[0], "the port"), _number(rest[1], "THRESHOLD"), size
            )
        elif kind == "signal":
            _arity(rest, "signal PORT", 1)
            guard = Flag(_text(rest[0], "the port"))
        elif kind == "timeout":
            _arity(rest, "timeout S", 1)
            guard = Timeout(_number(rest[0], "S"))
        else:
            raise SessionError(f"guard {kind!r}: one of below, above, signal, timeout")
        transitions.append(Transition(guard, target))
        return ""

    @_command(Phase.BUILD, "period S", "time between checks [s] (0.005; the paper's server: 1)")
    def period(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "period S", 1)
        self._period = validation.positive(f"{self.name}.period", _number(args[0], "the period"), unit="s")
        return ""

    @_command(
        Phase.BUILD,
        "transitionTime S",
        "blend each state's change of the stack over S seconds on smooth_stack (0: at once)",
    )
    def transitionTime(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "transitionTime S", 1)
        self._transition_time = validation.nonnegative(
            f"{self.name}.transitionTime", _number(args[0], "the transition time"), unit="s"
        )
        return ""

    @_command(Phase.BUILD, "initialStack TASK…", "the stack before the initial state's entry")
    def initialStack(self, args: tuple[Value, ...], context: Context | None) -> str:
        self.initial_stack = tuple(_text(a, "a task") for a in args)
        return ""

    @_command(Phase.RUN, "current", "the current state")
    def current(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "current", 0)
        return self.system.current_state(context)

    @_command(Phase.RUN, "list", "the stack it outputs, highest priority first")
    def list(self, args: tuple[Value, ...], context: Context | None) -> str:
        _arity(args, "list", 0)
        return " ".join(self.system.stack(context))

    def dependencies(self) -> Iterable[str]:
        return tuple(e.name for e in self.session.entities() if isinstance(e, StackedEntity))

    def construct(self) -> System:
        if not self.states:
            raise SessionError(f"{self.name} has no state (addState NAME)")
        states = [State(name, tuple(entry), tuple(tr)) for name, (entry, tr) in self.states.items()]
        b = self.session.builder
        return b.builder.AddSystem(
            TaskSequencer(
                states,
                next(iter(self.states)),
                tasks=list(b.tasks),
                stack=self.initial_stack,
                period=self._period,
                values=self.values,
                transition_time=self._transition_time,
                name=self.name,
            )
        )


#: The classes ``new`` makes: script class name -> entity class.
CLASSES: dict[str, type[Entity]] = {
    cls.CLASS: cls
    for cls in (
        FeatureGenericEntity,
        FeatureCoMEntity,
        Point6dEntity,
        Relative6dEntity,
        PostureEntity,
        JointLimitsEntity,
        TaskEntity,
        SelfCollisionEntity,
        SotEntity,
        PatternGeneratorEntity,
        AdmittanceEntity,
        SequencerEntity,
    )
}
AT_MOST_ONE = (SotEntity, PatternGeneratorEntity)
