"""Quasi-static torque control as one QP over task wrenches (Liu, Lober, Padois 2016, eq. 5-11).
Pure numpy + daqp.

A floating-base robot has ``n`` generalized velocities: the first ``n_base`` (6 for a
free flyer) are the unactuated root rows, the other ``n_a = n - n_base`` are actuated.
Each task ``i`` has a Jacobian ``J_i`` (m_i, n) and a task wrench ``w_i`` (m_i,): the
wrench the robot applies *on the environment* through the task (for a posture task, a
joint torque). The generalized force the tasks produce is ``Σ_i P_i J_iᵀ w_i + g``,
where ``g`` is the gravity term as written on the *left* side of the paper's eq. 1
(``g = -CalcGravityGeneralizedForces`` in Drake: ``+m·9.81`` on the vertical root row of a
robot at rest). The hierarchical form (eq. 9-11) is

    min_w   Σ_goal ‖w_iᵈ − w_i‖² + Σ_non-goal ω_r,i ‖w_i‖²                     (9a)
    s.t.    [Σ_i P_i J_iᵀ w_i + g]_root = 0             static equilibrium    (9b)
            −w_i ∈ friction cone_i                      each contact task     (9c)
            τ_min ≤ τ = [Σ_i P_i J_iᵀ w_i + g]_act ≤ τ_max                    (11)

and ``τ`` (eq. 10) is the control input. The weighted baseline (eq. 5-7) is the same
QP with ``P_i = I`` and the goal terms weighted by ``ω_t,i``.

The cost is diagonal: stacking all wrenches into ``x`` (m,) it is ``Σ_j h_j (x_j − d_j)²``
with ``h_j`` the task weight of variable j and ``d`` the desired wrenches (0 for non-goal
tasks), i.e. the QP ``min ½ xᵀ diag(h) x − (h∘d)ᵀ x`` (half the cost, minus a constant).

Friction cones. For a contact task (m = 3, a point force) the environment's reaction
``f = −w`` must satisfy, with ``n`` the cone's unit normal and ``t_1, t_2`` a tangent basis,
``n·f ≥ f_min`` and, for k facets with outward normals ``d_j = cos θ_j t_1 + sin θ_j t_2``,
``θ_j = 2πj/k``: ``d_j·f ≤ μ cos(π/k) (n·f)``. This is the regular k-sided pyramid
*inscribed* in the circular cone (its edges lie on the cone), so it is conservative; with
k = 4 it is the familiar ``|f_t1| ≤ μ/√2 f_n``, ``|f_t2| ≤ μ/√2 f_n``.

Solver: DAQP (a dense dual active-set solver, PyPI package ``daqp``), chosen by
``benchmarks/bench_generalized.py`` as the fastest dense QP solver available here on this
problem's size (it reuses its workspace and warm-starts from the last active set while the
problem structure stays the same). Other solvers can be plugged in as a callable taking
the :class:`QsProblem` (the benchmark does so to compare them through the same build).

Infeasibility. When the constraints cannot hold together (a minimum normal force that the
robot's weight cannot provide, torque bounds that the equilibrium violates, an equilibrium
that the task Jacobians cannot reach because nothing supports the base, ...) the solution
has ``status`` :attr:`SolveStatus.INFEASIBLE`; when the solver stops for another reason (iteration limit,
numerical trouble) or returns a point that violates the constraints beyond tolerance, it is
:attr:`SolveStatus.FAILED`. In both cases ``wrenches`` and ``tau`` are all NaN, never a partial answer,
and ``message`` says what went wrong. The caller must then not use ``tau``: it applies a
safe torque instead (e.g. the last feasible ``tau`` held for a few ticks, then a damped
hold of the posture) and reports the event; relaxing the stack (dropping a goal task,
lowering a minimum normal force) is the caller's decision, never made here. A goal that
the constraints forbid (e.g. a desired contact force outside its friction cone) is *not*
infeasible: the goal is a cost term, and the solution is the closest admissible wrench.
"""

from __future__ import annotations

import enum
import math
import time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import daqp
import numpy as np

from drake_sot.validation import nonnegative, positive_int

__all__ = [
    "FrictionCone",
    "QsProblem",
    "QsSolution",
    "QsTask",
    "QuasiStaticQP",
    "SolveStatus",
    "StackedQP",
    "StaticCapacity",
    "static_capacity",
]

_EQ = 5  # daqp sense flag of an equality row
# Tolerances of the final check of every answer, whatever solver produced it:
# equality rows (N, N·m) relative to 1 + the largest term of the equilibrium,
_EQ_TOL = 1e-9
# inequality rows (friction [N], torque bounds [N·m]) absolute, on top of the solver's own
_INEQ_TOL = 1e-6
_CACHE_SIZE = 8
# static_capacity: the largest factor tried on the torque bounds before reporting inf.
_LARGEST_SCALE = 1e15
#: The largest task weight: the Hessian's diagonal holds the weights, and weights 1e12 apart
#: (1e-4 regularisation against this) leave the QP's answer at the solver's precision.
MAX_WEIGHT = 1e8


