"""``drake-sot run --fixed-camera``: the replay's camera stays where it was put (the scenario's
replay otherwise follows the pelvis: tests/diagrams/test_replay_forces.py)."""

from replay_html import replay_messages

from drake_sot.app import cli
from drake_sot.systems.replay_view import CAMERA_PATH


def _animated_paths(page) -> set[str]:
    (animation,) = [m for m in replay_messages(page) if m.get("type") == "set_animation"]
    return {a["path"] for a in animation["animations"]}


def test_a_fixed_camera_is_not_animated_and_a_following_one_is(tmp_path):
    for fixed in (True, False):
        out = tmp_path / str(fixed)
        argv = ["run", "reach", "--duration", "0.3", "--out", str(out)]
        assert cli.main(argv + (["--fixed-camera"] if fixed else [])) == 0
        page = out / "reach.html"
        assert "<title>reach on embedded (drake_sot replay)</title>" in page.read_text()
        paths = _animated_paths(page)
        assert "/forces/soles/0" in paths
        assert (CAMERA_PATH in paths) is not fixed
