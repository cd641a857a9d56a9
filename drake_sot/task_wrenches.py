"""Desired task wrenches of motion and force tasks (Liu, Lober, Padois 2016, eq. 2-3).

In the quasi-static torque controller of Liu, Lober and Padois every goal-directed
task i asks for a task wrench ``w_i`` (a force/moment at an operational point, or a
joint torque for a posture task: what the robot applies *on the environment*
through the task) that the QP then tracks. This module is the one implementation of
those laws; :class:`~drake_sot.systems.generalized_controller.GeneralizedHierarchyController`
calls it every tick.

Sign convention — stated here and nowhere else: every error is drake_sot's, *current
minus desired*, the convention of the features and tasks of the kinematic SoT:

- motion task: ``e = s − s*`` (a feature's error) and ``ė`` its rate (``J v`` for a
  fixed goal);
- force task: ``e_w = w_measured − w*``.

The paper writes eq. 2-3 with desired minus current, i.e. with ``−e``, so its ``+``
signs become ``−`` here:

- motion, eq. 2: ``w = −K_P e − K_D ė`` (:func:`pd_wrench`);
- force, eq. 3: ``w = w* − K_P e_w − K_I ∫ e_w dt`` (:func:`pi_force_wrench`).

Anti-windup of eq. 3 — the one policy: *conditional integration*. The integral advances
by ``activity · e_w · dt``, where ``activity`` in [0, 1] is how much the task acts (in
the generalized hierarchy ``1 − α_ii``, α_ii = 1 being a deactivated task): a task that
does not act does not wind up, a task fading in or out integrates in proportion. A
caller whose task stops acting altogether (the controller's fallback) resets the
integral to zero. There is no clamp on the integral.

Gains may be scalars (``k I``), vectors (a diagonal ``diag(k)``) or symmetric positive
semidefinite matrices (the paper asks for symmetric positive definite gains; zero
components are allowed here: a task with no damping, say).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drake_sot.validation import per_axis, positive, vector

__all__ = ["ForceWrench", "check_gain", "pd_wrench", "pi_force_wrench"]

Gain = float | np.ndarray


def check_gain(name: str, gain: Gain, m: int) -> np.ndarray:
    """``gain`` as a scalar, (m,) or (m, m) float array, checked, or ValueError naming it.

    A scalar or vector must be finite and >= 0; a matrix finite, symmetric positive
    semidefinite.
    """
    k = np.asarray(gain, dtype=float)
    if k.ndim > 2 or (k.ndim == 1 and k.shape != (m,)) or (k.ndim == 2 and k.shape != (m, m)):
        raise ValueError(
            f"{name} must be a scalar, a ({m},) vector or a ({m}, {m}) matrix, got shape {k.shape}"
        )
    if not np.isfinite(k).all():
        raise ValueError(f"{name} = {gain!r}: contains NaN or Inf")
    if k.ndim < 2:
        if not (k >= 0.0).all():
            raise ValueError(f"{name} = {gain!r}: must be >= 0")
        return k
    if not np.allclose(k, k.T, rtol=1e-10, atol=1e-12 * np.abs(k).max(initial=0.0)):
        raise ValueError(f"{name} must be a symmetric positive semidefinite matrix: it is not symmetric")
    smallest = float(np.linalg.eigvalsh(k).min()) if m else 0.0
    if smallest < -1e-12 * max(np.abs(k).max(initial=0.0), 1.0):
        raise ValueError(f"{name} must be positive semidefinite: smallest eigenvalue {smallest}")
    return k


def _apply(k: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``K v`` for a checked gain: scalar or vector (diagonal) multiplies, matrix multiplies as a matrix."""
    return k @ v if type(k) is np.ndarray and k.ndim == 2 else k * v


def pd_wrench(
    error: np.ndarray, error_rate: np.ndarray, kp: Gain, kd: Gain, *, validate: bool = True
) -> np.ndarray:
    """Desired wrench of a motion task, ``w = −K_P e − K_D ė`` (eq. 2; signs: module docstring).

    With ``e = s − s*`` below the goal (``e < 0``) the wrench pushes toward it; with the
    task moving (``ė = J v`` for a fixed goal) it damps the motion.

    Args:
        error: (m,) task error ``e = s − s*``.
        error_rate: (m,) its time derivative ``ė``.
        kp, kd: gains: a scalar, an (m,) vector (diagonal gain) or an (m, m) symmetric
            positive semidefinite matrix; values >= 0.
        validate: check shapes, finiteness and gains. A caller that checked them once
            (a controller at construction, with :func:`check_gain`) may skip it every tick.

    Returns:
        (m,) desired task wrench ``w``.

    Raises:
        ValueError: shapes disagree, a value is not finite, a gain is negative or a gain
            matrix is not symmetric positive semidefinite.
    """
    if validate:
        error = vector("error", error)
        m = error.shape[0]
        error_rate = vector("error_rate", error_rate, m)
        kp, kd = check_gain("kp", kp, m), check_gain("kd", kd, m)
    return -_apply(kp, error) - _apply(kd, error_rate)


@dataclass(frozen=True)
class ForceWrench:
    """One step of a force task's law (eq. 3).

    Attributes:
        wrench: (m,) desired task wrench ``w = w* − K_P e_w − K_I ∫ e_w dt``.
        error: (m,) ``e_w = w_measured − w*``.
        integral: (m,) ``∫ e_w dt`` after this step (the caller's state) [wrench·s].
    """

    wrench: np.ndarray
    error: np.ndarray
    integral: np.ndarray


def pi_force_wrench(
    w_des: np.ndarray,
    w_measured: np.ndarray,
    integral: np.ndarray,
    dt: float,
    kp: Gain,
    ki: Gain,
    *,
    activity: float | np.ndarray = 1.0,
    validate: bool = True,
) -> ForceWrench:
    """Integrate a force task's error over ``dt`` and return its desired wrench (eq. 3).

    ``integral ← integral + activity · e_w · dt`` (backward Euler; the anti-windup of the
    module docstring), then ``w = w* − K_P e_w − K_I integral``.

    Args:
        w_des: (m,) desired wrench ``w*`` applied on the environment (the feed-forward).
        w_measured: (m,) measured wrench the robot applies on the environment.
        integral: (m,) ``∫ e_w dt`` before this step [wrench·s] (zeros at the start).
        dt: time step [s], finite and > 0.
        kp, ki: gains as in :func:`pd_wrench`.
        activity: in [0, 1], how much the task acts this step (``1 − α_ii``); a scalar, or
            (m,) per row (several tasks stacked in one call).
        validate: as in :func:`pd_wrench` (also checks ``integral``, ``dt``, ``activity``).

    Raises:
        ValueError: shapes other than (m,), a non-finite value, ``dt`` not > 0,
            ``activity`` outside [0, 1], or a bad gain; each named.
    """
    if validate:
        w_des = vector("w_des", w_des)
        m = w_des.shape[0]
        w_measured = vector("w_measured", w_measured, m)
        integral = vector("integral", integral, m)
        dt = positive("dt", dt, unit="s")
        activity = per_axis("activity", activity, m)
        if not ((activity >= 0.0) & (activity <= 1.0)).all():
            raise ValueError(f"activity = {activity}: every value must be in [0, 1]")
        kp, ki = check_gain("kp", kp, m), check_gain("ki", ki, m)
    e_w = w_measured - w_des
    integral = integral + activity * dt * e_w
    return ForceWrench(wrench=w_des - _apply(kp, e_w) - _apply(ki, integral), error=e_w, integral=integral)
