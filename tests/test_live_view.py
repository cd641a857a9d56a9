"""The live view moves while a served run records its replay: ``drake-sot serve reach --out`` shows
the robot as it is simulated at the printed Meshcat address (its ``/download`` page is the live
scene), and still writes the whole replay; its live plot shows the task errors as logged."""

from __future__ import annotations

import base64
import json
import urllib.request

import numpy as np
import pytest
from replay_html import _DATA_URL, _Reader, replay_messages
from served import start, stop

from drake_sot.remote import Client

DURATION = 2.5  # [s] simulated; reach moves its right-hand target at 1 s
HAND = "/drake/visualizer/sot_humanoid/r_hand"

pytestmark = pytest.mark.slow  # a served run of 2.5 s (~16 s)


def _live_hand(view: str) -> np.ndarray:
    """The right hand's position [m] in the live scene now (the page Meshcat serves at /download)."""
    html = urllib.request.urlopen(view + "/download", timeout=30).read()
    messages = [_Reader(base64.b64decode(m)).value() for m in _DATA_URL.findall(html)]
    (hand,) = [m for m in messages if m.get("type") == "set_transform" and m["path"] == HAND]
    return np.array(hand["matrix"][12:15])  # column-major 4x4: the translation


def test_a_served_run_that_records_moves_in_the_live_view_and_writes_the_whole_replay(tmp_path):
    proc, host, port = start("--port", "0", "--duration", str(DURATION), "--out", str(tmp_path))
    try:
        view = proc.view.rsplit(" ", 1)[1].strip()
        with Client(host, port, timeout=120.0) as client:
            client.read("dyn.com")
            assert client.t < 1.0  # the target has not moved yet
            before = _live_hand(view)
            while client.t < 2.2:  # ~1.2 s after the target moved (gain 2.5: ~95 % of the way)
                client.read("dyn.com")
            after = _live_hand(view)
            stack = client.run("sot.list").split()
            plot_url = proc.plot.rsplit(" ", 1)[1].strip()
            plotted = json.loads(urllib.request.urlopen(plot_url + "data", timeout=30).read())
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        stop(proc)
    assert proc.returncode == 0, stderr
    moved = after - before
    # the target moved +25 cm in x and +20 cm in z: the drawn hand followed it (a frozen view: 0)
    assert moved[0] > 0.1 and moved[2] > 0.08, moved
    (animation,) = [m for m in replay_messages(tmp_path / "reach.html") if m.get("type") == "set_animation"]
    (track,) = [a["clip"] for a in animation["animations"] if a["path"] == HAND]
    (position,) = [t for t in track["tracks"] if t["name"] == ".position"]
    times = np.array([key["time"] for key in position["keys"]]) / track["fps"]
    assert times[-1] == pytest.approx(DURATION, abs=2.0 / track["fps"])  # the replay covers the run
    drawn = np.array(position["keys"][-1]["value"])
    assert np.linalg.norm(drawn - after) < 0.05  # where the live view showed it, give or take 0.3 s

    # the live plot: the stack, and the right hand's position error per sample as the run logged it
    assert plotted["stack"] == stack and "log10 |e| taskRH [m]" in plotted["names"]
    times = np.array(plotted["t"])
    assert times[-1] > 2.0 and np.allclose(np.diff(times), 0.1, atol=0.006)
    with np.load(tmp_path / "reach.npz") as npz:
        logged_t, logged = npz["time"], npz["error/taskRH"][:, :3]
    k = np.searchsorted(logged_t, times - 1e-9)  # the logged sample of each plotted tick
    expected = np.log10(np.maximum(np.linalg.norm(logged[k], axis=1), 1e-6))
    np.testing.assert_allclose(plotted["series"]["log10 |e| taskRH [m]"], expected, atol=0.02)
