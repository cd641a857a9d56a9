"""Peer benchmark: ``drake_sot.hqp.solve_hqp`` against PlaCo's ``KinematicsSolver`` on TALOS.

    make bench-peers      (creates .venv-peers with placo, pin and example-robot-data, then runs this)

PlaCo (Rhoban, PyPI ``placo`` 0.10.2) pins ``pin`` 3.8 and ``numpy`` 2.3, so it lives in its own
virtual environment and is no dependency of the package; this file needs ``placo``, ``pinocchio``
(installed with placo) and ``example-robot-data`` (6.0.0), and finds ``drake_sot`` on the path. It
imports no pydrake: the hierarchy module is pure, and TALOS comes from the pure catalog of
``drake_sot.robots`` (the robot the scenarios and ``bench_robots.py`` simulate).

The problem (TALOS as ``drake_sot.robots.catalog.talos()`` describes it: ``talos_full_v2.urdf``
from example-robot-data with the robot layer's in-memory fixes (package map, ``package:///``
typos, the gripper linkage frozen, no geometry), the half-sitting of its SRDF by joint name;
nv = 36, 30 actuated joints), the same for both sides and solved call by call in one process:

    left foot 6D, right foot 6D, CoM 3D, right hand 6D, left hand 3D, head orientation 3D,
    posture 30D                                         (7 levels, 57 rows)

under the joint position limits (``q + dt q̇`` inside them) and velocity limits of the URDF
(60 inequality rows on the 30 actuated joints), for a 2 s trajectory at dt = 5 ms: the CoM sways
3 cm sideways, the right hand reaches 0.40 m forward and 0.20 m up, the left hand moves 0.15 m,
the head turns 0.4 rad. Each side integrates its own q.

- **drake_sot**: the Jacobians and task errors from Pinocchio (the same library and the same
  URDF text PlaCo loads, so the two sides start from the same task matrices to rounding, checked;
  Drake kinematics would make the comparison also measure two kinematics libraries), each level
  ``J q̇ = e / dt``,
  under a top level of the 30 joint-limit rows ``velocity_bounds(q, q_min, q_max, 1/dt, ±v_max)``,
  solved by ``solve_hqp`` (strict priorities), warm-started from the last step's result (as
  ``StackOfTasks`` does from tick to tick). Timed separately: "kinematics" (Pinocchio's
  Jacobians, frame placements, CoM Jacobian, errors, and the integration of q) and "solve".
- **PlaCo**: the same tasks in one weighted QP (PlaCo has no strict hierarchy): feet "hard"
  (equality constraints), the others "soft" (:data:`PLACO_WEIGHTED`), joint and velocity limits
  enabled. Timed: ``robot.update_kinematics()`` (frames and joint Jacobians, in C++) and
  ``solver.solve(True)`` (each task's Jacobian and error, the QP, the integration). The two sides
  do not cut kinematics and solve at the same place, so the whole steps are the comparison.

Beside them on the same levels at the same state: ``solve_hqp`` cold (no warm start), without the
limit level, and ``solve_strict``. The ratios are medians of per-step ratios (both timed in the
same step, their order alternating from step to step).

Agreement printed: (1) the task matrices and errors of the two sides at the start; (2) with the
six upper task levels "hard" in PlaCo and the posture "soft" (no limits), PlaCo's step equals
``solve_strict``'s q̇ dt (both are then the lexicographic solution) at states along the trajectory;
(3) the task errors of the two closed-loop runs, and the joint limits, step by step.

A second table, from the same run (the same steps, interleaved with the above), has self-collision
on both sides: TALOS's collision shapes (the model file's meshes, as their convex hulls, and
primitives: :class:`Collisions`) and the pairs the SRDF leaves, one row per pair closer than
``d_i`` keeping the distance ``d >= d_s`` (:data:`D_S`, :data:`D_I`). PlaCo: its
``AvoidSelfCollisionsKinematicsConstraint`` (hard, margin ``d_s``, trigger ``d_i``:
``d + J_d Δq >= d_s``), computing the distances inside ``solve``. drake_sot: the same distances from
Pinocchio/hpp-fcl on the same shapes and pairs, witness points, normals and Jacobians into
``distance_rows`` (at ``λ = 1/dt``, PlaCo's constraint), one level just below the limits, solved by
``solve_hqp``. Printed: the times, the rows filled per step on both sides, the least distance over
the run on each side with and without the rows, (4) that the two sides' pairs and distances at
the start are the same, and (5), since along the run no row binds, the rows binding: at a larger
margin (:data:`CHECK_MARGIN`), PlaCo with hard tasks and constraint equals ``solve_hqp`` with the
rows above the task levels, as in (2).
"""

from __future__ import annotations

import json
import os
import tempfile
import xml.etree.ElementTree as ET

# PlaCo (Eigen) runs on one thread; so does numpy's BLAS here (2 shared cores).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import dataclasses
import datetime
import pathlib
import platform
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial
from importlib.metadata import version

import numpy as np

from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import HqpResult, solve_hqp
from drake_sot.inequalities import distance_damper_gain, distance_rows, velocity_bounds
from drake_sot.robots.catalog import RobotDataMissing
from drake_sot.robots.catalog import talos as talos_description
from drake_sot.robots.urdf import prepare_urdf, resolve_package_uri

