"""MovingPoint (a point on a path, for a gaze or a reach target) and MeshcatMarker (drawing it)."""

import struct

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix

from drake_sot.diagrams.world import loopback_meshcat
from drake_sot.systems.marker import MeshcatMarker
from drake_sot.systems.moving_point import MovingPoint


def _circle(t):
    return np.array([np.cos(t), np.sin(t), 1.0]), np.array([-np.sin(t), np.cos(t), 0.0])


def test_moving_point_outputs_follow_the_path_in_time():
    R = RotationMatrix(RollPitchYaw(0.1, -0.2, 0.3))
    point = MovingPoint(_circle, orientation=R, name="ball")
    context = point.CreateDefaultContext()
    for t in (0.0, 0.7, 2.5):
        context.SetTime(t)
        p, v = _circle(t)
        np.testing.assert_array_equal(point.GetOutputPort("position").Eval(context), p)
        np.testing.assert_array_equal(point.GetOutputPort("velocity").Eval(context), v)
        pose = point.GetOutputPort("pose").Eval(context)
        np.testing.assert_array_equal(pose.translation(), p)
        np.testing.assert_allclose(pose.rotation().matrix(), R.matrix(), atol=1e-15)
        np.testing.assert_array_equal(point.GetOutputPort("spatial_velocity").Eval(context), [*v, 0, 0, 0])


def test_a_bad_path_is_reported_with_the_system_and_the_time():
    point = MovingPoint(lambda t: (np.array([np.nan, 0.0, 0.0]), np.zeros(3)), name="ball")
    context = point.CreateDefaultContext()
    context.SetTime(1.5)
    with pytest.raises(RuntimeError, match=r"'ball' at t = 1.5000 s: the path gave position \[nan"):
        point.GetOutputPort("position").Eval(context)
    short = MovingPoint(lambda t: (np.zeros(2), np.zeros(3)), name="flat")
    with pytest.raises(RuntimeError, match="expected two finite 3-vectors"):
        short.sample(0.0)


def _packed_matrix(packed: bytes) -> np.ndarray:
    """The 4 x 4 transform of a Meshcat ``set_transform`` message (msgpack: the key "matrix",
    an array16 header of 3 bytes, then 16 float64 items, each 0xcb + 8 big-endian bytes),
    column-major as three.js stores it."""
    start = packed.index(b"matrix") + len(b"matrix") + 3
    values = [struct.unpack(">d", packed[start + 9 * k + 1 : start + 9 * k + 9])[0] for k in range(16)]
    return np.array(values).reshape(4, 4, order="F")


def test_marker_draws_a_sphere_where_the_point_is():
    meshcat = loopback_meshcat()
    marker = MeshcatMarker(meshcat, "/drake_sot/object", radius=0.05)
    assert meshcat.HasPath("/drake_sot/object")
    context = marker.CreateDefaultContext()
    p = np.array([0.123, -0.456, 0.789])
    marker.GetInputPort("position").FixValue(context, p)
    marker.ForcedPublish(context)
    X = _packed_matrix(meshcat._GetPackedTransform("/drake_sot/object"))
    np.testing.assert_array_equal(X[:3, 3], p)
    np.testing.assert_array_equal(X[:3, :3], np.eye(3))


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(path=""), "path = '': must be a non-empty string"),
        (dict(radius=float("nan")), "radius = nan m: must be finite and > 0"),
        (dict(period=0.0), "period = 0.0 s: must be finite and > 0"),
    ],
)
def test_marker_arguments_are_checked(change, message):
    arguments = dict(path="/drake_sot/object") | change
    with pytest.raises(ValueError, match=message):
        MeshcatMarker(loopback_meshcat(), **arguments)
