"""Support polygons of rectangular soles, and point-in-polygon tests. Pure numpy/scipy."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from drake_sot import kernels


def sole_corners(x: float, y: float, yaw: float, size: tuple[float, float]) -> np.ndarray:
    """The 4 corners (4, 2) [m] of a sole of ``size`` = (length, width) centred at (x, y), turned by yaw."""
    half = 0.5 * np.array(size)
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * half
    c, s = np.cos(yaw), np.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + [x, y]


def support_polygon(soles: Sequence[np.ndarray]) -> np.ndarray:
    """Convex hull (k, 2), counter-clockwise, of the corners of the soles on the ground.

    Andrew's monotone chain on the few corners (8 for two soles): in plain Python about ten
    times faster than qhull (``scipy.spatial.ConvexHull``) at this size, which matters in the
    balance stabilizer's control tick, and compiled where built (:mod:`drake_sot.kernels`;
    :func:`support_polygon_numpy` is its oracle and fallback). Points on an edge are not vertices.
    """
    points = np.vstack(soles)
    if kernels.compiled is not None:
        return kernels.compiled.support_polygon(points)
    return support_polygon_numpy(points)


def support_polygon_numpy(points: np.ndarray) -> np.ndarray:
    """:func:`support_polygon` of the stacked corners ``points`` (n, 2) in Python: the compiled
    kernel's oracle and fallback."""
    xy = points.tolist()
    order = sorted(range(len(xy)), key=lambda i: (xy[i][0], xy[i][1]))

    def cross(o: int, a: int, b: int) -> float:
        return (xy[a][0] - xy[o][0]) * (xy[b][1] - xy[o][1]) - (xy[a][1] - xy[o][1]) * (xy[b][0] - xy[o][0])

    def chain(indices: list[int]) -> list[int]:
        hull: list[int] = []
        for i in indices:
            while len(hull) >= 2 and cross(hull[-2], hull[-1], i) <= 0.0:
                hull.pop()
            hull.append(i)
        return hull

    lower, upper = chain(order), chain(order[::-1])
    return points[lower[:-1] + upper[:-1]]


def signed_distance_inside(polygon: np.ndarray, point: np.ndarray) -> float:
    """Distance [m] from ``point`` to the boundary of a counter-clockwise convex polygon:
    positive inside, negative outside (then a lower bound of the distance to it)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    edge = b - a
    normal_in = np.stack((-edge[:, 1], edge[:, 0]), axis=1) / np.linalg.norm(edge, axis=1, keepdims=True)
    return float(np.min(np.einsum("ij,ij->i", point - a, normal_in)))
