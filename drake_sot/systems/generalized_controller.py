"""``GeneralizedHierarchyController``: torque-level hierarchical motion and force control
(Liu, Lober, Padois 2016): priority matrices, generalized projectors, the quasi-static QP.

What the torque family takes from a foundation ``Task`` — the one place this is stated:
the task's name, its error ``e = s − s*`` and its Jacobian ``J``. It does **not** use the
task's desired error rate ``ė* = −λ e + feed-forward``: neither the gain λ (the Task's
``gain`` parameter or input) nor the features' feed-forward of a moving reference. A
motion task's desired wrench is eq. 2 with its :class:`MotionTask`'s own ``kp`` and
``kd``, a force task's eq. 3 with its :class:`ForceTask`'s ``kp`` and ``ki``
(:mod:`drake_sot.task_wrenches`, which also states the sign convention of the errors);
a moving reference is followed with the lag of that PD. One Task can so feed both the
kinematic SoT (which uses λ) and this controller (which does not).

Status is not success. At each tick the controller says what it did, a
:class:`~drake_sot.quasistatic.SolveStatus`, on ``status`` (its ``code``) and in the ``report``:

- OPTIMAL (0): the QP is optimal and every goal-directed task got its desired
  wrench ``w^d`` to within the shortfall threshold;
- SHORT (1): the QP is optimal, but the constraints (torque bounds, friction
  cones, minimum normal forces, the base's equilibrium) kept at least one goal task from
  its desired wrench: its *relative shortfall* ``‖w* − w^d‖ / max(‖w^d‖, wrench_floor)``
  exceeds ``shortfall_threshold`` (defaults :data:`SHORTFALL_THRESHOLD` = 0.1 and
  :data:`WRENCH_FLOOR` = 1 N or N·m). The report names those tasks and their shortfalls.
  Why 10 %: in the feasible scenarios (``table_pounding``, ``priority_switching``) the
  goal tasks stay within ~1 % of their desired wrenches (what the contact forces'
  regularisation ω_r trades), so 10 % is ten times that noise, while a bound that really
  holds a task back cuts much more;
- INFEASIBLE (2) / FAILED (3): the QP has no solution (or the
  solver failed); the controller applies its fallback — gravity compensation on the
  contacts plus a posture PD — *saturated at the torque bounds*: ``saturation`` and the
  report say which joints were cut and by how much. No commanded torque ever exceeds its
  bound.

The QP's own torques are clipped to the bounds too: the QP's check accepts them only
within 1e-6 N·m of the bounds, so this clipping is below that tolerance.

At construction the controller checks that its contacts and torque bounds can hold the
robot still in ``q_posture`` with no goal task (:func:`drake_sot.quasistatic.static_capacity`);
if they cannot, it refuses to be built and names the bound (the effort limits of the
joints too weak and what they need, or the minimum normal force).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, ModelInstanceIndex
from pydrake.systems.framework import Context, DiscreteValues

from drake_sot.generalized import ProjectedJacobians, fallback_torques, inertia_weighted, relative_shortfall
from drake_sot.quasistatic import FrictionCone, QsTask, QuasiStaticQP, SolveStatus, static_capacity
from drake_sot.signals import TaskSignal
from drake_sot.systems.kinematics import momentum_rows
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.systems.task import Task
from drake_sot.task_wrenches import pd_wrench, pi_force_wrench
from drake_sot.transitions import Priorities
from drake_sot.validation import matrix, nonnegative, per_axis, positive, positive_int, vector

#: The controller's vector output ports (held in its discrete state), in declaration order.
VECTOR_OUTPUTS = (
    "tau",
    "wrenches",
    "desired_wrenches",
    "errors",
    "shortfall",
    "contact_forces",
    "status",
    "saturation",
)
#: Default relative shortfall above which a goal task counts as short.
SHORTFALL_THRESHOLD = 0.1
#: Default floor [N or N·m] of the desired wrench's norm in the relative shortfall.
WRENCH_FLOOR = 1.0


def _goal_task(what: str, task: Task) -> None:
    """Refuse what is not a foundation ``Task`` with at least one row."""
    if not isinstance(task, Task):
        raise TypeError(f"{what}.task must be a drake_sot Task, got {type(task).__name__}")
    if task.dimension < 1:
        raise ValueError(f"{what}: task {task.get_name()!r} has no feature (dimension 0): add() one first")


@dataclass(frozen=True)
class MotionTask:
    """A goal-directed task fed by a foundation ``Task`` (error e = s − s*, Jacobian J):
    its desired wrench is the PD of eq. 2 with the gain matrices ``K_P = k_p Λ`` and
    ``K_D = k_d Λ``, ``Λ = (J M⁻¹ Jᵀ)⁺`` the task-space inertia:
    ``w^d = Λ · pd_wrench(e, J v, k_p, k_d) = Λ (−k_p e − k_d J v)``.

    ``kp`` [1/s²] and ``kd`` [1/s] (finite, >= 0) are thus the task's own stiffness and
    damping per unit of inertia (ω = √kp): the same gains suit a hand and a light gripper
    joint, and the control period's zero-order hold stays stable (kd·dt ≪ 2) on every
    direction. The Task's λ and feed-forward are not used (module docstring).
    """

    task: Task
    kp: float
    kd: float

    def __post_init__(self) -> None:
        what = f"MotionTask({getattr(self.task, 'get_name', lambda: '?')()!r})"
        _goal_task(what, self.task)
        object.__setattr__(self, "kp", nonnegative(f"{what}.kp", self.kp, unit="1/s²"))
        object.__setattr__(self, "kd", nonnegative(f"{what}.kd", self.kd, unit="1/s"))


@dataclass(frozen=True)
class ForceTask:
    """A goal-directed wrench task (eq. 3) along the rows of a foundation ``Task``'s
    Jacobian: ``w^d = w* − K_P e_w − K_I ∫ e_w dt`` with ``e_w = w_measured − w*``
    (:func:`drake_sot.task_wrenches.pi_force_wrench`; its integral advances in proportion
    to ``1 − α_ii`` and is reset when the controller falls back). ``kp`` (dimensionless)
    and ``ki`` [1/s] finite, >= 0. Only the Task's Jacobian rows are used (module docstring).
    """

    task: Task
    kp: float
    ki: float

    def __post_init__(self) -> None:
        what = f"ForceTask({getattr(self.task, 'get_name', lambda: '?')()!r})"
        _goal_task(what, self.task)
        object.__setattr__(self, "kp", nonnegative(f"{what}.kp", self.kp))
        object.__setattr__(self, "ki", nonnegative(f"{what}.ki", self.ki, unit="1/s"))


@dataclass(frozen=True)
class ContactPoints:
    """Non-goal-directed contact tasks: one 3-D force per point of a frame (the sole
    corners), inside a linearised friction cone; their projectors are the identity.

    Attributes:
        frame: the frame's name in the controller's plant.
        points: (k, 3) [m] the points in that frame (k >= 1).
        mu: friction coefficient (finite, >= 0). facets: of the inscribed pyramid (>= 3).
        min_normal_force: [N] per point (finite, >= 0).
    """

    frame: str
    points: np.ndarray
    mu: float = 0.8
    facets: int = 4
    min_normal_force: float = 0.0

    def __post_init__(self) -> None:
        what = f"ContactPoints({self.frame!r})"
        if not isinstance(self.frame, str):
            raise TypeError(f"ContactPoints.frame must be a frame name, got {self.frame!r}")
        points = matrix(f"{what}.points", np.atleast_2d(np.asarray(self.points, dtype=float)), (None, 3))
        if not points.shape[0]:
            raise ValueError(f"{what}.points: needs at least one point")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "mu", nonnegative(f"{what}.mu", self.mu))
        object.__setattr__(self, "facets", positive_int(f"{what}.facets", self.facets, minimum=3))
        object.__setattr__(
            self, "min_normal_force", nonnegative(f"{what}.min_normal_force", self.min_normal_force, unit="N")
        )


@dataclass(frozen=True)
class TaskWrench:
    """One goal-directed task at one tick.

    Attributes:
        desired: (m,) ``w^d`` its law asks for (eq. 2 or 3) [N, N·m].
        achieved: (m,) ``w*`` the QP gave it (NaN when the controller fell back).
        error: (m,) its error (motion: ``s − s*`` [m, rad]; force: ``w_measured − w*`` [N]).
        shortfall: ``‖w* − w^d‖ / max(‖w^d‖, wrench_floor)`` (NaN on fallback).
    """

    desired: np.ndarray
    achieved: np.ndarray
    error: np.ndarray
    shortfall: float


@dataclass(frozen=True)
class ControllerReport:
    """What the controller did at its last tick: the ``report`` output.

    Attributes:
        status: how the tick's solve ended (module docstring).
        tasks: task name → :class:`TaskWrench`, every goal-directed task.
        short: ``(task, shortfall)`` of the tasks above the threshold, largest first.
        saturated: ``(actuated joint, cut [N·m])`` on fallback: the torque the fallback
            wanted minus the bound it was held to, for each joint it exceeded.
        threshold: the shortfall threshold in force.
    """

    status: SolveStatus
    tasks: Mapping[str, TaskWrench]
    short: tuple[tuple[str, float], ...]
    saturated: tuple[tuple[str, float], ...]
    threshold: float

    @property
    def fallback(self) -> bool:
        """True when the QP had no answer and the fallback torque was applied."""
        return self.status.fallback

    def summary(self) -> str:
        """One line: ``"optimal"``, ``"short: taskCom 87 %, ..."`` or ``"infeasible → fallback
        (saturated: r_knee by 12.3 N·m, ...)"``."""
        if self.status is SolveStatus.SHORT:
            return "short: " + ", ".join(f"{name} {100 * value:.0f} %" for name, value in self.short)
        if self.fallback:
            cut = ", ".join(f"{joint} by {value:+.3g} N·m" for joint, value in self.saturated)
            return f"{self.status.value} → fallback" + (f" (saturated: {cut})" if cut else "")
        return self.status.value


