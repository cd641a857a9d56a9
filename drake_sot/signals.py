"""The values that travel on abstract-valued ports between features, tasks and solvers.

Small immutable records of numpy arrays: matrices and structured values travel on
abstract-valued ports as small immutable dataclasses. Pure; no Drake.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FeatureSignal:
    """A feature's contribution to a task (Mansard et al. 2009, eq. 5-7).

    Attributes:
        error: ``e = s - s*`` (m,), the selected components only.
        jacobian: ``J = ∂e/∂q`` (m, nv), with respect to the generalized velocity v.
        feedforward: ``-∂e/∂t`` (m,): how the reference moves; a task adds it to its
            desired error rate so that a moving reference is tracked without lag.
    """

    error: np.ndarray
    jacobian: np.ndarray
    feedforward: np.ndarray


@dataclass(frozen=True)
class TaskSignal:
    """A task as the solver sees it: ``J q̇ = ė*`` with ``ė* = -λ e + feedforward``.

    Attributes:
        name: the task's name (the key the stack uses).
        error: ``e`` (m,).
        jacobian: ``J`` (m, nv).
        edot_des: ``ė*`` (m,).
    """

    name: str
    error: np.ndarray
    jacobian: np.ndarray
    edot_des: np.ndarray


@dataclass(frozen=True)
class BoundedTaskSignal:
    """An inequality task as the solver sees it: ``lower <= J q̇ <= upper`` row by row
    (a level of :func:`drake_sot.hqp.solve_hqp`; Escande, Mansard, Wieber 2014).

    Attributes:
        name: the task's name (the key the stack uses).
        error: (m,) how far the task's quantity is outside its allowed set, in the
            quantity's units (0 inside): what a plot of the task's error shows.
        jacobian: ``J`` (m, nv).
        lower: (m,) lower bounds of ``J q̇``; ``-inf`` where there is none.
        upper: (m,) upper bounds of ``J q̇``; ``+inf`` where there is none.
    """

    name: str
    error: np.ndarray
    jacobian: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


@dataclass(frozen=True)
class OperationalPoint:
    """A frame's pose and Jacobian at one configuration, in one value: what a pose feature reads
    from an operational point (``RobotKinematics``' ``<name>_frame`` output), one port
    evaluation instead of two.

    Attributes:
        rotation: ``R_WF`` (3, 3), the frame's orientation in world.
        translation: ``p_WF`` (3,) [m], the frame's origin in world.
        jacobian: (6, nv), rows ``[ω; v]`` (angular velocity, then the velocity of the frame
            origin, world frame), with respect to the generalized velocity v.
    """

    rotation: np.ndarray
    translation: np.ndarray
    jacobian: np.ndarray
