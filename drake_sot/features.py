"""Feature equations: errors ``e = s - s*``, their Jacobians and reference feed-forward.

Pure numpy; the Drake systems in ``drake_sot.systems.features`` are thin adapters over
these functions. Frame Jacobians follow Drake's convention: a (6, nv) matrix whose rows
are ``[ω; v]`` (angular velocity, then the velocity of the frame origin), both in the
world frame. A 6D feature orders its components ``[x, y, z, rx, ry, rz]``: translation
first, then the rotation vector, as the original SoT's ``FeaturePoint6d``. A visual point
(:func:`visual_point`) is the image of a world point in a pinhole camera, in normalised
image coordinates.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from drake_sot import so3

SelectionLike = str | Sequence[bool] | Sequence[int] | None


def selection_indices(selection: SelectionLike, size: int, *, name: str = "selection") -> np.ndarray:
    """Indices of the selected components of a feature of ``size`` components.

    ``selection`` is None (all), a string of '0'/'1' flags in component order
    (``"001000"`` selects z alone for a 6D feature), or a sequence of booleans.
    Raises ValueError naming the bad value when it has the wrong length, a character
    other than 0/1, or selects nothing.
    """
    if selection is None:
        return np.arange(size)
    if isinstance(selection, str):
        if len(selection) != size or set(selection) - {"0", "1"}:
            raise ValueError(f"{name} {selection!r} must be {size} characters of '0'/'1' (one per component)")
        flags = np.array([c == "1" for c in selection])
    else:
        flags = np.asarray(selection, dtype=bool)
        if flags.shape != (size,):
            raise ValueError(f"{name} has {flags.size} flags, expected {size} (one per component)")
    indices = np.flatnonzero(flags)
    if indices.size == 0:
        raise ValueError(f"{name} {selection!r} selects no component")
    return indices


def point6d(
    R: np.ndarray,
    p: np.ndarray,
    J: np.ndarray,
    R_des: np.ndarray,
    p_des: np.ndarray,
    velocity_des: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """6D pose error of a frame with respect to a desired pose, all in the world frame.

    ``e = [p - p*; log(R R*ᵀ)]``; its Jacobian is exact:
    ``J_e = [J_v; J_l⁻¹(e_o) J_ω]`` with ``J_l`` the left Jacobian of SO(3).

    Args:
        R, p: frame orientation (3, 3) and origin position (3,) [m].
        J: frame Jacobian (6, nv), rows ``[ω; v]``.
        R_des, p_des: desired orientation and position.
        velocity_des: desired spatial velocity ``[v*; ω*]`` (6,) of the reference
            [m/s, rad/s], world frame; None for a still reference.
    Returns:
        ``(e (6,), J_e (6, nv), feedforward (6,))`` where ``feedforward = -∂e/∂t``.
    """
    # ndarray.dot rather than @ on these small arrays: ~1 µs less a product (numpy 2's matmul dispatch).
    e_o = so3.log(R.dot(R_des.T))
    e = np.concatenate((p - p_des, e_o))
    J_e = np.concatenate((J[3:], so3.left_jacobian_inverse(e_o).dot(J[:3])))
    if velocity_des is None:
        feedforward = np.zeros(6)
    else:
        # X = R R*ᵀ moves as dX/dt = -X [ω*]ₓ when only the reference moves.
        feedforward = np.concatenate((velocity_des[:3], so3.right_jacobian_inverse(e_o) @ velocity_des[3:]))
    return e, J_e, feedforward


def point6d_relative(
    R_a: np.ndarray,
    p_a: np.ndarray,
    J_a: np.ndarray,
    R_b: np.ndarray,
    p_b: np.ndarray,
    J_b: np.ndarray,
    R_des: np.ndarray,
    p_des: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Error of the pose of frame a expressed in frame b, against a desired relative pose.

    With ``R_ba = R_bᵀ R_a`` and ``p_ba = R_bᵀ (p_a - p_b)``:
    ``e = [p_ba - p*; log(R_ba R*ᵀ)]``; exact Jacobian
    ``J_e = [R_bᵀ (J_va - J_vb + [p_a - p_b]ₓ J_ωb); J_l⁻¹(e_o) R_bᵀ (J_ωa - J_ωb)]``.

    Args:
        R_a, p_a, J_a: pose and Jacobian (6, nv, rows ``[ω; v]``) of the moving frame.
        R_b, p_b, J_b: the same for the reference frame.
        R_des, p_des: desired pose of a in b.
    Returns:
        ``(e (6,), J_e (6, nv))``.
    """
    d = p_a - p_b
    R_ba = R_b.T @ R_a
    e_o = so3.log(R_ba @ R_des.T)
    e = np.concatenate((R_b.T @ d - p_des, e_o))
    J_lin = R_b.T @ (J_a[3:] - J_b[3:] + so3.hat(d) @ J_b[:3])
    J_ang = so3.left_jacobian_inverse(e_o) @ R_b.T @ (J_a[:3] - J_b[:3])
    return e, np.vstack((J_lin, J_ang))


