"""ForceArrows, PairLines and FollowCamera: what they write into a Meshcat recording, read back from the
replay page as Chromium would receive it."""

import math

import numpy as np
import pytest
from pydrake.common.value import Value
from pydrake.geometry import Rgba
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import SpatialInertia
from replay_html import replay_messages

from drake_sot.diagrams.world import loopback_meshcat
from drake_sot.systems.replay_view import (
    CAMERA_PATH,
    FAR_COLOUR,
    NEAR_COLOUR,
    Arrow,
    ArrowGroup,
    FollowCamera,
    ForceArrows,
    PairLines,
    pair_colour,
)
from drake_sot.systems.self_collision import ClosestPair

FPS = 30.0


def _plant() -> MultibodyPlant:
    plant = MultibodyPlant(0.0)
    plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1))
    plant.Finalize()
    return plant


def _tracks(meshcat, path) -> dict:
    """The recorded tracks of ``path`` in a replay of ``meshcat``: property -> {frame: value}."""
    page = path.parent / "replay.html"
    meshcat.PublishRecording()
    page.write_text(meshcat.StaticHtml())
    (animation,) = [m for m in replay_messages(page) if m.get("type") == "set_animation"]
    return {
        str(a["path"]): {
            track["name"]: {key["time"]: key["value"] for key in track["keys"]}
            for track in a["clip"]["tracks"]
        }
        for a in animation["animations"]
    }


def _z_axis(quaternion_xyzw) -> np.ndarray:
    x, y, z, w = quaternion_xyzw
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


GROUP = ArrowGroup(
    "pulls",
    "a pull",
    Rgba(1, 0, 0, 1),
    100.0,
    6,
    (Arrow("box", (0.1, 0.0, 0.0), 3), Arrow("box", (0, 0, 0), 0)),
)


def test_an_arrow_starts_at_its_point_and_is_as_long_as_the_force_over_the_scale(tmp_path):
    meshcat = loopback_meshcat()
    plant = _plant()
    arrows = ForceArrows(meshcat, plant, [GROUP])
    context = arrows.CreateDefaultContext()
    X_WB = RigidTransform(RollPitchYaw(0.0, 0.0, math.pi / 2), [1.0, 2.0, 0.5])
    arrows.GetInputPort("body_poses").FixValue(context, [RigidTransform(), X_WB])
    # arrow 0: (0, 30, 40) N on the box's point (0.1, 0, 0), which the yaw of 90° puts at (1, 2.1, 0.5);
    # arrow 1: no force, hidden.
    arrows.GetInputPort("pulls").FixValue(context, [0.0, 0.0, 0.0, 0.0, 30.0, 40.0])
    meshcat.StartRecording(FPS, False)
    context.SetTime(1.0)
    arrows.ForcedPublish(context)
    context.SetTime(2.0)
    arrows.GetInputPort("pulls").FixValue(context, [0.0, 0.0, 0.0, np.nan, 0.0, 0.0])
    arrows.ForcedPublish(context)
    tracks = _tracks(meshcat, tmp_path / "x")

    first = tracks["/forces/pulls/0"]
    assert first[".visible"] == {30: True, 60: False}  # a NaN force hides the arrow
    assert first[".position"][30] == pytest.approx([1.0, 2.1, 0.5])
    assert _z_axis(first[".quaternion"][30]) == pytest.approx([0.0, 0.6, 0.8])
    head = tracks["/forces/pulls/0/head"][".position"][30]
    assert head == pytest.approx([0.0, 0.0, 0.5])  # 50 N at 100 N/m
    shaft = tracks["/forces/pulls/0/shaft"][".scale"][30]
    assert shaft[:2] == [1.0, 1.0] and 0.35 < shaft[2] < 0.5  # the head makes the rest
    assert tracks["/forces/pulls/1"][".visible"] == {30: False, 60: False}


def test_each_arrow_has_its_geometry_in_its_colour(tmp_path):
    meshcat = loopback_meshcat()
    ForceArrows(meshcat, _plant(), [GROUP])
    page = tmp_path / "replay.html"
    page.write_text(meshcat.StaticHtml())
    objects = {m["path"]: m["object"] for m in replay_messages(page) if m.get("type") == "set_object"}
    for i in (0, 1):
        for part, kind in (("shaft/cylinder", "CylinderGeometry"), ("head/cone", "CylinderGeometry")):
            scene = objects[f"/forces/pulls/{i}/{part}"]
            assert scene["geometries"][0]["type"] == kind, part
            assert scene["materials"][0]["color"] == 0xFF0000


@pytest.mark.parametrize(
    ("groups", "message"),
    [
        ([GROUP, GROUP], "two of one name"),
        ([ArrowGroup("g", "", Rgba(1, 0, 0, 1), 100.0, 4, (Arrow("box", (0, 0, 0), 2),))], "offset 2"),
        (
            [ArrowGroup("g", "", Rgba(1, 0, 0, 1), math.nan, 3, (Arrow("box", (0, 0, 0), 0),))],
            "newtons_per_metre",
        ),
    ],
    ids=["duplicate", "offset", "scale"],
)
def test_bad_arrow_groups_are_refused_by_name(groups, message):
    with pytest.raises(ValueError, match=message):
        ForceArrows(loopback_meshcat(), _plant(), groups)


def _camera_tracks(tmp_path, follow: bool) -> dict:
    meshcat = loopback_meshcat()
    camera = FollowCamera(meshcat, _plant(), "box")
    context = camera.CreateDefaultContext()
    camera.set_follow(context, follow)
    meshcat.StartRecording(FPS, False)
    for k, x in enumerate((0.0, 0.3, 0.6)):
        camera.GetInputPort("body_poses").FixValue(
            context, [RigidTransform(), RigidTransform([x, -0.2, 0.8])]
        )
        context.SetTime(k / FPS)
        camera.ForcedPublish(context)
    return _tracks(meshcat, tmp_path / "x")


