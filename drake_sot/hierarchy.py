"""The strict-priority solver of the Stack of Tasks (Mansard et al. 2009, eq. 8-9). Levels of
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

The generalized projector of soft priorities (Liu, Lober, Padois 2016) is in
:mod:`drake_sot.generalized`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from drake_sot.linalg import SvdSplit, full_rank_lstsq
from drake_sot.validation import nonnegative, real_array

__all__ = [
    "HierarchyResult",
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
        qdot0 = real_array("qdot0", qdot0)
        if qdot0.ndim != 1:
            raise ValueError(f"qdot0 must be a vector, got shape {qdot0.shape}")
        if not np.isfinite(qdot0).all():
            raise ValueError("qdot0 contains NaN or Inf")
    checked = []
    for i, level in enumerate(levels):
        if not isinstance(level, tuple | list) or len(level) != 2:
            size = f"{len(level)} entries" if isinstance(level, tuple | list) else type(level).__name__
            raise ValueError(
                f"levels[{i}] must be a pair (J, edot), got {size}; a level of bounds (J, lower, upper) "
                "is solve_hqp's"
            )
        J = real_array(f"levels[{i}]: J", level[0])
        edot = real_array(f"levels[{i}]: edot", level[1])
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
