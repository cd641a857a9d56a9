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


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` (3,) of two 3-vectors, on Python floats: faster than ``np.cross`` on
    3-vectors, which broadcasts and moves axes (``benchmarks/README.md``)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


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
    # Python floats (one tolist) rather than numpy scalars: a feature calls this at every control tick.
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R, dtype=float).tolist()
    vx, vy, vz = r21 - r12, r02 - r20, r10 - r01
    # atan2 keeps full precision at both ends, where arccos of the trace does not.
    theta = math.atan2(0.5 * math.sqrt(vx * vx + vy * vy + vz * vz), 0.5 * (r00 + r11 + r22 - 1.0))
    if theta < 1e-6:
        return np.array([0.5 * vx, 0.5 * vy, 0.5 * vz])
    if np.pi - theta < 1e-4:
        v = np.array([vx, vy, vz])
        # The symmetric part is cosθ I + (1 - cosθ) a aᵀ: read the axis from it.
        cos_theta = np.cos(theta)
        A = (0.5 * (R + R.T) - cos_theta * np.eye(3)) / (1.0 - cos_theta)
        k = int(np.argmax(np.diag(A)))
        axis = A[:, k] / np.linalg.norm(A[:, k])
        if axis @ v < 0.0:  # the antisymmetric part, 2 sinθ a, fixes the sign
            axis = -axis
        return theta * axis
    scale = theta / (2.0 * math.sin(theta))
    return np.array([scale * vx, scale * vy, scale * vz])


def left_jacobian_inverse(w: np.ndarray) -> np.ndarray:
    """``J_l^{-1}(w)`` (3, 3): maps a world angular velocity to ``d/dt log(X)``, ``X = exp(w)``."""
    x, y, z = np.asarray(w, dtype=float).tolist()
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
