"""Inequality tasks: LeafSystems that output ``lower <= J q̇ <= upper`` for ``StackOfTasks(solver="hqp")``.

Each keeps a quantity ``s(q)`` in an allowed set through the velocity damper of
:mod:`drake_sot.inequalities` (``λ (s_min - s) <= J q̇ <= λ (s_max - s)``) and may sit
at any level of the stack, like an equality task: the strict hierarchy of
:func:`drake_sot.hqp.solve_hqp` keeps it exactly when it can, and minimises its
violation given the levels above when it cannot.

Output ports (all):
    task: abstract :class:`~drake_sot.signals.BoundedTaskSignal` carrying the task's name:
        ``error`` (m,) how far ``s`` is outside its allowed set (0 inside), ``J`` (m, nv)
        w.r.t. v, and the bounds ``lower``, ``upper`` (m,) of ``J q̇`` (±inf where none).
        Plug it into the ``StackOfTasks`` input of the same name.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context

from drake_sot import inequalities as ineq
from drake_sot import validation
from drake_sot.signals import BoundedTaskSignal
from drake_sot.stack import task_name
from drake_sot.systems.features import _one_dof_joint_names, joint_units
from drake_sot.systems.leaf import SotLeafSystem

__all__ = [
    "CoMInSupportPolygon",
    "DistanceAbove",
    "InequalityTask",
    "JointPositionLimits",
    "JointVelocityLimits",
    "PointAbovePlane",
]


class InequalityTask(SotLeafSystem):
    """What every inequality task shares: its name, its dimension m and its ``task`` output
    (module docstring). Subclasses compute ``(error, J, lower, upper)`` in ``_compute``."""

    def __init__(self, name: str, dimension: int, units: str | Sequence[str]) -> None:
        super().__init__()
        self.set_name(task_name(name))
        self._m = validation.positive_int(f"task {name!r}: dimension", dimension)
        self._units = (units,) * self._m if isinstance(units, str) else tuple(units)

    @property
    def dimension(self) -> int:
        """Number of rows m."""
        return self._m

    @property
    def units(self) -> tuple[str, ...]:
        """The unit of each row's ``error`` (e.g. ``"m"``, ``"rad"``, ``"rad/s"``)."""
        return self._units

    def _declare_task(self, prerequisites: set) -> None:
        m = self._m
        self.DeclareAbstractOutputPort(
            "task",
            lambda: AbstractValue.Make(
                BoundedTaskSignal(self.get_name(), np.zeros(m), np.zeros((m, 0)), np.zeros(m), np.zeros(m))
            ),
            self._calc_task,
            prerequisites_of_calc=prerequisites,
        )

    def _compute(self, context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _calc_task(self, context: Context, value: AbstractValue) -> None:
        value.set_value(BoundedTaskSignal(self.get_name(), *self._compute(context)))


def _joints(plant: MultibodyPlant, joints: Sequence[str] | None, what: str) -> list:
    """The named one-DoF joints of ``plant`` (all of them when None), or ValueError naming the bad ones."""
    names = list(joints) if joints is not None else _one_dof_joint_names(plant)
    unknown = [j for j in names if not plant.HasJointNamed(j)]
    if unknown:
        raise ValueError(f"{what}: unknown joints {unknown}; the model has {_one_dof_joint_names(plant)}")
    objs = [plant.GetJointByName(j) for j in names]
    bad = [j.name() for j in objs if j.num_positions() != 1 or j.num_velocities() != 1]
    if bad:
        raise ValueError(f"{what}: joints {bad} are not one-DoF joints")
    if not objs:
        raise ValueError(f"{what}: no joint to limit")
    return objs


def _selection(plant: MultibodyPlant, joints: list) -> np.ndarray:
    """(m, nv): row i picks joint i's velocity."""
    J = np.zeros((len(joints), plant.num_velocities()))
    J[np.arange(len(joints)), [j.velocity_start() for j in joints]] = 1.0
    return J


class JointPositionLimits(InequalityTask):
    """Joint position limits as velocity bounds over the control period, with a margin.

    Row i: ``(q_min,i + margin - q⁺_i) / period <= q̇_i <= (q_max,i - margin - q⁺_i) / period``:
    the velocity damper with ``λ = 1/period``, where ``q⁺`` is where the joint will be
    when the q̇ solved now starts to act. A reference integrated with Euler steps of the
    control period (``Device``) then reaches ``q_max - margin`` at most and never passes
    it while the task holds; a joint already past the margin is brought back in one
    period. Rows of joints without limits (±inf) constrain nothing.

    With ``velocity_scale`` the rows also hold the joint velocity limits (times the
    scale): both bounds are clipped to ``[-scale v_max, scale v_max]``, which keeps
    ``lower <= upper`` and gives what a velocity-limit level above a position-limit level
    would (the position bound relaxed to the nearest velocity the limits allow), in one
    level of the hierarchy instead of two.

    The latency: ``Device`` integrates, at each tick, the q̇ that ``StackOfTasks`` solved
    at the tick before (Drake computes the updates of one instant from the state before
    it). The q̇ solved now from ``q`` acts from the next tick on, after the joint has
    moved by ``period · q̇_committed``: connect the ``qdot`` input to
    ``StackOfTasks.qdot`` and ``q⁺ = q + period · q̇_committed``. Without it ``q⁺ = q``,
    right for a q̇ applied at once; with the device's latency the joint would then
    overshoot the bound by up to one step and oscillate about it (the recurrence
    ``e⁺ = e - e⁻`` of the room left, whose roots lie on the unit circle).

    Input ports:
        q: configuration (nq,) of ``plant`` (the device's integrated reference).
        qdot: optional (nv,), the q̇ already committed for the next period [rad/s]
            (``StackOfTasks.qdot``); zero when unconnected.
    Output ports: ``task`` (one row per joint; ``error`` = how far ``q_i`` is outside
    ``[q_min + margin, q_max - margin]`` [rad or m]).

    Args:
        plant: the finalized robot model (its joints' position limits are used).
        period: the control period [s], finite > 0.
        joints: one-DoF joints to guard; None for all.
        margin: distance kept from each limit [rad or m], finite >= 0, less than half
            of every joint's range.
        velocity_scale: None, or the fraction in (0, 1] of the model's velocity limits
            the rows also hold.
        name: the task's name.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        *,
        period: float,
        joints: Sequence[str] | None = None,
        margin: float = 0.02,
        velocity_scale: float | None = None,
        name: str = "taskJointPositionLimits",
    ) -> None:
        objs = _joints(plant, joints, f"JointPositionLimits {name!r}")
        super().__init__(name, len(objs), joint_units(objs))
        self.joint_names = tuple(j.name() for j in objs)
        self._period = validation.positive(f"{name!r}: period", period, unit="s")
        margin = validation.nonnegative(f"{name!r}: margin", margin, unit="rad or m")
        lower = np.array([j.position_lower_limits()[0] for j in objs])
        upper = np.array([j.position_upper_limits()[0] for j in objs])
        room = upper - lower
        if not (room > 2 * margin).all():
            k = int(np.argmin(room > 2 * margin))
            raise ValueError(
                f"{name!r}: margin = {margin!r}: must leave room inside every joint's limits; "
                f"{self.joint_names[k]!r} has [{lower[k]:g}, {upper[k]:g}]"
            )
        self._low, self._high = lower + margin, upper - margin
        self._rates = (
            (-np.inf, np.inf) if velocity_scale is None else _velocity_limits(objs, velocity_scale, name)
        )
        self._q_index = np.array([j.position_start() for j in objs])
        self._v_index = np.array([j.velocity_start() for j in objs])
        self._J = _selection(plant, objs)
        self._q = self.DeclareVectorInputPort("q", plant.num_positions())
        self._qdot = self.DeclareVectorInputPort("qdot", plant.num_velocities())
        self._declare_task({self.all_input_ports_ticket()})

    def _compute(self, context):
        q = self._q.Eval(context)[self._q_index]
        ahead = (
            q + self._period * self._qdot.Eval(context)[self._v_index] if self._qdot.HasValue(context) else q
        )
        lower, upper = ineq.velocity_bounds(ahead, self._low, self._high, 1.0 / self._period, *self._rates)
        return ineq.outside(q, self._low, self._high), self._J, lower, upper


def _velocity_limits(joints: list, scale: float, name: str) -> tuple[np.ndarray, np.ndarray]:
    """``scale`` times the joints' velocity limits (lower, upper), ``scale`` checked in (0, 1]."""
    scale = validation.bounded(f"{name!r}: velocity scale", scale, 0.0, 1.0)
    if not scale > 0.0:
        raise ValueError(f"{name!r}: velocity scale = {scale!r}: must be > 0")
    return (
        scale * np.array([j.velocity_lower_limits()[0] for j in joints]),
        scale * np.array([j.velocity_upper_limits()[0] for j in joints]),
    )


class JointVelocityLimits(InequalityTask):
    """Joint velocity limits: ``-scale v_max,i <= q̇_i <= scale v_max,i``.

    No input: the bounds are constant (the model's velocity limits), computed once.
    Rows of joints without a velocity limit constrain nothing.

    Output ports: ``task`` (one row per joint; ``error`` is zero: the task holds no
    measure of the velocity, the solver keeps q̇ inside the bounds).

    Args:
        plant: the finalized robot model (its joints' velocity limits are used).
        joints: one-DoF joints to limit; None for all.
        scale: fraction of the model's limits to allow, in (0, 1].
        name: the task's name.
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        *,
        joints: Sequence[str] | None = None,
        scale: float = 1.0,
        name: str = "taskJointVelocityLimits",
    ) -> None:
        objs = _joints(plant, joints, f"JointVelocityLimits {name!r}")
        super().__init__(name, len(objs), [f"{unit}/s" for unit in joint_units(objs)])
        self.joint_names = tuple(j.name() for j in objs)
        self._signal = (np.zeros(len(objs)), _selection(plant, objs), *_velocity_limits(objs, scale, name))
        self._declare_task({self.nothing_ticket()})

    def _compute(self, context):
        return self._signal


class CoMInSupportPolygon(InequalityTask):
    """The CoM's ground projection kept inside the support polygon, ``margin`` from its edges.

    Row i, edge i of the polygon with inward normal ``n_i``: ``s_i = n_i · c_xy - o_i``
    (the distance inside that edge) kept ``>= margin`` by the velocity damper
    ``n_iᵀ J_com,xy q̇ >= λ (margin - s_i)``. The polygon comes from the feet in contact
    (``sole_size`` given: the convex hull of the soles' corners) or from a ``polygon``
    input. The task has a fixed number of rows (``max_vertices``); rows beyond the
    polygon's edges are zero and unbounded (they constrain nothing).

    Input ports:
        com: CoM position (3,) [m] (``RobotKinematics.com``).
        Jcom: abstract ``ndarray`` (3, nv) (``RobotKinematics.Jcom``).
        left_sole, right_sole: abstract ``RigidTransform``, sole frames in world (with
            ``sole_size``).
        contacts: optional (2,) [left, right], 1 when the foot is on the ground
            (``PatternGenerator.contacts``); both feet when unconnected (with ``sole_size``).
        polygon: abstract ``ndarray`` (k, 2), the polygon's vertices counter-clockwise
            [m], 3 <= k <= ``max_vertices`` (without ``sole_size``).
    Output ports: ``task`` (``error`` = ``s_i - margin`` where negative, else 0 [m]).

    Args:
        sole_size: (length, width) [m] of a sole centred on its frame; None to read
            the polygon from the ``polygon`` input.
        margin: distance kept from the edges [m], finite >= 0.
        gain: λ of the velocity damper [1/s], finite > 0.
        max_vertices: rows of the task (8 for two rectangular soles), >= 3.
        name: the task's name.
    """

    def __init__(
        self,
        *,
        sole_size: tuple[float, float] | None = None,
        margin: float = 0.02,
        gain: float = 5.0,
        max_vertices: int = 8,
        name: str = "taskCoMSupport",
    ) -> None:
        super().__init__(
            name, validation.positive_int(f"{name!r}: max_vertices", max_vertices, minimum=3), "m"
        )
        self._margin = validation.nonnegative(f"{name!r}: margin", margin, unit="m")
        self._gain = validation.positive(f"{name!r}: gain", gain, unit="1/s")
        self._com = self.DeclareVectorInputPort("com", 3)
        self._Jcom = self.DeclareAbstractInputPort("Jcom", AbstractValue.Make(np.zeros((3, 0))))
        if sole_size is None:
            self._sole = None
            self._polygon = self.DeclareAbstractInputPort("polygon", AbstractValue.Make(np.zeros((0, 2))))
        else:
            self._sole = tuple(validation.per_axis(f"{name!r}: sole_size", sole_size, 2, sign="positive"))
            self._feet = [
                self.DeclareAbstractInputPort(port, AbstractValue.Make(RigidTransform()))
                for port in ("left_sole", "right_sole")
            ]
            self._contacts = self.DeclareVectorInputPort("contacts", 2)
        self._declare_task({self.all_input_ports_ticket()})

    def _vertices(self, context: Context) -> np.ndarray:
        if self._sole is None:
            vertices = self._polygon.Eval(context)
        else:
            contacts = self._contacts.Eval(context) if self._contacts.HasValue(context) else (1.0, 1.0)
            poses = [port.Eval(context) for port in self._feet]
            vertices = ineq.feet_polygon(
                [(X.rotation().matrix(), X.translation()) for X in poses], contacts, self._sole
            )
        if not 3 <= len(vertices) <= self._m:
            raise RuntimeError(
                f"task {self.get_name()!r}: a support polygon of {len(vertices)} vertices; "
                f"expected 3 to {self._m} (max_vertices)"
            )
        return vertices

    def _compute(self, context):
        normals, offsets = ineq.polygon_edges(self._vertices(context))
        k = normals.shape[0]
        Jcom = self._Jcom.Eval(context)
        s = normals @ self._com.Eval(context)[:2] - offsets
        m = self._m
        error, J = np.zeros(m), np.zeros((m, Jcom.shape[1]))
        lower, upper = np.full(m, -np.inf), np.full(m, np.inf)
        error[:k] = ineq.outside(s, self._margin, np.inf)
        J[:k] = normals @ Jcom[:2]
        lower[:k], upper[:k] = ineq.velocity_bounds(s, self._margin, np.inf, self._gain)
        return error, J, lower, upper


def _unit(name: str, what: str, value) -> np.ndarray:
    v = validation.vector(f"{name!r}: {what}", value, 3)
    norm = float(np.linalg.norm(v))
    if not norm > 0.0:
        raise ValueError(f"{name!r}: {what} = {v}: must not be zero")
    return v / norm


class PointAbovePlane(InequalityTask):
    """A point of a frame (e.g. a hand's palm) kept above a plane (e.g. a table top).

    ``s = n · (p_Q - o) >= clearance`` with ``p_Q`` the point, ``n`` the plane's unit
    normal and ``o`` a point of it, by the velocity damper ``nᵀ J_Q q̇ >= λ (clearance - s)``.

    Input ports:
        position: abstract ``RigidTransform``, the frame's pose in world.
        Jq: abstract ``ndarray`` (6, nv), the frame Jacobian (rows ``[ω; v]``).
    Output ports: ``task`` (one row; ``error`` = ``s - clearance`` where negative [m]).

    Args:
        normal: the plane's normal (3,), world frame, toward the allowed side (normalised here).
        origin: a point of the plane (3,) [m].
        clearance: the least height above the plane [m] (finite; may be negative).
        offset: the point in the frame (3,) [m].
        gain: λ [1/s], finite > 0.
        name: the task's name.
    """

    def __init__(
        self,
        *,
        normal: Sequence[float] = (0.0, 0.0, 1.0),
        origin: Sequence[float] = (0.0, 0.0, 0.0),
        clearance: float = 0.0,
        offset: Sequence[float] = (0.0, 0.0, 0.0),
        gain: float = 5.0,
        name: str = "taskAbovePlane",
    ) -> None:
        super().__init__(name, 1, "m")
        self._normal = _unit(name, "normal", normal)
        self._origin = validation.vector(f"{name!r}: origin", origin, 3)
        self._clearance = validation.finite(f"{name!r}: clearance", clearance)
        self._offset = validation.vector(f"{name!r}: offset", offset, 3)
        self._gain = validation.positive(f"{name!r}: gain", gain, unit="1/s")
        self._pose = self.DeclareAbstractInputPort("position", AbstractValue.Make(RigidTransform()))
        self._J = self.DeclareAbstractInputPort("Jq", AbstractValue.Make(np.zeros((6, 0))))
        self._declare_task({self.all_input_ports_ticket()})

    def _compute(self, context):
        X = self._pose.Eval(context)
        p, Jp = ineq.point_in_frame(
            X.rotation().matrix(), X.translation(), self._J.Eval(context), self._offset
        )
        s, J = ineq.clearance_above_plane(p, Jp, self._normal, self._origin)
        lower, upper = ineq.velocity_bounds(s, self._clearance, np.inf, self._gain)
        return ineq.outside(s, self._clearance, np.inf), J, lower, upper


class DistanceAbove(InequalityTask):
    """Two bodies kept apart: the distance between a point of each above a bound.

    ``s = ||p_a - p_b|| >= minimum`` (points fixed in frames a and b; a body of radius
    ``r`` around each point is kept clear with ``minimum = r_a + r_b + margin``), by the
    velocity damper ``uᵀ (J_a - J_b) q̇ >= λ (minimum - s)``, ``u`` the unit vector from b to a.

    Input ports:
        position_a, position_b: abstract ``RigidTransform``, the frames' poses in world.
        Jq_a, Jq_b: abstract ``ndarray`` (6, nv), their Jacobians (rows ``[ω; v]``).
    Output ports: ``task`` (one row; ``error`` = ``s - minimum`` where negative [m]).

    Args:
        minimum: the least distance [m], finite > 0.
        offset_a, offset_b: the points in their frames (3,) [m].
        gain: λ [1/s], finite > 0.
        name: the task's name.
    """

    def __init__(
        self,
        *,
        minimum: float,
        offset_a: Sequence[float] = (0.0, 0.0, 0.0),
        offset_b: Sequence[float] = (0.0, 0.0, 0.0),
        gain: float = 5.0,
        name: str = "taskDistance",
    ) -> None:
        super().__init__(name, 1, "m")
        self._minimum = validation.positive(f"{name!r}: minimum", minimum, unit="m")
        self._offsets = (
            validation.vector(f"{name!r}: offset_a", offset_a, 3),
            validation.vector(f"{name!r}: offset_b", offset_b, 3),
        )
        self._gain = validation.positive(f"{name!r}: gain", gain, unit="1/s")
        self._ports = [
            (
                self.DeclareAbstractInputPort(f"position_{k}", AbstractValue.Make(RigidTransform())),
                self.DeclareAbstractInputPort(f"Jq_{k}", AbstractValue.Make(np.zeros((6, 0)))),
            )
            for k in ("a", "b")
        ]
        self._declare_task({self.all_input_ports_ticket()})

    def _compute(self, context):
        points = []
        for (pose, jacobian), offset in zip(self._ports, self._offsets, strict=True):
            X = pose.Eval(context)
            points.append(
                ineq.point_in_frame(X.rotation().matrix(), X.translation(), jacobian.Eval(context), offset)
            )
        s, J = ineq.point_distance(*points[0], *points[1])
        lower, upper = ineq.velocity_bounds(s, self._minimum, np.inf, self._gain)
        return ineq.outside(s, self._minimum, np.inf), J, lower, upper
