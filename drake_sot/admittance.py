"""Admittance control: a virtual mass-damper(-spring) driven by forces (pure numpy/scipy).

On a position-controlled robot a force task is made from a *reference* that obeys
the dynamics of a virtual mechanical system driven by the measured forces (paper
000, IV-C, eq. 11; Evrard et al. 2009, III-B, eq. 4, and the master side's eq. 8 with a
spring)::

    M r̈ + B ṙ + K (r - r_rest) = f

:class:`MassDamperSpring` integrates it exactly for a force held constant over a
step (zero-order hold), one independent second-order system per axis (diagonal M,
B, K), as the controller of a 6D point does at its control period.

:func:`joint_acceleration` and :func:`apparent_inertia` are the weighted
pseudo-inverse form of the same law (Mansard et al. 2009, eq. 12-14): with the joint weight
W = A (the robot's inertia matrix) and M = Λ = (J A⁻¹ Jᵀ)⁻¹ (the apparent inertia
of the end effector), the kinematic inverse of the admittance reference gives the
joint motion ``A q̈ = Jᵀ f - Jᵀ B J q̇`` of a gravity-compensated compliant robot.
:func:`coupled_step` integrates the admittance with such a full (non-diagonal) virtual mass,
the weighted variant's (Evrard et al. 2009, III-B, eq. 5-7).

No Drake here: the Drake adapter is :class:`drake_sot.systems.admittance.AdmittanceController`.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from drake_sot.linalg import weighted_pinv
from drake_sot.validation import per_axis, positive, positive_int, vector

__all__ = ["MassDamperSpring", "apparent_inertia", "coupled_step", "joint_acceleration"]

ArrayLike = float | np.ndarray | list | tuple

#: The largest entry of a step's transition (Φ, Γ): beyond it the virtual system (a mass of
#: 1e-300 kg, a stiffness of 1e300 N/m) is no admittance a robot can follow, and its reference
#: would overflow.
STEP_BOUND = 1e12


class MassDamperSpring:
    """``M r̈ + B ṙ + K (r - r_rest) = f`` per axis, integrated exactly under a zero-order hold.

    Each axis i is the linear system ``d/dt [y; v] = [[0, 1], [-K/M, -B/M]] [y; v]
    + [0; 1/M] f`` with ``y = r - r_rest``. For f constant over a step of ``dt``,
    ``[y; v](t + dt) = Φ [y; v](t) + Γ f`` exactly, with Φ and Γ read from the
    matrix exponential of the augmented system, computed once here for every axis.
    There is no stability condition on ``dt``.

    Args:
        mass: virtual mass per axis [kg, or kg m² for a rotation axis], > 0.
        damping: virtual damping per axis [N s/m, N m s/rad], >= 0.
        stiffness: virtual stiffness per axis [N/m, N m/rad], >= 0 (default 0: a
            mass-damper, the reference drifts at f/B under a constant force).
        dt: the step [s], > 0.
        n: number of axes; needed when every one of mass, damping, stiffness is a
            scalar, otherwise inferred from the array-like ones (6 for a 6D point:
            3 translation then 3 rotation axes).

    Raises:
        ValueError: naming the offending argument and its value (non-finite,
            mass <= 0, damping or stiffness < 0, dt <= 0, mismatched lengths), or the axis whose
            step is not finite or has an entry beyond :data:`STEP_BOUND` (a mass of 1e-300
            with a stiffness of 1e300).
    """

    def __init__(
        self,
        mass: ArrayLike,
        damping: ArrayLike,
        stiffness: ArrayLike = 0.0,
        dt: float | None = None,
        *,
        n: int | None = None,
    ) -> None:
        if dt is None:
            raise ValueError("dt (the step [s]) is required")
        dt = positive("dt", dt, unit="s")
        if n is None:
            sizes = {np.size(v) for v in (mass, damping, stiffness) if np.ndim(v) > 0}
            if len(sizes) > 1:
                raise ValueError(f"mass, damping and stiffness have different lengths {sorted(sizes)}")
            if not sizes:
                raise ValueError("mass, damping and stiffness are all scalars: give the number of axes n")
            n = sizes.pop()
        n = positive_int("n", n)
        self.mass = per_axis("mass", mass, n, sign="positive")
        self.damping = per_axis("damping", damping, n, sign="nonnegative")
        self.stiffness = per_axis("stiffness", stiffness, n, sign="nonnegative")
        self.n = self.mass.size
        self.dt = dt
        # Augmented per-axis system [y, v, f]: d/dt = [[0, 1, 0], [-K/M, -B/M, 1/M], [0, 0, 0]].
        self._phi = np.empty((self.n, 2, 2))
        self._gamma = np.empty((self.n, 2))
        for i, (m, b, k) in enumerate(zip(self.mass, self.damping, self.stiffness, strict=True)):
            with np.errstate(over="ignore", invalid="ignore"):  # checked just below
                F = np.array([[0.0, 1.0, 0.0], [-k / m, -b / m, 1.0 / m], [0.0, 0.0, 0.0]])
                E = scipy.linalg.expm(F * dt) if np.isfinite(F).all() else F
            if not (np.isfinite(E).all() and np.abs(E).max() <= STEP_BOUND):
                raise ValueError(
                    f"axis {i}: mass = {m:g}, damping = {b:g}, stiffness = {k:g} with dt = {dt:g} s give "
                    f"a step that is not finite or has an entry beyond {STEP_BOUND:g}: K/M, B/M or 1/M "
                    "is out of range"
                )
            self._phi[i] = E[:2, :2]
            self._gamma[i] = E[:2, 2]

    def step(
        self, x: np.ndarray, v: np.ndarray, f: np.ndarray, rest: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(x, v)`` after one step of ``dt`` under the force ``f`` held constant, all (n,).

        ``rest`` (n,) is the spring's rest position (default zero; unused on axes
        with K = 0).
        """
        x = vector("x", x, self.n)
        v = vector("v", v, self.n)
        f = vector("f", f, self.n)
        r = np.zeros(self.n) if rest is None else vector("rest", rest, self.n)
        y = x - r
        phi, gamma = self._phi, self._gamma
        y_next = phi[:, 0, 0] * y + phi[:, 0, 1] * v + gamma[:, 0] * f
        v_next = phi[:, 1, 0] * y + phi[:, 1, 1] * v + gamma[:, 1] * f
        return y_next + r, v_next


