"""The torque family's pure part (Liu, Lober, Padois 2016): the generalized projectors of soft
priorities and the controller's law, with no Drake; the LeafSystem
:class:`drake_sot.systems.generalized_controller.GeneralizedHierarchyController` keeps the ports,
the state and the events, and calls these.

- **Generalized projectors** (section 3.2): a priority matrix ``A_i = diag(alpha_ij I_mj)`` per
  task i (eq. 4) replaces the strict order; ``P_i(A_i) = I - B_i^T A^s_{i,r} B_i`` (eq. 8)
  projects task i completely (alpha = 1), partially (0 < alpha < 1) or not at all (alpha = 0)
  out of the directions of each task j (:func:`generalized_projector`,
  :func:`generalized_projectors`, :func:`projected_jacobians`).
- **Task-space inertia** ``Λ = (J M⁻¹ Jᵀ)⁺`` and the desired wrenches of the motion tasks
  weighted by it, eq. 2 with ``K_P = k_p Λ``, ``K_D = k_d Λ`` (:func:`task_inertia`,
  :func:`inertia_weighted`).
- **Relative shortfall** of each goal task, ``‖w* − w^d‖ / max(‖w^d‖, wrench_floor)``
  (:func:`relative_shortfall`).
- **Fallback** when the quasi-static QP has no answer: gravity compensation on the contacts plus
  a posture PD, saturated at the torque bounds (:func:`fallback_torques`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.linalg.lapack

from drake_sot import kernels
from drake_sot.linalg import pinv
from drake_sot.statics import contact_torques
from drake_sot.validation import nonnegative, positive_int

__all__ = [
    "fallback_torques",
    "generalized_projector",
    "generalized_projectors",
    "inertia_weighted",
    "inertia_weighted_numpy",
    "priority_matrix",
    "ProjectedJacobians",
    "projected_jacobians",
    "relative_shortfall",
    "task_inertia",
]

# --------------------------------------------------------------------------------------
# Generalized projector (Liu, Lober, Padois 2016, section 3.2)
# --------------------------------------------------------------------------------------

_GEQP3 = scipy.linalg.lapack.dgeqp3  # column-pivoted Householder QR
_ORGQR = scipy.linalg.lapack.dorgqr  # its orthonormal factor Q


def _alphas(alpha_row: Sequence[float] | np.ndarray, name: str = "alpha_row", ndim: int = 1) -> np.ndarray:
    """Return ``alpha_row`` as a float array (``ndim`` dimensions) with every value finite and in [0, 1],
    or raise ValueError naming the first bad entry."""
    a = np.asarray(alpha_row, dtype=float)
    if a.ndim != ndim:
        raise ValueError(
            f"{name} must be a {'vector' if ndim == 1 else 'matrix'} of priorities, got shape {a.shape}"
        )
    if not ((a >= 0.0) & (a <= 1.0)).all():  # also catches NaN
        index = np.unravel_index(int(np.argmin((a >= 0.0) & (a <= 1.0))), a.shape)
        where = "".join(f"[{int(k)}]" for k in index)
        raise ValueError(f"{name}{where} = {float(a[index])!r}: every alpha must be finite and in [0, 1]")
    return a


def priority_matrix(alpha_row: Sequence[float] | np.ndarray, dims: Sequence[int]) -> np.ndarray:
    """Priority matrix ``A_i = diag(alpha_i1 I_m1, ..., alpha_in I_mn)`` of task i
    (Liu, Lober, Padois 2016, eq. 4).

    Args:
        alpha_row: (n,) priorities ``alpha_ij`` in [0, 1] of each task j with
            respect to task i (``alpha_ij = 1``: j is strictly above i;
            ``alpha_ij = 0``: i is not restricted by j; ``alpha_ii`` is the
            activation of i itself, 1 meaning deactivated).
        dims: (n,) task dimensions ``m_j`` (non-negative integers).

    Returns:
        The (m, m) diagonal matrix, ``m = sum(dims)``.

    Raises:
        ValueError: an alpha outside [0, 1] or not finite (named by index), a
            negative or non-integer dimension, or lengths that differ.
    """
    a = _alphas(alpha_row)
    d = np.asarray(dims)
    if d.shape != a.shape:
        raise ValueError(
            f"dims has shape {d.shape} but alpha_row has shape {a.shape}; one dimension per task"
        )
    sizes = [positive_int(f"dims[{j}] (a task dimension)", m, minimum=0) for j, m in enumerate(dims)]
    return np.diag(np.repeat(a, sizes))


def _jacobians(jacobians: Sequence[np.ndarray]) -> tuple[list[np.ndarray], np.ndarray]:
    """The task Jacobians as 2-D float arrays with one column count, and their vertical
    stack, checked finite; or raise ValueError naming the task."""
    checked: list[np.ndarray] = []
    for j, J in enumerate(jacobians):
        J = np.asarray(J, dtype=float)
        if J.ndim != 2:
            raise ValueError(f"jacobians[{j}] must be a 2-D matrix (m_{j}, nv), got shape {J.shape}")
        if checked and J.shape[1] != checked[0].shape[1]:
            raise ValueError(
                f"jacobians[{j}] has shape {J.shape} but jacobians[0] has shape {checked[0].shape}; "
                "all tasks need the same number nv of columns"
            )
        checked.append(J)
    if not checked:
        raise ValueError("jacobians is empty: the generalized projector needs at least one task to know nv")
    stacked = np.vstack(checked)
    if not math.isfinite(stacked.sum()):  # NaN and Inf propagate; find the culprit only on failure
        bad = [j for j, J in enumerate(checked) if not np.isfinite(J).all()]
        if bad:
            raise ValueError(f"jacobians[{bad[0]}] of shape {checked[bad[0]].shape} contains NaN or Inf")
    return checked, stacked


def _unit(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(unit, nonzero)``: the rows that are not exactly zero, scaled to unit length, and the
    (m,) mask of those rows. A row whose squared norm would overflow (entries of 1e300) or
    underflow (entries of 1e-170) is first divided by its largest |entry|: the result is the
    same at every scale."""
    norms = np.sqrt(np.einsum("ij,ij->i", rows, rows))
    # Squared norms in [1e-280, 1e280] lost nothing that matters (an underflowed square is
    # < 1e-24 of the row's largest one): the common case, one pass.
    if norms.size and norms.min() > 1e-140 and norms.max() < 1e140:
        return rows / norms[:, None], np.ones(norms.size, dtype=bool)
    safe = (norms > 1e-140) & (norms < 1e140)
    peak = np.abs(rows).max(axis=1, initial=0.0)
    nonzero = peak > 0.0  # a zero row (a switched-off component) constrains nothing
    unit = np.zeros_like(rows)
    unit[safe] = rows[safe] / norms[safe, None]
    redo = nonzero & ~safe
    scaled = rows[redo] / peak[redo, None]
    unit[redo] = scaled / np.sqrt(np.einsum("ij,ij->i", scaled, scaled))[:, None]
    return (unit, nonzero) if nonzero.all() else (unit[nonzero], nonzero)


