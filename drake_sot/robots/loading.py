"""A robot description into a ``MultibodyPlant``: parse, fix, actuate, frame, make it touch.

:func:`load_robot` is :func:`~drake_sot.models.humanoid.load_humanoid` for any
:class:`~drake_sot.robots.description.RobotDescription`: for the embedded humanoid it is
that function; for a robot of files it reads the model file (URDF, SDF or MJCF), applies the
in-memory fixes of its format (:mod:`~drake_sot.robots.urdf`, :mod:`~drake_sot.robots.sdf`,
:mod:`~drake_sot.robots.mjcf`; visual meshes converted to OBJ through the cache of
:mod:`drake_sot.robots.meshes` when the plant has a SceneGraph), parses it, adds
one position-controlled actuator per moving joint with the description's drive, the
logical frames, and four contact spheres under each sole. The returned ``HumanoidInfo``
is what every builder reads; ``info.frames`` maps logical names to the plant's frames.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType

from pydrake.geometry import Box, Capsule, CollisionFilterDeclaration, GeometrySet, SceneGraph, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, PdControllerGains

from drake_sot.models.humanoid import (
    FRICTION,
    HumanoidInfo,
    add_body_collision,
    half_sitting_configuration,
    load_humanoid,
    sole_corner_points,
    weld_base,
)
from drake_sot.robots.catalog import get_robot
from drake_sot.robots.description import FrameSpec, RobotDescription
from drake_sot.robots.errors import RobotFileError, RobotFileMissing
from drake_sot.robots.meshes import cache_dir, converted_mesh
from drake_sot.robots.mjcf import prepare_mjcf
from drake_sot.robots.model_tree import model_format
from drake_sot.robots.model_values import check_model_values
from drake_sot.robots.sdf import prepare_sdf
from drake_sot.robots.urdf import prepare_urdf

_log = logging.getLogger(__name__)
#: The package name under which the parser finds the converted meshes (a URDF or an SDF parsed
#: from a string may name files only through packages; an MJCF names them by path).
MESH_PACKAGE = "drake_sot_meshes"
#: The file type Drake's ``Parser.AddModelsFromString`` takes for each model format.
PARSER_TYPES = {"urdf": "urdf", "sdf": "sdf", "mjcf": "xml"}


def _frame_name(key: str, spec: FrameSpec) -> str:
    """The plant frame of logical frame ``key``: the parent itself when the offset is zero."""
    if spec.xyz == (0.0, 0.0, 0.0) and spec.rpy == (0.0, 0.0, 0.0):
        return spec.parent
    return f"sot_{key}"


def model_text(
    robot: RobotDescription, *, geometry: bool, mesh_cache: Path | None = None
) -> tuple[str, str, list[str]]:
    """The format of ``robot``'s model file, its fixed text and the fixes applied (see
    :func:`~drake_sot.robots.urdf.prepare_urdf`, :func:`~drake_sot.robots.sdf.prepare_sdf`,
    :func:`~drake_sot.robots.mjcf.prepare_mjcf`); visual meshes converted into ``mesh_cache``
    (default the user cache) when ``geometry``.

    Raises RobotFileMissing (a FileNotFoundError) naming the model file or a mesh when it is
    missing, RobotFileError naming the model file when it is not well-formed XML (or not
    text) or of an unknown suffix, holds a number out of range (a mass, an inertia, an origin:
    :func:`~drake_sot.robots.model_values.check_model_values`), names a mesh package the robot
    does not map, a frozen joint or a weld's link it does not have, a mesh that cannot be
    converted or a mesh cache that cannot be written.
    """
    if robot.model_file is None:
        raise ValueError(f"robot {robot.name!r} is built in code: it has no model file")
    path = Path(robot.model_file)
    if not path.is_file():
        raise RobotFileMissing(f"robot {robot.name!r}: model file {path} does not exist")

    fmt = model_format(path)

    def mesh_uri(source: Path, scale: tuple[float, float, float]) -> str:
        converted = converted_mesh(source, scale, mesh_cache)
        if converted == source:  # an .obj at unit scale, read where it is
            return converted.resolve().as_uri()
        return f"package://{MESH_PACKAGE}/{converted.name}"

    def mesh_path(source: Path, scale: tuple[float, float, float]) -> str:
        return str(converted_mesh(source, scale, mesh_cache).resolve())

    fixes = {"frozen_joints": robot.frozen_joints, "added_welds": robot.added_welds}
    try:
        text = path.read_text()
        check_model_values(path, fmt, ET.fromstring(text))  # before Drake reads a number
        if fmt == "mjcf":
            mesh_file = mesh_path if geometry else None
            return fmt, *prepare_mjcf(text, directory=path.parent, mesh_file=mesh_file, **fixes)
        mesh_file = mesh_uri if geometry else None
        if fmt == "sdf":
            return fmt, *prepare_sdf(
                text, directory=path.parent, packages=robot.packages, mesh_file=mesh_file, **fixes
            )
        return fmt, *prepare_urdf(
            text, packages=robot.packages, mesh_file=mesh_file, directory=path.parent, **fixes
        )
    except (ET.ParseError, UnicodeDecodeError) as exc:
        raise RobotFileError(
            f"robot {robot.name!r}: model file {path}: not well-formed XML ({exc}): truncated or corrupt?"
        ) from None
    except OSError:  # RobotFileMissing, RobotFileError: they name their file
        raise
    except ValueError as exc:  # an unknown mesh package, a frozen joint or weld not in the model
        raise RobotFileError(f"robot {robot.name!r}: model file {path}: {exc}") from None


def load_robot(
    plant: MultibodyPlant,
    robot: str | RobotDescription = "embedded",
    *,
    pd_gains: bool = True,
    collision: bool = True,
    mesh_cache: Path | None = None,
) -> HumanoidInfo:
    """Add ``robot`` to a plant that is not finalized yet; does not finalize it.

    Args:
        plant: the plant (discrete or continuous); with a SceneGraph the visual meshes and
            (with ``collision``) the sole contact spheres are registered.
        robot: a robot name (``drake_sot.robots.ROBOTS``) or description.
        pd_gains: give the actuators the description's PD gains (position control through
            ``plant.get_desired_state_input_port``, which must then be connected).
        collision: register the sole contact spheres.
        mesh_cache: the mesh cache directory (default ``drake_sot.robots.meshes.cache_dir()``).

    Returns:
        The robot's ``HumanoidInfo``: frames by logical name, force sensors, half-sitting,
        actuated joints in actuator order. Default joint angles are the half-sitting ones.
    """
    robot = get_robot(robot)
    if plant.is_finalized():
        raise RuntimeError("load_robot needs a plant that is not finalized yet")
    if robot.model_file is None:
        info = load_humanoid(plant, pd_gains=pd_gains, collision=collision)
        return replace(info, frames=_frames(plant, robot, info), robot=robot.name)

    geometry = plant.geometry_source_is_registered()
    fmt, text, fixes = model_text(robot, geometry=geometry, mesh_cache=mesh_cache)
    _log.info("robot %s: %s", robot.name, "; ".join(fixes))
    parser = Parser(plant)
    if geometry and f"package://{MESH_PACKAGE}/" in text:
        # Some mesh was converted into the cache: the directory exists. A model with no mesh to
        # convert (primitives, or .obj meshes at unit scale) names no file there, and the cache
        # may not exist: Drake refuses a package whose directory is missing.
        parser.package_map().Add(MESH_PACKAGE, str(cache_dir() if mesh_cache is None else mesh_cache))
    try:
        (instance,) = parser.AddModelsFromString(text, PARSER_TYPES[fmt])
    except RuntimeError as exc:  # Drake's parse error names no file: the text came from memory
        reason = " ".join(str(exc).split())
        raise RobotFileError(
            f"robot {robot.name!r}: model file {robot.model_file}: Drake: {reason}"
        ) from None
    for name, drive in robot.drives.items():
        joint = plant.GetJointByName(name, instance)
        joint.set_default_angle(robot.half_sitting[name])
        actuator = plant.AddJointActuator(name, joint, drive.effort)
        actuator.set_default_rotor_inertia(drive.rotor_inertia)
        if pd_gains:
            actuator.set_controller_gains(PdControllerGains(p=drive.kp, d=drive.kd))
    info = HumanoidInfo(
        model_instance=instance,
        base_body=robot.base_body,
        actuated_joints=tuple(robot.drives),
        frames=MappingProxyType({}),
        force_sensors=robot.force_sensors,
        half_sitting=robot.half_sitting,
        mass=0.0,
        sole_size=robot.sole_size,
        robot=robot.name,
    )
    info = replace(info, frames=_frames(plant, robot, info), mass=_mass(plant, instance))
    if geometry and collision:
        radius = robot.contact_radius
        for side in ("left", "right"):
            frame = plant.GetFrameByName(info.frames[f"{side}_foot"], instance)
            X_BS = frame.GetFixedPoseInBodyFrame()
            for i, corner in enumerate(sole_corner_points(robot.sole_size)):
                plant.RegisterCollisionGeometry(
                    frame.body(),
                    RigidTransform(X_BS @ (corner + [0.0, 0.0, radius])),
                    Sphere(radius),
                    f"{side}_sole_contact_{i}",
                    FRICTION,
                )
    return info


def _mass(plant: MultibodyPlant, instance) -> float:
    """Sum of the masses of the instance's bodies (kg) in a plant that is not finalized."""
    return float(sum(plant.get_body(i).default_mass() for i in plant.GetBodyIndices(instance)))


