"""The compiled DCM stabilizer tick and support-polygon projection against their numpy versions, to
1e-12: random convex polygons (either orientation, repeated and in-line vertices), points inside and
outside, NaN measurements, offsets at their bound, hands' loads; and the same refusals (ValueError)."""

import numpy as np
import pytest
from kernel_paths import compiled_kernels

from drake_sot.stabilization import (
    HandLoad,
    StabilizerGains,
    project_into_polygon_numpy,
    stabilizer_step,
    stabilizer_step_numpy,
)
from drake_sot.support import sole_corners, support_polygon_numpy


def _polygon(rng: np.random.Generator) -> np.ndarray:
    """A convex polygon around the origin: 3-9 vertices on an ellipse, sometimes clockwise, with a
    repeated vertex or one in line with its neighbours."""
    k = int(rng.integers(3, 10))
    angles = np.sort(rng.uniform(0.0, 2 * np.pi, size=k))
    angles = np.unique(np.round(angles, 3))
    if angles.size < 3:
        angles = np.array([0.0, 2.0, 4.0])
    centre = rng.normal(scale=0.2, size=2)
    vertices = centre + np.stack((0.15 * np.cos(angles), 0.08 * np.sin(angles)), axis=1)
    if rng.random() < 0.2:
        vertices = np.insert(vertices, 1, vertices[1], axis=0)  # repeated
    if rng.random() < 0.2:
        vertices = np.insert(vertices, 1, 0.5 * (vertices[0] + vertices[1]), axis=0)  # in line
    return vertices[::-1].copy() if rng.random() < 0.3 else vertices


def _close(a, b) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b))
    finite = ~np.isnan(b)
    assert np.abs(a[finite] - b[finite]).max(initial=0.0) <= 1e-12 * (
        1.0 + np.abs(b[finite]).max(initial=0.0)
    )


@pytest.mark.parametrize("seed", range(60))
def test_the_projection_matches_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(seed)
    polygon = _polygon(rng)
    margin = float(rng.choice([0.0, 0.005, 0.02]))
    for point in rng.normal(scale=0.3, size=(6, 2)):
        try:
            expected = project_into_polygon_numpy(polygon, point, margin)
        except ValueError:
            with pytest.raises(ValueError):
                core.project_into_polygon(polygon, point, margin)
            continue
        _close(core.project_into_polygon(polygon, point, margin), expected)


@pytest.mark.parametrize(
    "polygon, point, margin",
    [
        (np.array([[0.0, 0.0], [1.0, 0.0]]), np.zeros(2), 0.0),  # 2 vertices
        (np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), np.zeros(2), 0.0),  # in line
        (np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]), np.zeros(2), 0.0),  # crossed
        (np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.zeros(2), 5.0),  # margin > inradius
        (np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([np.nan, 0.0]), 0.0),
        (np.array([[0.0, 0.0], [1e7, 0.0], [0.0, 1.0]]), np.zeros(2), 0.0),
    ],
)
def test_the_projection_refuses_what_numpy_refuses(polygon, point, margin):
    core = compiled_kernels()
    with pytest.raises(ValueError):
        project_into_polygon_numpy(polygon, point, margin)
    with pytest.raises(ValueError):
        core.project_into_polygon(polygon, point, margin)


@pytest.mark.parametrize("seed", range(60))
def test_a_stabilizer_tick_matches_numpy(seed):
    compiled_kernels()
    rng = np.random.default_rng(500 + seed)
    polygon = _polygon(rng)
    gains = StabilizerGains(
        max_offset=float(rng.choice([0.001, 0.1])), margin=float(rng.choice([0.0, 0.005]))
    )
    state = [rng.normal(scale=0.02, size=2) for _ in range(3)]
    if seed % 5 == 0:
        state[2] = np.full(2, np.nan)  # nothing filtered yet
    zmp = np.full(2, np.nan) if seed % 7 == 0 else rng.normal(scale=0.05, size=2)
    hands = None
    if seed % 3 == 0:
        wrenches = rng.normal(scale=5.0, size=(2, 6))
        hands = HandLoad(wrenches=wrenches, points=rng.normal(scale=0.3, size=(2, 3)), mass=60.0)
    kwargs = {
        "com_ref": rng.normal(scale=0.05, size=2),
        "com_vel_ref": rng.normal(scale=0.1, size=2),
        "zmp_ref": rng.normal(scale=0.05, size=2),
        "com": rng.normal(scale=0.05, size=2),
        "com_vel": rng.normal(scale=0.3, size=2),
        "zmp": zmp,
        "polygon": polygon,
        "omega": 3.5,
        "dt": 0.005,
        "gains": gains,
        "hands": hands,
    }
    try:
        expected = stabilizer_step_numpy(*state, **kwargs)
    except ValueError:
        with pytest.raises(ValueError):
            stabilizer_step(*state, **kwargs)
        return
    got = stabilizer_step(*state, **kwargs)  # the compiled path (the suite runs on it)
    for field in ("offset", "offset_rate", "zmp_filtered", "zmp_desired"):
        _close(getattr(got, field), getattr(expected, field))
    assert got.zmp_saturated == expected.zmp_saturated
    assert got.offset_saturated == expected.offset_saturated


@pytest.mark.parametrize("seed", range(40))
def test_the_support_polygon_matches_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(900 + seed)
    soles = [
        sole_corners(*rng.normal(scale=0.2, size=2), float(rng.uniform(-np.pi, np.pi)), (0.22, 0.12))
        for _ in range(int(rng.integers(1, 4)))
    ]
    points = np.vstack(soles)
    if seed % 4 == 0:
        points = np.vstack((points, points[:2], 0.5 * (points[0] + points[1])))  # repeated, on an edge
    np.testing.assert_array_equal(core.support_polygon(points), support_polygon_numpy(points))
