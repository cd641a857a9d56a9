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

What the rows hold is reported by name (:class:`ClosestPair`: the two shapes and their bodies,
the signed distance, the witness points in world) on the ``closest_pairs`` output, and, for
the logs, as fixed-size vectors: each row's distance and its pair as an index into the task's
``candidate_pairs``, a fixed list of names (the pairs change from tick to tick).

The damper is first order: over one period the distance also changes at second order in the
motion, most where a box's edge or corner takes over the closest points as a body slides
along another, and a pair that comes from beyond ``d_i`` to below ``d_s`` in one period is
seen too late. ``d_s`` absorbs it when the motion per period is small against ``d_s`` and
the shapes' curvature; how far a hand pulled into the torso gets inside ``d_s`` at which
speeds is measured in ``benchmarks/README.md`` (section ``bench_self_collision.py``). A pair
pressed and sliding along another (a hand pushed into the body by a task below) loses such
distance at every period and settles where the damper's push back, ``λ (d_s - d) T`` over a
period T, makes up for it: inside ``d_s`` by the loss over ``λ T``. With ``recovery`` the rows
of a pair inside ``d_s`` have their own gain, ``ḋ >= recovery (d_s - d)`` (1/T: the distance
lost asked back within one period), and the pair settles inside by about one period's loss
(:func:`~drake_sot.inequalities.distance_rows`).

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
from pydrake.common.value import AbstractValue
from pydrake.geometry import Box, CollisionFilterDeclaration, GeometrySet, SceneGraph, SignedDistancePair
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import BasicVector, Context, Diagram, DiagramBuilder, ValueProducer

from drake_sot import inequalities as ineq
from drake_sot import validation
from drake_sot.models import HumanoidInfo
from drake_sot.models.humanoid import FRICTION
from drake_sot.robots import RobotDescription, add_robot_collision, load_robot, weld_robot_base
from drake_sot.systems.inequalities import InequalityTask

__all__ = [
    "CandidatePair",
    "ClosestPair",
    "CollisionModel",
    "Obstacle",
    "SelfCollisionAvoidance",
    "add_obstacles",
    "make_collision_model",
]

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


@dataclass(frozen=True)
class CandidatePair:
    """A pair of collision shapes the task watches (one the collision filters leave), by name:
    the shapes' SceneGraph names (``shape_a`` before ``shape_b`` in alphabetical order) and the
    names of the bodies they are fixed on."""

    shape_a: str
    shape_b: str
    body_a: str
    body_b: str


