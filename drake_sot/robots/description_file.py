"""Your own robot: a description file (TOML) beside its model, read into a
:class:`~drake_sot.robots.description.RobotDescription`.

A description file names the model (a URDF, an SDF or an MJCF, relative to the file: what each
format may hold is in :mod:`drake_sot.robots.model_tree`) and says what the model cannot: the
logical frames, the sole, the force sensors, the half-sitting posture and the servo gains.
``drake-sot robot draft MODEL`` drafts one (:mod:`drake_sot.robots.draft`);
``--robot PATH`` (and ``robot=PATH`` in Python) loads one through :func:`load_description`.
The keys (``[name]`` a table, ``name[]`` an array of tables; defaults in parentheses)::

    name = "myrobot"              # (the file's stem) the robot's name
    title = "..."                 # (the model file's name) one line for `drake-sot list --robots`
    model = "myrobot.urdf"        # the model (.urdf, .sdf, or .xml for MJCF), relative to this file
    base_body = "pelvis"          # the floating base body: the model's root link
    sole_size = [0.23, 0.13]      # [m] sole length (x) and width (y), centred on the sole frame
    contact_radius = 0.01         # (0.01) [m] the four contact spheres under each sole
    frozen_joints = []            # (none) model joints made fixed at load (grippers, mimics)
    [packages]                    # (none) package name = directory (relative to this file)
    [frames]                      # every logical frame: a frame of the model, or a table
    left_foot = { parent = "l_foot", xyz = [0, 0, -0.075], rpy = [0, 0, 0] }   # [m], [rad]
    [force_sensors]               # left_ankle, right_ankle, left_wrist, right_wrist = weld joint
                                  #   (an MJCF's welds are named by Drake: "<parent>_welds_to_<child>")
    added_welds[]                 # (none) { name, parent, child, xyz }: a sensor weld the model lacks
    [half_sitting]                # (0 rad) joint = angle [rad]
    [drives]                      # regular expression = { kp, kd, rotor_inertia (0), effort (the model's) }
                                  #   (effort is needed where the model gives a joint none)
    collision[]                   # (none) { body, kind = box|sphere|capsule, dims, xyz, rpy }
    [step_timing]                 # (0.7 s, 0.1 s, 0.05 m) single_support, double_support, step_height
    [step_limits]                 # (0.35, 0.15, 0.35 m, 0.5 rad) max_stride, min_width, max_width, max_yaw

A drive applies to every moving joint whose name the regular expression matches (the first
that matches wins, in file order); every moving joint needs one.

No pydrake import here.
"""

from __future__ import annotations

import functools
import math
import re
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from drake_sot.footsteps import StepLimits, StepTiming
from drake_sot.robots.description import (
    FORCE_SENSORS,
    LOGICAL_FRAMES,
    CollisionShape,
    Drive,
    FrameSpec,
    RobotDescription,
)
from drake_sot.robots.errors import RobotFileError, RobotFileMissing
from drake_sot.robots.model_tree import MODEL_FORMATS, model_root, read_model_tree
from drake_sot.robots.urdf import AddedWeld
from drake_sot.validation import shown

#: The file suffix of a description.
DESCRIPTION_SUFFIX = ".toml"
#: The model files a description may name: URDF, SDF, MJCF (``.xml`` whose root is ``<mujoco>``),
#: parsed by Drake after the in-memory fixes of :mod:`~drake_sot.robots.urdf`,
#: :mod:`~drake_sot.robots.sdf` and :mod:`~drake_sot.robots.mjcf`.
MODEL_SUFFIXES = tuple(MODEL_FORMATS)
#: What ``--robot`` takes as a path: a description, or a model with its description beside it.
ROBOT_PATH_SUFFIXES = (DESCRIPTION_SUFFIX, *MODEL_SUFFIXES)
#: The collision shape kinds and how many dimensions each takes.
SHAPE_DIMS = {"box": 3, "sphere": 1, "capsule": 2}
#: The contact sphere radius [m] when the file gives none (the embedded robot's).
DEFAULT_CONTACT_RADIUS = 0.01

_TOP_KEYS = {
    "name",
    "title",
    "model",
    "base_body",
    "sole_size",
    "contact_radius",
    "frozen_joints",
    "packages",
    "frames",
    "force_sensors",
    "added_welds",
    "half_sitting",
    "drives",
    "collision",
    "step_timing",
    "step_limits",
}


class RobotDescriptionError(RobotFileError, ValueError):
    """A robot description file says something wrong: the message names the file, the key and
    the bad value, and what is accepted."""


def is_robot_path(name: str) -> bool:
    """True when ``name`` (a ``--robot`` value) is a path to a description or a model file
    (it ends with one of :data:`ROBOT_PATH_SUFFIXES`), rather than a robot's name."""
    return isinstance(name, str) and name.lower().endswith(ROBOT_PATH_SUFFIXES)


