"""Rotation-vector calculus on SO(3): exp, log and the Jacobians of the log.

The orientation error of a 6D feature is the rotation vector ``e = log(R R*^T)``;
its time derivative needs the inverse *left* Jacobian of SO(3):
``d/dt log(X) = J_l^{-1}(log X) ω`` when ``dX/dt = [ω]_x X`` (ω in the world frame).
Pure numpy; no Drake.
"""

from __future__ import annotations

import math

import numpy as np

_SMALL = 1e-8


def hat(w: np.ndarray) -> np.ndarray:
    """The skew-symmetric matrix ``[w]_x`` (3, 3) with ``[w]_x v = w × v``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def exp(w: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of the rotation vector ``w`` (3,) [rad] (Rodrigues)."""
    theta = float(np.linalg.norm(w))
    W = hat(w)
    if theta < _SMALL:
        return np.eye(3) + W + 0.5 * W @ W
    return np.eye(3) + (np.sin(theta) / theta) * W + ((1.0 - np.cos(theta)) / theta**2) * W @ W


def log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) [rad] of the rotation matrix ``R`` (3, 3), angle in [0, π].

    Accurate near the identity and near π (where the axis is taken from the
    symmetric part of R).
    """
    vx, vy, vz = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    # atan2 keeps full precision at both ends, where arccos of the trace does not.
    theta = math.atan2(
        0.5 * math.sqrt(vx * vx + vy * vy + vz * vz), 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    )
    v = np.array([vx, vy, vz])
    if theta < 1e-6:
        return 0.5 * v
    if np.pi - theta < 1e-4:
        # The symmetric part is cosθ I + (1 - cosθ) a aᵀ: read the axis from it.
        cos_theta = np.cos(theta)
        A = (0.5 * (R + R.T) - cos_theta * np.eye(3)) / (1.0 - cos_theta)
        k = int(np.argmax(np.diag(A)))
        axis = A[:, k] / np.linalg.norm(A[:, k])
        if axis @ v < 0.0:  # the antisymmetric part, 2 sinθ a, fixes the sign
            axis = -axis
        return theta * axis
    return theta / (2.0 * math.sin(theta)) * v


def left_jacobian_inverse(w: np.ndarray) -> np.ndarray:
    """``J_l^{-1}(w)`` (3, 3): maps a world angular velocity to ``d/dt log(X)``, ``X = exp(w)``."""
    x, y, z = float(w[0]), float(w[1]), float(w[2])
    theta2 = x * x + y * y + z * z
    if theta2 < 1e-12:
        coef = 1.0 / 12.0
    else:
        theta = math.sqrt(theta2)
        coef = (1.0 - 0.5 * theta / math.tan(0.5 * theta)) / theta2
    # I - W/2 + coef W², with W² = w wᵀ - θ² I written out.
    return np.array(
        [
            [1.0 + coef * (x * x - theta2), 0.5 * z + coef * x * y, -0.5 * y + coef * x * z],
            [-0.5 * z + coef * x * y, 1.0 + coef * (y * y - theta2), 0.5 * x + coef * y * z],
            [0.5 * y + coef * x * z, -0.5 * x + coef * y * z, 1.0 + coef * (z * z - theta2)],
        ]
    )


def right_jacobian_inverse(w: np.ndarray) -> np.ndarray:
    """``J_r^{-1}(w) = J_l^{-1}(-w)`` (3, 3): the same for a body-frame angular velocity."""
    return left_jacobian_inverse(-np.asarray(w))