#: Depth [m] of a point along the optical axis below which it does not count as in front of
#: the camera: the image coordinates X/Z, Y/Z of a point at or behind the camera plane are undefined.
MIN_DEPTH = 1e-3


def _depth(depth: float) -> float:
    """``depth`` if the point is in front of the camera, else ValueError naming it."""
    if not (math.isfinite(depth) and depth > MIN_DEPTH):
        raise ValueError(
            f"depth Z = {depth!r} m: the point must be in front of the camera (Z > {MIN_DEPTH} m)"
        )
    return depth


def interaction_matrix(x: float, y: float, depth: float) -> np.ndarray:
    """Interaction matrix of an image point (Chaumette & Hutchinson 2006): ``ṡ = L v_c``.

    For a point of the world, still, at normalised image coordinates ``s = (x, y) = (X/Z, Y/Z)``
    and depth ``Z`` in a camera moving with the spatial velocity ``v_c = [v; ω]`` (the linear
    velocity of the camera origin, then the angular velocity, both in the camera frame)::

        L = [ -1/Z    0    x/Z    x y    -(1 + x²)    y ]
            [   0   -1/Z   y/Z  1 + y²     -x y      -x ]

    Args:
        x, y: normalised image coordinates (no unit).
        depth: Z [m], > ``MIN_DEPTH``.
    Returns:
        L (2, 6).
    Raises:
        ValueError: ``depth`` not finite or not > ``MIN_DEPTH`` (the point is not in front
            of the camera), naming it.
    """
    inv_z = 1.0 / _depth(depth)
    return np.array(
        [
            [-inv_z, 0.0, x * inv_z, x * y, -(1.0 + x * x), y],
            [0.0, -inv_z, y * inv_z, 1.0 + y * y, -x * y, -x],
        ]
    )


def visual_point(
    R_WC: np.ndarray,
    p_WC: np.ndarray,
    J_C: np.ndarray,
    p_WP: np.ndarray,
    s_des: np.ndarray,
    point_velocity: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A world point P seen by a pinhole camera C: ``e = s - s*``, ``s = (X/Z, Y/Z)``.

    ``(X, Y, Z) = R_WCᵀ (p_WP - p_WC)`` is P in the camera frame, whose z axis is the optical
    axis (x to the image's right, y down); s is in normalised image coordinates (focal
    length 1: multiply by the focal length in pixels for pixels). The Jacobian goes through
    the camera frame's: with ``L`` the :func:`interaction_matrix`,
    ``J_e = L [R_WCᵀ J_v; R_WCᵀ J_ω]``. The point may move: ``∂s/∂t = (1/Z) [1 0 -x; 0 1 -y]
    R_WCᵀ ṗ_WP``, and the feed-forward is its opposite (the desired image point s* is still).

    Args:
        R_WC, p_WC: the camera's orientation (3, 3) and position (3,) [m] in world.
        J_C: the camera frame's Jacobian (6, nv), rows ``[ω; v]`` in world (Drake's).
        p_WP: the point's position in world (3,) [m].
        s_des: desired image point s* (2,) (``(0, 0)``: the image centre).
        point_velocity: ṗ_WP (3,) [m/s] in world; None for a still point.
    Returns:
        ``(e (2,), J_e (2, nv), feedforward (2,))`` with ``feedforward = -∂e/∂t``.
    Raises:
        ValueError: the point is not in front of the camera (Z <= ``MIN_DEPTH``), naming Z.
    """
    X, Y, Z = R_WC.T @ (p_WP - p_WC)
    Z = _depth(float(Z))
    x, y = X / Z, Y / Z
    L = interaction_matrix(x, y, Z)
    J_e = L[:, :3] @ (R_WC.T @ J_C[3:]) + L[:, 3:] @ (R_WC.T @ J_C[:3])
    e = np.array([x, y]) - s_des
    if point_velocity is None:
        feedforward = np.zeros(2)
    else:
        feedforward = -(np.array([[1.0, 0.0, -x], [0.0, 1.0, -y]]) @ (R_WC.T @ point_velocity)) / Z
    return e, J_e, feedforward