DT = 0.005  #: control period [s]
DURATION = 2.0  #: trajectory length [s]
FRAMES = {
    "left_foot": "left_sole_link",
    "right_foot": "right_sole_link",
    "right_hand": "gripper_right_base_link",
    "left_hand": "gripper_left_base_link",
    "head": "head_2_link",
}
#: The stack, highest priority first: (name, kind) with kind "frame" (6D), "com", "position",
#: "orientation" or "posture".
STACK = (
    ("left_foot", "frame"),
    ("right_foot", "frame"),
    ("com", "com"),
    ("right_hand", "frame"),
    ("left_hand", "position"),
    ("head", "orientation"),
    ("posture", "posture"),
)
#: PlaCo's priorities for the same stack, (priority, weight) per task: the feet hard, the others
#: soft by decades, and the posture (which cannot be met while the hands reach away) light enough
#: not to pull the tasks above it: weighted 1, it leaves the left hand 4 cm off at the end of the run.
PLACO_WEIGHTED = {
    "left_foot": ("hard", 1.0),
    "right_foot": ("hard", 1.0),
    "com": ("soft", 1e4),
    "right_hand": ("soft", 1e3),
    "left_hand": ("soft", 1e2),
    "head": ("soft", 1e1),
    "posture": ("soft", 1e-4),
}
#: The six upper tasks hard and the posture soft: with no limits, PlaCo's QP is then the
#: lexicographic problem of ``solve_strict`` (its small fixed regularisation aside, which is why
#: the posture keeps weight 1 here).
PLACO_STRICT = {name: ("hard", 1.0) for name, _ in STACK} | {"posture": ("soft", 1.0)}
D_S = 0.01  #: safety margin d_s [m] of the self-collision rows (``SelfCollisionAvoidance``'s): PlaCo's margin
D_I = 0.05  #: activation distance d_i [m] (``SelfCollisionAvoidance``'s): PlaCo's trigger
#: ``ξ`` [m/s] of the drake_sot side's distance damper: PlaCo's constraint ``d + J_d Δq >= d_s`` lets
#: ``d`` reach ``d_s`` in one step, the damper at ``λ = ξ / (d_i - d_s) = 1/dt`` (the controller's
#: default ξ = 0.2 m/s, λ = 5/s, would be another constraint).
XI = (D_I - D_S) / DT
#: d_s [m] of the agreement check (5): above the least distance at the start (0.0119 m, the legs'
#: shapes), so that rows bind; along the run the distances stay above D_S, where no row binds.
CHECK_MARGIN = 0.015


def talos_model() -> tuple[pathlib.Path, str, str, dict[str, float]]:
    """TALOS as ``drake_sot.robots`` describes it (its pure catalog: no pydrake): the model file,
    the URDF text with the robot layer's fixes and without geometry, the same text with the model
    file's collision shapes (:func:`with_collisions`), and the half-sitting angle [rad] of every
    moving joint (from the SRDF)."""
    try:
        robot = talos_description()
    except RobotDataMissing as error:
        raise SystemExit(f"{error}; or run `make bench-peers`") from error
    text, _ = prepare_urdf(
        robot.model_file.read_text(),
        packages=robot.packages,
        mesh_file=None,
        frozen_joints=robot.frozen_joints,
        added_welds=robot.added_welds,
    )
    collision_text = with_collisions(text, robot.model_file.read_text(), robot.packages)
    return robot.model_file, text, collision_text, dict(robot.half_sitting)


def with_collisions(text: str, source: str, packages: dict[str, pathlib.Path]) -> str:
    """URDF ``text`` (the robot layer's, without geometry) with the ``<collision>`` elements of the
    model file's text ``source`` put back in their links, mesh URIs resolved to files through
    ``packages`` (the ``package:///`` typos read as ``package://``): PlaCo's ``RobotWrapper`` looks
    for ``package://`` files under the URDF's directory only (``talos_data/robots``), where it does
    not find them.

    Raises what ``resolve_package_uri`` raises (an unknown package, a missing mesh file).
    """
    root = ET.fromstring(text)
    links = {link.get("name"): link for link in root.findall("link")}
    for link in ET.fromstring(source).findall("link"):
        for collision in link.findall("collision"):
            mesh = collision.find("geometry/mesh")
            if mesh is not None:
                mesh.set("filename", str(resolve_package_uri(mesh.get("filename", ""), packages)))
            links[link.get("name")].append(collision)
    return ET.tostring(root, encoding="unicode")


@dataclasses.dataclass
class Targets:
    """The set points of every task at one time."""

    poses: dict[str, np.ndarray]  # 4x4 world poses of the feet and the right hand
    left_hand: np.ndarray  # (3,)
    head: np.ndarray  # 3x3
    com: np.ndarray  # (3,)
    posture: np.ndarray  # (30,) actuated joint positions


def trajectory(start: Targets, t: float) -> Targets:
    """The targets at time ``t``: from ``start`` (the half-sitting's values), a smooth reach."""
    s = 0.5 * (1.0 - np.cos(np.pi * min(t / 1.5, 1.0)))  # 0 -> 1 over 1.5 s, then held
    poses = {name: pose.copy() for name, pose in start.poses.items()}
    poses["right_hand"][:3, 3] += s * np.array([0.40, -0.05, 0.20])
    yaw = 0.4 * s
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    return Targets(
        poses=poses,
        left_hand=start.left_hand + s * np.array([0.15, 0.05, 0.10]),
        head=rz @ start.head,
        com=start.com + np.array([0.0, 0.03 * np.sin(np.pi * t), 0.0]),
        posture=start.posture,
    )


