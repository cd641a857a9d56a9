"""Desired task wrenches of motion and force tasks (paper 004, eq. 2-3).

In the quasi-static torque controller of paper 004 every goal-directed task i
asks for a task wrench ``w_i`` (a force/moment at an operational point, or a
joint torque for a posture task) that the QP then tracks:

- a motion task uses a PD law, eq. 2: ``w = K_P e + K_D edot``
  (:func:`pd_wrench`);
- a force task uses a feed-forward plus PI law, eq. 3:
  ``w = w* + K_P e_w + K_I ∫ e_w dt`` with ``e_w = w* - w_measured``
  (:class:`PIForceController`).

Gains may be scalars (``k I``), vectors (a diagonal ``diag(k)``) or matrices;
the paper asks for symmetric positive definite gains, zero components are
allowed here (a task with no damping, say).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PIForceController", "pd_wrench"]

Gain = float | np.ndarray


def _vector(name: str, value: np.ndarray, size: int | None = None) -> np.ndarray:
    """Return ``value`` as a finite float vector (of length ``size`` if given) or raise ValueError."""
    v = np.asarray(value, dtype=float)
    if v.ndim != 1 or (size is not None and v.shape[0] != size):
        expected = f"({size},)" if size is not None else "a vector"
        raise ValueError(f"{name} must have shape {expected}, got {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError(f"{name} of shape {v.shape} contains NaN or Inf")
    return v


def _gain(name: str, gain: Gain, m: int) -> np.ndarray:
    """Return ``gain`` as a scalar, (m,) or (m, m) float array, checked, or raise ValueError.

    A scalar or vector must be >= 0; a matrix symmetric positive semidefinite.
    """
    k = np.asarray(gain, dtype=float)
    if k.ndim > 2 or (k.ndim == 1 and k.shape != (m,)) or (k.ndim == 2 and k.shape != (m, m)):
        raise ValueError(
            f"{name} must be a scalar, a ({m},) vector or a ({m}, {m}) matrix, got shape {k.shape}"
        )
    if not np.isfinite(k).all():
        raise ValueError(f"{name} contains NaN or Inf")
    if k.ndim < 2:
        if (k < 0.0).any():
            raise ValueError(f"{name} = {gain!r} must be >= 0")
        return k
    if not np.allclose(k, k.T, rtol=1e-10, atol=1e-12 * np.abs(k).max(initial=0.0)):
        raise ValueError(f"{name} must be a symmetric positive semidefinite matrix: it is not symmetric")
    smallest = float(np.linalg.eigvalsh(k).min()) if m else 0.0
    if smallest < -1e-12 * max(np.abs(k).max(initial=0.0), 1.0):
        raise ValueError(f"{name} must be positive semidefinite: smallest eigenvalue {smallest}")
    return k


def _apply(k: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``K v`` for a checked gain: scalar or vector (diagonal) multiplies, matrix multiplies as a matrix."""
    return k @ v if k.ndim == 2 else k * v


def pd_wrench(error: np.ndarray, error_rate: np.ndarray, kp: Gain, kd: Gain) -> np.ndarray:
    """Desired wrench of a motion task, ``w = K_P e + K_D edot`` (paper 004, eq. 2).

    Sign convention: ``e`` is the task error *towards the goal*,
    ``e = s* - s`` (desired minus current) and ``edot = ds*/dt - ds/dt``; the
    wrench then pulls the task toward its goal and damps its velocity.  The
    features of drake_sot (:mod:`drake_sot.features`, SoT convention) output
    the opposite, ``e_sot = s - s*``: pass ``-e_sot`` and ``-de_sot/dt``
    (for a fixed goal, ``-J v``), as in ``pd_wrench(-e_sot, -J @ v, kp, kd)``.

    Args:
        error: (m,) task error ``e = s* - s``.
        error_rate: (m,) its time derivative.
        kp, kd: gains: a scalar, an (m,) vector (diagonal gain) or an (m, m)
            symmetric positive semidefinite matrix; values >= 0.

    Returns:
        (m,) desired task wrench ``w``.

    Raises:
        ValueError: shapes disagree, a value is not finite, a gain is negative
            or a gain matrix is not symmetric positive semidefinite.
    """
    e = _vector("error", error)
    m = e.shape[0]
    edot = _vector("error_rate", error_rate, m)
    return _apply(_gain("kp", kp, m), e) + _apply(_gain("kd", kd, m), edot)