def _square(name: str, value, m: int) -> np.ndarray:
    """An (m, m) matrix from a matrix or from its diagonal (m,)."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        a = np.diag(a)
    if a.shape != (m, m) or not np.all(np.isfinite(a)):
        raise ValueError(
            f"{name} must be finite with shape ({m}, {m}) (or its diagonal ({m},)), got shape {a.shape}"
        )
    return a


def _full_row_rank(J: np.ndarray, A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validated (J, A, L) with A = L Lᵀ; J (m, n) must have full row rank."""
    J = np.asarray(J, dtype=float)
    if J.ndim != 2 or not np.all(np.isfinite(J)):
        raise ValueError(f"J must be a finite (m, n) matrix, got shape {J.shape}")
    A = np.asarray(A, dtype=float)
    if A.shape != (J.shape[1], J.shape[1]) or not np.all(np.isfinite(A)):
        raise ValueError(
            f"A must be finite with shape ({J.shape[1]}, {J.shape[1]}) to match J {J.shape}, got {A.shape}"
        )
    try:
        L = scipy.linalg.cholesky(A, lower=True)
    except np.linalg.LinAlgError as err:
        raise ValueError(f"A must be symmetric positive definite: Cholesky failed ({err})") from None
    G = scipy.linalg.solve_triangular(L, J.T, lower=True).T  # J L^-T
    s = np.linalg.svd(G, compute_uv=False)
    if J.shape[0] > J.shape[1] or s[-1] <= 1e-12 * max(s[0], 1.0):
        raise ValueError(f"J {J.shape} must have full row rank (singular values of J A^-1/2: {s})")
    return J, A, G


