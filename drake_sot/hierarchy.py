"""The strict-priority solver of the Stack of Tasks (Mansard et al. 2009, eq. 8-9) and the
generalized projector of soft priorities (Liu, Lober, Padois 2016, eq. 4 and 8). Levels of
inequalities (Escande, Mansard, Wieber 2014) are solved by :func:`drake_sot.hqp.solve_hqp`.

The recursion of eq. (8),

    qdot_i = qdot_{i-1} + (J_i P_{i-1})^+ (edot_i - J_i qdot_{i-1}),

with ``P_i`` the projector onto the null space of the augmented Jacobian
``(J_1, ..., J_i)`` (eq. 9), is computed here in null-space *basis* form, as
the original SoT does: instead of the n x n projector ``P_{i-1}`` we keep an
orthonormal basis ``Z_{i-1}`` (n, k_{i-1}) of that null space, so that
``P_{i-1} = Z_{i-1} Z_{i-1}^T`` and ``(J_i P_{i-1})^+ = Z_{i-1} (J_i Z_{i-1})^+``.
Each level costs one SVD of the small matrix ``J_i Z_{i-1}`` (m_i, k_{i-1}),
which gives at once the pseudo-inverse and the basis of what remains free:
``Z_i = Z_{i-1} V_i[:, r_i:]``.  The free space shrinks level by level and the
solver stops doing work once it is empty.  A tall level that keeps every singular
value (it takes all the freedom left, e.g. a posture task at the bottom) is solved by
a QR instead (:func:`drake_sot.linalg.full_rank_lstsq`: the same answer, certified by a
bound on the singular values, a third of the SVD's cost).

The generalized projector (:func:`generalized_projector`; Liu, Lober, Padois 2016,
section 3.2) replaces the strict order by a priority matrix ``A_i = diag(alpha_ij I_mj)``
per task i (eq. 4): ``P_i(A_i) = I - B_i^T A^s_{i,r} B_i`` (eq. 8) projects
task i completely (alpha = 1), partially (0 < alpha < 1) or not at all
(alpha = 0) out of the directions of each task j.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.linalg.lapack

from drake_sot.linalg import SvdSplit, full_rank_lstsq
from drake_sot.validation import nonnegative, positive_int

__all__ = [
    "HierarchyResult",
    "generalized_projector",
    "generalized_projectors",
    "priority_matrix",
    "projected_jacobians",
    "solve_strict",
]


@dataclass(frozen=True)
class HierarchyResult:
    """Outcome of :func:`solve_strict` for a stack of L levels on n joints.

    Attributes:
        qdot: (n,) joint velocity realising the stack.
        rank: per level, the rank of ``J_i Z_{i-1}``: how many task directions
            the level could use in the freedom left by the levels above it.
        free_dims: per level, the dimension of the null space of the augmented
            Jacobian ``(J_1, ..., J_i)`` left for the levels below it.
        residual: per level, ``||J_i qdot - edot_i||`` (2-norm) for the final qdot,
            computed when first read (a controller that does not read it does not pay).
    """

    qdot: np.ndarray
    rank: tuple[int, ...]
    free_dims: tuple[int, ...]
    levels: Sequence[tuple[np.ndarray, np.ndarray]] = field(default=(), repr=False)

    @cached_property
    def residual(self) -> tuple[float, ...]:
        """Per level, ``||J_i qdot - edot_i||`` for the final qdot."""
        return tuple(float(np.linalg.norm(J @ self.qdot - edot)) for J, edot in self.levels)


def _validate(
    levels: Sequence[tuple[np.ndarray, np.ndarray]], qdot0: np.ndarray | None
) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray | None]:
    """Return ``levels`` as float arrays and ``qdot0`` as a float vector, or raise ValueError.

    Every ``J_i`` must be 2-D with the same number n of columns, every
    ``edot_i`` of length m_i, ``qdot0`` of length n, and all values finite.
    """
    if qdot0 is not None:
        qdot0 = np.asarray(qdot0, dtype=float)
        if qdot0.ndim != 1:
            raise ValueError(f"qdot0 must be a vector, got shape {qdot0.shape}")
        if not np.isfinite(qdot0).all():
            raise ValueError("qdot0 contains NaN or Inf")
    checked = []
    for i, (J, edot) in enumerate(levels):
        J = np.asarray(J, dtype=float)
        edot = np.asarray(edot, dtype=float)
        if J.ndim != 2:
            raise ValueError(f"levels[{i}]: J must be a 2-D matrix, got shape {J.shape}")
        if edot.shape != (J.shape[0],):
            raise ValueError(
                f"levels[{i}]: edot has shape {edot.shape} but J has shape {J.shape}; "
                f"expected edot of shape ({J.shape[0]},)"
            )
        if checked and J.shape[1] != checked[0][0].shape[1]:
            raise ValueError(
                f"levels[{i}]: J has shape {J.shape} but levels[0] J has shape "
                f"{checked[0][0].shape}; all levels need the same number of columns"
            )
        if qdot0 is not None and J.shape[1] != qdot0.shape[0]:
            raise ValueError(
                f"levels[{i}]: J has shape {J.shape} but qdot0 has shape {qdot0.shape}; "
                f"expected {J.shape[1]} joints"
            )
        if not (np.isfinite(J).all() and np.isfinite(edot).all()):
            raise ValueError(f"levels[{i}]: J or edot contains NaN or Inf")
        checked.append((J, edot))
    return checked, qdot0


def solve_strict(
    levels: Sequence[tuple[np.ndarray, np.ndarray]],
    *,
    rank_threshold: float = 1e-6,
    damping: float = 0.0,
    qdot0: np.ndarray | None = None,
    validate: bool = True,
) -> HierarchyResult:
    """Solve a stack of tasks in strict priority (Mansard et al. 2009, eq. 8-9).

    Args:
        levels: ``(J_i, edot_i)`` pairs, highest priority first; ``J_i`` has
            shape (m_i, n) and ``edot_i`` shape (m_i,).
        rank_threshold: singular values of ``J_i Z_{i-1}`` at or below this
            absolute value are treated as zero (the SoT "damping").
        damping: if > 0, the kept singular values are inverted as
            ``s / (s^2 + damping^2)`` (damped least squares) instead of ``1/s``;
            the null spaces passed down are unchanged.
        qdot0: (n,) initial velocity (eq. 8 uses ``qdot_0 = 0``, the default).
            The levels correct it only inside the row space of the augmented
            Jacobian, so its component in the final null space is kept:
            ``Z_L Z_L^T qdot = Z_L Z_L^T qdot0``.  With ``damping = 0`` the
            result is the lexicographic least-squares solution closest to
            ``qdot0`` (the minimum-norm one when ``qdot0`` is None).
        validate: check shapes and finiteness (below). A caller that has checked
            them already (``StackOfTasks`` does, naming the task) may skip it;
            unchecked bad input gives undefined results.

    Rows of ``J_i`` that are exactly zero (a task component that is switched off, as
    in an inactive joint-limit row) are skipped: they cannot change q̇.

    Returns:
        The joint velocity and, per level, the rank used, the final residual
        and the remaining free dimensions.  With no levels, ``qdot`` is
        ``qdot0`` (or an empty vector) and the tuples are empty.

    Raises:
        ValueError: shapes disagree or a value is non-finite (the message
            names the level index and the shapes), or ``rank_threshold`` or
            ``damping`` is negative or not finite.
    """
    rank_threshold = nonnegative("rank_threshold", rank_threshold)
    damping = nonnegative("damping", damping)
    if validate:
        checked, qdot0 = _validate(levels, qdot0)
    else:
        checked = list(levels)
    if not checked:
        return HierarchyResult(qdot=np.zeros(0) if qdot0 is None else qdot0.copy(), rank=(), free_dims=())

    n = checked[0][0].shape[1]
    qdot = np.zeros(n) if qdot0 is None else qdot0.copy()
    Z: np.ndarray | None = None  # basis of the free space; None stands for I_n
    ranks: list[int] = []
    free_dims: list[int] = []
    for J, edot in checked:
        if Z is not None and Z.shape[1] == 0:
            ranks.append(0)
            free_dims.append(0)
            continue
        rows = np.flatnonzero(J.any(axis=1))
        if rows.size == 0:  # e.g. an inactive joint-limit level: nothing to solve, nothing taken
            ranks.append(0)
            free_dims.append(n if Z is None else Z.shape[1])
            continue
        if rows.size < J.shape[0]:  # zero rows constrain nothing: skip them in the SVD
            J, edot = J[rows], edot[rows]
        A = J if Z is None else J @ Z  # (m_i, k_{i-1})
        b = edot - J @ qdot
        # A tall level that takes all the freedom left: its least squares by QR (same answer).
        u = None if damping else full_rank_lstsq(A, b, rank_threshold)
        if u is None:
            split = SvdSplit.of(A, rank_threshold)
            u = split.solve(b, damping)  # (k_{i-1},)
            N = split.null_basis()  # (k_{i-1}, k_i)
            rank = split.rank
        else:
            N, rank = np.zeros((A.shape[1], 0)), A.shape[1]
        qdot += u if Z is None else Z @ u
        Z = N if Z is None else Z @ N
        ranks.append(rank)
        free_dims.append(Z.shape[1])

    return HierarchyResult(qdot=qdot, rank=tuple(ranks), free_dims=tuple(free_dims), levels=checked)


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


def _sorted_rows(
    jacobians: Sequence[np.ndarray], alpha: list[float], normalise: bool
) -> tuple[np.ndarray | None, list[tuple[int, float]]]:
    """The rows of the tasks with alpha > 0, stacked by decreasing alpha (stable), and their groups.

    Returns ``(rows, groups)``: ``rows`` (m, nv) with unit rows (normalised
    here if ``normalise``, exactly-zero rows removed) or None when no row is
    left, and ``groups`` the ``(end, alpha)`` of each run of equal alpha:
    rows ``[previous end, end)`` have priority ``alpha``.
    """
    order = sorted(
        (j for j, a in enumerate(alpha) if a > 0.0 and jacobians[j].shape[0]), key=lambda j: -alpha[j]
    )
    if not order:
        return None, []
    groups: list[tuple[int, float]] = []
    end = 0
    for j in order:
        end += jacobians[j].shape[0]
        if groups and groups[-1][1] == alpha[j]:
            groups[-1] = (end, alpha[j])
        else:
            groups.append((end, alpha[j]))
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
) -> tuple[Sequence[np.ndarray], list[np.ndarray], np.ndarray]:
    """``(jacobians, unit rows per task, alpha)`` for the batch functions, checked if ``validate``
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
    return jacobians, _unit_rows(jacobians, stacked), a


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
    jacobians, blocks, a = _batch(jacobians, alpha, validate)
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
    (no positive alpha in its row) gets its own Jacobian, not a copy.

    Args, Raises: as :func:`generalized_projectors`.
    """
    tol = nonnegative("rank_threshold", rank_threshold)
    jacobians, blocks, a = _batch(jacobians, alpha, validate)
    n, nv = len(jacobians), jacobians[0].shape[1]
    # The tasks of each distinct α row (e.g. all the tasks below the same upper ones).
    sharing: dict[bytes, list[int]] = {}
    for i in range(n):
        sharing.setdefault(a[i].tobytes(), []).append(i)
    out: list[np.ndarray] = list(jacobians)
    for tasks in sharing.values():
        rows, groups = _sorted_rows(blocks, a[tasks[0]].tolist(), normalise=False)
        if rows is None:
            continue  # P = I
        B, w = _basis(rows, groups, nv, tol)
        J = jacobians[tasks[0]] if len(tasks) == 1 else np.concatenate([jacobians[i] for i in tasks])
        JP = J - ((J @ B) * w) @ B.T
        begin = 0
        for i in tasks:
            end = begin + jacobians[i].shape[0]
            out[i] = JP[begin:end]
            begin = end
    return out
