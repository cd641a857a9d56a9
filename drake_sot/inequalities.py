"""Inequality tasks as velocity bounds (pure numpy): ``lower <= J q̇ <= upper``.

A quantity ``s(q)`` (m,) kept in ``[s_min, s_max]`` becomes, at the velocity level, the
bounds of the *velocity damper* (Faverjon and Tournassoud 1987; Kanoun, Lamiraux,
Wieber 2011):

    λ (s_min - s) <= ṡ = J q̇ <= λ (s_max - s)

with λ > 0 [1/s]: far from a bound the motion is free; approaching it, the velocity
toward it shrinks in proportion to the distance left, so ``s`` reaches the bound
exponentially and never crosses it (for a reference integrated with Euler steps of
``dt``, ``λ = 1/dt`` lets the bound be reached in one step and not passed: the joint
position limits of the Stack of Tasks' device). Outside ``[s_min, s_max]`` the bounds
drive ``s`` back at rate ``λ``. Rate bounds ``[r_min, r_max]`` on ``ṡ`` itself (joint
velocity limits) clip both: ``lower = clip(λ (s_min - s), r_min, r_max)`` and the same
for ``upper``, which keeps ``lower <= upper``.

For the distance ``d`` between two bodies the damper reads as in Kanoun, Lamiraux, Wieber
2011 (after Faverjon and Tournassoud 1987): with a safety margin ``d_s`` and an
activation distance ``d_i > d_s``, ``ḋ >= -ξ (d - d_s) / (d_i - d_s)`` for ``d < d_i``
(no row beyond), i.e. the damper above with ``s_min = d_s`` and ``λ = ξ / (d_i - d_s)``:
``ξ`` [m/s] is the approach speed allowed at the activation distance.

The functions here give ``s`` and ``J`` of the quantities the inequality tasks of
:mod:`drake_sot.systems.inequalities` use. Frame Jacobians follow Drake's convention
(as :mod:`drake_sot.features`): (6, nv), rows ``[ω; v]`` in the world frame.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from drake_sot import kernels, so3, validation
from drake_sot.support import sole_corners, support_polygon

__all__ = [
    "clearance_above_plane",
    "distance_damper_gain",
    "distance_rows",
    "feet_polygon",
    "outside",
    "point_distance",
    "point_in_frame",
    "polygon_edges",
    "velocity_bounds",
]


def velocity_bounds(
    s: np.ndarray,
    s_min: np.ndarray | float,
    s_max: np.ndarray | float,
    gain: float,
    rate_min: np.ndarray | float = -np.inf,
    rate_max: np.ndarray | float = np.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` on ``ṡ = J q̇`` keeping ``s`` in ``[s_min, s_max]`` (module docstring).

    ``s_min`` may be ``-inf`` and ``s_max`` ``+inf`` (no bound on that side), likewise the
    rates. Assumes ``s_min <= s_max``, ``rate_min <= rate_max`` and ``gain > 0`` (the
    systems check them once, at construction). Always ``lower <= upper``.
    """
    s = np.asarray(s, dtype=float)
    lower = gain * (s_min - s)
    upper = gain * (s_max - s)
    # np.minimum(np.maximum(·)) is np.clip at half its cost (a control tick calls this).
    return np.minimum(np.maximum(lower, rate_min), rate_max), np.minimum(
        np.maximum(upper, rate_min), rate_max
    )


def outside(s: np.ndarray, s_min: np.ndarray | float, s_max: np.ndarray | float) -> np.ndarray:
    """How far ``s`` is outside ``[s_min, s_max]``: ``s - clip(s, s_min, s_max)`` (0 inside)."""
    s = np.asarray(s, dtype=float)
    return s - np.minimum(np.maximum(s, s_min), s_max)