def apparent_inertia(J: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Λ = (J A⁻¹ Jᵀ)⁻¹ (m, m): the inertia of the robot seen at the task point (Mansard et al. 2009, IV-C).

    Args:
        J: (m, n) task Jacobian, full row rank.
        A: (n, n) joint-space inertia matrix, symmetric positive definite.
    """
    _, _, G = _full_row_rank(J, A)
    Lam = np.linalg.inv(G @ G.T)
    return 0.5 * (Lam + Lam.T)


def joint_acceleration(
    J: np.ndarray, A: np.ndarray, M: np.ndarray, B: np.ndarray, f: np.ndarray, rdot: np.ndarray
) -> np.ndarray:
    """q̈ = A⁻¹Jᵀ(J A⁻¹ Jᵀ)⁻¹ M⁻¹ (f − B ṙ) (n,): Mansard et al. 2009, eq. 13 with the weight W = A.

    The joint acceleration that realises the admittance ``M r̈ + B ṙ = f`` (eq. 11)
    through the A-weighted pseudo-inverse of J (eq. 12), the least-inertia-weighted
    solution of ``J q̈ = r̈``. With ``M = apparent_inertia(J, A)`` it satisfies
    ``A q̈ = Jᵀ f − Jᵀ B J q̇`` when ``ṙ = J q̇`` (eq. 14).

    Args:
        J: (m, n) task Jacobian, full row rank.
        A: (n, n) symmetric positive definite joint weight (the inertia matrix).
        M, B: (m, m) virtual mass and damping (or their diagonals (m,)); M invertible.
        f: (m,) force on the task point. rdot: (m,) its velocity ṙ.
    """
    J, A, _ = _full_row_rank(J, A)
    m = J.shape[0]
    M = _square("M", M, m)
    B = _square("B", B, m)
    f = np.asarray(f, dtype=float)
    rdot = np.asarray(rdot, dtype=float)
    if f.shape != (m,) or rdot.shape != (m,):
        raise ValueError(f"f and rdot must have shape ({m},), got {f.shape} and {rdot.shape}")
    rddot = np.linalg.solve(M, f - B @ rdot)
    return weighted_pinv(J, A, rank_threshold=0.0) @ rddot


def coupled_step(
    M: np.ndarray,
    B: np.ndarray,
    K: np.ndarray,
    y: np.ndarray,
    v: np.ndarray,
    f: np.ndarray,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """``(y, v)`` after one step of ``dt`` of ``M ÿ + B ẏ + K y = f``, f held constant, with full
    (m, m) matrices: the admittance whose virtual mass is an apparent inertia (Evrard et al.
    2009, eq. 7), which couples the axes.

    Exact for the zero-order hold, like :class:`MassDamperSpring` (its per-axis special case):
    the matrix exponential of the augmented system ``d/dt [y; v; f] = [[0, I, 0], [-M⁻¹K, -M⁻¹B,
    M⁻¹], [0, 0, 0]] [y; v; f]``, computed at each call (the mass changes with the posture).

    Args:
        M: (m, m) virtual mass, symmetric positive definite [kg].
        B, K: (m, m) damping [N s/m] and stiffness [N/m] (or their diagonals (m,)).
        y: (m,) displacement from the spring's rest [m]; v: (m,) velocity [m/s];
        f: (m,) force [N]; dt: the step [s], > 0.

    Raises:
        ValueError: naming the bad argument (shape, non-finite, M not positive definite, dt).
    """
    y = vector("y", y)
    m = y.size
    v = vector("v", v, m)
    f = vector("f", f, m)
    dt = positive("dt", dt, unit="s")
    M = _square("M", M, m)
    B = _square("B", B, m)
    K = _square("K", K, m)
    try:
        scipy.linalg.cholesky(0.5 * (M + M.T), lower=True)
    except np.linalg.LinAlgError:
        raise ValueError(f"M = {M.tolist()}: must be symmetric positive definite") from None
    Minv = np.linalg.inv(M)
    F = np.zeros((3 * m, 3 * m))
    F[:m, m : 2 * m] = np.eye(m)
    F[m : 2 * m, :m] = -Minv @ K
    F[m : 2 * m, m : 2 * m] = -Minv @ B
    F[m : 2 * m, 2 * m :] = Minv
    E = scipy.linalg.expm(F * dt)[: 2 * m] @ np.concatenate((y, v, f))
    return E[:m], E[m:]