class SolveStatus(enum.Enum):
    """How a solve of the torque layer ended: the QP's :attr:`QsSolution.status` (a plug-in
    solver returns one too) and the generalized controller's verdict on it, which its ``status``
    output carries as :attr:`code`.

    The QP returns OPTIMAL, INFEASIBLE or FAILED (see the module docstring); SHORT is the
    controller's: the QP was optimal but a goal-directed task falls short of its desired wrench
    by more than the threshold. The value is the name logs and reports show.
    """

    OPTIMAL = "optimal"
    SHORT = "short"
    INFEASIBLE = "infeasible"
    FAILED = "failed"

    @property
    def code(self) -> float:
        """The status as a number for a vector port: 0 optimal, 1 short, 2 infeasible, 3 failed."""
        return _CODES[self]

    @classmethod
    def of_code(cls, code: float) -> SolveStatus:
        """The status whose :attr:`code` is ``code``.

        Raises:
            ValueError: ``code`` is none of the codes (named, with the codes).
        """
        for status, value in _CODES.items():
            if value == code:
                return status
        raise ValueError(
            f"status code = {code!r}: must be one of {', '.join(f'{v:g}' for v in _CODES.values())}"
        )

    @property
    def fallback(self) -> bool:
        """True when the QP gave no answer (INFEASIBLE, FAILED): its torque must not be used."""
        return self in (SolveStatus.INFEASIBLE, SolveStatus.FAILED)


_CODES = {status: float(i) for i, status in enumerate(SolveStatus)}


