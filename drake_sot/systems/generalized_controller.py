"""``GeneralizedHierarchyController``: torque-level hierarchical motion and force control
(Liu, Lober, Padois 2016): priority matrices, generalized projectors, the quasi-static QP."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.framework import Context, DiscreteValues, LeafSystem

from drake_sot.hierarchy import generalized_projectors
from drake_sot.linalg import pinv
from drake_sot.quasistatic import FrictionCone, QsTask, QuasiStaticQP
from drake_sot.signals import TaskSignal
from drake_sot.statics import contact_torques
from drake_sot.systems.task import Task

#: ``status`` output values.
STATUS_OPTIMAL, STATUS_INFEASIBLE, STATUS_FAILED = 0.0, 1.0, 2.0

_POTRF, _POTRS = scipy.linalg.lapack.dpotrf, scipy.linalg.lapack.dpotrs  # Cholesky factor / solve
_TRTRS = scipy.linalg.lapack.dtrtrs  # triangular solve
#: Smallest squared relative Cholesky pivot for which a task's rows count as independent.
_INDEPENDENT = 1e-10


@dataclass(frozen=True)
class MotionTask:
    """A goal-directed task fed by a foundation ``Task`` (error e = s − s*, Jacobian J):
    its desired wrench is the PD of eq. 2 with the gain matrices ``K_P = k_p Λ`` and
    ``K_D = k_d Λ``, ``Λ = (J M⁻¹ Jᵀ)⁺`` the task-space inertia: ``w^d = Λ (−k_p e − k_d J v)``.

    ``kp`` [1/s²] and ``kd`` [1/s] are thus the task's own stiffness and damping per unit
    of inertia (ω = √kp): the same gains suit a hand and a light gripper joint, and the
    control period's zero-order hold stays stable (kd·dt ≪ 2) on every direction.
    """

    task: Task
    kp: float
    kd: float


@dataclass(frozen=True)
class ForceTask:
    """A goal-directed wrench task (eq. 3) along the rows of a foundation ``Task``'s
    Jacobian: ``w^d = w* + K_P e_w + K_I ∫ e_w dt`` with ``e_w = w* − w_measured``."""

    task: Task
    kp: float
    ki: float


@dataclass(frozen=True)
class ContactPoints:
    """Non-goal-directed contact tasks: one 3-D force per point of a frame (the sole
    corners), inside a linearised friction cone; their projectors are the identity."""

    frame: str
    points: np.ndarray  # (k, 3) in the frame [m]
    mu: float = 0.8
    facets: int = 4
    min_normal_force: float = 0.0  # [N] per point


def _task_inertia(J: np.ndarray, M_inv: np.ndarray, rank_threshold: float) -> np.ndarray:
    """Λ = (J M⁻¹ Jᵀ)⁺ (m, m) by the pseudo-inverse; rows of J that are zero (an inactive
    joint-limit row) get zero."""
    rows = np.flatnonzero(J.any(axis=1))
    task_inertia = np.zeros((J.shape[0], J.shape[0]))
    if rows.size:
        Jr = J[rows]
        task_inertia[np.ix_(rows, rows)] = pinv(Jr @ M_inv @ Jr.T, rank_threshold)
    return task_inertia


def _inertia_weighted(
    J: np.ndarray,
    tasks: Sequence[slice],
    M: np.ndarray,
    accelerations: np.ndarray,
    blocks: np.ndarray,
    rank_threshold: float,
) -> np.ndarray:
    """``Λ_i a_i`` for every task i at once, ``Λ_i = (J_i M⁻¹ J_iᵀ)⁺`` its task-space inertia.

    ``J`` (Σ m_i, nv) stacks the tasks' Jacobians, task i's rows being ``J[tasks[i]]``;
    ``M`` is the (nv, nv) mass matrix, ``accelerations`` the concatenation of the a_i
    (Σ m_i,), ``blocks`` the (Σ m_i, Σ m_i) boolean mask of the tasks' diagonal blocks.
    With ``M = L Lᵀ`` and ``Y = L⁻¹ Jᵀ``, ``J M⁻¹ Jᵀ = Yᵀ Y``; its block-diagonal part is
    factorised once (Cholesky); zero rows of a J_i (an inactive joint-limit row) get zero.
    When some task's rows are dependent or nearly so (a Cholesky pivot below
    ``_INDEPENDENT`` relative), every task falls back to its pseudo-inverse (threshold
    ``rank_threshold``).
    """
    L, info = _POTRF(M, lower=True, clean=True)
    if info != 0:
        raise RuntimeError(f"the mass matrix is not positive definite (LAPACK dpotrf info = {info})")
    active = J.any(axis=1)
    Y, _ = _TRTRS(L, J.T, lower=True)
    A = Y.T @ Y
    A *= blocks
    a = np.where(active, accelerations, 0.0)
    A.flat[:: A.shape[0] + 1] += ~active  # inactive rows: 1 on the diagonal, zero right-hand side
    diagonal = A.diagonal().copy()
    factor, info = _POTRF(A, lower=True, overwrite_a=True, clean=False)
    # L_kk² / A_kk is the squared relative distance of row k to the rows before it (in the
    # M⁻¹ metric): rounding lets Cholesky succeed on dependent rows, so test it.
    if info == 0 and (factor.diagonal() ** 2 >= _INDEPENDENT * diagonal).all():
        return _POTRS(factor, a, lower=True)[0]
    M_inv = _POTRS(L, np.eye(M.shape[0]), lower=True)[0]
    return np.concatenate(
        [_task_inertia(J[rows], M_inv, rank_threshold) @ accelerations[rows] for rows in tasks]
    )


class GeneralizedHierarchyController(LeafSystem):
    """Joint torques from prioritised motion and force tasks (paper 004 eq. 8-11).

    At each control tick the goal-directed tasks' wrenches and the contact forces are the
    variables of the quasi-static QP (eq. 9: goal-directed tasks tracked, contacts
    regularised, static equilibrium of the floating base, friction cones, torque
    bounds); each goal-directed task's Jacobian is modulated by its generalized
    projector ``P_i(A_i)`` (eq. 8) built from row i of the priority matrix; the torques
    are ``τ = Σ P_i J_iᵀ w_i* + g`` (eq. 10). If the QP is infeasible or fails, the
    controller falls back to a safe torque — gravity compensation on the contacts plus
    a posture PD — and says so on ``status``. With ``weighted=True`` it is the weighted
    baseline of eq. 5-7.

    Input ports:
        state: measured plant state ``[q; v]`` (nq + nv) in ``plant``'s layout.
        <task name>: one per motion and force task, abstract ``TaskSignal`` (a foundation
            ``Task``'s output: its error and Jacobian are used).
        alpha: the priority matrix (n_t·n_t,), row-major, over the goal-directed tasks in
            the order motion tasks then force tasks; row i is α_i1..α_in (eq. 4).
        <force task>_desired, <force task>_measured: (m,) the wrench [N] the robot
            should apply / applies along the task's rows.
    Output ports:
        tau: joint torques (na,) [N·m], actuator order (the plant's actuation input).
        wrenches: the goal-directed tasks' optimal wrenches w*, concatenated (Σ m_i,).
        errors: the goal-directed tasks' errors, concatenated: e = s − s* for motion
            tasks [m, rad], w* − w_measured for force tasks [N] (their PI integral grows
            in proportion to 1 − α_ii: a deactivated force task does not wind up).
        contact_forces: (3·k,) [N] ground forces on the robot at the contact points, world.
        status: (1,) 0 optimal, 1 infeasible → fallback, 2 solver failure → fallback.

    Args:
        plant: the controller's robot model (finalized; one free flyer first, or fixed base).
        actuated_joints: joint names in actuator order.
        motion_tasks, force_tasks, contacts: see the dataclasses.
        q_posture: the fallback posture (nq,).
        period: control period [s]. weighted: the eq. 5-7 baseline (ω_t from ``weights``).
        regularization: ω_r of the contact forces.
        fallback_gains: (kp, kd) of the fallback posture PD [N·m/rad, N·m·s/rad].
        effort_limits: (na,) torque bounds [N·m] in actuator order (eq. 11); default the
            model's actuator effort limits.
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
        effort_limits: np.ndarray | None = None,
        name: str = "generalized_controller",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._plant = plant
        self._plant_context = plant.CreateDefaultContext()
        nq, nv, na = plant.num_positions(), plant.num_velocities(), len(actuated_joints)
        self._nq, self._nv, self._na = nq, nv, na
        self._n_base = nv - na
        if self._n_base not in (0, 6):
            raise ValueError(
                f"{nv} velocities for {na} actuated joints: expected a fixed base or one free flyer"
            )
        joints = [plant.GetJointByName(j) for j in actuated_joints]
        self._v_act = np.array([j.velocity_start() for j in joints], dtype=int)  # actuator k -> v index
        self._q_act = np.array([j.position_start() for j in joints], dtype=int)
        effort = (
            np.array([plant.GetJointActuatorByName(j).effort_limit() for j in actuated_joints])
            if effort_limits is None
            else np.asarray(effort_limits, dtype=float)
        )
        self._motion, self._force = list(motion_tasks), list(force_tasks)
        goals = [t.task for t in self._motion] + [t.task for t in self._force]
        self._names = [t.get_name() for t in goals]
        if len(set(self._names)) != len(self._names):
            raise ValueError(f"task names must be unique: {self._names}")
        self._dims = [t.dimension for t in goals]
        motion_dims = [t.task.dimension for t in self._motion]
        self._kp_rows = np.repeat([t.kp for t in self._motion], motion_dims)
        self._kd_rows = np.repeat([t.kd for t in self._motion], motion_dims)
        ends = np.cumsum(motion_dims).tolist()
        self._motion_slices = [slice(end - m, end) for end, m in zip(ends, motion_dims, strict=True)]
        self._motion_blocks = scipy.linalg.block_diag(*[np.ones((m, m)) for m in motion_dims]) > 0.0
        self._contacts = list(contacts)
        self._contact_frames = [plant.GetFrameByName(c.frame) for c in self._contacts]
        self._contact_offsets = [
            np.asarray(c.points, dtype=float).reshape(-1, 3).T for c in self._contacts
        ]  # (3, k)
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
        self._weights = dict(weights or {})
        unknown = sorted(set(self._weights) - set(self._names))
        if unknown:
            raise ValueError(f"weights for unknown tasks {unknown}; tasks: {self._names}")
        self._weighted = weighted
        self._regularization = regularization
        self._period = period
        self._q_posture = np.asarray(q_posture, dtype=float)
        self._fallback_gains = fallback_gains
        self._rank_threshold = 1e-8
        tau_v = np.empty(na)  # effort limits in the v order of the actuated rows
        tau_v[self._v_act - self._n_base] = effort
        self._qp = QuasiStaticQP(nv, self._n_base, tau_min=-tau_v, tau_max=tau_v)

        self._state = self.DeclareVectorInputPort("state", nq + nv)
        empty = TaskSignal("", np.zeros(0), np.zeros((0, nv)), np.zeros(0))
        self._task_ports = [self.DeclareAbstractInputPort(n, AbstractValue.Make(empty)) for n in self._names]
        n_t = len(self._names)
        self._alpha = self.DeclareVectorInputPort("alpha", n_t * n_t)
        self._force_ports = [
            (
                self.DeclareVectorInputPort(f"{t.task.get_name()}_desired", t.task.dimension),
                self.DeclareVectorInputPort(f"{t.task.get_name()}_measured", t.task.dimension),
            )
            for t in self._force
        ]
        m_total = sum(self._dims)
        n_contact = sum(len(c.points) for c in self._contacts)
        self._x_tau = self.DeclareDiscreteState(na)
        self._x_wrench = self.DeclareDiscreteState(m_total)
        self._x_error = self.DeclareDiscreteState(m_total)
        self._x_contact = self.DeclareDiscreteState(3 * n_contact)
        self._x_status = self.DeclareDiscreteState(1)
        self._x_integral = self.DeclareDiscreteState(sum(t.task.dimension for t in self._force) or 1)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        for name, index in (
            ("tau", self._x_tau),
            ("wrenches", self._x_wrench),
            ("errors", self._x_error),
            ("contact_forces", self._x_contact),
            ("status", self._x_status),
        ):
            self.DeclareStateOutputPort(name, index)

    @property
    def task_names(self) -> list[str]:
        """The goal-directed tasks, in the order of the alpha matrix's rows and columns."""
        return list(self._names)

    def error_slices(self) -> dict[str, slice]:
        """Where each goal-directed task's error lies in the ``errors`` output."""
        ends = np.cumsum(self._dims).tolist()
        return {n: slice(e - m, e) for n, e, m in zip(self._names, ends, self._dims, strict=True)}

    # --- one control tick -------------------------------------------------------------
    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        x = self._state.Eval(context)
        q, v = x[: self._nq], x[self._nq :]
        plant, pc = self._plant, self._plant_context
        plant.SetPositions(pc, q)
        plant.SetVelocities(pc, v)
        g = -plant.CalcGravityGeneralizedForces(pc)  # gravity as on the left of eq. 1
        M = plant.CalcMassMatrix(pc)
        n_t = len(self._names)
        alpha = self._alpha.Eval(context).reshape(n_t, n_t)
        signals = [port.Eval(context) for port in self._task_ports]
        jacobians = [s.jacobian for s in signals]
        n_motion = len(self._motion)
        errors = [s.error for s in signals[:n_motion]]
        desired: list[np.ndarray] = []
        if n_motion:
            # eq. 2 with K_P = k_p Λ, K_D = k_d Λ: w^d = Λ (−k_p e − k_d J v), all motion tasks at once.
            J_motion = np.concatenate(jacobians[:n_motion])
            acceleration = -self._kp_rows * np.concatenate(errors) - self._kd_rows * (J_motion @ v)
            wrench = _inertia_weighted(
                J_motion, self._motion_slices, M, acceleration, self._motion_blocks, self._rank_threshold
            )
            desired = [wrench[sl] for sl in self._motion_slices]
        integral = context.get_discrete_state(self._x_integral).get_value().copy()
        offset = 0
        for k, (t, (des_port, meas_port)) in enumerate(zip(self._force, self._force_ports, strict=True)):
            m = t.task.dimension
            w_star, w_meas = des_port.Eval(context), meas_port.Eval(context)
            e_w = w_star - w_meas
            # A task projected into its own null space (α_ii = 1) does not act: no wind-up.
            i = len(self._motion) + k
            integral[offset : offset + m] += (1.0 - alpha[i, i]) * e_w * self._period
            desired.append(w_star + t.kp * e_w + t.ki * integral[offset : offset + m])  # eq. 3
            errors.append(e_w)
            offset += m
        projectors = [None] * n_t if self._weighted else generalized_projectors(jacobians, alpha)
        tasks = [
            QsTask(name, J, desired=w_d, weight=self._weights.get(name, 1.0), projector=P)
            for name, J, w_d, P in zip(self._names, jacobians, desired, projectors, strict=True)
        ]
        contact_jacobians = self._contact_jacobians()
        tasks += [
            QsTask(name, contact_jacobians[3 * p : 3 * p + 3], weight=self._regularization, friction=cone)
            for p, (name, cone) in enumerate(self._contact_points)
        ]
        solution = self._qp.solve(tasks, g, weighted=self._weighted)
        if solution.status == "optimal":
            tau_v = solution.tau
            wrenches = np.concatenate([solution.wrenches[n] for n in self._names])
            # The contact task's wrench is what the robot applies on the ground:
            # the ground's force is its opposite.
            contact = (
                -np.concatenate([solution.wrenches[t.name] for t in tasks[len(self._names) :]])
                if self._contacts
                else np.zeros(0)
            )
            status = STATUS_OPTIMAL
        else:
            tau_v = self._fallback(q, v, g, contact_jacobians)
            wrenches = np.zeros(sum(self._dims))
            contact = np.zeros(discrete_state.get_vector(self._x_contact).size())
            status = STATUS_INFEASIBLE if solution.status == "infeasible" else STATUS_FAILED
            integral[:] = 0.0  # no wind-up while the force tasks are not acting
        discrete_state.get_mutable_vector(self._x_tau).SetFromVector(tau_v[self._v_act - self._n_base])
        discrete_state.get_mutable_vector(self._x_wrench).SetFromVector(wrenches)
        discrete_state.get_mutable_vector(self._x_error).SetFromVector(np.concatenate(errors))
        discrete_state.get_mutable_vector(self._x_contact).SetFromVector(contact)
        discrete_state.get_mutable_vector(self._x_status).SetFromVector([status])
        discrete_state.get_mutable_vector(self._x_integral).SetFromVector(integral)

    def _contact_jacobians(self) -> np.ndarray:
        """(3·k, nv): the translational Jacobians of all the contact points, stacked (world)."""
        plant, pc, world = self._plant, self._plant_context, self._plant.world_frame()
        blocks = [
            plant.CalcJacobianTranslationalVelocity(pc, JacobianWrtVariable.kV, frame, points, world, world)
            for points, frame in zip(self._contact_offsets, self._contact_frames, strict=True)
        ]
        return np.vstack(blocks) if blocks else np.zeros((0, self._nv))

    def _fallback(self, q: np.ndarray, v: np.ndarray, g: np.ndarray, contact_jacobians) -> np.ndarray:
        """Gravity compensation on the contacts (equal shares) plus a posture PD, in the v order."""
        kp, kd = self._fallback_gains
        J = contact_jacobians
        # contact_torques expects 6-row contacts; split the stacked point forces into 6-row blocks.
        pad = (-J.shape[0]) % 6
        J = np.vstack((J, np.zeros((pad, self._nv))))
        tau_static, _ = contact_torques(g, J, self._n_base)
        posture = np.zeros(self._na)
        qa = self._q_act
        posture[self._v_act - self._n_base] = kp * (self._q_posture[qa] - q[qa]) - kd * v[self._v_act]
        return tau_static + posture
