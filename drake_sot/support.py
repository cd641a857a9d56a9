"""Support polygons of rectangular soles, and point-in-polygon tests. Pure numpy/scipy."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial import ConvexHull


def sole_corners(x: float, y: float, yaw: float, size: tuple[float, float]) -> np.ndarray:
    """The 4 corners (4, 2) [m] of a sole of ``size`` = (length, width) centred at (x, y), turned by yaw."""
    half = 0.5 * np.array(size)
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * half
    c, s = np.cos(yaw), np.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + [x, y]


def support_polygon(soles: Sequence[np.ndarray]) -> np.ndarray:
    """Convex hull (k, 2), counter-clockwise, of the corners of the soles on the ground."""
    points = np.vstack(soles)
    return points[ConvexHull(points).vertices]


def signed_distance_inside(polygon: np.ndarray, point: np.ndarray) -> float:
    """Distance [m] from ``point`` to the boundary of a counter-clockwise convex polygon:
    positive inside, negative outside (then a lower bound of the distance to it)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    edge = b - a
    normal_in = np.stack((-edge[:, 1], edge[:, 0]), axis=1) / np.linalg.norm(edge, axis=1, keepdims=True)
    return float(np.min(np.einsum("ij,ij->i", point - a, normal_in)))