def point_in_frame(
    R: np.ndarray, p: np.ndarray, J: np.ndarray, offset: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """World position (3,) of a point fixed in a frame, and its translational Jacobian (3, nv).

    The point is ``p + R r`` with ``r`` = ``offset`` in the frame; its velocity is
    ``v + ω × (R r)``, so ``J_Q = J_v - [R r]_× J_ω``.

    Args:
        R, p: the frame's orientation (3, 3) and origin (3,) [m] in world.
        J: the frame Jacobian (6, nv), rows ``[ω; v]``.
        offset: the point in the frame (3,) [m].
    """
    r = R @ offset
    return p + r, J[3:] - so3.hat(r) @ J[:3]


def clearance_above_plane(
    point: np.ndarray, J_point: np.ndarray, normal: np.ndarray, origin: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Signed height (1,) [m] of a point above a plane and its Jacobian (1, nv).

    ``s = n · (p - o)`` with ``n`` the plane's unit normal (pointing to the side where
    ``s > 0``) and ``o`` a point of the plane; ``J = nᵀ J_p``.
    """
    return np.array([normal @ (point - origin)]), (normal @ J_point)[None, :]


def point_distance(
    p_a: np.ndarray, J_a: np.ndarray, p_b: np.ndarray, J_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance (1,) [m] between two points and its Jacobian (1, nv).

    ``s = ||p_a - p_b||``, ``J = uᵀ (J_a - J_b)`` with ``u = (p_a - p_b) / s``. Where the
    points coincide the gradient is undefined: the row is then zero (it constrains
    nothing) and ``s = 0``; a bound ``s >= d_min > 0`` is reported violated by
    ``d_min`` and cannot be restored from there, so keep the bound's margin.
    """
    delta = p_a - p_b
    s = float(np.linalg.norm(delta))
    if not s > 0.0:
        return np.zeros(1), np.zeros((1, J_a.shape[1]))
    return np.array([s]), ((delta / s) @ (J_a - J_b))[None, :]


def distance_damper_gain(name: str, margin: float, activation: float, speed: float) -> float:
    """``λ = ξ / (d_i - d_s)`` [1/s] of the distance damper (module docstring), the three checked.

    Args:
        name: what the parameters belong to, for the messages.
        margin: the safety margin ``d_s`` [m], finite >= 0.
        activation: the activation distance ``d_i`` [m], finite and > ``margin``.
        speed: ``ξ`` [m/s], finite > 0.

    Raises:
        ValueError: naming the parameter and its value: NaN, ±inf, a negative margin, an
            activation distance not above the margin, a speed that is not > 0.
    """
    margin = validation.nonnegative(f"{name}: safety margin d_s", margin, unit="m")
    activation = validation.finite(f"{name}: activation distance d_i", activation)
    if not activation > margin:
        raise ValueError(
            f"{name}: activation distance d_i = {activation!r} m: "
            f"must be > the safety margin d_s = {margin!r} m"
        )
    return validation.positive(f"{name}: ξ", speed, unit="m/s") / (activation - margin)


def distance_rows(
    distances: np.ndarray,
    normals: np.ndarray,
    J_a: np.ndarray,
    J_b: np.ndarray,
    margin: float,
    gain: float,
    rows: int,
    recovery: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(error, J, lower, upper)`` of the distance damper for k pairs of bodies, in ``rows`` rows.

    Pair i has signed distance ``d_i`` between witness points ``p_A`` on body A and ``p_B``
    on body B, and unit normal ``n_i`` from B to A (``(p_A - p_B) / |p_A - p_B|`` when
    ``d_i > 0``). Its row is ``J_d = n_iᵀ (J_A - J_B)``, the rate ``ḋ`` of the distance
    (the witness points move with their bodies), bounded below by ``λ (d_s - d_i)``
    (:func:`velocity_bounds`; module docstring), or, for a pair inside the margin
    (``d_i < d_s``) and a ``recovery`` gain, by ``recovery (d_s - d_i)``; ``error`` is
    ``d_i - d_s`` where negative, else 0 [m]. Rows k to ``rows - 1`` are zero and unbounded:
    they constrain nothing.

    Why a second gain inside the margin: the row is first order, and a pair sliding along
    another (the closest points moving over a box's edge) loses distance at second order within
    each period. Under ``λ`` alone the pair then settles where ``λ (d_s - d) T`` equals that
    loss per period ``T``, inside the margin by the loss over ``λ T`` (5 × it at λ = 43/s, T =
    5 ms); ``recovery`` = 1/T asks the lost distance back within one period, and the pair
    settles inside by about the loss of one period.

    Args:
        distances: (k,) signed distances [m], k <= ``rows``.
        normals: (k, 3) unit normals, from B to A, world frame.
        J_a, J_b: (k, 3, nv) translational Jacobians of the witness points on A and on B
            (world frame, w.r.t. v).
        margin: ``d_s`` [m]; gain: ``λ`` [1/s] (:func:`distance_damper_gain`).
        rows: the number of rows m.
        recovery: [1/s] the gain inside the margin (checked by the caller: finite, >= ``gain``);
            None: ``gain`` there too.

    Raises:
        ValueError: more pairs than rows.

    The compiled kernel computes it where built (:mod:`drake_sot.kernels`);
    :func:`distance_rows_numpy` is its oracle and fallback.
    """
    if kernels.compiled is not None:
        return kernels.compiled.distance_rows(distances, normals, J_a, J_b, margin, gain, rows, recovery)
    return distance_rows_numpy(distances, normals, J_a, J_b, margin, gain, rows, recovery)


def distance_rows_numpy(
    distances: np.ndarray,
    normals: np.ndarray,
    J_a: np.ndarray,
    J_b: np.ndarray,
    margin: float,
    gain: float,
    rows: int,
    recovery: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`distance_rows` in numpy: the compiled kernel's oracle and fallback."""
    k = len(distances)
    if k > rows:
        raise ValueError(f"{k} pairs of bodies: more than the {rows} rows")
    nv = J_a.shape[2]
    error, J = np.zeros(rows), np.zeros((rows, nv))
    lower, upper = np.full(rows, -np.inf), np.full(rows, np.inf)
    d = np.asarray(distances, dtype=float)
    J[:k] = np.einsum("ij,ijk->ik", normals, J_a - J_b)
    error[:k] = outside(d, margin, np.inf)
    lower[:k], upper[:k] = velocity_bounds(d, margin, np.inf, gain)
    if recovery is not None:
        lower[:k] = np.where(d < margin, recovery * (margin - d), lower[:k])
    return error, J, lower, upper


def polygon_edges(vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inward unit normals (k, 2) and offsets (k,) of the edges of a convex polygon.

    ``vertices`` (k, 2), counter-clockwise, k >= 3. A point ``c`` is inside when every
    ``normals @ c - offsets >= 0``; each value is its distance [m] to the edge's line.

    Raises:
        ValueError: not (k, 2) with k >= 3, not finite, a zero-length edge, or not
            counter-clockwise and convex (a vertex on the wrong side of an edge).
    """
    v = validation.matrix("polygon vertices", vertices, (None, 2))
    if v.shape[0] < 3:
        raise ValueError(f"polygon vertices: a polygon needs >= 3 vertices, got {v.shape[0]}")
    edge = np.roll(v, -1, axis=0) - v
    length = np.linalg.norm(edge, axis=1)
    if not (length > 0.0).all():
        raise ValueError(f"polygon vertices: edge {int(np.argmin(length > 0.0))} has zero length")
    normals = np.stack((-edge[:, 1], edge[:, 0]), axis=1) / length[:, None]
    offsets = np.einsum("ij,ij->i", normals, v)
    inside = normals @ v.T - offsets[:, None]  # (edges, vertices): every vertex on the inner side
    if not (inside >= -1e-12 * (1.0 + np.abs(v).max())).all():
        raise ValueError("polygon vertices must be counter-clockwise and convex")
    return normals, offsets


def feet_polygon(
    soles: Sequence[tuple[np.ndarray, np.ndarray]], contacts: Sequence[float], size: tuple[float, float]
) -> np.ndarray:
    """Support polygon (k, 2), counter-clockwise: the convex hull of the soles in contact.

    Args:
        soles: per foot, its sole frame's orientation (3, 3) and origin (3,) in world.
        contacts: per foot, > 0.5 when it is on the ground.
        size: the sole's (length, width) [m], centred on the sole frame.

    Raises:
        ValueError: no foot in contact.
    """
    corners = [
        sole_corners(p[0], p[1], float(np.arctan2(R[1, 0], R[0, 0])), size)
        for (R, p), c in zip(soles, contacts, strict=True)
        if c > 0.5
    ]
    if not corners:
        raise ValueError("no foot in contact: the support polygon is empty")
    return support_polygon(corners)