class Talos:
    """TALOS in Pinocchio, for the drake_sot side: task Jacobians and errors at q."""

    def __init__(self, pin, urdf_text: str, half_sitting: dict[str, float]):
        self.pin = pin
        self.model = pin.buildModelFromXML(urdf_text, pin.JointModelFreeFlyer())
        self.data = self.model.createData()
        self.q0 = pin.neutral(self.model)  # the base at the origin, upright
        for name, angle in half_sitting.items():
            self.q0[self.model.joints[self.model.getJointId(name)].idx_q] = angle
        self.frame_ids = {name: self.model.getFrameId(frame) for name, frame in FRAMES.items()}
        self.nv = self.model.nv
        self.joint_names = [self.model.names[i] for i in range(2, self.model.njoints)]
        self.q_min = self.model.lowerPositionLimit[7:].copy()
        self.q_max = self.model.upperPositionLimit[7:].copy()
        self.v_max = self.model.velocityLimit[6:].copy()
        self.posture_J = np.eye(self.nv)[6:]

    def targets_at(self, q: np.ndarray) -> Targets:
        """The task values at ``q`` (the trajectory's start)."""
        pin, data = self.pin, self.data
        pin.forwardKinematics(self.model, data, q)
        pin.updateFramePlacements(self.model, data)
        pose = {name: data.oMf[self.frame_ids[name]].homogeneous.copy() for name in FRAMES}
        return Targets(
            poses={name: pose[name] for name in ("left_foot", "right_foot", "right_hand")},
            left_hand=pose["left_hand"][:3, 3].copy(),
            head=pose["head"][:3, :3].copy(),
            com=pin.centerOfMass(self.model, data, q).copy(),
            posture=q[7:].copy(),
        )

    def tasks(self, q: np.ndarray, targets: Targets) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per level of :data:`STACK`, ``(J, e)`` with ``J Δq = e`` the step that closes the error:
        Jacobians in the world-aligned frame at the body (rows linear then angular, as PlaCo's),
        position errors ``p* - p``, orientation errors ``log(R* Rᵀ)``, CoM and posture ``x* - x``."""
        pin, model, data = self.pin, self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        jcom = pin.jacobianCenterOfMass(model, data, True)
        out = []
        for name, kind in STACK:
            if kind == "com":
                out.append((jcom, targets.com - data.com[0]))
                continue
            if kind == "posture":
                out.append((self.posture_J, targets.posture - q[7:]))
                continue
            fid = self.frame_ids[name]
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            placement = data.oMf[fid]
            if kind == "frame":
                target = targets.poses[name]
                e_pos = target[:3, 3] - placement.translation
                e_rot = pin.log3(target[:3, :3] @ placement.rotation.T)
                out.append((J, np.concatenate([e_pos, e_rot])))
            elif kind == "position":
                out.append((J[:3], targets.left_hand - placement.translation))
            else:
                out.append((J[3:], pin.log3(targets.head @ placement.rotation.T)))
        return out

    def limit_level(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``lower <= q̇_joints <= upper``: ``q + dt q̇`` inside the position limits, ``|q̇| <= v_max``."""
        lower, upper = velocity_bounds(q[7:], self.q_min, self.q_max, 1.0 / DT, -self.v_max, self.v_max)
        return self.posture_J, lower, upper


def pair_names(geometry) -> list[tuple[str, str]]:
    """The collision pairs of a Pinocchio ``geometry`` model as sorted pairs of shape names."""
    objects = geometry.geometryObjects
    return sorted(
        tuple(sorted((objects[p.first].name, objects[p.second].name))) for p in geometry.collisionPairs
    )


class Collisions:
    """TALOS's collision shapes in Pinocchio/hpp-fcl (coal) and the pairs that may collide, for the
    drake_sot side's self-collision level; PlaCo is given the same shapes and pairs
    (:meth:`give_to`).

    The shapes are the model file's collision meshes (STL) and primitives; each mesh is replaced by
    its convex hull (coal's qhull), on both sides: mesh-to-mesh distances take ~0.5 s per call for
    the 883 pairs (timed once, printed), the hulls' ~2 ms. The pairs are all the pairs of shapes on
    different joints (Pinocchio's ``addAllCollisionPairs``, which PlaCo's ``RobotWrapper`` calls when
    it finds no ``collisions.json``) less the SRDF's ``disable_collisions`` (by its reasons:
    adjacent links, pairs never in collision, pairs in contact at the default pose), which PlaCo
    does not read: it is given the remaining pairs by link name through its ``load_collision_pairs``.

    Args: the ``pinocchio`` and ``coal`` modules; ``model``, TALOS's Pinocchio model (the drake_sot
    side's); ``collision_text``, the URDF text of :func:`with_collisions`; ``srdf``, the SRDF's text;
    ``q0``, the configuration at which the meshes' and the hulls' least distances are measured.
    Raises what Pinocchio raises for a mesh it cannot load or an SRDF naming a link it lacks.
    """

    def __init__(self, pin, coal, model, collision_text: str, srdf: str, q0: np.ndarray):
        self.pin, self.model = pin, model
        self.geometry = pin.buildGeomFromUrdfString(model, collision_text, pin.COLLISION)
        self.geometry.addAllCollisionPairs()
        pin.removeCollisionPairsFromXML(model, self.geometry, srdf)
        self.data = self.geometry.createData()
        measure = model.createData()
        self.mesh_time, _ = _time(pin.computeDistances, model, measure, self.geometry, self.data, q0)
        self.mesh_least = min(r.min_distance for r in self.data.distanceResults)
        for shape in self.geometry.geometryObjects:
            if isinstance(shape.geometry, coal.BVHModelBase):
                shape.geometry.buildConvexHull(True, "Qt")
                shape.geometry = shape.geometry.convex
        self.data = self.geometry.createData()
        self.measure = measure  # for distances at a q of either side, apart from the drake_sot side's data
        self.hull_least = self.least(q0)
        objects = self.geometry.geometryObjects
        self.pairs = [(p.first, p.second) for p in self.geometry.collisionPairs]
        self.joints = np.array([(objects[a].parentJoint, objects[b].parentJoint) for a, b in self.pairs])
        self.gain = distance_damper_gain("self-collision", D_S, D_I, XI)

    def distances(self, q: np.ndarray) -> np.ndarray:
        """The signed distance [m] of every pair at ``q`` (hpp-fcl, the hulls)."""
        self.pin.computeDistances(self.model, self.measure, self.geometry, self.data, q)
        return np.array([r.min_distance for r in self.data.distanceResults])

    def least(self, q: np.ndarray) -> float:
        """The least signed distance [m] over the pairs at ``q``."""
        return float(self.distances(q).min())

    def level(
        self, data, margin: float = D_S, geometry_data=None
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], int]:
        """The self-collision level ``(J_d, lower, upper)`` at the joint placements and Jacobians of
        Pinocchio's ``data`` (``computeJointJacobians`` at q), and the number k of its rows that
        hold a pair: one row per pair closer than ``d_i``, ``J_d q̇ >= λ (d_s - d)`` with
        ``d_s = margin`` (``distance_rows``; one unbounded row when no pair is that close), the
        witness points ``p_A``, ``p_B`` fixed on their joints, ``n`` from B to A (minus coal's
        normal, which goes from A to B, at contact and in penetration too).

        The distances go through ``geometry_data`` (a ``GeometryData`` of the shapes), by default
        the one kept from step to step: coal's GJK then starts from the last step's result and,
        where the closest features are faces or edges (witness points not unique), may return
        other witness points, hence other rows, than a fresh one (PlaCo makes one at each call)."""
        pin, model = self.pin, self.model
        geometry_data = self.data if geometry_data is None else geometry_data
        pin.updateGeometryPlacements(model, data, self.geometry, geometry_data)
        pin.computeDistances(self.geometry, geometry_data)
        results = geometry_data.distanceResults
        near = [i for i, r in enumerate(results) if r.min_distance < D_I]
        k = len(near)
        J_a, J_b = np.zeros((k, 3, model.nv)), np.zeros((k, 3, model.nv))
        normals, distances = np.zeros((k, 3)), np.zeros(k)
        for row, i in enumerate(near):
            r = results[i]
            distances[row], normals[row] = r.min_distance, -r.normal
            for J_point, joint, point in ((J_a, 0, r.getNearestPoint1()), (J_b, 1, r.getNearestPoint2())):
                J = pin.getJointJacobian(model, data, int(self.joints[i, joint]), pin.WORLD)
                J_point[row] = J[:3] - pin.skew(point) @ J[3:]  # the velocity of the point fixed there
        _, J_d, lower, upper = distance_rows(distances, normals, J_a, J_b, margin, self.gain, max(k, 1))
        return (J_d, lower, upper), k

    def give_to(self, robot) -> None:
        """Give PlaCo's ``robot`` (a RobotWrapper loaded from the same URDF text) the same shapes
        (the hulls, by reference) and, through its ``load_collision_pairs``, the same pairs."""
        theirs = robot.collision_model
        ours = self.geometry.geometryObjects
        assert [o.name for o in theirs.geometryObjects] == [o.name for o in ours], "the shapes differ"
        for shape, hull in zip(theirs.geometryObjects, ours, strict=True):
            shape.geometry = hull.geometry
        frames = self.model.frames
        links = sorted({tuple(frames[ours[i].parentFrame].name for i in pair) for pair in self.pairs})
        with tempfile.TemporaryDirectory() as directory:
            path = pathlib.Path(directory) / "collisions.json"
            path.write_text(json.dumps(links))
            robot.load_collision_pairs(str(path))