@dataclass(frozen=True, eq=False)
class FrictionCone:
    """Linearised Coulomb cone of a point contact, on the force the environment applies.

    Attributes:
        mu: friction coefficient (≥ 0; 0 = frictionless, the force is along the normal).
        facets: number of faces k ≥ 3 of the inscribed pyramid.
        normal: contact normal (3,) in the world frame, pointing into the robot (away from
            the environment); normalised on construction and stored as a tuple.
        min_normal_force: lower bound on the normal force [N] (≥ 0), e.g. to keep a
            contact loaded.
    """

    mu: float
    facets: int = 4
    normal: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 1.0)
    min_normal_force: float = 0.0

    def __post_init__(self) -> None:
        mu = nonnegative("FrictionCone.mu", self.mu)
        facets = positive_int("FrictionCone.facets", self.facets, minimum=3)
        nrm = np.asarray(self.normal, dtype=float)
        length = float(np.linalg.norm(nrm)) if nrm.shape == (3,) else 0.0
        if nrm.shape != (3,) or not (math.isfinite(length) and length > 1e-12):
            raise ValueError(f"FrictionCone.normal = {self.normal!r}: must be a finite nonzero (3,) vector")
        fmin = nonnegative("FrictionCone.min_normal_force", self.min_normal_force, unit="N")
        object.__setattr__(self, "mu", mu)
        object.__setattr__(self, "facets", facets)
        object.__setattr__(self, "normal", tuple(float(v) for v in nrm / length))
        object.__setattr__(self, "min_normal_force", fmin)
        object.__setattr__(self, "_key", (mu, self.facets, self.normal, fmin))
        object.__setattr__(self, "_hash", hash(self._key))

    # Cones are part of the structure key looked up every tick: hash once, compare cheaply.
    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if not isinstance(other, FrictionCone):
            return NotImplemented
        return self._key == other._key

    def tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """An orthonormal tangent basis ``(t_1, t_2)`` with ``t_1 × t_2 = normal``.

        For the normal +z it is ``(x, y)``; otherwise ``t_1`` is the world x axis (or y,
        if x is nearly normal) made orthogonal to the normal.
        """
        nrm = np.array(self.normal)
        seed = np.array([1.0, 0.0, 0.0]) if abs(nrm[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        t1 = seed - (seed @ nrm) * nrm
        t1 /= np.linalg.norm(t1)
        return t1, np.cross(nrm, t1)

    def halfspaces(self) -> tuple[np.ndarray, np.ndarray]:
        """``(C (k+1, 3), b (k+1,))`` with the cone ``{f : C f ≤ b}`` on the reaction force f.

        Rows 0..k-1 are the facets ``d_j·f − μ cos(π/k) n·f ≤ 0``; the last row is
        ``−n·f ≤ −f_min``.
        """
        k = self.facets
        nrm = np.array(self.normal)
        t1, t2 = self.tangents()
        theta = 2.0 * np.pi * np.arange(k) / k
        d = np.cos(theta)[:, None] * t1 + np.sin(theta)[:, None] * t2
        C = np.vstack([d - self.mu * math.cos(math.pi / k) * nrm, -nrm])
        b = np.zeros(k + 1)
        b[-1] = -self.min_normal_force
        return C, b


@dataclass(frozen=True)
class QsTask:
    """One task of the quasi-static QP.

    Attributes:
        name: unique name (key of :attr:`QsSolution.wrenches`).
        jacobian: ``J_i`` (m, n).
        desired: ``w_iᵈ`` (m,) for a goal-directed task; None for a non-goal-directed one
            (contacts, a regularised posture), whose wrench is only regularised.
        weight: ``ω_t`` of a goal task (used by the weighted baseline only; eq. 9 uses 1)
            or ``ω_r`` of a non-goal task (both forms; small, e.g. 1e-4..1e-3). Finite, > 0,
            at most :data:`MAX_WEIGHT`, checked when the task is made (ValueError naming it).
        projector: ``P_i`` (n, n), e.g. the generalized projector of eq. 8; None for the
            identity. Ignored by the weighted baseline; must be None on a contact task.
        friction: the friction cone of a contact point task (m == 3); its wrench is the
            force the robot applies on the environment, and its negative lies in the cone.
    """

    name: str
    jacobian: np.ndarray
    desired: np.ndarray | None = None
    weight: float = 1.0
    projector: np.ndarray | None = None
    friction: FrictionCone | None = None

    def __post_init__(self) -> None:
        # Checked here, whether or not the form solved uses it: a goal task's weight is read by
        # the weighted baseline only, and NaN, -1 or 0 must not pass as "optimal" in the other.
        weight = self.weight
        if isinstance(weight, bool) or not isinstance(weight, int | float | np.floating | np.integer):
            raise ValueError(f"task weights must be numbers: QsTask {self.name!r} weight = {weight!r}")
        if not (0.0 < weight <= MAX_WEIGHT):
            raise ValueError(
                f"task weights must be finite and > 0 (at most {MAX_WEIGHT:g}): "
                f"QsTask {self.name!r} weight = {weight!r}"
            )


@dataclass(frozen=True)
class QsSolution:
    """Outcome of :meth:`QuasiStaticQP.solve`.

    Attributes:
        wrenches: task name → optimal task wrench ``w_i*`` (m_i,) (NaN unless optimal).
        tau: (n_a,) actuated torques ``τ`` of eq. 10 / eq. 7 [N·m] (NaN unless optimal).
        status: OPTIMAL, INFEASIBLE (constraints cannot hold together) or FAILED
            (:class:`SolveStatus`).
        cost: ``Σ_goal ω‖wᵈ − w‖² + Σ_non-goal ω_r‖w‖²`` at the solution (the weights of
            the form solved: 1 for goal tasks in the hierarchical form); NaN unless optimal.
        root_residual: ``max |[Σ P_i J_iᵀ w_i + g]_root|`` (N, N·m); NaN unless optimal.
        solve_time: wall time of the whole call (QP build + solve + checks) [s].
        message: what went wrong, empty when optimal.
        iterations: solver iterations (active-set changes for DAQP; 0 if unknown).
    """

    wrenches: dict[str, np.ndarray]
    tau: np.ndarray
    status: SolveStatus
    cost: float
    root_residual: float
    solve_time: float
    message: str = ""
    iterations: int = 0


@dataclass(frozen=True)
class QsProblem:
    """The dense QP of one tick: ``min ½ xᵀ diag(h) x − (h∘d)ᵀ x`` subject to
    ``A_eq x = b_eq`` and ``lower ≤ A_in x ≤ upper`` (±inf where a side is absent).

    ``x`` stacks the task wrenches in task order (``slices[name]``). The arrays are the
    solver's work buffers: read them, copy them, do not write them.

    Attributes:
        h: (m,) diagonal of the Hessian (the task weights, > 0).
        d: (m,) desired wrenches (0 for non-goal tasks); the linear term is ``-h*d``.
        A_eq, b_eq: root rows of ``Σ P_i J_iᵀ`` (n_base, m) and ``-g_root``.
        A_in, lower, upper: torque-bound rows (actuated rows of ``Σ P_i J_iᵀ`` with a finite
            bound, bounds shifted by ``-g_act``) then friction rows (on w, lower = -inf).
        n_torque_rows: how many of the first rows of ``A_in`` are torque rows.
        slices: task name → slice of ``x``.
    """

    h: np.ndarray
    d: np.ndarray
    A_eq: np.ndarray
    b_eq: np.ndarray
    A_in: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    n_torque_rows: int
    slices: dict[str, slice] = field(repr=False)

    @property
    def H(self) -> np.ndarray:
        """Dense Hessian ``diag(h)`` (m, m)."""
        return np.diag(self.h)

    @property
    def f(self) -> np.ndarray:
        """Linear term ``-h*d`` (m,)."""
        return -self.h * self.d


# A plug-in solver: QsProblem -> (x or None, status, message, iterations).
SolverFn = Callable[[QsProblem], tuple[np.ndarray | None, SolveStatus, str, int]]


class _Layout:
    """Everything that depends only on the problem's structure: sizes, slices, the constant
    friction rows and the work buffers (allocated once, overwritten every tick)."""

    def __init__(
        self,
        tasks: Sequence[QsTask],
        n: int,
        n_base: int,
        tau_min: np.ndarray,
        tau_max: np.ndarray,
        weighted: bool,
    ) -> None:
        if not tasks:
            raise ValueError("no task: the QP needs at least one task")
        names = [t.name for t in tasks]
        if len(set(names)) != len(names):
            dup = sorted({x for x in names if names.count(x) > 1})
            raise ValueError(f"task names must be unique, repeated: {dup}")
        for t in tasks:
            J = t.jacobian
            if not isinstance(J, np.ndarray) or J.ndim != 2 or J.shape[1] != n or J.shape[0] < 1:
                raise ValueError(
                    f"task {t.name!r}: jacobian must be an (m >= 1, {n}) array, got {np.shape(J)}"
                )
            if t.friction is not None:
                if not isinstance(t.friction, FrictionCone):
                    raise ValueError(f"task {t.name!r}: friction must be a FrictionCone, got {t.friction!r}")
                if J.shape[0] != 3:
                    raise ValueError(
                        f"task {t.name!r}: a friction cone needs a 3-D point force task, got m = {J.shape[0]}"
                    )
                if not weighted and t.projector is not None:
                    raise ValueError(
                        f"task {t.name!r}: a contact task is never projected "
                        "(Liu, Lober, Padois 2016, §3.3); set projector=None"
                    )
        dims = [t.jacobian.shape[0] for t in tasks]
        ends = np.cumsum(dims).tolist()
        self.m = m = ends[-1]
        self.slices = {t.name: slice(e - k, e) for t, k, e in zip(tasks, dims, ends, strict=True)}
        self.task_slices = list(self.slices.values())
        self.dims = np.array(dims)
        self.goal = [(i, self.task_slices[i], dims[i]) for i, t in enumerate(tasks) if t.desired is not None]
        self.use_projector = [not weighted and t.projector is not None for t in tasks]
        # Torque rows: actuated rows with at least one finite bound.
        self.tau_rows = np.flatnonzero(np.isfinite(tau_min) | np.isfinite(tau_max))
        nt = self.tau_rows.size
        self.all_tau = nt == n - n_base
        # Friction rows act on w = -f: C f <= b  <=>  (-C) w <= b.
        contacts = [t for t in tasks if t.friction is not None]
        blocks = [(self.slices[t.name], *t.friction.halfspaces()) for t in contacts]
        nf = sum(C.shape[0] for _, C, _ in blocks)
        self.n_base, self.n_torque, self.n_friction = n_base, nt, nf
        rows = n_base + nt + nf
        self.AT = np.zeros((m, n))  # (Σ P_i J_iᵀ)ᵀ: row block i is J_i P_iᵀ
        self.C = np.zeros((rows, m))  # all constraint rows: [root; torque; friction]
        self.upper = np.full(rows, np.inf)
        self.lower = np.full(rows, -np.inf)
        r = n_base + nt
        for sl, C, b in blocks:
            k = C.shape[0]
            self.C[r : r + k, sl] = -C
            self.upper[r : r + k] = b
            r += k
        self.tau_lo = tau_min[self.tau_rows]
        self.tau_hi = tau_max[self.tau_rows]
        self.sense = np.zeros(rows, dtype=np.int32)
        self.sense[:n_base] = _EQ
        self.weights: tuple[float, ...] = ()
        self.h = np.empty(m)
        self.d = np.zeros(m)
        self.f = np.zeros(m)
        self.H = np.zeros((m, m))
        self.H_diag = self.H.reshape(-1)[:: m + 1]  # view of the diagonal
        self.H_changed = True
        self.model: daqp.Model | None = None  # DAQP workspace, set up on first solve
        self.problem = QsProblem(
            h=self.h,
            d=self.d,
            A_eq=self.C[:n_base],
            b_eq=self.upper[:n_base],
            A_in=self.C[n_base:],
            lower=self.lower[n_base:],
            upper=self.upper[n_base:],
            n_torque_rows=nt,
            slices=self.slices,
        )


def _set_weights(lay: _Layout, tasks: Sequence[QsTask], weighted: bool) -> None:
    """The cost's diagonal ``lay.h``: goal tasks 1 (eq. 9) or ω_t (eq. 5); non-goal tasks ω_r."""
    weights = tuple([t.weight if (weighted or t.desired is None) else 1.0 for t in tasks])
    if weights == lay.weights:
        return
    w = np.array(weights, dtype=float)
    if not (np.isfinite(w).all() and (w > 0.0).all()):
        bad = [t.name for t, v in zip(tasks, w, strict=True) if not (np.isfinite(v) and v > 0.0)]
        raise ValueError(f"task weights must be finite and > 0, not for {bad}")
    lay.h[:] = np.repeat(w, lay.dims)
    lay.H_diag[:] = lay.h
    lay.weights, lay.H_changed = weights, True


class StackedQP:
    """The quasi-static QP of a fixed set of tasks (:meth:`QuasiStaticQP.stacked`), fed stacked
    arrays at every tick: the same problem, answer and checks as :meth:`QuasiStaticQP.solve`
    with tasks of those Jacobians and desired wrenches, without building the structure of
    :class:`QsTask` objects each tick (what a controller whose tasks never change pays for
    nothing).

    Attributes:
        rows: the (m, n) work buffer of the stacked rows, task i's at ``slices[name]``: a
            caller may write the rows there and pass it to :meth:`solve` (no copy).
        slices: task name → its rows (and its part of ``x``), in the order of the tasks given.
        goal_rows: how many entries ``desired`` has (the goal tasks' rows, in task order).
    """

    def __init__(self, qp: QuasiStaticQP, lay: _Layout) -> None:
        self._qp, self._lay = qp, lay
        self.rows = lay.AT
        self.slices = dict(lay.slices)
        goal = [np.arange(sl.start, sl.stop) for _, sl, _ in lay.goal]
        index = np.concatenate(goal) if goal else np.zeros(0, dtype=int)
        self.goal_rows = index.size
        # Goal rows first and together (the common layout): one slice instead of an index.
        self._goal = slice(0, index.size) if (index == np.arange(index.size)).all() else index

    def solve(self, rows: np.ndarray, desired: np.ndarray, g: np.ndarray) -> QsSolution:
        """Solve eq. 9-11 (or eq. 5-7 if the stacked QP is weighted) for this tick.

        Args:
            rows: (m, n) the tasks' rows stacked in task order: ``J_i P_i`` of the goal tasks
                (``J_i`` for the weighted form), ``J_i`` of the others; :attr:`rows` itself may
                be passed after writing into it.
            desired: (:attr:`goal_rows`,) the goal tasks' desired wrenches, concatenated in
                task order.
            g: (n,) as in :meth:`QuasiStaticQP.solve`.
        Raises:
            ValueError: a shape that does not match, or NaN/Inf (naming the task).
        """
        t0 = time.perf_counter()
        qp, lay = self._qp, self._lay
        g = qp._gravity(g)
        if rows is not lay.AT:
            if getattr(rows, "shape", None) != lay.AT.shape:
                raise ValueError(f"rows must be {lay.AT.shape}, got {np.shape(rows)}")
            lay.AT[:] = rows
        if getattr(desired, "shape", None) != (self.goal_rows,):
            raise ValueError(f"desired must be ({self.goal_rows},), got {np.shape(desired)}")
        lay.d[self._goal] = desired
        if not math.isfinite(lay.AT.sum() + lay.d.sum() + g.sum()):
            if not np.isfinite(g).all():
                raise ValueError("g contains NaN or Inf")
            for name, sl in self.slices.items():
                if not (np.isfinite(lay.AT[sl]).all() and np.isfinite(lay.d[sl]).all()):
                    raise ValueError(f"task {name!r}: its rows or desired wrench contain NaN or Inf")
            raise ValueError("the QP data overflow (values near 1e308)")
        qp._fill_constraints(lay, g)
        return qp._solve_filled(lay, g, t0)


class QuasiStaticQP:
    """Quasi-static whole-body controller QP (Liu, Lober, Padois 2016, eq. 9-11, or the eq. 5-7
    baseline).

    Args:
        n: number of generalized velocities.
        n_base: number of unactuated root rows first in v (6 for a free flyer, 0 for a
            fixed base: then there is no equilibrium constraint).
        tau_min, tau_max: (n - n_base,) torque bounds [N·m]; None or ±inf for no bound.
        solver: "daqp" (default), or a callable ``f(problem: QsProblem) -> (x, status,
            message, iterations)`` with a :class:`SolveStatus` OPTIMAL, INFEASIBLE or FAILED (x None
            unless optimal), to solve the same QP with another solver.
        warm_start: let DAQP start from the previous tick's active set while the problem
            structure (tasks, sizes, contact cones) is unchanged.

    A new structure (a task added or removed, another size or cone, projector given or not)
    builds new buffers; the last few structures are kept, so alternating between them
    costs nothing extra.
    """

    def __init__(
        self,
        n: int,
        n_base: int = 6,
        tau_min: np.ndarray | None = None,
        tau_max: np.ndarray | None = None,
        solver: str | SolverFn = "daqp",
        warm_start: bool = True,
    ) -> None:
        n = positive_int("n", n)
        n_base = positive_int("n_base", n_base, minimum=0)
        if not n_base <= n:
            raise ValueError(f"n_base = {n_base}: must be <= n = {n}")
        self.n, self.n_base, self.n_a = n, n_base, n - n_base
        self.tau_min = self._bound("tau_min", tau_min, -np.inf)
        self.tau_max = self._bound("tau_max", tau_max, np.inf)
        if np.any(self.tau_min > self.tau_max):
            bad = np.flatnonzero(self.tau_min > self.tau_max).tolist()
            raise ValueError(f"tau_min > tau_max at actuated rows {bad}")
        if not (solver == "daqp" or callable(solver)):
            raise ValueError(f"solver must be 'daqp' or a callable taking a QsProblem, got {solver!r}")
        self.solver = solver
        self.warm_start = bool(warm_start)
        self._layouts: OrderedDict[tuple, _Layout] = OrderedDict()

    def _bound(self, name: str, value: np.ndarray | None, default: float) -> np.ndarray:
        if value is None:
            return np.full(self.n_a, default)
        b = np.array(value, dtype=float).reshape(-1)
        if b.shape != (self.n_a,) or np.isnan(b).any():
            raise ValueError(f"{name} must be ({self.n_a},) without NaN, got shape {np.shape(value)}")
        return b

    # ------------------------------------------------------------------ build
    def _layout(self, tasks: Sequence[QsTask], weighted: bool) -> _Layout:
        try:
            key = (
                weighted,
                *[
                    (t.name, t.jacobian.shape, t.desired is None, t.projector is None, t.friction)
                    for t in tasks
                ],
            )
        except AttributeError:  # a Jacobian that is not an array: let _Layout say which
            key = None
        lay = self._layouts.get(key) if key is not None else None
        if lay is None:
            lay = _Layout(tasks, self.n, self.n_base, self.tau_min, self.tau_max, weighted)
            self._layouts[key] = lay
            if len(self._layouts) > _CACHE_SIZE:
                self._layouts.popitem(last=False)
        elif next(reversed(self._layouts)) != key:
            self._layouts.move_to_end(key)
        return lay

    def build(self, tasks: Sequence[QsTask], g: np.ndarray, *, weighted: bool = False) -> QsProblem:
        """Assemble the dense QP of ``tasks`` and ``g`` (n,) into the work buffers and return it.

        The returned :class:`QsProblem` views the buffers: the next ``build`` or ``solve``
        with the same structure overwrites it. Raises ValueError as :meth:`solve`.
        """
        lay = self._layout(tasks, weighted)
        self._fill(lay, tasks, g, weighted)
        return lay.problem

    def _fill(self, lay: _Layout, tasks: Sequence[QsTask], g: np.ndarray, weighted: bool) -> np.ndarray:
        n = self.n
        g = self._gravity(g)
        AT = lay.AT
        for t, proj, sl in zip(tasks, lay.use_projector, lay.task_slices, strict=True):
            if proj:
                P = t.projector
                if getattr(P, "shape", None) != (n, n):
                    P = np.asarray(P, dtype=float)
                    if P.shape != (n, n):
                        raise ValueError(f"task {t.name!r}: projector must be ({n}, {n}), got {P.shape}")
                np.matmul(t.jacobian, P.T, out=AT[sl])  # (P Jᵀ)ᵀ
            else:
                AT[sl] = t.jacobian
        _set_weights(lay, tasks, weighted)
        d = lay.d
        for i, sl, m in lay.goal:
            wd = tasks[i].desired
            if getattr(wd, "shape", None) != (m,) and np.shape(wd) != (m,):
                raise ValueError(f"task {tasks[i].name!r}: desired must be ({m},), got {np.shape(wd)}")
            d[sl] = wd
        # NaN and Inf propagate through sums (a false alarm needs values near 1e308).
        if not math.isfinite(AT.sum() + d.sum() + g.sum()):
            self._raise_nonfinite(tasks, g)
        self._fill_constraints(lay, g)
        return g

    def _gravity(self, g: np.ndarray) -> np.ndarray:
        g = np.asarray(g, dtype=float)
        if g.shape != (self.n,):
            raise ValueError(f"g must be ({self.n},), got {g.shape}")
        return g

    def _fill_constraints(self, lay: _Layout, g: np.ndarray) -> None:
        """The linear term and the constraint rows from ``lay.AT``, ``lay.d`` and ``g``."""
        nb = self.n_base
        np.multiply(lay.h, lay.d, out=lay.f)
        np.negative(lay.f, out=lay.f)
        # Constraint rows: root (equality), bounded torque rows, friction (constant).
        C, nt, AT = lay.C, lay.n_torque, lay.AT
        if lay.all_tau:
            C[: nb + nt] = AT.T
        else:
            C[:nb] = AT[:, :nb].T
            C[nb : nb + nt] = AT[:, nb + lay.tau_rows].T
        np.negative(g[:nb], out=lay.upper[:nb])
        lay.lower[:nb] = lay.upper[:nb]
        if nt:
            gt = g[nb:] if lay.all_tau else g[nb + lay.tau_rows]
            np.subtract(lay.tau_hi, gt, out=lay.upper[nb : nb + nt])
            np.subtract(lay.tau_lo, gt, out=lay.lower[nb : nb + nt])

    @staticmethod
    def _raise_nonfinite(tasks: Sequence[QsTask], g: np.ndarray) -> None:
        if not np.isfinite(g).all():
            raise ValueError("g contains NaN or Inf")
        for t in tasks:
            for what, a in (("jacobian", t.jacobian), ("desired", t.desired), ("projector", t.projector)):
                if a is not None and not np.isfinite(a).all():
                    raise ValueError(f"task {t.name!r}: {what} contains NaN or Inf")
        raise ValueError("the QP data overflow (values near 1e308)")

    # ------------------------------------------------------------------ solve
    def solve(self, tasks: Sequence[QsTask], g: np.ndarray, *, weighted: bool = False) -> QsSolution:
        """Solve eq. 9-11 (``weighted=False``) or the eq. 5-7 baseline (``weighted=True``).

        Args:
            tasks: the active tasks, in any order (the order fixes the layout of x only).
            g: (n,) gravity term on the left side of eq. 1 (``-CalcGravityGeneralizedForces``).
            weighted: True for the weighted baseline: projectors ignored, goal weights ω_t.
        Returns:
            The solution; check ``status`` before using ``tau`` (see the module docstring).
        Raises:
            ValueError on malformed input (sizes, NaN/Inf, weights <= 0, duplicate names,
            no task, a projected or non-3-D contact task), naming the task.
        """
        t0 = time.perf_counter()
        lay = self._layout(tasks, weighted)
        return self._solve_filled(lay, self._fill(lay, tasks, g, weighted), t0)

    def stacked(self, tasks: Sequence[QsTask], *, weighted: bool = False) -> StackedQP:
        """The QP of a fixed set of tasks, fed at every tick with stacked arrays instead of
        :class:`QsTask` objects: :meth:`StackedQP.solve` is :meth:`solve` without building and
        looking up the structure of ``tasks`` each time.

        ``tasks`` give the structure only: names, row counts (their Jacobians' shapes; the
        values are not used), which tasks are goal-directed (``desired`` not None; its value is
        not used), weights and friction cones. None may carry a projector: the rows handed to
        :meth:`StackedQP.solve` are the projected ones, ``J_i P_i``. Raises ValueError as
        :meth:`solve` on a malformed structure, or for a task with a projector.
        """
        projected = [t.name for t in tasks if t.projector is not None]
        if projected:
            raise ValueError(
                f"tasks {projected}: a stacked QP takes the projected rows J_i P_i; give no projector"
            )
        lay = _Layout(tasks, self.n, self.n_base, self.tau_min, self.tau_max, weighted)
        _set_weights(lay, tasks, weighted)
        return StackedQP(self, lay)

    def _solve_filled(self, lay: _Layout, g: np.ndarray, t0: float) -> QsSolution:
        """Solve the QP held in ``lay``'s buffers (filled for ``g``), check and report the answer."""
        if self.solver == "daqp":
            x, status, message, iters = self._solve_daqp(lay)
        else:
            x, status, message, iters = self.solver(lay.problem)
        if status is SolveStatus.OPTIMAL:
            x = np.asarray(x, dtype=float)
            status, message = self._check(lay, x)
            if status is not SolveStatus.OPTIMAL:
                lay.model = None  # do not warm-start from it
        elif status not in (SolveStatus.INFEASIBLE, SolveStatus.FAILED):
            status, message = (
                SolveStatus.FAILED,
                f"solver status {status!r}: not OPTIMAL, INFEASIBLE or FAILED ({message})",
            )
        if status is SolveStatus.INFEASIBLE and not message:
            message = self._diagnose(lay)
        return self._solution(lay, g, x, status, message, iters, t0)

    def _solve_daqp(self, lay: _Layout) -> tuple[np.ndarray | None, SolveStatus, str, int]:
        warm = self.warm_start and lay.model is not None
        if warm:
            if lay.H_changed:
                flag = lay.model.update(H=lay.H, f=lay.f, A=lay.C, bupper=lay.upper, blower=lay.lower)
            else:
                flag = lay.model.update(f=lay.f, A=lay.C, bupper=lay.upper, blower=lay.lower)
        else:
            lay.model = daqp.Model()
            lay.model.settings = {"primal_tol": 1e-9}
            flag, _ = lay.model.setup(lay.H, lay.f, lay.C, lay.upper, lay.lower, lay.sense)
        lay.H_changed = False
        info: dict = {}
        if flag >= 0:
            x, _, flag, info = lay.model.solve()
        if flag < 0 and warm:  # retry from scratch: the previous active set may not fit
            lay.model = None
            return self._solve_daqp(lay)
        iters = int(info.get("iterations", 0))
        if flag > 0:
            return x, SolveStatus.OPTIMAL, "", iters
        lay.model = None  # do not warm-start from a failed solve
        if flag == -1:
            return None, SolveStatus.INFEASIBLE, "", iters
        if flag == -6:  # DAQP: overdetermined active set, e.g. inconsistent equilibrium rows
            if self._equilibrium_gap(lay) is not None:
                return None, SolveStatus.INFEASIBLE, "", iters
            return (
                None,
                SolveStatus.FAILED,
                "DAQP: linearly dependent active constraints (exitflag -6)",
                iters,
            )
        return None, SolveStatus.FAILED, f"DAQP stopped with exitflag {flag}", iters

    def _check(self, lay: _Layout, x: np.ndarray) -> tuple[SolveStatus, str]:
        """Verify an answer independently of the solver: equilibrium and every inequality."""
        if x.shape != (lay.m,) or not math.isfinite(x.sum()):
            return SolveStatus.FAILED, f"solver returned a non-finite or mis-shaped x {x.shape}"
        nb = self.n_base
        r = lay.C @ x
        r -= lay.upper
        if nb:
            eq = np.abs(r[:nb]).max()
            scale = 1.0 + np.abs(lay.upper[:nb]).max() + np.abs(lay.C[:nb]).max() * np.abs(x).max()
            if eq > _EQ_TOL * scale:
                return SolveStatus.FAILED, f"equilibrium residual {eq:.3g} after the solve"
        viol = r[nb:].max(initial=0.0)
        r += lay.upper
        viol = max(viol, (lay.lower[nb:] - r[nb:]).max(initial=0.0))
        if viol > _INEQ_TOL:
            return (
                SolveStatus.FAILED,
                f"a friction or torque-bound row is violated by {viol:.3g} after the solve",
            )
        return SolveStatus.OPTIMAL, ""

    def _equilibrium_gap(self, lay: _Layout) -> float | None:
        """Least-squares residual of the equilibrium rows alone, or None if they can be met."""
        nb = self.n_base
        if not nb:
            return None
        Aeq, beq = lay.C[:nb], lay.upper[:nb]
        y, *_ = np.linalg.lstsq(Aeq, beq, rcond=None)
        res = float(np.abs(Aeq @ y - beq).max())
        return res if res > 1e-9 * (1.0 + np.abs(beq).max()) else None

    def _diagnose(self, lay: _Layout) -> str:
        """Say which constraint group is impossible: the equilibrium alone, or all together."""
        gap = self._equilibrium_gap(lay)
        if gap is not None:
            return (
                f"static equilibrium (eq. 9b) cannot be met: the root rows of the (projected) task "
                f"Jacobians cannot balance g_root (least-squares residual {gap:.3g}); is a contact active?"
            )
        return (
            "constraints cannot hold together "
            "(equilibrium with friction cones, min normal forces, torque bounds)"
        )

    def _solution(self, lay, g, x, status, message, iters, t0) -> QsSolution:
        nb = self.n_base
        if status is not SolveStatus.OPTIMAL:
            nan = float("nan")
            return QsSolution(
                wrenches={name: np.full(sl.stop - sl.start, nan) for name, sl in lay.slices.items()},
                tau=np.full(self.n_a, nan),
                status=status,
                cost=nan,
                root_residual=nan,
                solve_time=time.perf_counter() - t0,
                message=message,
                iterations=iters,
            )
        gen = x @ lay.AT
        gen += g  # Σ P_i J_iᵀ w_i + g
        e = x - lay.d
        return QsSolution(
            wrenches={name: x[sl] for name, sl in lay.slices.items()},
            tau=gen[nb:],
            status=SolveStatus.OPTIMAL,
            cost=float(lay.h @ (e * e)),
            root_residual=float(np.abs(gen[:nb]).max()) if nb else 0.0,
            solve_time=time.perf_counter() - t0,
            message="",
            iterations=iters,
        )


@dataclass(frozen=True)
class StaticCapacity:
    """Whether contacts and torque bounds can hold a robot at rest: :func:`static_capacity`.

    Attributes:
        feasible: the static equilibrium (eq. 9b-c, 11 with no goal task) has a solution.
        contacts_hold: the contacts alone, without torque bounds, can balance the root rows
            (always True on a fixed base).
        tau: (n_a,) [N·m] the static torques: of the least-force solution within the bounds
            when ``feasible``; within the bounds scaled by ``scale`` when only the torque
            bounds are too small; NaN when the contacts cannot hold the robot.
        scale: 1 when feasible; else the smallest factor on every finite bound (scaled about
            zero) that makes the equilibrium feasible, to 0.1 % (inf when the contacts cannot).
        exceeded: the actuated rows whose bound ``tau`` exceeds (empty when feasible).
        message: the QP's diagnosis when the contacts cannot hold the robot, else empty.
    """

    feasible: bool
    contacts_hold: bool
    tau: np.ndarray
    scale: float
    exceeded: tuple[int, ...]
    message: str = ""


def static_capacity(
    contacts: Sequence[QsTask],
    g: np.ndarray,
    *,
    n_base: int,
    tau_min: np.ndarray | None = None,
    tau_max: np.ndarray | None = None,
) -> StaticCapacity:
    """Can ``contacts`` and the torque bounds hold the robot still, with no goal task at all?

    The quasi-static QP of eq. 9-11 with the contact tasks only (each regularised by its
    weight, inside its friction cone with its minimum normal force): if it is infeasible,
    no goal-directed task can make it feasible without a goal wrench that itself carries
    the robot, so a controller should refuse to start. When the contacts could hold the
    base without the torque bounds, the bounds are scaled up by bisection to the smallest
    factor that suffices, which says which joints are too weak and what they need.

    Args:
        contacts: contact point tasks (``friction`` set, no ``desired``); may be empty.
        g: (n,) gravity term on the left of eq. 1 at the configuration to hold.
        n_base, tau_min, tau_max: as in :class:`QuasiStaticQP`.

    Raises:
        ValueError: as :meth:`QuasiStaticQP.solve`, or a contact task with a ``desired``.
    """
    g = np.asarray(g, dtype=float)
    qp = QuasiStaticQP(g.size, n_base, tau_min, tau_max, warm_start=False)
    for t in contacts:
        if t.desired is not None or t.friction is None:
            raise ValueError(
                f"task {t.name!r}: static_capacity takes contact tasks only (friction, no desired)"
            )
    lo, hi = qp.tau_min, qp.tau_max

    def solve(scale: float) -> np.ndarray | None:
        """Static torques with the bounds scaled by ``scale`` (inf: no bound), or None if infeasible."""
        low_s, high_s = (None, None) if math.isinf(scale) else (scale * lo, scale * hi)
        if not contacts:  # nothing but gravity: tau = g_act, the root rows must vanish
            if n_base and np.abs(g[:n_base]).max() > _EQ_TOL * (1.0 + np.abs(g).max()):
                return None
            tau = g[n_base:].copy()
            return tau if low_s is None or np.all((low_s <= tau) & (tau <= high_s)) else None
        sol = QuasiStaticQP(g.size, n_base, low_s, high_s, warm_start=False).solve(contacts, g)
        return sol.tau if sol.status is SolveStatus.OPTIMAL else None

    tau = solve(1.0)
    if tau is not None:
        return StaticCapacity(True, True, tau, 1.0, ())
    unbounded = solve(np.inf)
    if unbounded is None:
        message = (
            qp.solve(contacts, g).message
            if contacts
            else "no contact holds the floating base (its root rows of g are not zero)"
        )
        return StaticCapacity(False, False, np.full(qp.n_a, np.nan), np.inf, (), message)
    low, high, tau = 1.0, 2.0, solve(2.0)
    while tau is None and high < _LARGEST_SCALE:  # some finite scale suffices unless a bound is 0
        low, high = high, 2.0 * high
        tau = solve(high)
    if tau is None:
        tau, high = unbounded, np.inf
    while math.isfinite(high) and high > 1.001 * low:
        middle = math.sqrt(low * high)
        found = solve(middle)
        if found is None:
            low = middle
        else:
            high, tau = middle, found
    exceeded = tuple(int(k) for k in np.flatnonzero((tau > hi) | (tau < lo)))
    return StaticCapacity(False, True, tau, high, exceeded)
