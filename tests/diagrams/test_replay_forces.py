"""The replay of ``walk_then_interact`` shows what happens: arrows for the contact forces at the
soles, the wrist sensors' readings, the partner's pulls and a push, which move and scale with the
logged forces; a camera that follows the logged pelvis; the scenario and the robot in the page's
title and a legend. Read back from the page (the messages headless Chromium receives), checked
against the run's npz logs and the plant's kinematics."""

import numpy as np
import pytest
from headless import chromium, screenshot
from replay_html import replay_messages

from drake_sot.diagrams import walk_then_interact as wti
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import run_scenario

FPS = 30.0  # the recording's frames per second (the visualizer's publish rate)
DURATION = 8.5  # [s] the walk (over near 5 s), then 1.5 s of the partner's pull (from 7 s)
PUSH = ExternalPush(8.0, "pelvis", (0.0, 60.0, 0.0), 0.2)
# [N/m] the scales the legend states, one per kind of arrow
SCALES = {"soles": 1000.0, "admittance_taskForce": 100.0, "partner": 100.0, "pushes": 500.0}


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay")
    output = run_scenario(wti.SCENARIO, out, duration=DURATION, pushes=[PUSH])
    assert output.result.completed, output.result.failure
    page = out / "walk_then_interact.html"
    messages = replay_messages(page)
    (animation,) = [m for m in messages if m.get("type") == "set_animation"]
    tracks = {
        str(a["path"]): {
            track["name"]: {key["time"]: key["value"] for key in track["keys"]}
            for track in a["clip"]["tracks"]
        }
        for a in animation["animations"]
    }
    return output, page, messages, tracks


def _at(arrays, frame: int) -> int:
    """The log sample at a frame's time (frames at multiples of 0.1 s fall on a logged tick)."""
    t = arrays["time"]
    k = int(np.searchsorted(t, frame / FPS - 1e-9))
    assert abs(t[k] - frame / FPS) < 1e-9
    return k


def _z_axis(quaternion_xyzw) -> np.ndarray:
    x, y, z, w = quaternion_xyzw
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def _shown(tracks, path: str, force: np.ndarray, scale: float, frame: int) -> None:
    """The arrow at ``path`` shows ``force`` [N] at ``frame``: visible, along it, |force|/scale long."""
    assert tracks[path][".visible"][frame] is True, (path, frame)
    length = np.linalg.norm(force) / scale
    assert tracks[f"{path}/head"][".position"][frame][2] == pytest.approx(length, rel=1e-6, abs=1e-9)
    assert _z_axis(tracks[path][".quaternion"][frame]) == pytest.approx(
        force / np.linalg.norm(force), abs=1e-6
    )


def _frames(tracks, path: str, start: float, end: float) -> list[int]:
    """The frames at multiples of 0.1 s in [start, end) [s] where the arrow is shown."""
    return [
        f
        for f, visible in tracks[path][".visible"].items()
        if visible and f % 3 == 0 and start <= f / FPS < end - 1e-9
    ]


def test_the_page_names_the_scenario_and_the_robot_and_has_a_legend(replay):
    _, page, _, _ = replay
    html = page.read_text()
    assert "<title>walk_then_interact on embedded (drake_sot replay)</title>" in html
    legend = html[html.index('<div id="drake-sot-legend"') :]
    for text in ("contact force on each sole", "wrist sensor", "partner", "push"):
        assert text in legend, text
    for scale in ("1000 N per m", "100 N per m", "500 N per m"):
        assert scale in legend


def test_every_force_has_its_arrows_geometry(replay):
    _, _, messages, _ = replay
    objects = {m["path"] for m in messages if m.get("type") == "set_object"}
    for group, count in (
        ("soles", 2),
        ("admittance_taskForce", 1),
        ("admittance_taskForceLH", 1),
        ("partner", 2),
        ("pushes", 1),
    ):
        for i in range(count):
            assert {f"/forces/{group}/{i}/shaft/cylinder", f"/forces/{group}/{i}/head/cone"} <= objects, group