def _frames(plant: MultibodyPlant, robot: RobotDescription, info: HumanoidInfo) -> MappingProxyType:
    """Add the logical frames that are offsets (``sot_<name>``); logical name → plant frame name."""
    names = {}
    for key, spec in robot.frames.items():
        name = _frame_name(key, spec)
        if not plant.HasFrameNamed(spec.parent, info.model_instance):
            raise ValueError(
                f"robot {robot.name!r}: logical frame {key!r} on {spec.parent!r}, not in the model"
            )
        if name != spec.parent:
            parent = plant.GetFrameByName(spec.parent, info.model_instance)
            plant.AddFrame(FixedOffsetFrame(name, parent, RigidTransform(RollPitchYaw(spec.rpy), spec.xyz)))
        names[key] = name
    return MappingProxyType(names)


def add_robot_collision(
    plant: MultibodyPlant, scene_graph: SceneGraph, info: HumanoidInfo, robot: str | RobotDescription
) -> None:
    """Whole-body collision shapes, so that a fallen robot lies on the ground: the embedded
    humanoid's :func:`~drake_sot.models.humanoid.add_body_collision`, or the description's
    simple shapes (``RobotDescription.collision``: trunk, head, thighs, shanks, upper arms,
    forearms, hands). As on the embedded humanoid, the collisions between *neighbouring*
    colliding bodies are excluded: each body with shapes (the soles' spheres included) and
    its nearest ancestor with shapes in the kinematic tree (a thigh and the pelvis across
    the hip's shape-less links, a shank and its sole), whose shapes overlap or touch as
    the joints between them move. Every other pair collides: an arm with the torso, one
    leg with the other. Call after :func:`load_robot` (the soles' spheres) and before ``Finalize``."""
    robot = get_robot(robot)
    if robot.model_file is None:
        add_body_collision(plant, scene_graph, info)
        return
    if plant.is_finalized():
        raise RuntimeError("add_robot_collision needs a plant that is not finalized yet")
    for i, shape in enumerate(robot.collision):
        geometry = {"box": Box, "sphere": Sphere, "capsule": Capsule}[shape.kind](*shape.dims)
        plant.RegisterCollisionGeometry(
            plant.GetBodyByName(shape.body, info.model_instance),
            RigidTransform(RollPitchYaw(shape.rpy), shape.xyz),
            geometry,
            f"{shape.body}_collision_{i}",
            FRICTION,
        )
    parent = {}  # body -> its parent body in the tree (the base has none)
    for index in plant.GetJointIndices(info.model_instance):
        joint = plant.get_joint(index)
        parent[joint.child_body().index()] = joint.parent_body().index()
    shapes = {
        body: plant.GetCollisionGeometriesForBody(plant.get_body(body))
        for body in plant.GetBodyIndices(info.model_instance)
    }
    declaration = CollisionFilterDeclaration()
    for body, ids in shapes.items():
        if not ids:
            continue
        ancestor = parent.get(body)
        while ancestor is not None and not shapes.get(ancestor):
            ancestor = parent.get(ancestor)
        if ancestor is not None:
            declaration.ExcludeBetween(GeometrySet(ids), GeometrySet(shapes[ancestor]))
    scene_graph.collision_filter_manager().Apply(declaration)


