"""Support polygon geometry against hand-checkable cases."""

import numpy as np
import pytest

from drake_sot.support import signed_distance_inside, sole_corners, support_polygon


def test_sole_corners_rotate_about_the_centre():
    corners = sole_corners(1.0, 2.0, np.pi / 2, (0.2, 0.1))
    expected = {(0.95, 2.1), (0.95, 1.9), (1.05, 2.1), (1.05, 1.9)}
    assert {tuple(np.round(c, 12)) for c in corners} == expected


def test_two_soles_hull_and_distances():
    left, right = sole_corners(0.0, 0.1, 0.0, (0.2, 0.1)), sole_corners(0.0, -0.1, 0.0, (0.2, 0.1))
    hull = support_polygon([left, right])
    assert len(hull) == 4  # the two rectangles span one rectangle 0.2 x 0.3
    assert signed_distance_inside(hull, np.array([0.0, 0.0])) == pytest.approx(
        0.1
    )  # 0.1 to the front/back edges
    assert signed_distance_inside(hull, np.array([0.0, 0.14])) == pytest.approx(0.01)
    assert signed_distance_inside(hull, np.array([0.0, 0.2])) == pytest.approx(-0.05)
    single = support_polygon([left])
    assert signed_distance_inside(single, np.array([0.0, 0.0])) < 0


def test_support_polygon_is_qhulls_hull_counter_clockwise():
    """The monotone chain gives the same cycle of vertices as qhull (scipy's ConvexHull, an
    independent algorithm), on sole pairs at random poses and on random point clouds."""
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(3)
    for _ in range(300):
        if rng.random() < 0.5:
            soles = [
                sole_corners(*(0.2 * rng.normal(size=2)), rng.uniform(-3, 3), (0.2, 0.1)) for _ in range(2)
            ]
        else:
            soles = [rng.normal(size=(int(rng.integers(3, 12)), 2))]
        points = np.vstack(soles)
        expected = points[ConvexHull(points).vertices]
        hull = support_polygon(soles)
        assert hull.shape == expected.shape
        start = int(np.flatnonzero(np.all(np.isclose(hull, expected[0]), axis=1))[0])
        np.testing.assert_allclose(np.roll(hull, -start, axis=0), expected)