def _unit_rows(jacobians: Sequence[np.ndarray], stacked: np.ndarray) -> list[np.ndarray]:
    """Per task, its rows scaled to unit length, exactly-zero rows removed: (m'_j, nv) each.
    ``stacked`` is the vertical stack of ``jacobians``."""
    unit, nonzero = _unit(stacked)
    # Row k of the stack is row kept[k] of unit (zero rows removed).
    kept = range(stacked.shape[0] + 1) if unit.shape[0] == stacked.shape[0] else np.cumsum([0, *nonzero])
    blocks, begin = [], 0
    for J in jacobians:
        end = begin + J.shape[0]
        blocks.append(unit[kept[begin] : kept[end]])
        begin = end
    return blocks


def _order(sizes: Sequence[int], alpha: list[float]) -> tuple[list[int], list[tuple[int, float]]]:
    """``(order, groups)``: the tasks with alpha > 0 and at least one row (``sizes[j]`` rows), by
    decreasing alpha (stable), and the ``(end, alpha)`` of each run of equal alpha in their stacked
    rows: rows ``[previous end, end)`` have priority ``alpha``."""
    order = sorted((j for j, a in enumerate(alpha) if a > 0.0 and sizes[j]), key=lambda j: -alpha[j])
    groups: list[tuple[int, float]] = []
    end = 0
    for j in order:
        end += sizes[j]
        if groups and groups[-1][1] == alpha[j]:
            groups[-1] = (end, alpha[j])
        else:
            groups.append((end, alpha[j]))
    return order, groups