def _gravity_rows(plant: MultibodyPlant) -> tuple[slice, np.ndarray] | None:
    """``(rows, w)`` with ``-τ_g(q) = w M(q)[rows]`` (the generalized force gravity exerts, on the
    left of eq. 1), or None (then Drake's gravity forces are used).

    Gravity is uniform, so ``τ_g = Σ m_i J_iᵀ g = (m J_com)ᵀ g`` (J_i the Jacobian of body i's
    centre of mass), and ``m J_com`` is three rows of M on a floating base that carries every
    moving body (:func:`~drake_sot.systems.kinematics.momentum_rows`): with M computed anyway
    for the task-space inertias, one (3,)·(3, nv) product instead of Drake's gravity forces.
    None when those rows do not exist or gravity is switched off for some model instance.
    """
    rows = momentum_rows(plant)
    field = plant.gravity_field()
    if rows is None or not all(
        field.is_enabled(ModelInstanceIndex(i)) for i in range(plant.num_model_instances())
    ):
        return None
    return rows, -np.asarray(field.gravity_vector(), dtype=float)


class GeneralizedHierarchyController(SotLeafSystem):
    """Joint torques from prioritised motion and force tasks (Liu, Lober, Padois 2016,
    eq. 8-11).

    At each control tick the goal-directed tasks' wrenches and the contact forces are the
    variables of the quasi-static QP (eq. 9: goal-directed tasks tracked, contacts
    regularised, static equilibrium of the floating base, friction cones, torque
    bounds); each goal-directed task's Jacobian is modulated by its generalized
    projector ``P_i(A_i)`` (eq. 8) built from row i of the priority matrix; the torques
    are ``τ = Σ P_i J_iᵀ w_i* + g`` (eq. 10). If the QP is infeasible or fails, the
    controller falls back to a safe torque — gravity compensation on the contacts plus
    a posture PD, saturated at the torque bounds — and says so. With ``weighted=True``
    it is the weighted baseline of eq. 5-7. Status, shortfall and saturation: see the
    module docstring.

    Making one leaves the process's BLAS threads as they are: with OpenBLAS's default threads
    the update is many times slower on a loaded machine (``benchmarks/README.md``), so the
    front-ends (the command line, serving, the study workers) call
    :func:`drake_sot.blas.limit_blas_threads` when they start a run; a notebook decides for itself.

    The goal-directed tasks are named (their Tasks' names); :attr:`task_names` is their
    order in the concatenated outputs (motion tasks, then force tasks, as given), and
    :meth:`error_slices` says where each one lies. Priorities arrive by name and are
    permuted into that order every tick.

    Input ports:
        state: measured plant state ``[q; v]`` (nq + nv) in ``plant``'s layout.
        <task name>: one per motion and force task, abstract ``TaskSignal`` (a foundation
            ``Task``'s output: its error and Jacobian are used).
        priorities: abstract :class:`~drake_sot.transitions.Priorities` (α with its task
            names, e.g. ``PrioritySchedule.priorities``), over exactly this controller's
            goal-directed tasks, in any order; checked every tick (an unknown or missing
            name raises ValueError listing the known ones).
        <force task>_desired, <force task>_measured: (m,) the wrench [N] the robot
            should apply / applies on the environment along the task's rows.
    Output ports:
        tau: joint torques (na,) [N·m], actuator order (the plant's actuation input);
            always within the torque bounds.
        wrenches: (Σ m_i,) the goal-directed tasks' achieved wrenches w* [N, N·m],
            concatenated in :attr:`task_names` order (NaN on fallback).
        desired_wrenches: (Σ m_i,) their desired wrenches w^d (eq. 2-3), same layout.
        errors: (Σ m_i,) their errors, same layout: e = s − s* for motion tasks [m, rad],
            w_measured − w* for force tasks [N].
        shortfall: (n_t,) each goal task's relative shortfall ‖w* − w^d‖ / max(‖w^d‖,
            wrench_floor), :attr:`task_names` order (NaN on fallback).
        contact_forces: (3·k,) [N] ground forces on the robot at the contact points, world.
        status: (1,) the :class:`~drake_sot.quasistatic.SolveStatus` code: OPTIMAL 0, SHORT 1,
            INFEASIBLE 2, FAILED 3 (2 and 3: fallback).
        saturation: (na,) [N·m] actuator order: on fallback, the torque wanted minus the
            torque commanded (nonzero where a bound cut it); 0 when the QP answered.
        report: abstract :class:`ControllerReport`: all of the above by task and joint name.
        stack: abstract ``tuple[str, ...]`` for a ``StackHistory``: the active goal tasks
            (α_ii < 1 in the current priorities) from the highest priority (least
            Σ_j≠i α_ij) down, then (from the last tick)
            ``short:<task>`` per short task, ``fallback:<infeasible|failed>`` and
            ``saturated:<joint>`` while they hold.

    Args:
        plant: the controller's robot model (finalized; one free flyer first, or fixed base).
        actuated_joints: joint names in actuator order.
        motion_tasks, force_tasks, contacts: see the dataclasses; task names are unique.
        q_posture: (nq,) the fallback posture, also where the weight is checked at
            construction.
        period: control period [s] (> 0). weighted: the eq. 5-7 baseline (ω_t from ``weights``,
            each > 0).
        regularization: ω_r of the contact forces (> 0).
        fallback_gains: (kp, kd) of the fallback posture PD [N·m/rad, N·m·s/rad] (>= 0).
        effort_limits: (na,) or scalar torque bounds [N·m] in actuator order (eq. 11),
            each > 0 or +inf; default the model's actuator effort limits.
        shortfall_threshold: relative shortfall above which a task is short (> 0).
        wrench_floor: [N or N·m] floor of ‖w^d‖ in the relative shortfall (> 0).

    Raises:
        ValueError: a bad argument (named), or contacts and torque bounds that cannot hold
            the robot at ``q_posture`` (the message names the bound).
    """

    def __init__(
        self,
        plant: MultibodyPlant,
        actuated_joints: Sequence[str],
        *,
        motion_tasks: Sequence[MotionTask],
        force_tasks: Sequence[ForceTask] = (),
        contacts: Sequence[ContactPoints] = (),
        q_posture: np.ndarray,
        period: float = 0.005,
        weighted: bool = False,
        weights: dict[str, float] | None = None,
        regularization: float = 1e-4,
        fallback_gains: tuple[float, float] = (200.0, 10.0),
        effort_limits: np.ndarray | float | None = None,
        shortfall_threshold: float = SHORTFALL_THRESHOLD,
        wrench_floor: float = WRENCH_FLOOR,
        name: str = "generalized_controller",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._plant = plant
        self._plant_context = plant.CreateDefaultContext()
        self._world = plant.world_frame()  # kept: each call of world_frame() makes a new binding
        self._gravity_rows = _gravity_rows(plant)
        nq, nv, na = plant.num_positions(), plant.num_velocities(), len(actuated_joints)
        self._nq, self._nv, self._na = nq, nv, na
        self._n_base = nv - na
        if self._n_base not in (0, 6):
            raise ValueError(
                f"{nv} velocities for {na} actuated joints: expected a fixed base or one free flyer"
            )
        unknown = [j for j in actuated_joints if not plant.HasJointNamed(j)]
        if unknown:
            raise ValueError(f"actuated_joints: no joint named {unknown} in the plant")
        self._actuated = tuple(actuated_joints)
        joints = [plant.GetJointByName(j) for j in actuated_joints]
        self._v_act = np.array([j.velocity_start() for j in joints], dtype=int)  # actuator k -> v index
        self._q_act = np.array([j.position_start() for j in joints], dtype=int)
        effort = per_axis(
            "effort_limits",
            [plant.GetJointActuatorByName(j).effort_limit() for j in actuated_joints]
            if effort_limits is None
            else effort_limits,
            na,
            sign="positive",
            allow_inf=True,
        )
        self._period = positive("period", period, unit="s")
        self._regularization = positive("regularization", regularization)
        if len(fallback_gains) != 2:
            raise ValueError(f"fallback_gains = {fallback_gains!r}: must be a pair (kp, kd)")
        self._fallback_gains = (
            nonnegative("fallback_gains[0] (kp)", fallback_gains[0], unit="N·m/rad"),
            nonnegative("fallback_gains[1] (kd)", fallback_gains[1], unit="N·m·s/rad"),
        )
        self._threshold = positive("shortfall_threshold", shortfall_threshold)
        self._floor = positive("wrench_floor", wrench_floor, unit="N or N·m")
        self._q_posture = vector("q_posture", q_posture, nq)
        self._motion, self._force = list(motion_tasks), list(force_tasks)
        for what, items, kind in (
            ("motion_tasks", self._motion, MotionTask),
            ("force_tasks", self._force, ForceTask),
        ):
            bad = [type(t).__name__ for t in items if not isinstance(t, kind)]
            if bad:
                raise TypeError(f"{what} must hold {kind.__name__}s, got {bad}")
        goals = [t.task for t in self._motion] + [t.task for t in self._force]
        if not goals:
            raise ValueError(
                "motion_tasks and force_tasks are both empty: needs at least one goal-directed task"
            )
        self._names = tuple(t.get_name() for t in goals)
        if len(set(self._names)) != len(self._names):
            raise ValueError(f"task names must be unique: {list(self._names)}")
        self._dims = [t.dimension for t in goals]
        ends = np.cumsum(self._dims).tolist()
        self._slices = {n: slice(e - m, e) for n, e, m in zip(self._names, ends, self._dims, strict=True)}
        self._starts = np.array([e - m for e, m in zip(ends, self._dims, strict=True)], dtype=int)
        motion_dims = self._dims[: len(self._motion)]
        self._kp_rows = np.repeat([t.kp for t in self._motion], motion_dims)
        self._kd_rows = np.repeat([t.kd for t in self._motion], motion_dims)
        self._motion_slices = list(self._slices.values())[: len(self._motion)]
        self._motion_rows = sum(motion_dims)
        self._motion_blocks = scipy.linalg.block_diag(*[np.ones((m, m)) for m in motion_dims]) > 0.0
        self._jacobians = np.empty((sum(self._dims), nv))  # the goal tasks' J_i, stacked, every tick
        self._projected = ProjectedJacobians(self._dims)
        self._contacts = list(contacts)
        self._contact_frames = []
        for c in self._contacts:
            if not plant.HasFrameNamed(c.frame):
                raise ValueError(f"ContactPoints({c.frame!r}): no frame of that name in the plant")
            self._contact_frames.append(plant.GetFrameByName(c.frame))
        self._contact_offsets = [c.points.T for c in self._contacts]  # (3, k)
        cones = [
            FrictionCone(mu=c.mu, facets=c.facets, min_normal_force=c.min_normal_force)
            for c in self._contacts
        ]
        # One 3-D contact force task per point: (name, cone), in the order of the stacked Jacobian rows.
        self._contact_points = [
            (f"contact{k}_{p}", cone)
            for k, (c, cone) in enumerate(zip(self._contacts, cones, strict=True))
            for p in range(len(c.points))
        ]
        self._weights = {n: positive(f"weights[{n!r}]", w) for n, w in (weights or {}).items()}
        unknown = sorted(set(self._weights) - set(self._names))
        if unknown:
            raise ValueError(f"weights for unknown tasks {unknown}; tasks: {list(self._names)}")
        self._weighted = bool(weighted)
        self._rank_threshold = 1e-8
        self._tau_v = np.empty(na)  # effort limits in the v order of the actuated rows
        self._tau_v[self._v_act - self._n_base] = effort
        self._qp = QuasiStaticQP(nv, self._n_base, tau_min=-self._tau_v, tau_max=self._tau_v)
        self._check_static_capacity()
        # The QP's tasks never change (α changes their rows, not their set): its structure once.
        self._stacked = self._qp.stacked(
            [
                QsTask(name, np.zeros((m, nv)), desired=np.zeros(m), weight=self._weights.get(name, 1.0))
                for name, m in zip(self._names, self._dims, strict=True)
            ]
            + [
                QsTask(name, np.zeros((3, nv)), weight=self._regularization, friction=cone)
                for name, cone in self._contact_points
            ],
            weighted=self._weighted,
        )

        self._state = self.DeclareVectorInputPort("state", nq + nv)
        empty = TaskSignal("", np.zeros(0), np.zeros((0, nv)), np.zeros(0))
        self._task_ports = [self.DeclareAbstractInputPort(n, AbstractValue.Make(empty)) for n in self._names]
        n_t = len(self._names)
        self._priorities = self.DeclareAbstractInputPort(
            "priorities", AbstractValue.Make(Priorities(self._names, np.zeros((n_t, n_t))))
        )
        self._force_ports = [
            (
                self.DeclareVectorInputPort(f"{t.task.get_name()}_desired", t.task.dimension),
                self.DeclareVectorInputPort(f"{t.task.get_name()}_measured", t.task.dimension),
            )
            for t in self._force
        ]
        force_dims = self._dims[len(self._motion) :]
        self._kp_force = np.repeat([t.kp for t in self._force], force_dims)
        self._ki_force = np.repeat([t.ki for t in self._force], force_dims)
        m_total = sum(self._dims)
        n_contact = len(self._contact_points)
        sizes = {
            "tau": na,
            "wrenches": m_total,
            "desired_wrenches": m_total,
            "errors": m_total,
            "shortfall": n_t,
            "contact_forces": 3 * n_contact,
            "status": 1,
            "saturation": na,
        }
        self._x = {name: self.DeclareDiscreteState(sizes[name]) for name in VECTOR_OUTPUTS}
        self._x_integral = self.DeclareDiscreteState(max(sum(t.task.dimension for t in self._force), 1))
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        for port_name, index in self._x.items():
            self.DeclareStateOutputPort(port_name, index)
        self.DeclareAbstractOutputPort(
            "report",
            lambda: AbstractValue.Make(ControllerReport(SolveStatus.OPTIMAL, {}, (), (), 0.0)),
            self._calc_report,
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclareAbstractOutputPort(
            "stack",
            lambda: AbstractValue.Make(()),
            self._calc_stack,
            prerequisites_of_calc={self.xd_ticket(), self.input_port_ticket(self._priorities.get_index())},
        )

    @property
    def task_names(self) -> tuple[str, ...]:
        """The goal-directed tasks, in the order of the concatenated outputs: motion tasks
        then force tasks, as given."""
        return self._names

    @property
    def actuated_joints(self) -> tuple[str, ...]:
        """The actuated joints, in the order of ``tau`` and ``saturation``."""
        return self._actuated

    def error_slices(self) -> dict[str, slice]:
        """Task name → its slice of ``errors``, ``wrenches`` and ``desired_wrenches``."""
        return dict(self._slices)

    # --- construction-time check ---------------------------------------------------------
    def _check_static_capacity(self) -> None:
        """Refuse contacts and torque bounds that cannot hold the robot at ``q_posture``."""
        plant, pc = self._plant, self._plant_context
        plant.SetPositions(pc, self._q_posture)
        plant.SetVelocities(pc, np.zeros(self._nv))
        g = -plant.CalcGravityGeneralizedForces(pc)
        jacobians = self._contact_jacobians()
        contacts = [
            QsTask(name, jacobians[3 * p : 3 * p + 3], weight=self._regularization, friction=cone)
            for p, (name, cone) in enumerate(self._contact_points)
        ]
        capacity = static_capacity(
            contacts, g, n_base=self._n_base, tau_min=-self._tau_v, tau_max=self._tau_v
        )
        if capacity.feasible:
            return
        weight = plant.CalcTotalMass(pc) * float(np.linalg.norm(plant.gravity_field().gravity_vector()))
        if not capacity.contacts_hold:
            pressed = sum(c.min_normal_force * len(c.points) for c in self._contacts)
            if pressed > weight:
                per_point = ", ".join(f"{c.frame}: {c.min_normal_force:g} N" for c in self._contacts)
                raise ValueError(
                    f"min_normal_force per point ({per_point}) over {len(self._contact_points)} points "
                    f"({pressed:.0f} N) exceeds the robot's weight ({weight:.0f} N): the contacts cannot "
                    "hold the robot at q_posture"
                )
            frames = ", ".join(c.frame for c in self._contacts) or "none"
            raise ValueError(
                f"the contacts (frames: {frames}) cannot hold the robot's weight ({weight:.0f} N) at "
                f"q_posture: {capacity.message}"
            )
        rows = sorted(capacity.exceeded, key=lambda r: -abs(capacity.tau[r]) / self._tau_v[r])
        act = {int(v) - self._n_base: k for k, v in enumerate(self._v_act)}  # v row -> actuator
        joints = ", ".join(
            f"{self._actuated[act[r]]} (needs ~{abs(capacity.tau[r]):.3g} N·m, "
            f"limit {self._tau_v[r]:.3g} N·m)"
            for r in rows
        )
        raise ValueError(
            f"effort limits cannot hold the robot's weight ({weight:.0f} N) at q_posture: the torque "
            f"bounds would need to be {capacity.scale:.3g} times larger; the static torques there exceed "
            f"the effort limits of {joints}"
        )

    # --- one control tick -------------------------------------------------------------
    def _alpha(self, context: Context) -> np.ndarray:
        """α (n_t, n_t) in :attr:`task_names` order, from the priorities checked by name."""
        priorities = self._priorities.Eval(context)
        if not isinstance(priorities, Priorities):
            raise TypeError(
                f"{self.get_name()!r}: input port 'priorities' carries a {type(priorities).__name__}, "
                "not a drake_sot.transitions.Priorities (plug PrioritySchedule.priorities)"
            )
        if priorities.task_names == self._names:
            return priorities.alpha
        return priorities.in_order(self._names)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        x = self._state.Eval(context)
        q, v = x[: self._nq], x[self._nq :]
        plant, pc = self._plant, self._plant_context
        plant.SetPositionsAndVelocities(pc, x)
        M = None
        if self._gravity_rows is None:
            g = -plant.CalcGravityGeneralizedForces(pc)  # gravity as on the left of eq. 1
        else:  # the same from the mass matrix, needed anyway (_gravity_rows)
            momentum, weight = self._gravity_rows
            M = plant.CalcMassMatrix(pc)
            g = weight @ M[momentum]
        alpha = self._alpha(context)
        signals = [port.Eval(context) for port in self._task_ports]
        jacobians = np.concatenate([s.jacobian for s in signals], out=self._jacobians)
        errors = np.concatenate([s.error for s in signals])
        desired = np.empty(errors.size)
        if self._motion:
            # eq. 2 with K_P = k_p Λ, K_D = k_d Λ: w^d = Λ pd_wrench(e, J v), all motion tasks at once.
            rows = self._motion_rows
            J_motion = jacobians[:rows]
            a = pd_wrench(errors[:rows], J_motion @ v, self._kp_rows, self._kd_rows, validate=False)
            if M is None:
                M = plant.CalcMassMatrix(pc)
            desired[:rows] = inertia_weighted(
                J_motion, self._motion_slices, M, a, self._motion_blocks, self._rank_threshold
            )
        integral = context.get_discrete_state(self._x_integral).get_value().copy()
        if self._force:
            # eq. 3 for all force tasks at once; the integral advances by 1 − α_ii (no wind-up off).
            w_star = np.concatenate([port.Eval(context) for port, _ in self._force_ports])
            w_meas = np.concatenate([port.Eval(context) for _, port in self._force_ports])
            if not math.isfinite(w_star.sum() + w_meas.sum()):
                self._raise_nonfinite_force(context)
            n_motion = len(self._motion)
            activity = np.repeat(1.0 - alpha.diagonal()[n_motion:], self._dims[n_motion:])
            step = pi_force_wrench(
                w_star,
                w_meas,
                integral,
                self._period,
                self._kp_force,
                self._ki_force,
                activity=activity,
                validate=False,
            )
            integral = step.integral
            desired[self._motion_rows :] = step.wrench
            errors[self._motion_rows :] = step.error
        # Each goal task enters the QP through J_i P_i (eq. 9-10: P_i J_iᵀ w_i, P_i symmetric), formed
        # without the (nv, nv) projectors, then the contact points' rows. The QP checks every row for
        # NaN and names the task: no second check here.
        rows = self._stacked.rows
        goal_rows = desired.size
        if self._weighted:
            rows[:goal_rows] = jacobians
        else:
            self._projected(jacobians, alpha, rows[:goal_rows])
        contact_jacobians = self._contact_jacobians(rows[goal_rows:])
        solution = self._stacked.solve(rows, desired, g)
        saturation = np.zeros(self._na)
        if solution.status is SolveStatus.OPTIMAL:
            # Within the QP check's 1e-6 N·m of the bounds: hold them exactly.
            tau_v = np.clip(solution.tau, -self._tau_v, self._tau_v)
            wrenches = np.concatenate([solution.wrenches[n] for n in self._names])
            # The contact task's wrench is what the robot applies on the ground:
            # the ground's force is its opposite.
            contact = (
                -np.concatenate([solution.wrenches[name] for name, _ in self._contact_points])
                if self._contacts
                else np.zeros(0)
            )
            shortfall = relative_shortfall(wrenches, desired, self._starts, self._floor)
            status = SolveStatus.SHORT if (shortfall > self._threshold).any() else SolveStatus.OPTIMAL
        else:
            qa, va = self._q_act, self._v_act
            tau_v, cut = fallback_torques(
                g,
                contact_jacobians,
                self._n_base,
                va - self._n_base,
                self._q_posture[qa] - q[qa],
                v[va],
                self._fallback_gains,
                self._tau_v,
            )
            saturation = cut[va - self._n_base]
            wrenches = np.full(desired.size, np.nan)
            shortfall = np.full(len(self._names), np.nan)
            contact = np.zeros(3 * len(self._contact_points))
            status = solution.status
            integral[:] = 0.0  # the force tasks do not act: no wind-up (task_wrenches' policy)
        for port_name, value in (
            ("tau", tau_v[self._v_act - self._n_base]),
            ("wrenches", wrenches),
            ("desired_wrenches", desired),
            ("errors", errors),
            ("shortfall", shortfall),
            ("contact_forces", contact),
            ("status", np.array([status.code])),
            ("saturation", saturation),
        ):
            discrete_state.set_value(self._x[port_name], value)  # one binding call, not two
        discrete_state.set_value(self._x_integral, integral)

    def _calc_stack(self, context: Context, value: AbstractValue) -> None:
        alpha = self._alpha(context)
        diagonal = alpha.diagonal()
        rank = np.where(diagonal < 1.0, alpha.sum(axis=1) - diagonal, np.inf)  # inf: deactivated
        status = SolveStatus.of_code(context.get_discrete_state(self._x["status"]).get_value()[0])
        shortfall = context.get_discrete_state(self._x["shortfall"]).get_value()
        saturation = context.get_discrete_state(self._x["saturation"]).get_value()
        active = sorted((k for k in range(len(self._names)) if math.isfinite(rank[k])), key=lambda k: rank[k])
        tokens = [self._names[k] for k in active]
        tokens += [
            f"short:{n}" for n, short in zip(self._names, shortfall > self._threshold, strict=True) if short
        ]
        if status.fallback:
            tokens.append(f"fallback:{status.value}")
        tokens += [f"saturated:{j}" for j, cut in zip(self._actuated, saturation, strict=True) if cut]
        value.set_value(tuple(tokens))

    def _raise_nonfinite_force(self, context: Context) -> None:
        for port in (p for pair in self._force_ports for p in pair):
            if not np.isfinite(port.Eval(context)).all():
                raise ValueError(f"{self.get_name()!r}: input {port.get_name()!r} contains NaN or Inf")

    def _calc_report(self, context: Context, value: AbstractValue) -> None:
        get = {name: context.get_discrete_state(index).get_value() for name, index in self._x.items()}
        tasks = {
            name: TaskWrench(
                desired=get["desired_wrenches"][sl].copy(),
                achieved=get["wrenches"][sl].copy(),
                error=get["errors"][sl].copy(),
                shortfall=float(get["shortfall"][k]),
            )
            for k, (name, sl) in enumerate(self._slices.items())
        }
        short = sorted(
            ((name, t.shortfall) for name, t in tasks.items() if t.shortfall > self._threshold),
            key=lambda item: -item[1],
        )
        saturated = tuple(
            (joint, float(cut)) for joint, cut in zip(self._actuated, get["saturation"], strict=True) if cut
        )
        value.set_value(
            ControllerReport(
                status=SolveStatus.of_code(get["status"][0]),
                tasks=tasks,
                short=tuple(short),
                saturated=saturated,
                threshold=self._threshold,
            )
        )

    def _contact_jacobians(self, out: np.ndarray | None = None) -> np.ndarray:
        """(3·k, nv): the translational Jacobians of all the contact points, stacked (world), written
        into ``out`` when given (and returned)."""
        plant, pc, world = self._plant, self._plant_context, self._world
        if out is None:
            out = np.empty((3 * len(self._contact_points), self._nv))
        begin = 0
        for points, frame in zip(self._contact_offsets, self._contact_frames, strict=True):
            end = begin + 3 * points.shape[1]
            out[begin:end] = plant.CalcJacobianTranslationalVelocity(
                pc, JacobianWrtVariable.kV, frame, points, world, world
            )
            begin = end
        return out
