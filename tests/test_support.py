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