def _sorted_rows(
    jacobians: Sequence[np.ndarray], alpha: list[float], normalise: bool
) -> tuple[np.ndarray | None, list[tuple[int, float]]]:
    """The rows of the tasks with alpha > 0, stacked by decreasing alpha (stable), and their groups.

    Returns ``(rows, groups)``: ``rows`` (m, nv) with unit rows (normalised
    here if ``normalise``, exactly-zero rows removed) or None when no row is
    left, and ``groups`` as :func:`_order` makes them.
    """
    order, groups = _order([J.shape[0] for J in jacobians], alpha)
    if not order:
        return None, []
    rows = jacobians[order[0]] if len(order) == 1 else np.concatenate([jacobians[j] for j in order])
    if normalise:
        rows, nonzero = _unit(rows)
        if not nonzero.all():  # some switched-off component (zero row): it constrains nothing
            kept = np.concatenate([[0], np.cumsum(nonzero)])
            groups = [(int(kept[e]), a) for e, a in groups]
            if not rows.shape[0]:
                return None, []
    return rows, groups


def _basis(
    rows: np.ndarray, groups: list[tuple[int, float]], nv: int, tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(B, w)`` of eq. 8, ``P = I - B diag(w) Bᵀ``, from the unit ``rows`` and ``groups`` made by
    :func:`_sorted_rows`: ``B`` (nv, r) orthonormal, ``w`` (r,) the alpha of each column's origin row.

    The rows are taken one group of equal alpha at a time, in decreasing
    alpha.  Each group's rows are made orthogonal to the basis ``B`` already
    built and a column-pivoted QR of what remains gives the new basis vectors:
    those with ``|R_kk| > tol``.  Within a group every basis of the new
    directions gives the same ``alpha sum b b^T``, so pivoting there is
    allowed; the order between groups, which matters, is kept.  A vector
    coming from a small ``|R_kk|`` carries rounding errors ~eps/|R_kk| along
    ``B``: it is projected once more (Gram-Schmidt's "twice is enough").
    """
    B = np.empty((nv, nv))  # columns 0..r-1: orthonormal basis built so far
    weights = np.empty(nv)  # alpha of the origin row of each basis vector
    r = 0
    begin = 0
    for end, a in groups:
        if r == nv:
            break
        group = rows[begin:end]
        begin = end
        if not group.shape[0]:
            continue
        Br = B[:, :r]
        if r:
            group = group - (group @ Br) @ Br.T
        if group.shape[0] == 1:  # one row: a Gram-Schmidt step, no factorisation
            v = group[0]
            norm = float(np.sqrt(v @ v))
            if norm <= tol:
                continue
            q = (v / norm)[:, None]
            smallest = norm
        else:
            qr, _, tau, _, info = _GEQP3(group.T, overwrite_a=r > 0)  # group^T Pi = Q R, |R_kk| decreasing
            if info != 0:  # pragma: no cover - LAPACK argument error, impossible with checked input
                raise RuntimeError(f"LAPACK dgeqp3 failed with info = {info}")
            d = np.abs(qr.diagonal())
            k = min(int(np.count_nonzero(d > tol)), nv - r)
            if k == 0:
                continue
            q, _, info = _ORGQR(qr[:, :k], tau[:k])
            if info != 0:  # pragma: no cover
                raise RuntimeError(f"LAPACK dorgqr failed with info = {info}")
            smallest = d[k - 1]
        if r and smallest < 1e-4:
            q = q - Br @ (Br.T @ q)
        k = q.shape[1]
        B[:, r : r + k] = q
        weights[r : r + k] = a
        r += k
    return B[:, :r], weights[:r]


def _projector(rows: np.ndarray | None, groups: list[tuple[int, float]], nv: int, tol: float) -> np.ndarray:
    """Eq. 8, ``P = I - B diag(w) Bᵀ`` (:func:`_basis`), from the output of :func:`_sorted_rows`."""
    if rows is None:
        return np.eye(nv)
    B, w = _basis(rows, groups, nv, tol)
    P = (B * -w) @ B.T
    P.flat[:: nv + 1] += 1.0
    return P


def generalized_projector(
    jacobians: Sequence[np.ndarray],
    alpha_row: Sequence[float] | np.ndarray,
    *,
    rank_threshold: float = 1e-9,
    validate: bool = True,
) -> np.ndarray:
    """Generalized projector ``P_i(A_i) = I - B_i^T A^s_{i,r} B_i`` of task i
    (Liu, Lober, Padois 2016, eq. 8).

    The rows of the augmented Jacobian ``J = (J_1; ...; J_n)`` are sorted by
    decreasing alpha (the diagonal of eq. 4's ``A_i``; stable for equal
    alphas), an orthonormal basis ``B_i`` of the row space is built in that
    order from the rows independent of those already taken (the ``origin``
    rows), and each basis vector is weighted by the alpha of its origin row.
    Equivalently, with ``a_1 > a_2 > ... > a_G > 0`` the distinct positive
    alphas (``a_{G+1} = 0``), ``S_g`` the span of the rows whose alpha is
    >= ``a_g`` and ``Pi_S`` the orthogonal projector onto S,

        P = I - sum_g (a_g - a_{g+1}) Pi_{S_g},

    which is how it is computed: one column-pivoted QR per distinct alpha
    value (zero alphas cost nothing).

    Consequences (tested): ``P`` is symmetric with eigenvalues in
    ``{1} ∪ {1 - alpha_ij}``, hence in [0, 1]; a direction shared by several
    tasks is removed with the largest of their alphas; the result does not
    depend on the order of the tasks (ties included), and it is continuous
    in alpha: ``||P(a) - P(a')||_2 <= ||a - a'||_1``.  In particular
    ``alpha_ij = 1`` for every j != i with ``alpha_ii = 0`` gives the
    null-space projector of the other tasks, all alphas 0 give the identity,
    and ``alpha_ii = 1`` cancels task i: ``J_i P = 0`` (more generally
    ``J_j P = (1 - a_1) J_j`` for every task j at the largest alpha ``a_1``).

    The rank decisions are scale-free: exactly-zero rows are skipped and the
    others normalised to unit length (each divided by its largest |entry| before
    its norm is taken, so rows of 1e300 or 1e-170 count as the same rows scaled
    to 1: no overflow, no underflow), and a row counts as independent of the
    rows above it when the distance from its unit vector to their span
    exceeds ``rank_threshold``.  When a row crosses that threshold the
    projector jumps (the rank changes), as any projector does.

    Args:
        jacobians: the n task Jacobians ``J_j`` (m_j, nv), in task order.
        alpha_row: (n,) the priorities ``alpha_i1 .. alpha_in`` of task i, each in [0, 1].
        rank_threshold: relative independence threshold (see above), >= 0.
        validate: check shapes, finiteness and ranges. A caller that has done
            so may skip it; unchecked bad input gives undefined results.
            :func:`generalized_projectors` validates and prepares the rows
            once for all the tasks.

    Returns:
        The (nv, nv) matrix ``P_i(A_i)``.

    Raises:
        ValueError: an alpha outside [0, 1] or not finite, ``len(alpha_row) !=
            len(jacobians)``, no task, Jacobians that are not 2-D, not finite or
            with different column counts (messages name the task index and
            shapes), or a negative ``rank_threshold``.
    """
    tol = nonnegative("rank_threshold", rank_threshold)
    if validate:
        jacobians, _ = _jacobians(jacobians)
        alpha = _alphas(alpha_row)
        if alpha.size != len(jacobians):
            raise ValueError(
                f"alpha_row has {alpha.size} values but there are {len(jacobians)} Jacobians; "
                "one alpha per task"
            )
    else:
        alpha = np.asarray(alpha_row, dtype=float)
    rows, groups = _sorted_rows(jacobians, alpha.tolist(), normalise=True)
    return _projector(rows, groups, jacobians[0].shape[1], tol)


def _batch(
    jacobians: Sequence[np.ndarray], alpha: np.ndarray, validate: bool
) -> tuple[Sequence[np.ndarray], np.ndarray, np.ndarray]:
    """``(jacobians, their vertical stack, alpha)`` for the batch functions, checked if ``validate``
    (ValueError as :func:`generalized_projectors`)."""
    n = len(jacobians)
    if validate:
        jacobians, stacked = _jacobians(jacobians)
        a = np.asarray(alpha, dtype=float)
        if a.shape != (n, n):
            raise ValueError(f"alpha has shape {a.shape} but there are {n} Jacobians; expected ({n}, {n})")
        _alphas(a, name="alpha", ndim=2)
    else:
        stacked, a = np.concatenate(jacobians), alpha
    return jacobians, stacked, a


def generalized_projectors(
    jacobians: Sequence[np.ndarray],
    alpha: np.ndarray,
    *,
    rank_threshold: float = 1e-9,
    validate: bool = True,
) -> np.ndarray:
    """Generalized projectors of all the tasks at once (Liu, Lober, Padois 2016, eq. 8).

    Same result as ``[generalized_projector(jacobians, alpha[i]) for i in
    range(n)]``, but the input is checked and the rows normalised once, and
    tasks with equal α rows share one computation.

    Args:
        jacobians: the n task Jacobians ``J_j`` (m_j, nv).
        alpha: (n, n) priority parameters; row i is ``alpha_row`` of task i
            in :func:`generalized_projector`.
        rank_threshold: as in :func:`generalized_projector`.
        validate: as in :func:`generalized_projector` (a controller whose caller
            checks the results, as the quasi-static QP does, may skip it every tick).

    Returns:
        (n, nv, nv): ``P[i]`` is the projector of task i.

    Raises:
        ValueError: as :func:`generalized_projector`, or ``alpha`` not (n, n).
    """
    tol = nonnegative("rank_threshold", rank_threshold)
    jacobians, stacked, a = _batch(jacobians, alpha, validate)
    blocks = _unit_rows(jacobians, stacked)
    n, nv = len(jacobians), jacobians[0].shape[1]
    # Tasks with the same α row have the same projector (e.g. both hands' orientation
    # tasks in a symmetric hierarchy): compute each distinct row once.
    distinct: dict[bytes, np.ndarray] = {}
    out = np.empty((n, nv, nv))
    for i in range(n):
        key = a[i].tobytes()
        if key not in distinct:
            distinct[key] = _projector(*_sorted_rows(blocks, a[i].tolist(), normalise=False), nv, tol)
        out[i] = distinct[key]
    return out


def _rows_of(ranges: list[tuple[int, int]]) -> slice | np.ndarray:
    """The rows ``[begin, end)`` of each range in turn: a slice when they follow each other (a view,
    no copy), else an index array."""
    if all(ranges[k][1] == ranges[k + 1][0] for k in range(len(ranges) - 1)):
        return slice(ranges[0][0], ranges[-1][1])
    every = np.arange(max(e for _, e in ranges))
    return np.concatenate([every[b:e] for b, e in ranges])


#: One set of tasks sharing an α row: the unit rows its basis is built from (sorted by decreasing
#: alpha), their groups of equal alpha (:func:`_order`), and the rows of those tasks in the stack.
_Share = tuple[slice | np.ndarray, list[tuple[int, float]], slice | np.ndarray]


def _plan(alpha: np.ndarray, starts: np.ndarray, kept: np.ndarray) -> list[_Share]:
    """What eq. 8 needs of the (n, n) ``alpha`` for :func:`_project`: one :data:`_Share` per distinct
    α row with some positive alpha on a row that is not zero. Task j's rows in the stack are
    ``[starts[j], starts[j + 1])``, its unit rows ``[kept[j], kept[j + 1])`` (:func:`_kept`)."""
    n = alpha.shape[0]
    sharing: dict[bytes, list[int]] = {}
    for i in range(n):
        sharing.setdefault(alpha[i].tobytes(), []).append(i)
    units = [(int(kept[j]), int(kept[j + 1])) for j in range(n)]
    plan: list[_Share] = []
    for tasks in sharing.values():
        order, groups = _order([e - b for b, e in units], alpha[tasks[0]].tolist())
        if order:  # else P = I
            rows = [(int(starts[i]), int(starts[i + 1])) for i in tasks if starts[i + 1] > starts[i]]
            if rows:
                plan.append((_rows_of([units[j] for j in order]), groups, _rows_of(rows)))
    return plan


def _project(stacked: np.ndarray, unit: np.ndarray, plan: list[_Share], tol: float, out: np.ndarray) -> None:
    """``out = J_i P_i`` for every task (``stacked`` (Σ m_i, nv) the tasks' Jacobians, ``unit`` its
    rows that are not zero scaled to unit length): with ``P_i = I - B diag(w) Bᵀ`` (:func:`_basis`),
    ``J_i P_i = J_i - ((J_i B) diag(w)) Bᵀ`` once for all the tasks that share an α row; the
    others' projector is the identity."""
    out[:] = stacked
    for index, groups, rows in plan:
        B, w = _basis(unit[index], groups, stacked.shape[1], tol)
        J = stacked[rows]
        JB = J @ B
        if groups[0][1] != 1.0 or len(groups) > 1:  # else every weight is 1
            JB *= w
        if isinstance(rows, slice):  # out[rows] is a view: write in place
            np.subtract(J, JB @ B.T, out=out[rows])
        else:
            out[rows] = J - JB @ B.T


def _starts(dims: Sequence[int]) -> np.ndarray:
    """(n + 1,) where each task's rows begin in the stack, and the stack's end."""
    return np.concatenate([[0], np.cumsum(dims, dtype=int)])


def _kept(starts: np.ndarray, nonzero: np.ndarray) -> np.ndarray:
    """Where each task's unit rows begin (and the last one's end) once the zero rows of the stack
    (``nonzero`` False) are removed, from where its rows begin in the stack (``starts``)."""
    return starts if nonzero.all() else np.concatenate([[0], np.cumsum(nonzero)])[starts]


def projected_jacobians(
    jacobians: Sequence[np.ndarray],
    alpha: np.ndarray,
    *,
    rank_threshold: float = 1e-9,
    validate: bool = True,
) -> list[np.ndarray]:
    """Every task's Jacobian times its generalized projector, ``J_i P_i(A_i)`` (m_i, nv)
    (Liu, Lober, Padois 2016, eq. 8): what the quasi-static QP of eq. 9-11 uses (``P_i`` is
    symmetric, so ``J_i P_i = (P_i J_iᵀ)ᵀ``), without forming the (nv, nv) projectors.

    Same result as ``[J_i @ P_i for J_i, P_i in zip(jacobians, generalized_projectors(jacobians,
    alpha))]`` up to rounding: with ``P_i = I - B diag(w) Bᵀ`` (:func:`generalized_projector`'s
    basis of the rows sorted by decreasing alpha), ``J_i P_i = J_i - ((J_i B) diag(w)) Bᵀ``,
    computed once for all the tasks that share an α row. A task whose projector is the identity
    (no positive alpha in its row) gets its own Jacobian, not a copy. :class:`ProjectedJacobians`
    does the same tick after tick for a fixed set of tasks.

    Args, Raises: as :func:`generalized_projectors`.
    """
    tol = nonnegative("rank_threshold", rank_threshold)
    jacobians, stacked, a = _batch(jacobians, alpha, validate)
    unit, nonzero = _unit(stacked)
    starts = _starts([J.shape[0] for J in jacobians])
    plan = _plan(a, starts, _kept(starts, nonzero))
    projected = np.empty_like(stacked)
    _project(stacked, unit, plan, tol, projected)
    moved = np.zeros(stacked.shape[0], dtype=bool)
    for _, _, rows in plan:
        moved[rows] = True
    return [
        projected[b:e] if moved[b:e].any() else J
        for J, b, e in zip(jacobians, starts[:-1], starts[1:], strict=True)
    ]


class ProjectedJacobians:
    """:func:`projected_jacobians` of a fixed list of tasks, tick after tick, stacked in and out:
    what a controller calls every tick. Which rows eq. 8 takes, in which order and in which groups
    of equal alpha depends on α (and on which rows are exactly zero) only: it is worked out again
    only when one of them changed since the last call (α stays put between transitions).

    Args:
        dims: (n,) the tasks' row counts m_i (>= 0).
        rank_threshold: as in :func:`generalized_projector` (>= 0).

    Raises:
        ValueError: a negative or non-integer dimension, or a negative ``rank_threshold``.
    """

    def __init__(self, dims: Sequence[int], rank_threshold: float = 1e-9) -> None:
        sizes = [positive_int(f"dims[{j}] (a task dimension)", m, minimum=0) for j, m in enumerate(dims)]
        self._starts = _starts(sizes)
        self._tol = nonnegative("rank_threshold", rank_threshold)
        self._key: bytes | None = None
        self._plan: list[_Share] = []

    def __call__(self, stacked: np.ndarray, alpha: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Write ``J_i P_i(A_i)`` of every task into ``out`` and return it: the compiled kernel
        (:mod:`drake_sot.kernels`), else :meth:`numpy`.

        Args:
            stacked: (Σ m_i, nv) the tasks' Jacobians stacked in task order, finite (not checked:
                the quasi-static QP checks what it is given).
            alpha: (n, n) the priority parameters, each in [0, 1] (not checked), as in
                :func:`generalized_projectors`.
            out: (Σ m_i, nv) C-contiguous float64, where the projected rows go (not ``stacked``).
        """
        if kernels.compiled is not None:
            kernels.compiled.projected_jacobians(stacked, alpha, self._starts, self._tol, out)
            return out
        return self.numpy(stacked, alpha, out)

    def numpy(self, stacked: np.ndarray, alpha: np.ndarray, out: np.ndarray) -> np.ndarray:
        """:meth:`__call__` in numpy: the compiled kernel's oracle and fallback. Which rows eq. 8
        takes, in which order and groups, is worked out again only when α or the zero rows changed."""
        unit, nonzero = _unit(stacked)
        key = alpha.tobytes() + (b"" if nonzero.all() else nonzero.tobytes())
        if key != self._key:
            self._plan = _plan(alpha, self._starts, _kept(self._starts, nonzero))
            self._key = key
        _project(stacked, unit, self._plan, self._tol, out)
        return out


# --------------------------------------------------------------------------------------
# The controller's law: task-space inertia, shortfall, fallback
# --------------------------------------------------------------------------------------

_POTRF, _POTRS = scipy.linalg.lapack.dpotrf, scipy.linalg.lapack.dpotrs  # Cholesky factor / solve
_TRTRS = scipy.linalg.lapack.dtrtrs  # triangular solve
#: Smallest squared relative Cholesky pivot for which a task's rows count as independent.
_INDEPENDENT = 1e-10


def task_inertia(J: np.ndarray, M_inv: np.ndarray, rank_threshold: float) -> np.ndarray:
    """Task-space inertia ``Λ = (J M⁻¹ Jᵀ)⁺`` (m, m) of a task's Jacobian ``J`` (m, nv), by the
    pseudo-inverse (:func:`drake_sot.linalg.pinv`, singular values <= ``rank_threshold`` or below
    its relative floor count as zero); rows of ``J`` that are zero (an inactive joint-limit row)
    get zero rows and columns. ``M_inv`` is the inverse (nv, nv) of the mass matrix.

    Raises:
        ValueError: NaN or Inf in ``J M⁻¹ Jᵀ``, or a negative ``rank_threshold``.
    """
    rows = np.flatnonzero(J.any(axis=1))
    inertia = np.zeros((J.shape[0], J.shape[0]))
    if rows.size:
        Jr = J[rows]
        inertia[np.ix_(rows, rows)] = pinv(Jr @ M_inv @ Jr.T, rank_threshold)
    return inertia


def inertia_weighted(
    J: np.ndarray,
    tasks: Sequence[slice],
    M: np.ndarray,
    accelerations: np.ndarray,
    blocks: np.ndarray,
    rank_threshold: float,
) -> np.ndarray:
    """``Λ_i a_i`` for every task i at once, ``Λ_i = (J_i M⁻¹ J_iᵀ)⁺`` its task-space inertia
    (:func:`task_inertia`): the desired wrenches of eq. 2 with ``K_P = k_p Λ``, ``K_D = k_d Λ``
    when ``a_i = −k_p e_i − k_d J_i v``.

    ``J`` (Σ m_i, nv) stacks the tasks' Jacobians, task i's rows being ``J[tasks[i]]``;
    ``M`` is the (nv, nv) mass matrix, ``accelerations`` the concatenation of the a_i
    (Σ m_i,), ``blocks`` the (Σ m_i, Σ m_i) boolean mask of the tasks' diagonal blocks.
    With ``M = L Lᵀ`` and ``Y = L⁻¹ Jᵀ``, ``J M⁻¹ Jᵀ = Yᵀ Y``; its block-diagonal part is
    factorised once (Cholesky); zero rows of a J_i (an inactive joint-limit row) get zero.
    When some task's rows are dependent or nearly so (a Cholesky pivot below
    ``_INDEPENDENT`` relative), every task falls back to its pseudo-inverse (threshold
    ``rank_threshold``). Inputs are assumed finite and of matching sizes.

    Returns:
        (Σ m_i,) the weighted accelerations ``Λ_i a_i``, concatenated in task order.

    Raises:
        RuntimeError: ``M`` not positive definite (LAPACK's ``info`` named).

    The compiled kernel (:mod:`drake_sot.kernels`) takes the Cholesky path, one task's block at a
    time; where it cannot (M not positive definite, dependent rows), :func:`inertia_weighted_numpy`
    runs, as it does when the kernels are numpy's.
    """
    if kernels.compiled is not None:
        starts = [rows.start for rows in tasks]
        starts.append(tasks[-1].stop if tasks else 0)
        weighted = kernels.compiled.inertia_weighted(J, starts, M, accelerations, _INDEPENDENT)
        if weighted is not None:
            return weighted
    return inertia_weighted_numpy(J, tasks, M, accelerations, blocks, rank_threshold)


def inertia_weighted_numpy(
    J: np.ndarray,
    tasks: Sequence[slice],
    M: np.ndarray,
    accelerations: np.ndarray,
    blocks: np.ndarray,
    rank_threshold: float,
) -> np.ndarray:
    """:func:`inertia_weighted` in numpy (LAPACK): the compiled kernel's oracle and fallback."""
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
        [task_inertia(J[rows], M_inv, rank_threshold) @ accelerations[rows] for rows in tasks]
    )


def relative_shortfall(
    achieved: np.ndarray, desired: np.ndarray, starts: np.ndarray, floor: float
) -> np.ndarray:
    """Each goal task's relative shortfall ``‖w* − w^d‖ / max(‖w^d‖, floor)`` (n_t,).

    ``achieved`` and ``desired`` (Σ m_i,) are the wrenches ``w*`` the QP gave and ``w^d`` the
    law asked for [N, N·m], concatenated; ``starts`` (n_t,) the first index of each task (each
    task at least one row); ``floor`` > 0 [N or N·m] keeps a near-zero desired wrench from
    turning rounding into a large ratio. Inputs are assumed checked (the controller's
    construction does); a NaN wrench gives a NaN shortfall.
    """
    gap2, need2 = np.add.reduceat(np.square([achieved - desired, desired]), starts, axis=1)
    return np.sqrt(gap2 / np.maximum(need2, floor**2))


def fallback_torques(
    g: np.ndarray,
    contact_jacobians: np.ndarray,
    n_base: int,
    actuated: np.ndarray,
    position_error: np.ndarray,
    velocity: np.ndarray,
    gains: tuple[float, float],
    bound: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The safe torque when the quasi-static QP has no answer: gravity compensation on the
    contacts (equal shares, :func:`drake_sot.statics.contact_torques`) plus a posture PD
    ``k_p (q_posture − q) − k_d v`` on the actuated joints, saturated at the torque bounds.

    Args:
        g: (nv,) ``−τ_g``, the generalized gravity force on the left of eq. 1 [N, N·m].
        contact_jacobians: (3·k, nv) the contact points' stacked translational Jacobians.
        n_base: unactuated base velocities (6 for a free flyer, 0 for a fixed base).
        actuated: (na,) int, for each actuator its row in the actuated velocities
            (``velocity_start − n_base``).
        position_error, velocity: (na,) ``q_posture − q`` [rad] and ``v`` [rad/s], actuator order.
        gains: ``(k_p, k_d)`` [N·m/rad, N·m·s/rad].
        bound: (nv − n_base,) the torque bounds [N·m] (> 0 or +inf) in the actuated v order.

    Returns:
        ``(τ, cut)``, both (nv − n_base,) in the actuated v order [N·m]: the torque held within
        ``±bound`` and the torque wanted minus it (nonzero where a bound cut it).

    Raises:
        ValueError: NaN or Inf in ``g`` or the contact Jacobians, or sizes that disagree
            (:func:`drake_sot.statics.contact_torques` names them).
    """
    kp, kd = gains
    # contact_torques expects 6-row contacts; split the stacked point forces into 6-row blocks.
    pad = (-contact_jacobians.shape[0]) % 6
    J = np.vstack((contact_jacobians, np.zeros((pad, g.size))))
    wanted, _ = contact_torques(g, J, n_base)
    wanted[actuated] += kp * position_error - kd * velocity
    tau = np.clip(wanted, -bound, bound)
    return tau, wanted - tau