class PIForceController:
    """Force task with feed-forward and PI correction, ``w = w* + K_P e_w + K_I ∫ e_w dt`` (paper 004, eq. 3).

    ``e_w = w* - w_measured`` is the wrench error (desired minus measured
    wrench that the robot applies on the environment).  Each :meth:`step`
    first integrates the current error, ``I <- I + e_w dt`` (backward Euler),
    then returns ``w* + K_P e_w + K_I I``.

    Anti-windup: with ``integral_limit`` set, each component of the integral
    state ``I`` (units of wrench x seconds) is clamped to
    ``[-integral_limit, integral_limit]`` after the update.  The clamp is
    never silent: :attr:`saturated` tells which components were clamped at
    the last step and :attr:`saturation_count` how many steps clamped at
    least one component since the last :meth:`reset`.  Without a limit the
    integral is never modified.

    Args:
        dim: task dimension m (>= 1).
        kp, ki: gains: a scalar, an (m,) vector (diagonal) or an (m, m)
            symmetric positive semidefinite matrix.
        integral_limit: None (no anti-windup), or a positive scalar or (m,)
            vector bounding ``|I_k|`` [wrench·s].

    Raises:
        ValueError: ``dim`` < 1, a gain of the wrong shape or negative, or an
            ``integral_limit`` that is not positive or of the wrong shape.
    """

    def __init__(
        self, dim: int, kp: Gain, ki: Gain, *, integral_limit: float | np.ndarray | None = None
    ) -> None:
        if isinstance(dim, bool) or int(dim) != dim or dim < 1:
            raise ValueError(f"dim must be an integer >= 1, got {dim!r}")
        self._m = int(dim)
        self._kp = _gain("kp", kp, self._m)
        self._ki = _gain("ki", ki, self._m)
        if integral_limit is None:
            self._limit = None
        else:
            limit = np.asarray(integral_limit, dtype=float)
            if limit.ndim > 1 or (limit.ndim == 1 and limit.shape != (self._m,)):
                raise ValueError(
                    f"integral_limit must be a scalar or a ({self._m},) vector, got shape {limit.shape}"
                )
            if not (np.isfinite(limit).all() and (limit > 0.0).all()):
                raise ValueError(f"integral_limit = {integral_limit!r} must be finite and > 0")
            self._limit = np.broadcast_to(limit, (self._m,)).copy()
        self._integral = np.zeros(self._m)
        self._saturated = np.zeros(self._m, dtype=bool)
        self._saturation_count = 0

    @property
    def dim(self) -> int:
        """Task dimension m."""
        return self._m

    @property
    def integral(self) -> np.ndarray:
        """(m,) copy of the integral state ``∫ e_w dt`` [wrench·s]."""
        return self._integral.copy()

    @property
    def integral_limit(self) -> np.ndarray | None:
        """(m,) anti-windup bound of the integral state, or None."""
        return None if self._limit is None else self._limit.copy()

    @property
    def saturated(self) -> np.ndarray:
        """(m,) bool: the integral components clamped by the anti-windup at the last step."""
        return self._saturated.copy()

    @property
    def saturation_count(self) -> int:
        """Number of steps since the last reset at which the anti-windup clamped something."""
        return self._saturation_count

    def reset(self, integral: np.ndarray | None = None) -> None:
        """Zero the integral state (or set it to ``integral``, (m,)) and the saturation report.

        Raises:
            ValueError: ``integral`` of the wrong shape, not finite, or beyond ``integral_limit``.
        """
        if integral is None:
            value = np.zeros(self._m)
        else:
            value = _vector("integral", integral, self._m).copy()
            if self._limit is not None and (np.abs(value) > self._limit).any():
                raise ValueError(f"integral {value} exceeds integral_limit {self._limit}")
        self._integral = value
        self._saturated = np.zeros(self._m, dtype=bool)
        self._saturation_count = 0

    def step(self, w_des: np.ndarray, w_measured: np.ndarray, dt: float) -> np.ndarray:
        """Integrate the wrench error over ``dt`` and return the desired task wrench (eq. 3).

        Args:
            w_des: (m,) desired wrench ``w*`` applied on the environment (the feed-forward).
            w_measured: (m,) measured wrench.
            dt: time step [s], finite and > 0.

        Returns:
            (m,) ``w* + K_P e_w + K_I ∫ e_w dt``.

        Raises:
            ValueError: shapes other than (m,), a non-finite value, or ``dt <= 0``.
        """
        w_star = _vector("w_des", w_des, self._m)
        e_w = w_star - _vector("w_measured", w_measured, self._m)
        dt = float(dt)
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be finite and > 0, got {dt!r}")
        integral = self._integral + e_w * dt
        if self._limit is not None:
            self._saturated = np.abs(integral) > self._limit
            if self._saturated.any():
                integral = np.clip(integral, -self._limit, self._limit)
                self._saturation_count += 1
        self._integral = integral
        return w_star + _apply(self._kp, e_w) + _apply(self._ki, integral)
