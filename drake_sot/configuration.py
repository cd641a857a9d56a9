"""Integration on the configuration manifold of a free-flying robot.

Layout (Drake's quaternion floating joint first, then the joints):
``q = [qw, qx, qy, qz, x, y, z, joints...]`` (nq = nv + 1) and
``v = [ωx, ωy, ωz, vx, vy, vz, joint rates...]`` with ω and v the angular velocity
and the velocity of the base origin, both expressed in the world frame.
Pure numpy; no Drake.
"""

from __future__ import annotations

import numpy as np

from drake_sot import so3


def quaternion_to_rotation(wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a unit quaternion ``[w, x, y, z]``."""
    w, x, y, z = wxyz / np.linalg.norm(wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def quaternion_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` of two ``[w, x, y, z]`` quaternions."""
    aw, av = a[0], a[1:]
    bw, bv = b[0], b[1:]
    return np.concatenate(([aw * bw - av @ bv], aw * bv + bw * av + np.cross(av, bv)))


def rotation_vector_to_quaternion(w: np.ndarray) -> np.ndarray:
    """Unit quaternion ``[w, x, y, z]`` of the rotation vector ``w`` (3,) [rad]."""
    theta = float(np.linalg.norm(w))
    if theta < 1e-12:
        return np.concatenate(([1.0], 0.5 * w))  # first order, normalised by the caller
    return np.concatenate(([np.cos(0.5 * theta)], np.sin(0.5 * theta) * w / theta))


def integrate(q: np.ndarray, v: np.ndarray, dt: float, floating_base: bool = True) -> np.ndarray:
    """Configuration reached from ``q`` after moving at constant ``v`` for ``dt`` seconds.

    The free flyer moves on SE(3) with constant world-frame ω and base-origin
    velocity: ``R⁺ = exp(ω dt) R``, ``p⁺ = p + v dt``; the quaternion is normalised.
    Joints integrate linearly. Returns a new (nq,) array.
    """
    q_next = np.array(q, dtype=float)
    if not floating_base:
        q_next += dt * v
        return q_next
    dq = rotation_vector_to_quaternion(dt * v[:3])
    quat = quaternion_multiply(dq, q[:4])
    q_next[:4] = quat / np.linalg.norm(quat)
    q_next[4:7] += dt * v[3:6]
    q_next[7:] += dt * v[6:]
    return q_next


def difference(q0: np.ndarray, q1: np.ndarray, floating_base: bool = True) -> np.ndarray:
    """Velocity ``v`` (nv,) such that ``integrate(q0, v, 1) == q1`` (the inverse of integrate)."""
    if not floating_base:
        return np.asarray(q1, dtype=float) - q0
    R0 = quaternion_to_rotation(q0[:4])
    R1 = quaternion_to_rotation(q1[:4])
    return np.concatenate((so3.log(R1 @ R0.T), q1[4:7] - q0[4:7], q1[7:] - q0[7:]))