def description_path(path: str | Path) -> Path:
    """The description file of ``path``: itself when it is a ``.toml``, else the ``.toml`` of the
    same stem beside the model file (:func:`load_description` checks that it names that model).

    Raises:
        RobotFileMissing: the file (or the description beside the model) does not exist; for a
            model, the message says how to draft one.
        RobotDescriptionError: ``path`` is neither a description nor a model file.
        RobotFileError: a model that is not well-formed XML or not of the format its suffix says
            (an ``.xml`` whose root is not ``<mujoco>``), naming it.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == DESCRIPTION_SUFFIX:
        if not path.is_file():
            raise RobotFileMissing(f"robot description {path} does not exist")
        return path
    if suffix not in MODEL_SUFFIXES:
        raise RobotDescriptionError(
            f"--robot {path}: a path must end with one of {', '.join(ROBOT_PATH_SUFFIXES)} (MJCF)"
        )
    model_root(path)  # it exists and is what its suffix says
    beside = path.with_suffix(DESCRIPTION_SUFFIX)
    if not beside.is_file():
        raise RobotFileMissing(
            f"robot model file {path}: no description {beside} beside it; draft one with "
            f"`drake-sot robot draft {path} > {beside}` and edit it"
        )
    return beside


def load_description(path: str | Path) -> RobotDescription:
    """The robot described by the TOML file ``path`` (see the module docstring), or by the
    description beside the model file ``path``; read once per version of the file (cached by
    its path and modification time: a model file edited since is read again once its
    description is touched, or in a new process).

    Raises:
        RobotFileMissing: the file, or the model it names, does not exist.
        RobotDescriptionError: the file is not TOML (where) or nests too deeply, a key is
            unknown, missing or of the wrong type, a value out of range (naming the file, the
            key and the value), a joint without a drive (or without an effort limit), a
            half-sitting angle outside its limits; the description beside a model file ``path``
            names another model.
        RobotFileError: the description cannot be read (permissions), the model file is not
            well-formed XML, not of the format its suffix says, or holds what
            :mod:`~drake_sot.robots.model_tree` does not read.
    """
    described = description_path(path).resolve()
    robot = _cached_description(described, described.stat().st_mtime_ns)
    if (
        Path(path).suffix.lower() in MODEL_SUFFIXES
        and Path(robot.model_file).resolve() != Path(path).resolve()
    ):
        raise RobotDescriptionError(
            f"robot description {described} (beside {path}) describes model {robot.model_file}, not {path}: "
            "give the path of the description of this model"
        )
    return robot


@functools.lru_cache(maxsize=16)
def _cached_description(path: Path, _mtime_ns: int) -> RobotDescription:
    """:func:`load_description` of the resolved ``path`` (``_mtime_ns`` keys the cache)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise RobotDescriptionError(f"robot description {path}: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:  # no permission to read it
        raise RobotFileError(f"robot description {path}: cannot be read: {exc.strerror or exc}") from None
    except ValueError as exc:  # TOMLDecodeError, or an integer of more than 4300 digits
        reason = str(exc).split(";")[0]
        raise RobotDescriptionError(
            f"robot description {path}: not TOML, or not a value TOML reads: {reason}"
        ) from None
    except RecursionError:  # arrays nested a thousand deep
        raise RobotDescriptionError(f"robot description {path}: values nested too deeply to read") from None
    return _Reader(path, data).description()


class _Reader:
    """Reads the keys of one description file, each error naming the file and the key."""

    def __init__(self, path: Path, data: dict[str, Any]) -> None:
        self.path = path
        self.data = data

    def error(self, key: str, value: Any, accepted: str) -> RobotDescriptionError:
        return RobotDescriptionError(f"robot description {self.path}: {key} = {shown(value)}: {accepted}")

    def get(self, table: Mapping[str, Any], key: str, where: str, default: Any = ...) -> Any:
        if key in table:
            return table[key]
        if default is ...:
            raise RobotDescriptionError(f"robot description {self.path}: {where}{key} is missing")
        return default

    def string(self, key: str, value: Any) -> str:
        if not (isinstance(value, str) and value.strip()):
            raise self.error(key, value, "must be a non-empty string")
        return value

    def number(self, key: str, value: Any, check: Callable[[float], bool], accepted: str) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(key, value, f"must be a number {accepted}")
        try:
            number = float(value)
        except OverflowError:
            raise self.error(key, value, f"must be a number {accepted}") from None
        if not (math.isfinite(number) and check(number)):
            raise self.error(key, value, f"must be a number {accepted}")
        return number

    def numbers(self, key: str, value: Any, size: int, check: Callable[[float], bool], accepted: str):
        if not (isinstance(value, list) and len(value) == size):
            raise self.error(key, value, f"must be an array of {size} numbers {accepted}")
        return tuple(self.number(f"{key}[{i}]", v, check, accepted) for i, v in enumerate(value))

    def table(self, key: str, value: Any) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.error(key, value, "must be a table")
        return value

    def tables(self, key: str, value: Any) -> list[dict[str, Any]]:
        if not (isinstance(value, list) and all(isinstance(v, dict) for v in value)):
            raise self.error(key, value, "must be an array of tables")
        return value

    def keys(self, where: str, table: Mapping[str, Any], allowed: set[str] | tuple[str, ...]) -> None:
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            raise RobotDescriptionError(
                f"robot description {self.path}: {where}unknown key {unknown[0]!r}; "
                f"known: {', '.join(sorted(allowed))}"
            )

    def xyz(self, key: str, value: Any) -> tuple[float, float, float]:
        return self.numbers(key, value, 3, lambda v: abs(v) <= 100.0, "(finite, within ±100)")

    def frame(self, key: str, value: Any) -> FrameSpec:
        if isinstance(value, str):
            return FrameSpec(self.string(key, value))
        spec = self.table(key, value)
        self.keys(f"{key}: ", spec, {"parent", "xyz", "rpy"})
        return FrameSpec(
            self.string(f"{key}.parent", self.get(spec, "parent", f"{key}.")),
            self.xyz(f"{key}.xyz", spec.get("xyz", [0.0, 0.0, 0.0])),
            self.xyz(f"{key}.rpy", spec.get("rpy", [0.0, 0.0, 0.0])),
        )

    def drive_table(self, joints: Mapping[str, Any]) -> dict[str, Drive]:
        patterns = self.table("drives", self.get(self.data, "drives", ""))
        compiled = {}
        for pattern in patterns:
            try:
                compiled[pattern] = re.compile(pattern)
            except re.error as exc:
                raise self.error("drives key", pattern, f"must be a regular expression ({exc})") from None
        drives: dict[str, Drive] = {}
        for name, joint in joints.items():
            for pattern, value in patterns.items():
                key = f"drives.{pattern!r}"
                if not compiled[pattern].search(name):
                    continue
                gains = self.table(key, value)
                self.keys(f"{key}: ", gains, {"kp", "kd", "rotor_inertia", "effort"})
                nonnegative = (lambda v: v >= 0.0, "(finite, >= 0)")
                positive = (lambda v: v > 0.0, "(finite, > 0)")
                drives[name] = Drive(
                    kp=self.number(f"{key}.kp", self.get(gains, "kp", f"{key}."), *positive),
                    kd=self.number(f"{key}.kd", self.get(gains, "kd", f"{key}."), *nonnegative),
                    effort=self.effort(key, name, gains.get("effort", joint.effort)),
                    rotor_inertia=self.number(
                        f"{key}.rotor_inertia", gains.get("rotor_inertia", 0.0), *nonnegative
                    ),
                )
                break
        missing = [name for name in joints if name not in drives]
        if missing:
            raise RobotDescriptionError(
                f"robot description {self.path}: drives: no pattern matches joints {missing}; "
                f"patterns: {list(patterns)}"
            )
        return drives

    def effort(self, key: str, joint: str, value: float | None) -> float:
        if value is None:
            raise RobotDescriptionError(
                f"robot description {self.path}: {key}.effort is missing: the model gives joint "
                f"{joint!r} no effort limit; give it [N m] (> 0)"
            )
        return self.number(f"{key}.effort", value, lambda v: v > 0.0, "(finite, > 0)")

    def description(self) -> RobotDescription:
        data, here = self.data, self.path.parent
        self.keys("", data, _TOP_KEYS)
        model = here / self.string("model", self.get(data, "model", ""))
        if model.suffix.lower() not in MODEL_SUFFIXES:
            raise self.error(
                "model", str(model), f"must be a model file ending with {', '.join(MODEL_SUFFIXES)} (MJCF)"
            )
        if not model.is_file():
            raise RobotFileMissing(f"robot description {self.path}: model = {str(model)!r} does not exist")
        packages = {
            self.string("packages key", name): here / self.string(f"packages.{name}", directory)
            for name, directory in self.table("packages", data.get("packages", {})).items()
        }
        frozen = data.get("frozen_joints", [])
        if not isinstance(frozen, list):
            raise self.error("frozen_joints", frozen, "must be an array of joint names")
        frozen = tuple(self.string(f"frozen_joints[{i}]", j) for i, j in enumerate(frozen))
        tree = read_model_tree(model)
        joints = tree.model_joints(frozen)
        base_body = self.string("base_body", self.get(data, "base_body", ""))
        if base_body != tree.root:
            raise self.error(
                "base_body", base_body, f"must be the model's root link {tree.root!r} (its floating base)"
            )

        frames_table = self.table("frames", self.get(data, "frames", ""))
        self.keys("frames: ", frames_table, LOGICAL_FRAMES)
        frames = {
            key: self.frame(f"frames.{key}", self.get(frames_table, key, "frames.")) for key in LOGICAL_FRAMES
        }
        sensors_table = self.table("force_sensors", self.get(data, "force_sensors", ""))
        self.keys("force_sensors: ", sensors_table, FORCE_SENSORS)
        sensors = {
            key: self.string(f"force_sensors.{key}", self.get(sensors_table, key, "force_sensors."))
            for key in FORCE_SENSORS
        }
        welds = []
        for i, weld in enumerate(self.tables("added_welds", data.get("added_welds", []))):
            key = f"added_welds[{i}]"
            self.keys(f"{key}: ", weld, {"name", "parent", "child", "xyz"})
            welds.append(
                AddedWeld(
                    *(
                        self.string(f"{key}.{k}", self.get(weld, k, f"{key}."))
                        for k in ("name", "parent", "child")
                    ),
                    self.xyz(f"{key}.xyz", weld.get("xyz", [0.0, 0.0, 0.0])),
                )
            )

        angles = self.table("half_sitting", data.get("half_sitting", {}))
        self.keys("half_sitting: ", angles, tuple(joints))
        half_sitting = {}
        for name, (lower, upper) in ((n, (j.lower, j.upper)) for n, j in joints.items()):
            angle = angles.get(name, 0.0)
            half_sitting[name] = self.number(
                f"half_sitting.{name}", angle, lambda v, lo=lower, hi=upper: lo <= v <= hi,
                f"[rad] within the joint's limits [{lower:g}, {upper:g}]",
            )  # fmt: skip

        shapes = []
        for i, shape in enumerate(self.tables("collision", data.get("collision", []))):
            key = f"collision[{i}]"
            self.keys(f"{key}: ", shape, {"body", "kind", "dims", "xyz", "rpy"})
            kind = self.get(shape, "kind", f"{key}.")
            if kind not in SHAPE_DIMS:
                raise self.error(f"{key}.kind", kind, f"must be one of {', '.join(SHAPE_DIMS)}")
            dims = self.numbers(
                f"{key}.dims", self.get(shape, "dims", f"{key}."), SHAPE_DIMS[kind],
                lambda v: 0.0 < v <= 10.0, "[m] (> 0, at most 10)",
            )  # fmt: skip
            shapes.append(
                CollisionShape(
                    self.string(f"{key}.body", self.get(shape, "body", f"{key}.")),
                    kind,
                    dims,
                    self.xyz(f"{key}.xyz", shape.get("xyz", [0.0, 0.0, 0.0])),
                    self.xyz(f"{key}.rpy", shape.get("rpy", [0.0, 0.0, 0.0])),
                )
            )

        sole = self.numbers(
            "sole_size", self.get(data, "sole_size", ""), 2, lambda v: 0.0 < v <= 2.0, "[m] (> 0, at most 2)"
        )
        radius = self.number(
            "contact_radius", data.get("contact_radius", DEFAULT_CONTACT_RADIUS),
            lambda v: 0.0 < v <= 0.1, "[m] (> 0, at most 0.1)",
        )  # fmt: skip
        try:
            return RobotDescription(
                name=self.string("name", data.get("name", self.path.stem)),
                title=self.string(
                    "title", data.get("title", f"{model.name} (described by {self.path.name})")
                ),
                model_file=model,
                packages=packages,
                base_body=base_body,
                frames=frames,
                sole_size=(sole[0], sole[1]),
                contact_radius=radius,
                force_sensors=sensors,
                half_sitting=half_sitting,
                drives=self.drive_table(joints),
                joint_limits={name: (j.lower, j.upper) for name, j in joints.items()},
                added_welds=tuple(welds),
                frozen_joints=frozen,
                collision=tuple(shapes),
                step_timing=self.dataclass("step_timing", StepTiming),
                step_limits=self.dataclass("step_limits", StepLimits),
            )
        except RobotDescriptionError:
            raise
        except ValueError as exc:  # RobotDescription's own checks
            raise RobotDescriptionError(f"robot description {self.path}: {exc}") from None

    def dataclass(self, key: str, kind: type[StepTiming] | type[StepLimits]):
        table = self.table(key, self.data.get(key, {}))
        fields = tuple(kind.__dataclass_fields__)
        self.keys(f"{key}: ", table, fields)
        values = {
            name: self.number(f"{key}.{name}", value, lambda v: v > 0.0, "(finite, > 0)")
            for name, value in table.items()
        }
        try:
            return kind(**values)
        except ValueError as exc:
            raise RobotDescriptionError(f"robot description {self.path}: {key}: {exc}") from None