def stack_levels(
    tasks: list[tuple[np.ndarray, np.ndarray]],
    limits: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The levels of ``solve_hqp`` in velocity units: ``J q̇ = e / dt`` per task (each task closes its
    error in one period, PlaCo's unit gain), under ``limits`` when given; each as ``StackOfTasks``
    passes an equality task, ``(J, target, target)`` with the same array twice."""
    levels = [(J, target, target) for J, target in ((J, e / DT) for J, e in tasks)]
    return levels if limits is None else [limits, *levels]


class Placo:
    """PlaCo's KinematicsSolver on its own RobotWrapper, holding the same stack; with
    ``collisions``, loaded from the URDF text with the collision shapes, given the same shapes and
    pairs as the drake_sot side (:meth:`Collisions.give_to`) and PlaCo's self-collision constraint
    (hard, margin ``d_s``, trigger ``d_i``)."""

    def __init__(
        self,
        placo,
        urdf: pathlib.Path,
        urdf_text: str,
        q0: np.ndarray,
        priorities: dict[str, tuple[str, float]],
        *,
        limits: bool,
        collisions: Collisions | None = None,
    ):
        # ignore_collisions: no pairs at loading (all of them, and a warning listing the pairs in
        # contact at q = 0); the shapes are loaded all the same.
        self.robot = placo.RobotWrapper(str(urdf), placo.Flags.ignore_collisions, urdf_text)
        if collisions is not None:
            collisions.give_to(self.robot)
        self.robot.state.q = q0.copy()
        self.robot.update_kinematics()
        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.mask_fbase(False)
        self.solver.dt = DT
        self.solver.enable_joint_limits(limits)
        self.solver.enable_velocity_limits(limits)
        if collisions is not None:
            self.collision_constraint = self.solver.add_avoid_self_collisions_constraint()
            self.collision_constraint.configure("self_collisions", "hard", 1.0)
            self.collision_constraint.self_collisions_margin = D_S
            self.collision_constraint.self_collisions_trigger = D_I
        self.tasks = {}
        eye = np.eye(4)
        for name, kind in STACK:
            if kind == "frame":
                task = self.solver.add_frame_task(FRAMES[name], eye)
            elif kind == "com":
                task = self.solver.add_com_task(np.zeros(3))
            elif kind == "position":
                task = self.solver.add_position_task(FRAMES[name], np.zeros(3))
            elif kind == "orientation":
                task = self.solver.add_orientation_task(FRAMES[name], np.eye(3))
            else:
                task = self.solver.add_joints_task()
            priority, weight = priorities[name]
            task.configure(name, priority, *((weight, weight) if kind == "frame" else (weight,)))
            self.tasks[name] = task
        self.joint_names = list(self.robot.joint_names())

    def set_targets(self, targets: Targets) -> None:
        for name in ("left_foot", "right_foot", "right_hand"):
            self.tasks[name].T_world_frame = targets.poses[name]
        self.tasks["com"].target_world = targets.com
        self.tasks["left_hand"].target_world = targets.left_hand
        self.tasks["head"].R_world_frame = targets.head
        self.tasks["posture"].set_joints(dict(zip(self.joint_names, targets.posture, strict=True)))

    def matrices(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """PlaCo's ``(A, b)`` per level of :data:`STACK` after its last solve (``A Δq = b``)."""
        out = []
        for name, kind in STACK:
            task = self.tasks[name]
            if kind == "frame":
                parts = (task.position(), task.orientation())
                out.append((np.vstack([p.A for p in parts]), np.concatenate([p.b.ravel() for p in parts])))
            elif kind == "posture":  # one row per joint, in the order of the joint names: sort by column
                order = np.argsort(np.argmax(np.abs(task.A), axis=1))
                out.append((task.A[order], task.b.ravel()[order]))
            else:
                out.append((task.A, task.b.ravel()))
        return out


def _time(fn: Callable[..., object], *args: object) -> tuple[float, object]:
    t0 = time.perf_counter()
    value = fn(*args)
    return time.perf_counter() - t0, value


@dataclasses.dataclass
class Step:
    """One timed step of the drake_sot side."""

    kinematics: float  # [s]: task Jacobians and errors, limit bounds, distances and their rows, integration
    solve: float  # [s]: solve_hqp
    tasks: list[tuple[np.ndarray, np.ndarray]]
    levels: list[tuple[np.ndarray, np.ndarray, np.ndarray]]  # the limit level first
    result: HqpResult
    q_next: np.ndarray
    collision_rows: int  # the rows of the self-collision level that hold a pair (0 without it)


def drake_sot_step(
    pin,
    talos: Talos,
    q: np.ndarray,
    target: Targets,
    previous: HqpResult | None,
    collisions: Collisions | None = None,
) -> Step:
    """One step of the drake_sot controller, warm-started from its last step's result ``previous``
    (None at the first step), as ``StackOfTasks`` does from tick to tick; with ``collisions``, the
    self-collision level just below the limits."""
    t_kin, tasks = _time(talos.tasks, q, target)
    t_lim, limits = _time(talos.limit_level, q)
    levels = stack_levels(tasks, limits)
    t_col, rows = 0.0, 0
    if collisions is not None:
        t_col, (level, rows) = _time(collisions.level, talos.data)
        levels.insert(1, level)
    t_hqp, result = _time(partial(solve_hqp, validate=False, warm_start=previous), levels)
    t_int, q_next = _time(pin.integrate, talos.model, q, result.qdot * DT)
    return Step(t_kin + t_lim + t_col + t_int, t_hqp, tasks, levels, result, q_next, rows)


def collision_check(
    talos: Talos, collisions: Collisions, checker: Placo, q: np.ndarray, target: Targets
) -> tuple[float, int] | None:
    """Check (5) at ``q``: PlaCo's ``checker`` (the six upper tasks hard, the posture soft, no limits,
    its self-collision constraint hard at margin :data:`CHECK_MARGIN`) against ``solve_hqp`` on the
    self-collision level at that margin above the 7 levels (distances from a fresh
    ``GeometryData``, as PlaCo's): with the tasks and the rows feasible together, both are the
    lexicographic solution. Returns ``(max |Δq diff| [rad], the rows at their bound)``, or None
    when PlaCo finds its hard constraints infeasible together (its QPError, a RuntimeError)."""
    tasks = talos.tasks(q, target)
    level, _ = collisions.level(talos.data, CHECK_MARGIN, collisions.geometry.createData())
    result = solve_hqp([level, *stack_levels(tasks, None)])
    checker.robot.state.q = q.copy()
    checker.robot.update_kinematics()
    checker.set_targets(target)
    try:
        step = checker.solver.solve(False)
    except RuntimeError:
        return None
    return float(np.abs(step - result.qdot * DT).max()), len(result.levels[0].active_lower)


def placo_step(peer: Placo) -> tuple[float, float]:
    """PlaCo's step, timed: ``(update_kinematics, solve(True))`` [s]."""
    t_kin, _ = _time(peer.robot.update_kinematics)
    t_solve, _ = _time(peer.solver.solve, True)
    return t_kin, t_solve


def run(passes: int) -> dict:
    import coal
    import pinocchio as pin
    import placo

    urdf, urdf_text, collision_text, half_sitting = talos_model()
    talos = Talos(pin, urdf_text, half_sitting)
    srdf = (urdf.parents[1] / "srdf" / "talos.srdf").read_text()
    collisions = Collisions(pin, coal, talos.model, collision_text, srdf, talos.q0)
    assert sorted(talos.joint_names) == sorted(half_sitting), "the description and Pinocchio differ"
    steps = round(DURATION / DT)
    start = talos.targets_at(talos.q0)
    targets = [trajectory(start, k * DT) for k in range(steps)]
    peer = Placo(placo, urdf, urdf_text, talos.q0, PLACO_WEIGHTED, limits=True)
    checker = Placo(placo, urdf, urdf_text, talos.q0, PLACO_STRICT, limits=False)
    sc_peer = Placo(placo, urdf, collision_text, talos.q0, PLACO_WEIGHTED, limits=True, collisions=collisions)
    sc_checker = Placo(
        placo, urdf, collision_text, talos.q0, PLACO_STRICT, limits=False, collisions=collisions
    )
    sc_checker.collision_constraint.self_collisions_margin = CHECK_MARGIN
    assert peer.joint_names == talos.joint_names, "PlaCo and Pinocchio order the joints differently"
    # (4) The same collision pairs and the same distances at the start.
    collision_pairs = pair_names(collisions.geometry)
    same_pairs = pair_names(sc_peer.robot.collision_model) == collision_pairs
    index = {pair: i for i, pair in enumerate(collisions.pairs)}
    start_distances = collisions.distances(talos.q0)
    placo_distances = {(d.objA, d.objB): d.min_distance for d in sc_peer.robot.distances()}
    distance_gap = max(abs(d - start_distances[index[pair]]) for pair, d in placo_distances.items())

    # (1) The same task matrices at the start.
    peer.set_targets(targets[0])
    peer.solver.solve(False)
    matrix_gap = max(
        max(np.abs(J - A).max(), np.abs(e - b).max())
        for (J, e), (A, b) in zip(talos.tasks(talos.q0, targets[0]), peer.matrices(), strict=True)
    )

    names = ("placo_kin", "placo_solve", "kin", "hqp", "hqp_cold", "hqp_free", "strict")
    names += ("sc_placo_kin", "sc_placo_solve", "sc_kin", "sc_hqp")
    times: dict[str, list[float]] = {name: [] for name in names}
    sides = ("hqp", "placo", "sc_hqp", "sc_placo")  # sc_: the runs with self-collision
    errors = {side: np.zeros((steps, len(STACK))) for side in sides}
    excess = dict.fromkeys(sides, 0.0)
    least = dict.fromkeys(sides, collisions.least(talos.q0))  # least distance over pass 0 [m]
    collision_rows: dict[str, list[int]] = {"sc_hqp": [], "sc_placo": []}  # pass 0, per step
    collision_binding = 0  # pass 0: steps with a row of drake_sot's self-collision level at its bound
    collision_effect = {"hqp": 0.0, "placo": 0.0}  # pass 0: max |q with - q without self-collision|
    limit_steps = binding_steps = 0
    q_gap = 0.0
    iterations: list[int] = []
    cold_iterations: list[int] = []
    limited_joints: set[str] = set()
    strict_gap = hqp_gap = warm_gap = 0.0
    checks: list[tuple[float, int] | None] = []  # (5), at every 20th state of pass 0
    for p in range(passes):
        q, sc_q = talos.q0.copy(), talos.q0.copy()
        peer.robot.state.q = talos.q0.copy()
        sc_peer.robot.state.q = talos.q0.copy()
        last: HqpResult | None = None  # the controller's last result: its warm start
        sc_last: HqpResult | None = None
        for k, target in enumerate(targets):
            peer.set_targets(target)
            sc_peer.set_targets(target)
            if p == 0:  # the rows of PlaCo's constraint at this step: its pairs closer than the trigger
                collision_rows["sc_placo"].append(
                    sum(d.min_distance < D_I for d in sc_peer.robot.distances())
                )
            if k % 2:  # alternate which side runs first
                placo_kin, placo_solve = placo_step(peer)
                ours = drake_sot_step(pin, talos, q, target, last)
                sc_placo = placo_step(sc_peer)
                sc_ours = drake_sot_step(pin, talos, sc_q, target, sc_last, collisions)
            else:
                ours = drake_sot_step(pin, talos, q, target, last)
                placo_kin, placo_solve = placo_step(peer)
                sc_ours = drake_sot_step(pin, talos, sc_q, target, sc_last, collisions)
                sc_placo = placo_step(sc_peer)
            free = ours.levels[1:]
            pairs = [(J, e) for J, e, _ in free]
            sample = (
                placo_kin,
                placo_solve,
                ours.kinematics,
                ours.solve,
                _time(partial(solve_hqp, validate=False), ours.levels)[0],
                _time(partial(solve_hqp, validate=False), free)[0],
                _time(partial(solve_strict, validate=False), pairs)[0],
                *sc_placo,
                sc_ours.kinematics,
                sc_ours.solve,
            )
            for name, value in zip(names, sample, strict=True):
                times[name].append(value)
            if p == 0:
                errors["hqp"][k] = [np.linalg.norm(e) for _, e in ours.tasks]
                errors["placo"][k] = [np.linalg.norm(b) for _, b in peer.matrices()]
                errors["sc_hqp"][k] = [np.linalg.norm(e) for _, e in sc_ours.tasks]
                errors["sc_placo"][k] = [np.linalg.norm(b) for _, b in sc_peer.matrices()]
                collision_rows["sc_hqp"].append(sc_ours.collision_rows)
                collision_binding += bool(sc_ours.result.levels[1].active_lower)
                limits = ours.result.levels[0]
                active = limits.active_lower + limits.active_upper
                limit_steps += bool(active)
                limited_joints.update(talos.joint_names[i] for i in active)
                iterations.append(ours.result.iterations)
                cold = solve_hqp(ours.levels)
                cold_iterations.append(cold.iterations)
                warm_gap = max(warm_gap, np.abs(ours.result.qdot - cold.qdot).max())
                # a limit binds when q̇ differs from the same levels' solution without limits
                binding_steps += bool(np.abs(ours.result.qdot - solve_hqp(free).qdot).max() > 1e-9)
                if k % 20 == 0:  # (2) PlaCo with hard upper levels equals solve_strict
                    checker.robot.state.q = q.copy()
                    checker.robot.update_kinematics()
                    checker.set_targets(target)
                    strict = solve_strict(pairs).qdot
                    strict_gap = max(strict_gap, np.abs(checker.solver.solve(False) - strict * DT).max())
                    hqp_gap = max(hqp_gap, np.abs(solve_hqp(free).qdot - strict).max())
                    checks.append(collision_check(talos, collisions, sc_checker, q, target))
            q, last = ours.q_next, ours.result
            sc_q, sc_last = sc_ours.q_next, sc_ours.result
            if p == 0:
                q_gap = max(q_gap, np.abs(q - peer.robot.state.q).max())
                collision_effect["hqp"] = max(collision_effect["hqp"], np.abs(sc_q - q).max())
                gap = np.abs(sc_peer.robot.state.q - peer.robot.state.q).max()
                collision_effect["placo"] = max(collision_effect["placo"], gap)
            states = {
                "hqp": q,
                "placo": peer.robot.state.q,
                "sc_hqp": sc_q,
                "sc_placo": sc_peer.robot.state.q,
            }
            for side, qs in states.items():
                over = np.maximum(qs[7:] - talos.q_max, talos.q_min - qs[7:]).max()
                excess[side] = max(excess[side], over)
                if p == 0:
                    least[side] = min(least[side], collisions.least(qs))
    return {
        "times": times,
        "errors": errors,
        "excess": excess,
        "limit_steps": limit_steps,
        "binding_steps": binding_steps,
        "q_gap": q_gap,
        "matrix_gap": matrix_gap,
        "strict_gap": strict_gap,
        "hqp_gap": hqp_gap,
        "iterations": iterations,
        "cold_iterations": cold_iterations,
        "warm_gap": warm_gap,
        "limited_joints": limited_joints,
        "steps": steps,
        "passes": passes,
        "nv": talos.nv,
        "rows": sum(J.shape[0] for J, _ in talos.tasks(talos.q0, targets[0])),
        "least": least,
        "collision_rows": collision_rows,
        "collision_binding": collision_binding,
        "checks": checks,
        "collision_effect": collision_effect,
        "pairs": len(collision_pairs),
        "same_pairs": same_pairs,
        "distance_gap": distance_gap,
        "mesh_time": collisions.mesh_time,
        "mesh_least": collisions.mesh_least,
        "hull_least": collisions.hull_least,
    }


def _median_ratio(a: list[float], b: list[float]) -> float:
    return statistics.median(x / y for x, y in zip(a, b, strict=True))


def report(out: dict) -> str:
    t = out["times"]
    ours = [k + s for k, s in zip(t["kin"], t["hqp"], strict=True)]
    placo_step = [k + s for k, s in zip(t["placo_kin"], t["placo_solve"], strict=True)]
    us = {name: 1e6 * statistics.median(v) for name, v in t.items()}
    pairs = len(ours)
    step = 1e6 * statistics.median(placo_step)

    def row(label: str, samples: list[float], part: list[float] | None) -> str:
        median = 1e6 * statistics.median(samples)
        ratio = "-" if part is None else f"{_median_ratio(samples, part):.2f}"
        return f"| {label} | {median:.0f} µs | {_median_ratio(samples, placo_step):.2f} | {ratio} |"

    iterations = out["iterations"]
    actuated = out["nv"] - 6
    lines = [
        f"TALOS talos_full_v2, grippers frozen (drake_sot.robots; nv = {out['nv']}), {len(STACK)} task "
        f"levels ({out['rows']} rows) + {actuated} joint-limit rows, "
        f"{out['steps']} steps of {1e3 * DT:g} ms x {out['passes']} passes = {pairs} interleaved pairs; "
        f"placo {version('placo')}, pin {version('pin')}, numpy {np.__version__}, Python "
        f"{platform.python_version()}, {datetime.date.today()}",
        "",
        "| measurement | median | ÷ PlaCo step | ÷ PlaCo's part |",
        "|---|---|---|---|",
        f"| PlaCo step: update_kinematics + solve(True), {2 * actuated} limit rows | {step:.0f} µs | 1 | - |",
        f"| - update_kinematics (frames, joint Jacobians) | {us['placo_kin']:.0f} µs | - | 1 |",
        f"| - solve(True) (task Jacobians, errors, QP, integration) | {us['placo_solve']:.0f} µs | - | 1 |",
        row("drake_sot step: kinematics + solve_hqp with limits", ours, None),
        row("- kinematics (Pinocchio, task errors, limit bounds, integration)", t["kin"], t["placo_kin"]),
        row(f"- solve_hqp, {actuated} limit rows above the 7 levels, warm", t["hqp"], t["placo_solve"]),
        row(f"solve_hqp, {actuated} limit rows above the 7 levels, cold", t["hqp_cold"], t["placo_solve"]),
        row("solve_hqp, the 7 levels without limits", t["hqp_free"], t["placo_solve"]),
        row("solve_strict, the 7 levels", t["strict"], t["placo_solve"]),
        "",
        f"solve_hqp with limits: {statistics.median(iterations):.0f} active-set iterations per step "
        f"warm (median; max {max(iterations)}), {statistics.median(out['cold_iterations']):.0f} cold "
        f"(max {max(out['cold_iterations'])}); a joint is at a limit in {out['limit_steps']} of "
        f"{out['steps']} steps ({', '.join(sorted(out['limited_joints']))}), and the limits change q̇ "
        f"in {out['binding_steps']} of them.",
        "",
        "Agreement:",
        f"- task matrices and errors at the start, drake_sot (Pinocchio) vs PlaCo: max |diff| "
        f"{out['matrix_gap']:.1e}",
        f"- PlaCo with the six upper tasks hard and the posture soft, no limits, vs solve_strict "
        f"(q̇ dt) at every 20th state of the run: max |Δq diff| {out['strict_gap']:.1e} rad; "
        f"solve_hqp without limits vs solve_strict there: max |q̇ diff| {out['hqp_gap']:.1e} rad/s",
        f"- solve_hqp with limits, warm-started vs cold, every step: max |q̇ diff| "
        f"{out['warm_gap']:.1e} rad/s",
        f"- joint limits: largest excursion past a position limit, drake_sot {out['excess']['hqp']:.1e} rad, "
        f"PlaCo {out['excess']['placo']:.1e} rad; largest gap between the two runs' joint positions "
        f"{out['q_gap']:.1e} rad",
        "",
        "Task error norms in the closed-loop runs (each side on its own q), drake_sot / PlaCo:",
        "",
        "| task | mean | at 1.0 s | at the end |",
        "|---|---|---|---|",
    ]
    lines += error_rows(out, "hqp", "placo")
    return "\n".join(lines + ["", *report_collisions(out)])


def error_rows(out: dict, ours: str, theirs: str) -> list[str]:
    """The rows of the task error table: per task, the mean, mid-run and last error norms of the
    run ``ours`` and of the run ``theirs`` (keys of ``out["errors"]``)."""
    mid, rows = out["steps"] // 2, []
    for i, (name, _) in enumerate(STACK):
        h, p = out["errors"][ours][:, i], out["errors"][theirs][:, i]
        rows.append(
            f"| {name} | {h.mean():.1e} / {p.mean():.1e} | {h[mid]:.1e} / {p[mid]:.1e} "
            f"| {h[-1]:.1e} / {p[-1]:.1e} |"
        )
    return rows


def check_line(checks: list[tuple[float, int] | None]) -> str:
    """The line of check (5): the largest gap and the rows at a bound over the states PlaCo solved."""
    solved = [check for check in checks if check is not None]
    if not solved:
        return f"- PlaCo found its hard constraints infeasible at all {len(checks)} states of check (5)"
    bound = [rows for _, rows in solved]
    return (
        f"- the rows binding: with d_s = {CHECK_MARGIN} m, the six upper tasks hard in PlaCo and the "
        f"posture soft, no limits, PlaCo's step equals solve_hqp's (the rows above the 7 levels) q̇ dt "
        f"to {max(gap for gap, _ in solved):.1e} rad at {len(solved)} of the {len(checks)} states "
        f"checked (every 20th of the run), "
        f"{min(bound)}-{max(bound)} rows at their bound (distances from a fresh GeometryData on both "
        f"sides); PlaCo found the problem infeasible at the other {len(checks) - len(solved)}"
    )


def report_collisions(out: dict) -> list[str]:
    """The second table: the same runs with self-collision on both sides."""
    t = out["times"]
    step = [k + s for k, s in zip(t["placo_kin"], t["placo_solve"], strict=True)]
    ours = [k + s for k, s in zip(t["kin"], t["hqp"], strict=True)]
    sc_step = [k + s for k, s in zip(t["sc_placo_kin"], t["sc_placo_solve"], strict=True)]
    sc_ours = [k + s for k, s in zip(t["sc_kin"], t["sc_hqp"], strict=True)]

    def row(label: str, samples: list[float], part: list[float] | None) -> str:
        median = 1e6 * statistics.median(samples)
        ratio = "-" if part is None else f"{_median_ratio(samples, part):.2f}"
        return f"| {label} | {median:.0f} µs | {_median_ratio(samples, sc_step):.2f} | {ratio} |"

    def rows(side: str) -> str:
        filled = out["collision_rows"][side]
        return (
            f"median {statistics.median(filled):.0f}, max {max(filled)}, "
            f"mean {statistics.fmean(filled):.1f}; in {sum(n > 0 for n in filled)} of {len(filled)} steps"
        )

    least = out["least"]
    return [
        f"With self-collision on both sides: the {out['pairs']} pairs of TALOS's collision shapes "
        f"(convex hulls of the meshes) that the SRDF leaves, a row per pair closer than d_i = {D_I} m "
        f"keeping d >= d_s = {D_S} m (PlaCo: its AvoidSelfCollisionsKinematicsConstraint, hard, "
        f"margin d_s, trigger d_i; drake_sot: distance_rows at λ = 1/dt as a level just below the "
        f"limits), the same runs interleaved with the ones above:",
        "",
        "| measurement | median | ÷ PlaCo step | ÷ PlaCo's part |",
        "|---|---|---|---|",
        f"| PlaCo step with self-collision | {1e6 * statistics.median(sc_step):.0f} µs | 1 | - |",
        f"| - update_kinematics | {1e6 * statistics.median(t['sc_placo_kin']):.0f} µs | - | 1 |",
        f"| - solve(True) (the {out['pairs']} distances, the rows, the QP) "
        f"| {1e6 * statistics.median(t['sc_placo_solve']):.0f} µs | - | 1 |",
        row("drake_sot step with self-collision", sc_ours, None),
        row(
            f"- kinematics (as above, the {out['pairs']} distances, the rows)", t["sc_kin"], t["sc_placo_kin"]
        ),
        row("- solve_hqp, limits, self-collision, the 7 levels, warm", t["sc_hqp"], t["sc_placo_solve"]),
        "",
        f"drake_sot step ÷ PlaCo step: {_median_ratio(ours, step):.2f} without self-collision, "
        f"{_median_ratio(sc_ours, sc_step):.2f} with; self-collision's cost, step with ÷ step "
        f"without: drake_sot {_median_ratio(sc_ours, ours):.2f}, PlaCo {_median_ratio(sc_step, step):.2f}.",
        f"Rows filled per step (pairs closer than d_i): drake_sot {rows('sc_hqp')}; "
        f"PlaCo {rows('sc_placo')}.",
        f"Least distance over the run (the same hpp-fcl model, on each side's q): with self-collision "
        f"drake_sot {least['sc_hqp']:.4f} m, PlaCo {least['sc_placo']:.4f} m; without, drake_sot "
        f"{least['hqp']:.4f} m, PlaCo {least['placo']:.4f} m. A row of drake_sot's self-collision level "
        f"is at its bound in {out['collision_binding']} of {out['steps']} steps; the rows change the "
        f"run's joint positions by {out['collision_effect']['hqp']:.1e} rad (drake_sot) and "
        f"{out['collision_effect']['placo']:.1e} rad (PlaCo) at most.",
        "",
        "Agreement:",
        f"- the pairs: PlaCo's (its load_collision_pairs, by link name) and drake_sot's (all pairs less "
        f"the SRDF's disable_collisions) {'are the same' if out['same_pairs'] else 'DIFFER'} "
        f"({out['pairs']} pairs); their distances at the start, PlaCo's distances() vs drake_sot's: "
        f"max |diff| {out['distance_gap']:.1e} m",
        f"- meshes vs their convex hulls at the start: least distance {out['mesh_least']:.4f} m on the "
        f"meshes, {out['hull_least']:.4f} m on the hulls; computeDistances over the pairs took "
        f"{1e3 * out['mesh_time']:.0f} ms on the meshes (once)",
        check_line(out["checks"]),
        f"- joint limits: largest excursion past a position limit, drake_sot {out['excess']['sc_hqp']:.1e} "
        f"rad, PlaCo {out['excess']['sc_placo']:.1e} rad",
        "",
        "Task error norms in the runs with self-collision, drake_sot / PlaCo:",
        "",
        "| task | mean | at 1.0 s | at the end |",
        "|---|---|---|---|",
        *error_rows(out, "sc_hqp", "sc_placo"),
    ]


def main() -> None:
    passes = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    print(report(run(passes)))


if __name__ == "__main__":
    main()
