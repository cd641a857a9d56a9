"""What a run says of its self-collision avoidance: the embedded robot on a fixed base, its right
arm folded so that its forearm, hand and finger are 2.5 to 4 cm from the torso, holds that
posture for 0.2 s under ``taskSelfCollision`` (``drake-sot run`` of a scenario made here). The
npz holds each tick's rows by name, the run's summary prints the least distance and the pairs
within d_i at the end, and the replay draws those pairs; each checked against Drake's
signed-distance query asked on a collision model of the test's own at the logged reference
configuration."""

from __future__ import annotations

import contextlib
import io

import collision_queries
import numpy as np
import pytest
from replay_html import replay_messages

from drake_sot.app import cli
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.scenario import Scenario, ScenarioSetup
from drake_sot.models import half_sitting_configuration
from drake_sot.robots import make_robot_control_model

NAME = "fold_arm"
TASK = "taskSelfCollision"
D_S, D_I = 0.01, 0.045  # d_i clear of the feet's pairs, 4 and 5 cm apart (see Query.near)
FPS = 30.0  # the recording's frames per second
#: The right arm folded against the torso (half-sitting otherwise).
FOLDED = {"r_shoulder_pitch": -0.8, "r_shoulder_roll": -0.2, "r_shoulder_yaw": 0.5, "r_elbow": -2.3}


def _folded() -> np.ndarray:
    plant, info = make_robot_control_model("embedded", fixed_base=True)
    q = half_sitting_configuration(plant, info)
    for joint, angle in FOLDED.items():
        q[plant.GetJointByName(joint).position_start()] = angle
    return q


def _build(meshcat) -> ScenarioSetup:
    b = HumanoidSoTBuilder(fixed_base=True, q0=_folded(), meshcat=meshcat)
    b.add_self_collision_task(TASK, d_s=D_S, d_i=D_I)
    b.add_posture_task("taskPosture")
    return ScenarioSetup(b.build(stack=[TASK, "taskPosture"], solver="hqp"), [], 0.2)


class Query(collision_queries.Query):
    """The shared query on the embedded robot on a fixed base, its pairs within D_I as a list."""

    def __init__(self) -> None:
        super().__init__("embedded", fixed_base=True)

    def near(self, q: np.ndarray) -> list[tuple[float, frozenset, frozenset, np.ndarray, np.ndarray]]:
        """The pairs closer than D_I at ``q``, closest first: (distance, the shapes' names, the
        bodies' names, the witness points on A and on B in world)."""
        pairs = []
        for shapes, (distance, points) in super().near(q, D_I).items():
            (a, (body_a, p_a)), (b, (body_b, p_b)) = points.items()  # A's, then B's
            pairs.append((distance, shapes, frozenset((body_a, body_b)), p_a, p_b))
        return sorted(pairs, key=lambda pair: (pair[0], sorted(pair[1])))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("collision")
    stdout = io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stdout(stdout):
        patch.setitem(cli.SCENARIOS, NAME, Scenario(NAME, "the right arm folded against the torso", _build))
        status = cli.main(["run", NAME, "--duration", "0.2", "--out", str(out)])
    assert status == 0
    arrays = dict(np.load(out / f"{NAME}.npz"))
    return arrays, stdout.getvalue(), out / f"{NAME}.html", Query()


def _bodies(record, k: int) -> frozenset:
    return frozenset((str(record["body_a"][k]), str(record["body_b"][k])))