def test_the_partner_and_wrist_arrows_show_the_logged_forces_at_the_hands(replay):
    output, _, _, tracks = replay
    arrays = output.arrays
    plant, info = output.setup.built.plant, output.setup.built.info
    context = plant.CreateDefaultContext()
    hands = output.setup.extras.hands  # right, left: the partner's order
    pulled = _frames(tracks, "/forces/partner/0", wti.GRIP_AT, DURATION)
    assert len(pulled) >= 10  # the partner pulls from 7 s on
    for frame in pulled:
        k = _at(arrays, frame)
        plant.SetPositions(context, info.model_instance, arrays["q"][k])
        for i, hand in enumerate(hands):
            force = arrays["partner_forces"][k, 3 * i : 3 * i + 3]
            _shown(tracks, f"/forces/partner/{i}", force, SCALES["partner"], frame)
            origin = plant.GetBodyByName(hand).EvalPoseInWorld(context).translation()
            assert tracks[f"/forces/partner/{i}"][".position"][frame] == pytest.approx(origin, abs=1e-6)
    measured = _frames(tracks, "/forces/admittance_taskForce/0", wti.GRIP_AT, DURATION)
    assert len(measured) >= 10
    for frame in measured:
        wrench = arrays["wrench/taskForce"][_at(arrays, frame)]
        _shown(tracks, "/forces/admittance_taskForce/0", wrench[3:], SCALES["admittance_taskForce"], frame)


def test_the_sole_arrows_carry_the_robot_and_follow_the_logged_contact_forces(replay):
    output, _, _, tracks = replay
    arrays = output.arrays
    plant = output.setup.built.plant
    weight = plant.CalcTotalMass(plant.CreateDefaultContext()) * 9.81
    standing = arrays["time"] < 0.9  # before the walk's first step
    total = arrays["sole_forces"][:, 2] + arrays["sole_forces"][:, 5]
    assert np.median(total[standing]) == pytest.approx(weight, rel=0.1)
    frames = _frames(tracks, "/forces/soles/0", 0.5, DURATION)
    assert len(frames) > 30
    for frame in frames:
        force = arrays["sole_forces"][_at(arrays, frame), :3]
        _shown(tracks, "/forces/soles/0", force, SCALES["soles"], frame)


def test_the_push_arrow_shows_only_while_the_push_lasts(replay):
    _, _, _, tracks = replay
    shown = [f for f, visible in tracks["/forces/pushes/0"][".visible"].items() if visible]
    assert shown and PUSH.time - 1e-9 <= min(shown) / FPS and max(shown) / FPS < PUSH.end + 1 / FPS
    for frame in shown:
        _shown(tracks, "/forces/pushes/0", np.array(PUSH.force), SCALES["pushes"], frame)


def test_the_camera_follows_the_logged_pelvis(replay):
    output, _, _, tracks = replay
    arrays = output.arrays
    plant, info = output.setup.built.plant, output.setup.built.info
    context = plant.CreateDefaultContext()
    camera = tracks["/Cameras/default"][".position"]
    frames = [f for f in camera if f % 3 == 0]
    assert frames[-1] / FPS > DURATION - 0.2
    for frame in frames:
        plant.SetPositions(context, info.model_instance, arrays["q"][_at(arrays, frame)])
        x, y, _ = plant.GetBodyByName(info.base_body).EvalPoseInWorld(context).translation()
        assert camera[frame] == pytest.approx([x, y, 0.0], abs=1e-6)
    assert camera[frames[-1]][0] > 0.4  # the robot walked 4 steps forward, and the camera with it


def test_chromium_draws_the_arrows_of_the_replay(replay, tmp_path):
    """At the page's first frames the robot stands: the two green arrows of its soles are drawn
    beside its feet (above the legend, which has a green swatch of its own)."""
    _, page, _, _ = replay
    if chromium() is None:
        pytest.skip("chromium is not installed (make test installs it with apt)")
    pixels = screenshot(page, tmp_path / "shot.png", size="1000,700")
    scene = pixels[: int(0.8 * pixels.shape[0])]
    r, g, b = scene[..., 0], scene[..., 1], scene[..., 2]
    green = (g > 0.4) & (g > 2 * r) & (g > 2 * b)
    assert green.sum() > 20, "no sole arrow drawn"
