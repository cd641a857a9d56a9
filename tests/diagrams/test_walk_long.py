"""The ``walk_long`` scenario in physics: 30 steps (forward, turning both ways, sideways,
backward, stop), every landing on its footprint with no growth of the error, and the ZMP
measured by the ankle sensors inside the support polygon.

The support polygon is computed here, independently of the library: the soles' contact
spheres read from the scene graph, placed by the simulated robot's configuration, those
touching the ground (their centre within one radius + 1 mm of it), and their convex hull by
Andrew's monotone chain.
"""

import math

import numpy as np
import pytest
from pydrake.geometry import Sphere
from pydrake.math import RollPitchYaw

from drake_sot.diagrams import walk_long
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow

SETTLE = 10  # ticks (50 ms) after touch-down, when a landing is measured
TOUCHING = 1e-3  # [m] a contact sphere touches the ground when its bottom is below this


@pytest.fixture(scope="module")
def walk_long_run(tmp_path_factory):
    out_dir = tmp_path_factory.mktemp("walk_long")
    output = run_scenario(walk_long.SCENARIO, out_dir, record=False)
    assert output.result.completed, output.result.failure
    return output, out_dir


def _landings(output):
    """(step, measured [x, y, yaw] of its sole SETTLE ticks after touch-down), per planned step."""
    built, arrays = output.setup.built, output.arrays
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    phase = arrays["phase"][:, 0]
    # A landing ends a single-support phase (the generator's phase switches to double support).
    ticks = [k for k in range(1, len(phase)) if phase[k - 1] != 0 and phase[k] == 0]
    steps = output.setup.extras.steps
    assert len(ticks) == len(steps) == 30
    measured = []
    for k, step in zip(ticks, steps, strict=True):
        plant.SetPositions(context, info.model_instance, arrays["q"][k + SETTLE])
        X = plant.GetFrameByName(info.frames[f"{step.side}_foot"], info.model_instance).CalcPoseInWorld(
            context
        )
        measured.append((step, np.array([*X.translation()[:2], RollPitchYaw(X.rotation()).yaw_angle()])))
    return measured


def _errors(output):
    """Per landing: position error [m], yaw error [rad]."""
    pos, yaw = [], []
    for step, (x, y, th) in _landings(output):
        pos.append(math.hypot(x - step.x, y - step.y))
        yaw.append(abs(math.remainder(th - step.yaw, 2 * math.pi)))
    return np.array(pos), np.array(yaw)


def test_the_walk_has_every_kind_of_step(walk_long_run):
    """Forward, backward, sideways, turning left and right: read from the footprints."""
    output, _ = walk_long_run
    steps = output.setup.extras.steps
    yaws = np.array([s.yaw for s in steps])
    assert yaws.max() == pytest.approx(math.pi / 2) and yaws[-1] == pytest.approx(0.0)
    assert np.any(np.diff(yaws) > 0.3) and np.any(np.diff(yaws) < -0.3)  # both ways
    xs = np.array([s.x for s in steps])
    assert xs.max() - xs[0] > 1.2 and xs[-1] < xs.max() - 0.5  # forward, then backward
    ys = np.array([s.y for s in steps if s.side == "left"])
    assert ys[-1] - ys[0] > 0.25  # sideways to the left


def test_every_landing_is_within_2_cm_of_its_footprint(walk_long_run):
    output, _ = walk_long_run
    pos, yaw = _errors(output)
    print("landing errors [mm]:", np.round(1000 * pos, 1))
    print("yaw errors [deg]:", np.round(np.degrees(yaw), 2))
    print(f"max {1000 * pos.max():.1f} mm, mean {1000 * pos.mean():.1f} mm", end="; ")
    print(f"yaw max {np.degrees(yaw.max()):.2f}°, mean {np.degrees(yaw.mean()):.2f}°")
    assert pos.max() < 0.02, f"landing {int(pos.argmax())} is {1000 * pos.max():.1f} mm off"
    assert np.degrees(yaw.max()) < 3.0


def test_landing_errors_do_not_grow(walk_long_run):
    """Open loop, the landing error is a running sum of each step's placement error (2.4-3.6 mm
    per forward step, :mod:`drake_sot.anchoring`). Here the last 10 landings are no worse than
    the first 10 (margins: 1 mm on the mean, 2 mm on the largest), and over the forward
    steps 4 to 8 the error grows by less than 0.5 mm a step."""
    output, _ = walk_long_run
    pos, _ = _errors(output)
    first, last = pos[:10], pos[-10:]
    assert last.mean() <= first.mean() + 1e-3, (first.mean(), last.mean())
    assert last.max() <= first.max() + 2e-3, (first.max(), last.max())
    assert (pos[7] - pos[3]) / 4 < 0.5e-3, np.round(1000 * pos[:8], 2)


def _contact_points(output):
    """side → (body, (n, 3) sphere centres in the body frame, radii): the soles' contact spheres."""
    built = output.setup.built
    plant, info = built.plant, built.info
    inspector = built.diagram.GetSubsystemByName("scene_graph").model_inspector()
    points = {}
    for side in ("left", "right"):
        body = plant.GetFrameByName(info.frames[f"{side}_foot"], info.model_instance).body()
        centres, radii = [], []
        for geometry in plant.GetCollisionGeometriesForBody(body):
            shape = inspector.GetShape(geometry)
            if isinstance(shape, Sphere):
                centres.append(inspector.GetPoseInFrame(geometry).translation())
                radii.append(shape.radius())
        assert len(centres) == 4, f"{side} sole: {len(centres)} contact spheres"
        points[side] = (body, np.array(centres), np.array(radii))
    return points


def _hull(points: np.ndarray) -> np.ndarray:
    """Convex hull, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted(map(tuple, points))
    if len(pts) < 3:
        return np.array(pts)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def _inside(polygon: np.ndarray, p: np.ndarray) -> bool:
    """``p`` inside or on the counter-clockwise convex polygon (every edge has it on its left)."""
    if len(polygon) < 3:
        return False
    a, b = polygon, np.roll(polygon, -1, axis=0)
    cross = (b[:, 0] - a[:, 0]) * (p[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[0] - a[:, 0])
    return bool(np.all(cross >= -1e-12))


def test_measured_zmp_stays_in_the_support_polygon(walk_long_run):
    output, _ = walk_long_run
    built, arrays = output.setup.built, output.arrays
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    spheres = _contact_points(output)
    inside, defined = [], 0
    for q, zmp in zip(arrays["q"], arrays["zmp"], strict=True):
        if not np.all(np.isfinite(zmp)):
            continue
        defined += 1
        plant.SetPositions(context, info.model_instance, q)
        touching = []
        for body, centres, radii in spheres.values():
            X = plant.EvalBodyPoseInWorld(context, body)
            world = (X.rotation().matrix() @ centres.T).T + X.translation()
            touching += [c[:2] for c, r in zip(world, radii, strict=True) if c[2] - r < TOUCHING]
        inside.append(_inside(_hull(np.array(touching)), zmp) if len(touching) >= 3 else False)
    share = float(np.mean(inside))
    print(f"ZMP inside the support polygon in {100 * share:.2f} % of {defined} samples")
    assert defined > 0.95 * len(arrays["time"])  # the feet carried the robot throughout
    assert share >= 0.99


def test_walk_long_artefacts(walk_long_run):
    _, out_dir = walk_long_run
    for name in ("walk_long.svg", "walk_long.png", "walk_long.npz", "walk_long_zmp.png"):
        assert (out_dir / name).stat().st_size > 1000, name
