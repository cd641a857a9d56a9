"""Pseudo-inverses and null-space bases (pure numpy/scipy).

Every function takes a Jacobian-like matrix ``J`` of shape ``(m, n)`` (m task
rows, n joints) and works from one singular value decomposition.  A singular
value ``s_k`` is *kept* when it is strictly greater than

    max(rank_threshold, max(m, n) · eps · s_max)

and the others are treated as exact zeros.  ``rank_threshold`` is an absolute
value in the units of ``J`` (the original Stack of Tasks calls it the "damping"
of its pseudo-inverse, although it truncates rather than damps; true damping,
damped least squares, is :func:`damped_pinv`).  The second term is the
relative floor below which a singular value is rounding noise (``eps`` the
float64 machine epsilon, ``s_max`` the largest singular value): the floor of
LAPACK's and numpy's ``matrix_rank``/``pinv``.  Without it, a rank decision
compares a float to exactly zero and depends on the last bits of a BLAS
result: the second singular value of [[1, 1], [1, 1]] comes out as 0 or as
3e-17 depending on the library, and its inverse as 0 or as 3e16.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from drake_sot.validation import matrix, nonnegative

__all__ = [
    "SvdSplit",
    "damped_pinv",
    "full_rank_lstsq",
    "null_space_basis",
    "pinv",
    "rank",
    "weighted_pinv",
]


_EPS = float(np.finfo(float).eps)
_GESDD = scipy.linalg.lapack.dgesdd
_GELS = scipy.linalg.lapack.dgels
_TRTRI = scipy.linalg.lapack.dtrtri


@dataclass(frozen=True)
class SvdSplit:
    """One SVD of a matrix ``A`` of shape ``(m, k)``, split at its numerical rank.

    ``A = U[:, :p] @ diag(s) @ Vt[:p]`` with ``p = min(m, k)``.  ``U`` is thin,
    ``(m, p)``; ``Vt`` is always complete, ``(k, k)``, so that its last
    ``k - rank`` rows span ker A.  One instance gives the rank, the action of
    the (damped) pseudo-inverse and the null-space basis, which is what one
    level of the strict-priority solver needs.

    Attributes:
        U: (m, p) left singular vectors.
        s: (p,) singular values, descending.
        Vt: (k, k) right singular vectors (rows).
        rank: number of singular values > max(rank threshold, relative floor)
            (see the module docstring).
    """

    U: np.ndarray
    s: np.ndarray
    Vt: np.ndarray
    rank: int

    @classmethod
    def of(cls, A: np.ndarray, rank_threshold: float = 1e-6) -> SvdSplit:
        """Decompose ``A`` (m, k); singular values <= ``max(rank_threshold,
        max(m, k)·eps·s_max)`` count as zero.

        ``A`` is assumed finite (validate with the public functions first).
        """
        m, k = A.shape
        if m and k:
            # LAPACK's divide and conquer, as numpy.linalg.svd calls it, without numpy's
            # wrapper (~3.5 µs a call, a tenth of the small SVDs of a control tick).
            U, s, Vt, info = _GESDD(A, compute_uv=1, full_matrices=int(m < k))
            if info:
                raise np.linalg.LinAlgError(f"SVD of a {m}x{k} matrix did not converge (LAPACK info {info})")
        else:
            U, s, Vt = np.linalg.svd(A, full_matrices=m < k)
        floor = max(rank_threshold, max(m, k) * _EPS * float(s[0])) if s.size else rank_threshold
        return cls(U=U, s=s, Vt=Vt, rank=int(np.count_nonzero(s > floor)))

    def _inverse_values(self, damping: float) -> np.ndarray:
        """(rank,) inverted kept singular values: 1/s, or s/(s^2 + damping^2)."""
        s = self.s[: self.rank]
        return s / (s * s + damping * damping) if damping > 0.0 else 1.0 / s

    def solve(self, b: np.ndarray, damping: float = 0.0) -> np.ndarray:
        """Return ``A^+ b`` of shape (k,) for ``b`` of shape (m,).

        With ``damping > 0`` the kept singular values are inverted as
        ``s / (s^2 + damping^2)`` (damped least squares on the kept subspace).
        """
        r = self.rank
        return self.Vt[:r].T @ (self._inverse_values(damping) * (self.U[:, :r].T @ b))

    def pinv(self, damping: float = 0.0) -> np.ndarray:
        """Return the (damped) pseudo-inverse of ``A``, shape (k, m)."""
        r = self.rank
        return (self.Vt[:r].T * self._inverse_values(damping)) @ self.U[:, :r].T

    def null_basis(self) -> np.ndarray:
        """Return an orthonormal basis of ker A, shape (k, k - rank)."""
        return self.Vt[self.rank :].T


def full_rank_lstsq(A: np.ndarray, b: np.ndarray, rank_threshold: float = 1e-6) -> np.ndarray | None:
    """``A^+ b`` (k,) for a tall ``A`` (m, k), m >= k, by Householder QR, when ``A`` certainly has
    full column rank by :class:`SvdSplit`'s rule; None when that is not certain (use the SVD).

    With ``A = Q R``, the singular values of ``A`` are those of ``R``, and
    ``σ_min >= 1 / ||R⁻¹||_F`` while ``σ_max <= ||R||_F``. The QR answer is taken only when
    ``1 / ||R⁻¹||_F > max(rank_threshold, max(m, k)·eps·||R||_F)``, which implies that every
    singular value is above :class:`SvdSplit`'s floor: the SVD would keep all k of them, its
    null space would be empty and its ``A^+ b`` is this least-squares solution (equal up to
    rounding). One QR and one triangular inverse cost about a third of the SVD of a 30 x 16
    matrix. ``A`` and ``b`` are assumed finite and of matching sizes.
    """
    m, k = A.shape
    if m < k or not k:
        return None
    qr, x, info = _GELS(A, b)
    if info:
        return None  # R is exactly singular
    # dtrtri reads and writes the upper triangle only (below it: the Householder vectors).
    R_inv, info = _TRTRI(qr[:k])
    if info:
        return None
    R_inv *= _upper_mask(k)
    a = A.ravel()
    floor = max(rank_threshold, max(m, k) * _EPS * math.sqrt(float(a.dot(a))))  # ||R||_F = ||A||_F
    r = R_inv.ravel()
    if math.sqrt(float(r.dot(r))) * floor >= 1.0:  # .dot: cheaper than @ on vectors
        return None  # the smallest singular value may be at or below the floor
    return x[:k]


@functools.cache
def _upper_mask(k: int) -> np.ndarray:
    """(k, k) ones on and above the diagonal, zeros below (Fortran order, as LAPACK's outputs)."""
    return np.asfortranarray(np.triu(np.ones((k, k))))


def pinv(J: np.ndarray, rank_threshold: float = 1e-6) -> np.ndarray:
    """Rank-revealing Moore-Penrose pseudo-inverse of ``J`` (m, n) -> (n, m).

    Singular values <= ``rank_threshold`` (absolute) or below the relative floor
    (module docstring) are treated as zero.  This threshold is what the original
    SoT calls the "damping" of its pseudo-inverse.
    """
    J = matrix("J", J)
    return SvdSplit.of(J, nonnegative("rank_threshold", rank_threshold)).pinv()


def damped_pinv(J: np.ndarray, damping: float) -> np.ndarray:
    """Damped least-squares inverse ``J^T (J J^T + damping^2 I)^-1`` of ``J`` (m, n) -> (n, m).

    Computed by SVD as ``V diag(s / (s^2 + damping^2)) U^T``, which stays
    bounded (by ``1 / (2 damping)``) near singularities.  ``damping = 0`` gives
    the Moore-Penrose pseudo-inverse in which the singular values below the
    relative floor ``max(m, n)·eps·s_max`` (rounding noise, see the module
    docstring) are dropped, as ``numpy.linalg.pinv`` does.
    """
    J = matrix("J", J)
    return SvdSplit.of(J, 0.0).pinv(nonnegative("damping", damping))


def weighted_pinv(J: np.ndarray, W: np.ndarray, rank_threshold: float = 1e-6) -> np.ndarray:
    """Weighted pseudo-inverse ``W^-1 J^T (J W^-1 J^T)^+`` (Mansard et al. 2009, eq. 12), (m, n) -> (n, m).

    ``W`` (n, n) is a symmetric positive definite joint weight: ``J^#W y`` is
    the solution of ``J x = y`` (least squares if inconsistent) minimising
    ``x^T W x``.  With the Cholesky factor ``W = L L^T`` it is computed as
    ``L^-T (J L^-T)^+``, an exact identity that avoids forming ``W^-1`` and
    squaring the condition number; ``rank_threshold`` (absolute) applies to
    the singular values of the scaled Jacobian ``J L^-T``.

    Raises:
        ValueError: non-finite input, ``W`` not (n, n), not symmetric, or not
            positive definite.
    """
    J = matrix("J", J)
    W = matrix("W", W)
    n = J.shape[1]
    if W.shape != (n, n):
        raise ValueError(f"W must have shape ({n}, {n}) to match J of shape {J.shape}, got {W.shape}")
    if not np.allclose(W, W.T, rtol=1e-10, atol=1e-12 * np.abs(W).max(initial=0.0)):
        raise ValueError("W must be symmetric positive definite: W is not symmetric")
    try:
        L = scipy.linalg.cholesky(W, lower=True)
    except np.linalg.LinAlgError as err:
        raise ValueError(f"W must be symmetric positive definite: Cholesky failed ({err})") from None
    G = scipy.linalg.solve_triangular(L, J.T, lower=True).T  # J L^-T, (m, n)
    G_pinv = SvdSplit.of(G, nonnegative("rank_threshold", rank_threshold)).pinv()
    return scipy.linalg.solve_triangular(L, G_pinv, lower=True, trans="T")


def null_space_basis(J: np.ndarray, rank_threshold: float = 1e-6) -> np.ndarray:
    """Orthonormal basis ``Z`` of ker J for ``J`` (m, n): shape (n, n - rank), ``J Z = 0``, ``Z^T Z = I``."""
    J = matrix("J", J)
    return SvdSplit.of(J, nonnegative("rank_threshold", rank_threshold)).null_basis()


def rank(J: np.ndarray, rank_threshold: float = 1e-6) -> int:
    """Number of singular values of ``J`` (m, n) strictly greater than ``rank_threshold``
    and than the relative floor (module docstring)."""
    J = matrix("J", J)
    return SvdSplit.of(J, nonnegative("rank_threshold", rank_threshold)).rank
