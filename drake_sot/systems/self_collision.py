"""Self-collision avoidance as an inequality task: every pair of the robot's collision shapes
kept apart by the distance damper (Faverjon and Tournassoud 1987; Kanoun, Lamiraux, Wieber 2011).

For each pair (A, B) of collision shapes that may collide (the pairs the collision filters of
:func:`~drake_sot.robots.add_robot_collision` leave: not two neighbouring bodies) and whose
signed distance ``d`` is below the activation distance ``d_i``, one row

    ``J_d q̇ >= -ξ (d - d_s) / (d_i - d_s)``,   ``J_d = nᵀ (J_pA - J_pB)``,

with ``p_A``, ``p_B`` the witness points (the closest points of A and B), ``n`` the unit normal
from B to A (``(p_A - p_B) / |p_A - p_B|`` for ``d > 0``; Drake's ``nhat_BA_W``, defined at
contact and in penetration too), ``J_pA``, ``J_pB`` the translational Jacobians of the witness
points fixed on their bodies, ``d_s`` the safety margin and ``ξ`` [m/s] the approach speed
allowed at ``d_i``: ``ḋ = J_d q̇`` then shrinks with the distance left, so ``d`` tends to
``d_s`` and does not cross it (:mod:`drake_sot.inequalities`). A pair beyond ``d_i`` has no
row: far from each other, the bodies move freely.

The damper is first order: over one period the distance also changes at second order in the
motion, most where a box's edge or corner takes over the closest points as a body slides
along another, and a pair that comes from beyond ``d_i`` to below ``d_s`` in one period is
seen too late. ``d_s`` absorbs it when the motion per period is small against ``d_s`` and
the shapes' curvature; how far a hand pulled into the torso gets inside ``d_s`` at which
speeds is measured in ``benchmarks/README.md`` (section ``bench_self_collision.py``).

The distances and witness points come from Drake's signed-distance query
(``QueryObject.ComputeSignedDistancePairwiseClosestPoints(max_distance=d_i)``) on the robot's
own collision model: the controller's model (``make_robot_control_model``) has no
SceneGraph, so :func:`make_collision_model` builds the same plant (same q and v layout) with a
SceneGraph, the shapes and the filters of the simulated robot (one home for both:
:func:`~drake_sot.robots.add_robot_collision`).

Obstacles of the environment (:class:`Obstacle`, boxes fixed in the world, e.g. a table) join
the model: each pair of a robot shape and an obstacle gets a row like a pair of the robot's own
shapes (the obstacle's Jacobian is zero), except the feet's shapes, which stand on the floor and
may rest on a box: their contact is the robot's support, not a collision to avoid. The floor is
not an obstacle. :func:`add_obstacles` puts the same boxes in the simulated world.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Box, CollisionFilterDeclaration, GeometrySet, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import Context, Diagram, DiagramBuilder

from drake_sot import inequalities as ineq
from drake_sot import validation
from drake_sot.models import HumanoidInfo
from drake_sot.models.humanoid import FRICTION
from drake_sot.robots import RobotDescription, add_robot_collision, load_robot, weld_robot_base
from drake_sot.systems.inequalities import InequalityTask

__all__ = ["CollisionModel", "Obstacle", "SelfCollisionAvoidance", "add_obstacles", "make_collision_model"]

OBSTACLE_COLOUR = np.array([0.55, 0.42, 0.30, 1.0])  # RGBA of an obstacle in the views


@dataclass(frozen=True)
class Obstacle:
    """A box fixed in the world that the robot avoids (a table).

    Attributes:
        name: the box's name; its shapes are ``<name>_collision`` and ``<name>_visual``.
        size: (3,) its edges along its own x, y, z [m], each finite > 0.
        pose: its centre and orientation in the world frame.

    Raises:
        ValueError: ``size`` not three finite numbers > 0 (naming it).
    """

    name: str
    size: tuple[float, float, float]
    pose: RigidTransform

    def __post_init__(self) -> None:
        size = np.asarray(self.size, dtype=float)
        if size.shape != (3,) or not np.all(size > 0) or not np.all(np.isfinite(size)):
            raise ValueError(f"obstacle {self.name!r}: size = {self.size!r}: three finite edges > 0 [m]")


def add_obstacles(plant: MultibodyPlant, obstacles: Sequence[Obstacle], *, visual: bool = True) -> list:
    """Register each obstacle's box on the world body of ``plant`` (not finalized yet) as a
    collision shape (the robot's friction) and, with ``visual``, a visual one. Returns the
    collision shapes' ids, in the order of ``obstacles``.

    Raises:
        RuntimeError: ``plant`` is finalized (Drake's); two obstacles with one name (Drake's).
    """
    world, ids = plant.world_body(), []
    for obstacle in obstacles:
        box = Box(*obstacle.size)
        ids.append(
            plant.RegisterCollisionGeometry(world, obstacle.pose, box, f"{obstacle.name}_collision", FRICTION)
        )
        if visual:
            plant.RegisterVisualGeometry(
                world, obstacle.pose, box, f"{obstacle.name}_visual", OBSTACLE_COLOUR
            )
    return ids


@dataclass(frozen=True)
class CollisionModel:
    """The robot's model with its collision shapes: ``plant`` (finalized, continuous, without
    PD gains: the q and v of the controller's model) registered with ``scene_graph`` in
    ``diagram``; ``info`` as :func:`~drake_sot.robots.load_robot` returns it."""

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    info: HumanoidInfo


def _leg_shapes(plant: MultibodyPlant, info: HumanoidInfo, foot) -> list:
    """The collision shapes of the bodies from ``foot`` up to the base, the base's excluded."""
    parent = {
        plant.get_joint(j).child_body().index(): plant.get_joint(j).parent_body()
        for j in plant.GetJointIndices(info.model_instance)
    }
    shapes, body = [], foot
    while body.name() != info.base_body and body.index() in parent:
        shapes += plant.GetCollisionGeometriesForBody(body)
        body = parent[body.index()]
    return shapes


def make_collision_model(
    robot: str | RobotDescription = "embedded",
    *,
    fixed_base: bool = False,
    obstacles: Sequence[Obstacle] = (),
    leg_pairs: bool = True,
) -> CollisionModel:
    """The controller's model of ``robot`` (as ``make_robot_control_model``) with a SceneGraph
    holding the simulated robot's collision shapes and filters (the soles' contact spheres
    and :func:`~drake_sot.robots.add_robot_collision`'s body shapes), and the ``obstacles``
    (no floor), which the feet's shapes are filtered against (module docstring). Without
    ``leg_pairs`` the shapes of one leg (its bodies from the foot up to the base) are filtered
    against the other leg's: where a footstep plan keeps the legs apart (walking), rows on them
    would slow a swing foot passing the stance leg within ``d_i`` and it would land off its
    footprint (the embedded humanoid's turning steps in ``walk``: up to 2.7 cm off, 1 cm
    without the task).

    Raises what :func:`~drake_sot.robots.load_robot` raises (an unknown robot, a model file
    that is missing or broken), and what :func:`add_obstacles` raises.
    """
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    info = load_robot(plant, robot, pd_gains=False)
    add_robot_collision(plant, scene_graph, info, robot)
    if fixed_base:
        weld_robot_base(plant, info, robot)
    boxes = add_obstacles(plant, obstacles, visual=False)
    feet = [plant.GetFrameByName(info.frames[f"{side}_foot"]).body() for side in ("left", "right")]
    declaration = CollisionFilterDeclaration()
    if boxes:
        soles = [g for foot in feet for g in plant.GetCollisionGeometriesForBody(foot)]
        declaration.ExcludeBetween(GeometrySet(soles), GeometrySet(boxes))
    if not leg_pairs:
        left, right = (_leg_shapes(plant, info, foot) for foot in feet)
        declaration.ExcludeBetween(GeometrySet(left), GeometrySet(right))
    scene_graph.collision_filter_manager().Apply(declaration)
    plant.Finalize()
    return CollisionModel(builder.Build(), plant, scene_graph, info)


class SelfCollisionAvoidance(InequalityTask):
    """The robot's collision shapes kept ``d_s`` apart by the distance damper (module docstring).

    The task has a fixed number of rows, ``max_pairs``: at each evaluation the pairs closer
    than ``d_i``, closest first; the rows beyond them are zero and unbounded (they constrain
    nothing). When more than ``max_pairs`` pairs are closer than ``d_i``, the farthest of them
    get no row at that evaluation: their bounds are the loosest.

    The system keeps one scratch context of its collision model (``model``, the
    :class:`CollisionModel` the distances are computed on): evaluate it from one thread.

    Input ports:
        q: configuration (nq,) of the controller's model of ``robot`` (the device's
            integrated reference) [m, quaternion, rad].
    Output ports:
        task: abstract :class:`~drake_sot.signals.BoundedTaskSignal`, ``max_pairs`` rows [m]:
            ``error`` = ``d - d_s`` where negative, else 0 [m]; ``J`` (max_pairs, nv) the rows
            ``J_d`` w.r.t. v [m/rad, 1]; ``lower`` = ``-ξ (d - d_s) / (d_i - d_s)`` [m/s],
            ``upper`` = +inf.

    Args:
        robot: a robot name (``drake_sot.robots.ROBOTS``) or description.
        fixed_base: the base welded where half-sitting puts it, as the controller's model
            (``make_robot_control_model(fixed_base=True)``).
        d_s: safety margin [m], finite >= 0.
        d_i: activation distance [m], finite and > ``d_s``.
        xi: ``ξ``, the approach speed allowed at ``d_i`` [m/s], finite > 0.
        max_pairs: the number of rows, >= 1.
        name: the task's name.
        obstacles: boxes fixed in the world, avoided like the robot's own shapes (the feet
            excepted; :func:`make_collision_model`).
        leg_pairs: rows for the pairs of one leg's shapes and the other's (False: none, where
            a footstep plan keeps the legs apart; :func:`make_collision_model`).

    Raises:
        ValueError: naming the bad parameter and its value (NaN, ±inf, ``d_s < 0``,
            ``d_i <= d_s``, ``xi <= 0``, ``max_pairs < 1``); what
            :func:`make_collision_model` raises.
    """

    def __init__(
        self,
        robot: str | RobotDescription = "embedded",
        *,
        fixed_base: bool = False,
        d_s: float = 0.01,
        d_i: float = 0.05,
        xi: float = 0.2,
        max_pairs: int = 16,
        name: str = "taskSelfCollision",
        obstacles: Sequence[Obstacle] = (),
        leg_pairs: bool = True,
    ) -> None:
        rows = validation.positive_int(f"{name!r}: max_pairs", max_pairs)
        super().__init__(name, rows, "m")
        self._gain = ineq.distance_damper_gain(repr(name), d_s, d_i, xi)
        self._d_s, self._d_i = float(d_s), float(d_i)
        self.model = make_collision_model(
            robot, fixed_base=fixed_base, obstacles=obstacles, leg_pairs=leg_pairs
        )
        plant, scene_graph = self.model.plant, self.model.scene_graph
        self._context = self.model.diagram.CreateDefaultContext()
        self._plant_context = plant.GetMyMutableContextFromRoot(self._context)
        self._scene_context = scene_graph.GetMyContextFromRoot(self._context)
        inspector = scene_graph.model_inspector()
        self._world = plant.world_frame()
        # The shapes that may collide, row g of the tables (found by the value of the shape's id):
        # its body (an index into _frames), its rotation and origin in the body frame. Plain numpy:
        # at a tick, Drake's ``RigidTransform @`` and the hashes of its id types cost more than the
        # Jacobians.
        geometries = sorted(
            {g for pair in inspector.GetCollisionCandidates() for g in pair}, key=lambda g: g.get_value()
        )
        self._row = {g.get_value(): row for row, g in enumerate(geometries)}
        self._names = {g: inspector.GetName(g) for g in geometries}
        body_frames = [plant.GetBodyFromFrameId(inspector.GetFrameId(g)).body_frame() for g in geometries]
        unique = {int(frame.index()): frame for frame in body_frames}  # in the order first seen
        self._frames = list(unique.values())
        self._body = np.array([list(unique).index(int(frame.index())) for frame in body_frames])
        poses = [inspector.GetPoseInFrame(g) for g in geometries]
        self._R_BG = np.array([X.rotation().matrix() for X in poses])
        self._p_BG = np.array([X.translation() for X in poses])
        self._q = self.DeclareVectorInputPort("q", plant.num_positions())
        self._declare_task({self.all_input_ports_ticket()})

    def _closest(self, context: Context) -> list:
        """The pairs closer than ``d_i`` at the input q, closest first, at most ``max_pairs``."""
        self.model.plant.SetPositions(self._plant_context, self._q.Eval(context))
        query = self.model.scene_graph.get_query_output_port().Eval(self._scene_context)
        pairs = query.ComputeSignedDistancePairwiseClosestPoints(max_distance=self._d_i)
        return sorted(pairs, key=lambda pair: pair.distance)[: self._m]

    def pairs(self, context: Context) -> tuple[tuple[str, str, float], ...]:
        """The rows' pairs at the input q: (shape A, shape B, signed distance [m]), in row order."""
        return tuple((self._names[p.id_A], self._names[p.id_B], p.distance) for p in self._closest(context))

    def _witness_jacobians(self, pairs: list) -> tuple[np.ndarray, np.ndarray]:
        """(k, 3, nv) twice: the translational Jacobians of the witness points on A and on B,
        each fixed on its body; one Drake call per body for all its points."""
        plant = self.model.plant
        rows = np.array(
            [self._row[g.get_value()] for pair in pairs for g in (pair.id_A, pair.id_B)], dtype=int
        )
        local = np.array([p for pair in pairs for p in (pair.p_ACa, pair.p_BCb)]).reshape(len(rows), 3)
        in_body = np.einsum("kij,kj->ki", self._R_BG[rows], local) + self._p_BG[rows]
        bodies = self._body[rows]
        J = np.empty((len(rows), 3, plant.num_velocities()))
        for body in np.unique(bodies):
            at = np.flatnonzero(bodies == body)
            J[at] = plant.CalcJacobianTranslationalVelocity(
                self._plant_context,
                JacobianWrtVariable.kV,
                self._frames[body],
                in_body[at].T,
                self._world,
                self._world,
            ).reshape(len(at), 3, -1)
        return J[0::2], J[1::2]

    def _compute(self, context):
        pairs = self._closest(context)
        J_a, J_b = self._witness_jacobians(pairs)
        return ineq.distance_rows(
            np.array([p.distance for p in pairs]),
            np.array([p.nhat_BA_W for p in pairs]).reshape(len(pairs), 3),
            J_a,
            J_b,
            self._d_s,
            self._gain,
            self._m,
        )