def test_the_camera_follows_the_body_on_the_ground_unless_fixed(tmp_path):
    positions = _camera_tracks(tmp_path, True)[CAMERA_PATH][".position"]
    assert positions == {k: pytest.approx([x, -0.2, 0.0]) for k, x in enumerate((0.0, 0.3, 0.6))}
    assert CAMERA_PATH not in _camera_tracks(tmp_path, False)


def test_a_draw_at_frame_k_time_lands_on_frame_k(tmp_path):
    """8.2 s is frame 245 to Meshcat (floor(8.2 × 30) in floating point): the camera drawn at
    8.2 s must still be frame 246, the one the visualizer's 246th publish is."""
    meshcat = loopback_meshcat()
    camera = FollowCamera(meshcat, _plant(), "box")
    context = camera.CreateDefaultContext()
    camera.GetInputPort("body_poses").FixValue(context, [RigidTransform(), RigidTransform([1.0, 0.0, 0.8])])
    meshcat.StartRecording(FPS, False)
    context.SetTime(246 * (1 / FPS))
    camera.ForcedPublish(context)
    assert list(_tracks(meshcat, tmp_path / "x")[CAMERA_PATH][".position"]) == [246]


def _pair(distance: float, p_WCb, direction) -> ClosestPair:
    """A pair ``distance`` [m] apart, its point on B at ``p_WCb``, the one on A ``distance`` along
    the unit ``direction``."""
    p_WCa = np.asarray(p_WCb) + distance * np.asarray(direction)
    return ClosestPair("a", "b", "body_a", "body_b", distance, tuple(p_WCa), tuple(p_WCb), 0)


def test_a_pair_is_a_line_between_its_points_coloured_by_its_distance(tmp_path):
    """Two pairs of three rows: each drawn from its point on B towards the one on A, as long as
    their distance, in the colour of its distance (the first of 5 at d_i = 5 cm, the middle one
    at 3 cm, halfway to d_s = 1 cm), the third row hidden; then no pair: every row hidden."""
    meshcat = loopback_meshcat()
    lines = PairLines(meshcat, "taskSelf", 3, 0.01, 0.05)
    context = lines.CreateDefaultContext()
    pairs = (_pair(0.03, (1.0, 2.0, 0.5), (0.0, 0.6, 0.8)), _pair(0.05, (0.0, 0.0, 1.0), (1.0, 0.0, 0.0)))
    lines.GetInputPort("closest_pairs").FixValue(context, Value[object](pairs))
    meshcat.StartRecording(FPS, False)
    context.SetTime(1.0)
    lines.ForcedPublish(context)
    lines.GetInputPort("closest_pairs").FixValue(context, Value[object](()))
    context.SetTime(2.0)
    lines.ForcedPublish(context)
    tracks = _tracks(meshcat, tmp_path / "x")

    for row, (pair, colour) in enumerate(zip(pairs, (2, 0), strict=True)):
        path = f"/self_collision/taskSelf/{row}"
        assert tracks[path][".visible"] == {30: True, 60: False}
        assert tracks[path][".position"][30] == pytest.approx(pair.p_WCb)
        direction = (np.array(pair.p_WCa) - pair.p_WCb) / pair.distance
        assert _z_axis(tracks[path][".quaternion"][30]) == pytest.approx(direction)
        assert tracks[f"{path}/line"][".scale"][30] == pytest.approx([1.0, 1.0, pair.distance])
        shown = [c for c in range(5) if tracks[f"{path}/line/{c}"][".visible"][30]]
        assert shown == [colour]
    assert tracks["/self_collision/taskSelf/2"][".visible"] == {30: False, 60: False}


def test_each_colour_of_a_pair_line_has_its_geometry(tmp_path):
    """Row 0's line, a cylinder in each colour: green (the far colour) first, red (the near one)
    last."""
    meshcat = loopback_meshcat()
    PairLines(meshcat, "taskSelf", 1, 0.01, 0.05)
    page = tmp_path / "replay.html"
    page.write_text(meshcat.StaticHtml())
    objects = {m["path"]: m["object"] for m in replay_messages(page) if m.get("type") == "set_object"}
    colours = []
    for c in range(5):
        scene = objects[f"/self_collision/taskSelf/0/line/{c}/cylinder"]
        assert scene["geometries"][0]["type"] == "CylinderGeometry"
        colours.append(scene["materials"][0]["color"])
    assert _rgb(colours[0]) == pytest.approx(255 * FAR_COLOUR.rgba[:3], abs=1)
    assert _rgb(colours[-1]) == pytest.approx(255 * NEAR_COLOUR.rgba[:3], abs=1)
    assert len(set(colours)) == 5


def _rgb(colour: int) -> list[int]:
    """A Meshcat colour (0xRRGGBB) as [R, G, B], 0 to 255."""
    return [(colour >> 16) & 0xFF, (colour >> 8) & 0xFF, colour & 0xFF]


@pytest.mark.parametrize(
    ("distance", "colour"), [(0.08, 0), (0.05, 0), (0.04, 1), (0.03, 2), (0.02, 3), (0.01, 4), (-0.01, 4)]
)
def test_a_pair_colour_goes_from_the_first_at_d_i_to_the_last_at_d_s(distance, colour):
    assert pair_colour(distance, 0.01, 0.05) == colour


def test_pair_lines_refuse_an_activation_distance_not_beyond_the_margin():
    with pytest.raises(ValueError, match="'taskSelf': d_i = 0.01 m: must be > d_s = 0.01 m"):
        PairLines(loopback_meshcat(), "taskSelf", 2, 0.01, 0.01)