@dataclass(frozen=True)
class ClosestPair:
    """One row of :class:`SelfCollisionAvoidance` at a tick: a pair of collision shapes closer
    than the activation distance ``d_i``.

    Attributes:
        shape_a, shape_b: the shapes' SceneGraph names (A and B as Drake's query orders them).
        body_a, body_b: the names of the bodies A and B are fixed on.
        distance: the signed distance [m] (negative when they interpenetrate).
        p_WCa, p_WCb: the witness points on A and on B, world frame [m].
        index: the pair's index in the task's ``candidate_pairs``.
    """

    shape_a: str
    shape_b: str
    body_a: str
    body_b: str
    distance: float
    p_WCa: tuple[float, float, float]
    p_WCb: tuple[float, float, float]
    index: int


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
        closest_pairs: abstract ``tuple[ClosestPair, ...]``, the pairs of the rows (closest
            first, at most ``max_pairs``) at the input q, by name, with their signed distances
            [m] and witness points in world [m].
        distances: (max_pairs,) [m] each row's signed distance, NaN for a row without a pair.
        pair_indices: (max_pairs,) each row's pair as an index into ``candidate_pairs``, -1 for
            a row without a pair.

    Attributes:
        candidate_pairs: every pair the task watches (:class:`CandidatePair`), in a fixed
            order (by the shapes' names): what ``pair_indices`` index.

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
        recovery: [1/s] the gain of a row whose pair is inside the margin: its bound is then
            ``recovery (d_s - d)``, the distance lost asked back at that rate (1/T, one control
            period T: back in one period to first order); None: the damper's
            ``ξ / (d_i - d_s)`` there too (module docstring, on the second order).

    Raises:
        ValueError: naming the bad parameter and its value (NaN, ±inf, ``d_s < 0``,
            ``d_i <= d_s``, ``xi <= 0``, ``max_pairs < 1``, ``recovery <= 0``); what
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
        recovery: float | None = None,
    ) -> None:
        rows = validation.positive_int(f"{name!r}: max_pairs", max_pairs)
        super().__init__(name, rows, "m")
        self._gain = ineq.distance_damper_gain(repr(name), d_s, d_i, xi)
        self._recovery = (
            None if recovery is None else validation.positive(f"{name!r}: recovery", recovery, unit="1/s")
        )
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
        self._body = np.array([list(unique).index(int(frame.index())) for frame in body_frames], dtype=int)
        poses = [inspector.GetPoseInFrame(g) for g in geometries]
        # Shaped even when no pair may collide (a drafted robot's soles only, legs apart): then
        # every tick has no row, and the tables are indexed by an empty list.
        self._R_BG = np.array([X.rotation().matrix() for X in poses]).reshape(len(poses), 3, 3)
        self._p_BG = np.array([X.translation() for X in poses]).reshape(len(poses), 3)
        self._q = self.DeclareVectorInputPort("q", plant.num_positions())
        self._declare_task({self.all_input_ports_ticket()})
        self._declare_reports()

    def _closest(self, context: Context) -> list:
        """The pairs closer than ``d_i`` at the input q, closest first (pairs at one distance by
        their shapes' names: Drake's query returns them in an order that varies from one model to
        another), at most ``max_pairs`` (Drake's ``SignedDistancePair``), computed once per input
        q for the task and the reports.

        The scratch context is left at that q (the witness points' Jacobians and poses are
        computed on it), whichever context set it last."""
        q = self._q.Eval(context)
        if not np.array_equal(self.model.plant.GetPositions(self._plant_context), q):
            self.model.plant.SetPositions(self._plant_context, q)
        return self._closest_cache.Eval(context)

    def _query(self, context: Context) -> list:
        """:meth:`_closest`, computed (the scratch context at the input q)."""
        query = self.model.scene_graph.get_query_output_port().Eval(self._scene_context)
        pairs = query.ComputeSignedDistancePairwiseClosestPoints(max_distance=self._d_i)
        # Drake may also report a pair at max_distance (its box-box distances carry ~1e-5 m of
        # noise): only those strictly closer than d_i get a row.
        closer = [pair for pair in pairs if pair.distance < self._d_i]
        return sorted(closer, key=lambda p: (p.distance, self._names[p.id_A], self._names[p.id_B]))[: self._m]

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
            self._recovery,
        )

    # --- what the rows hold, by name: the reports ---------------------------------------------
    @property
    def d_s(self) -> float:
        """The safety margin [m]."""
        return self._d_s

    @property
    def d_i(self) -> float:
        """The activation distance [m]."""
        return self._d_i

    def _declare_reports(self) -> None:
        """The cache of the rows' pairs (the task's and the reports' one query a tick), the
        fixed list of the candidate pairs and the ``closest_pairs``, ``distances`` and
        ``pair_indices`` outputs."""
        self._closest_cache = self.DeclareCacheEntry(
            "closest",
            ValueProducer(
                allocate=lambda: AbstractValue.Make([]),
                calc=lambda context, value: value.set_value(self._query(context)),
            ),
            prerequisites_of_calc={self.all_input_ports_ticket()},
        )
        plant, inspector = self.model.plant, self.model.scene_graph.model_inspector()
        self._bodies = {g: plant.GetBodyFromFrameId(inspector.GetFrameId(g)).name() for g in self._names}
        named = sorted(
            tuple(sorted(((self._names[a], self._bodies[a]), (self._names[b], self._bodies[b]))))
            for a, b in inspector.GetCollisionCandidates()
        )
        self.candidate_pairs = tuple(
            CandidatePair(a, b, body_a, body_b) for (a, body_a), (b, body_b) in named
        )
        index = {(p.shape_a, p.shape_b): k for k, p in enumerate(self.candidate_pairs)}
        self._index = {
            frozenset((a.get_value(), b.get_value())): index[tuple(sorted((self._names[a], self._names[b])))]
            for a, b in inspector.GetCollisionCandidates()
        }
        ticket = {self._closest_cache.ticket()}
        self.DeclareAbstractOutputPort(
            "closest_pairs",
            lambda: AbstractValue.Make(()),
            self._calc_closest_pairs,
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort("distances", self._m, self._calc_distances, prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort(
            "pair_indices", self._m, self._calc_indices, prerequisites_of_calc=ticket
        )

    def _pair_index(self, pair: SignedDistancePair) -> int:
        """The index of ``pair`` (a row's, from Drake's query) in ``candidate_pairs``."""
        return self._index[frozenset((pair.id_A.get_value(), pair.id_B.get_value()))]

    def _calc_closest_pairs(self, context: Context, value: AbstractValue) -> None:
        pairs = self._closest(context)
        query = self.model.scene_graph.get_query_output_port().Eval(self._scene_context)
        value.set_value(
            tuple(
                ClosestPair(
                    shape_a=self._names[p.id_A],
                    shape_b=self._names[p.id_B],
                    body_a=self._bodies[p.id_A],
                    body_b=self._bodies[p.id_B],
                    distance=float(p.distance),
                    p_WCa=tuple(map(float, query.GetPoseInWorld(p.id_A) @ p.p_ACa)),
                    p_WCb=tuple(map(float, query.GetPoseInWorld(p.id_B) @ p.p_BCb)),
                    index=self._pair_index(p),
                )
                for p in pairs
            )
        )

    def _calc_distances(self, context: Context, output: BasicVector) -> None:
        distances = np.full(self._m, np.nan)
        pairs = self._closest(context)
        distances[: len(pairs)] = [p.distance for p in pairs]
        output.SetFromVector(distances)

    def _calc_indices(self, context: Context, output: BasicVector) -> None:
        indices = np.full(self._m, -1.0)
        pairs = self._closest(context)
        indices[: len(pairs)] = [self._pair_index(p) for p in pairs]
        output.SetFromVector(indices)