def test_the_npz_holds_each_ticks_pairs_by_name(run):
    """Every logged tick: the distances of the rows are those of the pairs the query finds within
    d_i at the logged reference q, closest first, NaN beyond; each row's pair index names, through
    ``collision/<task>/pairs``, the shapes of the pair at that distance."""
    arrays, _, _, query = run
    distance, pair = arrays[f"collision/{TASK}/distance"], arrays[f"collision/{TASK}/pair"]
    record = arrays[f"collision/{TASK}/pairs"]
    assert list(arrays[f"collision/{TASK}/margins"]) == [D_S, D_I]
    assert distance.shape == pair.shape == (len(arrays["time"]), 16) and len(arrays["time"]) >= 40
    assert pair.dtype.kind == "i"
    for k in range(len(arrays["time"])):
        near = query.near(arrays["q_ref"][k])
        assert len(near) >= 4  # the forearm, the hand and the finger near the torso; the feet
        np.testing.assert_allclose(distance[k, : len(near)], [d for d, *_ in near], atol=1e-9)
        assert np.isnan(distance[k, len(near) :]).all() and (pair[k, len(near) :] == -1).all()
        by_shapes = {shapes: d for d, shapes, *_ in near}
        for d, index in zip(distance[k, : len(near)], pair[k, : len(near)], strict=True):
            shapes = frozenset((str(record["shape_a"][index]), str(record["shape_b"][index])))
            assert by_shapes[shapes] == pytest.approx(d, abs=1e-9)


def test_the_summary_prints_the_least_distance_and_the_pairs_within_d_i_at_the_end(run):
    arrays, stdout, _, query = run
    lines = [line for line in stdout.splitlines() if line.startswith(f"{TASK}: ")]
    assert len(lines) == 2, stdout
    least, at_end = lines
    time = arrays["time"]
    first = [(query.near(q)[0], t) for t, q in zip(time, arrays["q_ref"], strict=True)]
    (d, _, bodies, *_), t = min(first, key=lambda item: item[0][0])  # the earliest of equal ones
    assert f"least distance {d:.4f} m ({_named(least, bodies)}) at t = {t:.3f} s" in least
    assert f"outside the margin d_s = {D_S:g} m" in least
    near = query.near(arrays["q_ref"][-1])
    closest = {}
    for distance, _, pair, *_ in near:
        closest.setdefault(pair, distance)
    expected = ", ".join(f"{_named(at_end, pair)} {distance:.4f} m" for pair, distance in closest.items())
    assert at_end == f"{TASK}: at the end (t = {time[-1]:.3f} s), closer than d_i = {D_I:g} m: {expected}"
    assert {"r_forearm", "torso"} <= set().union(*closest)


def _named(line: str, bodies: frozenset) -> str:
    """The pair of bodies as ``line`` writes it (either order)."""
    a, b = sorted(bodies)
    return f"{a}–{b}" if f"{a}–{b}" in line else f"{b}–{a}"


def test_the_replay_draws_the_pairs_within_d_i_between_their_witness_points(run):
    """At the last frame (t = 0.2 s): one visible line per pair the query finds within d_i, from
    its point on B to its point on A, in the colour of its distance (rounded share of the way
    from d_i to d_s, in 4 steps); the other rows hidden. The legend names the task."""
    arrays, _, page, query = run
    (animation,) = [m for m in replay_messages(page) if m.get("type") == "set_animation"]
    tracks = {
        str(a["path"]): {
            track["name"]: {key["time"]: key["value"] for key in track["keys"]}
            for track in a["clip"]["tracks"]
        }
        for a in animation["animations"]
    }
    frame = round(0.2 * FPS)
    near = query.near(arrays["q_ref"][-1])
    drawn = []
    for row in range(16):
        path = f"/self_collision/{TASK}/{row}"
        if not tracks[path][".visible"][frame]:
            continue
        start = np.array(tracks[path][".position"][frame])
        x, y, z, w = tracks[path][".quaternion"][frame]
        axis = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
        length = tracks[f"{path}/line"][".scale"][frame][2]
        colours = [c for c in range(5) if tracks[f"{path}/line/{c}"][".visible"][frame]]
        drawn.append((start, start + length * axis, colours))
    assert len(drawn) == len(near)
    for distance, _, _, p_WCa, p_WCb in near:
        colour = min(4, max(0, round(4 * (D_I - distance) / (D_I - D_S))))
        matches = [
            line
            for line in drawn
            if np.allclose(line[0], p_WCb, atol=1e-6) and np.allclose(line[1], p_WCa, atol=1e-6)
        ]
        assert matches and all(line[2] == [colour] for line in matches), (distance, p_WCa, p_WCb)
    html = page.read_text()
    legend = html[html.index('<div id="drake-sot-legend"') :]
    assert f"{TASK}: pairs of collision shapes closer than {D_I:g} m" in legend