def weld_robot_base(plant: MultibodyPlant, info: HumanoidInfo, robot: str | RobotDescription) -> None:
    """Weld the base to the world where half-sitting puts it (soles on z = 0): the fixed-base
    robot of the paper's real-iCub experiments. Call before ``Finalize``."""
    robot = get_robot(robot)
    if robot.model_file is None:
        weld_base(plant, info)
        return
    free = MultibodyPlant(time_step=0.0)
    free_info = load_robot(free, robot, pd_gains=False, collision=False)
    free.Finalize()
    context = free.CreateDefaultContext()
    free.SetPositions(context, half_sitting_configuration(free, free_info))
    base = free.GetBodyByName(robot.base_body)
    plant.WeldFrames(
        plant.world_frame(),
        plant.GetBodyByName(robot.base_body, info.model_instance).body_frame(),
        base.EvalPoseInWorld(context),
    )


def make_robot_control_model(
    robot: str | RobotDescription = "embedded", *, fixed_base: bool = False
) -> tuple[MultibodyPlant, HumanoidInfo]:
    """The controller's model of ``robot``: a finalized continuous plant without SceneGraph
    (no geometry, no mesh conversion) and without PD gains; see
    :func:`~drake_sot.models.humanoid.make_control_model`."""
    plant = MultibodyPlant(time_step=0.0)
    info = load_robot(plant, robot, pd_gains=False, collision=False)
    if fixed_base:
        weld_robot_base(plant, info, robot)
    plant.Finalize()
    return plant, info
