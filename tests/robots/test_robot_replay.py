"""The recorded replay of a robot from example-robot-data shows its meshes (headless Chromium)."""

from __future__ import annotations

import numpy as np
import pytest
from headless import chromium, screenshot
from robot_data import robot_or_skip

from drake_sot.diagrams import reach
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow


def _replay_pixels(robot: str, tmp_path) -> np.ndarray:
    out = tmp_path / robot
    output = run_scenario(reach.SCENARIO, out, duration=0.1, record=True, parameters={"robot": robot})
    assert output.result.completed, output.result.failure
    return screenshot(out / "reach.html", tmp_path / f"{robot}.png")


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_replay_shows_the_robot_meshes_not_the_embedded_robot(name, tmp_path):
    robot_or_skip(name)
    if chromium() is None:
        pytest.skip("chromium is not installed (make test installs it with apt)")
    robot, embedded = _replay_pixels(name, tmp_path), _replay_pixels("embedded", tmp_path)
    colours = np.unique(np.round(robot.reshape(-1, 3) * 255).astype(int), axis=0)
    assert len(colours) > 50, "the replay rendered as a blank page"
    # Same camera, ground and lighting: only the robot differs. A robot ~1.5 % of the view.
    changed = np.abs(robot - embedded).max(axis=2) > 0.1
    assert changed.mean() > 0.003, f"only {changed.mean():.4f} of the pixels differ from the embedded robot's"
    # The meshes are shaded surfaces: many grey levels where the robot differs, not one flat colour.
    shades = np.unique(np.round(robot[changed] * 255).astype(int), axis=0)
    assert len(shades) > 100
