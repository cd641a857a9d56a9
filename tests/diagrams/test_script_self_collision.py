"""``new TaskSelfCollision`` in a script: the self-collision inequality task
(``SelfCollisionAvoidance``) made, set and read by script lines, pushed below the joint limits. In
``examples/self_collision.sot`` the embedded humanoid standing on its feet pulls its right hand into
its chest: with the task no shape of the arm comes closer to the body than the margin ``d_s``,
without it the arm goes into the torso, both measured by Drake's signed-distance query on a
collision model of the test's own at every logged reference configuration and on the session's
simulated plant; ``get`` and ``pairs`` agree with that query; bad settings are refused naming
them."""

from __future__ import annotations

import re
from pathlib import Path

import collision_queries
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot.diagrams.script_entities import (
    MAX_APPROACH_SPEED,
    MAX_COLLISION_DISTANCE,
    MAX_COLLISION_PAIRS,
)
from drake_sot.diagrams.script_session import ScriptSession, SessionError
from drake_sot.script import Call, Name, Set, Signal, Vector, parse_value

TASK = "taskSelfCollision"
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "self_collision.sot"
#: [m, m, m/s] the example's settings (not the defaults); d_i clear of the feet's pairs, 4, 5 and 6
#: cm apart (``Query.near``).
D_S, D_I, XI = 0.02, 0.065, 1.0
ARM = ("r_forearm", "r_hand", "r_finger")


def _session(with_task: bool) -> ScriptSession:
    """The example script run (1.5 s), or without its lines that name the task."""
    text = EXAMPLE.read_text()
    for line in (
        f"set {TASK}.d_s {D_S}",
        f"set {TASK}.d_i {D_I}",
        f"set {TASK}.xi {XI}",
        f"set {TASK}.maxPairs 32",
    ):
        assert line in text
    if not with_task:
        text = "\n".join(line for line in text.splitlines() if TASK not in line)
    session = ScriptSession()
    session.run_script(text, source=EXAMPLE.name)
    return session


@pytest.fixture(scope="module")
def query() -> collision_queries.Query:
    return collision_queries.Query("embedded")


@pytest.fixture(scope="module")
def runs() -> dict[bool, ScriptSession]:
    return {with_task: _session(with_task) for with_task in (True, False)}


def _arm_distance(query: collision_queries.Query, q: np.ndarray) -> float:
    """The least signed distance [m] of a shape of the right arm to another shape at ``q`` (inf
    beyond 4.5 cm: clear of the feet's pairs, 4 and 5 cm apart)."""
    near = query.near(q, 0.045)
    arm = [d for d, points in near.values() if any(body in ARM for body, _ in points.values())]
    return min(arm, default=np.inf)


def _reference(session: ScriptSession) -> np.ndarray:
    """(samples, nq): the reference configuration the loop integrated, at every logged tick."""
    context = session.simulator.get_context()
    return session.built.loggers["q_ref"].FindLog(context).data().T


def _simulated_arm_distances(session: ScriptSession) -> list[float]:
    """At every logged sample, the least signed distance [m] of the simulated plant's right-arm
    shapes to the robot's other shapes, asked of the session's own SceneGraph (the logged state put
    in a context of the session's diagram)."""
    built = session.built
    plant, scene_graph = built.plant, built.diagram.GetSubsystemByName("scene_graph")
    context = built.diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    scene_context = scene_graph.GetMyContextFromRoot(context)
    inspector = scene_graph.model_inspector()
    arm = {g for body in ARM for g in plant.GetCollisionGeometriesForBody(plant.GetBodyByName(body))}
    log = built.loggers["state"].FindLog(session.simulator.get_context()).data().T
    out = []
    for state in log:
        plant.SetPositions(plant_context, built.info.model_instance, state[: plant.num_positions()])
        query = scene_graph.get_query_output_port().Eval(scene_context)
        out.append(
            min(
                (
                    p.distance
                    for p in query.ComputeSignedDistancePairwiseClosestPoints(max_distance=0.05)
                    if {p.id_A, p.id_B} & arm
                    and "ground" not in inspector.GetName(p.id_A) + inspector.GetName(p.id_B)
                ),
                default=np.inf,
            )
        )
    return out


def test_the_task_stops_the_arm_at_the_margin_and_without_it_the_arm_goes_into_the_torso(runs, query):
    """The damper is first order: as the hand slides past the pelvis's edge (0.2 s in) the
    reference gets about 2 mm inside d_s (``benchmarks/README.md``, bench_self_collision.py: 1-3 mm
    on boxes sliding along each other), 5 mm allowed. The simulated arm lags its reference (1 cm
    there): it never touches the body, and ends at the margin with its reference. Without the task
    the reference arm ends 3 cm and more inside the torso and the simulated one in contact with it."""
    with_task = [_arm_distance(query, q) for q in _reference(runs[True])]
    assert min(with_task) > D_S - 0.005
    assert abs(with_task[-1] - D_S) < 0.002
    simulated = _simulated_arm_distances(runs[True])
    assert min(simulated) > 0.0
    assert abs(simulated[-1] - D_S) < 0.002
    without = [_arm_distance(query, q) for q in _reference(runs[False])]
    assert without[-1] < -0.03
    assert _simulated_arm_distances(runs[False])[-1] < 0.001


def test_get_and_pairs_tell_the_rows_an_independent_query_finds(runs, query):
    """At the end of the run with the task: ``get taskSelfCollision.distances`` is the pairs closer
    than d_i at the reference configuration (``get dyn.q``), closest first, then NaN;
    ``pair_indices`` name those pairs (in the task's ``candidate_pairs``); ``taskSelfCollision.pairs``
    writes them by name, with their distances."""
    session = runs[True]
    q = parse_value(session.execute("get dyn.q")).array
    near = query.near(q, D_I)
    expected = sorted(distance for distance, _ in near.values())
    assert 2 < len(expected) < 32  # the arm's pairs and the feet's, within the 32 rows
    distances = _vector(session.execute(f"get {TASK}.distances"))
    assert distances.shape == (32,)
    np.testing.assert_allclose(distances[: len(expected)], expected, atol=1e-9)
    assert np.isnan(distances[len(expected) :]).all()
    indices = _vector(session.execute(f"get {TASK}.pair_indices"))
    candidates = session.system(TASK).candidate_pairs
    named = [
        frozenset((candidates[int(k)].shape_a, candidates[int(k)].shape_b)) for k in indices[: len(expected)]
    ]
    assert set(named) == set(near) and len(named) == len(near)
    assert (indices[len(expected) :] == -1).all()
    lines = session.execute(f"{TASK}.pairs").splitlines()
    assert len(lines) == len(expected)
    for line in lines:
        a, body_a, b, body_b, distance = re.fullmatch(
            r"(\S+) \((\S+)\) and (\S+) \((\S+)\): (\S+) m", line
        ).groups()
        found, points = near[frozenset((a, b))]
        assert float(distance) == pytest.approx(found, abs=1e-9)
        assert {a: body_a, b: body_b} == {shape: body for shape, (body, _) in points.items()}
    written = [float(line.rsplit(" ", 2)[-2]) for line in lines]
    assert written == sorted(written)  # closest first


def _vector(text: str) -> np.ndarray:
    """A vector as ``get`` writes it, ``[n](x,…)``, NaN entries included (``parse_value`` reads
    finite values only)."""
    size, entries = re.fullmatch(r"\[(\d+)\]\((.*)\)", text).groups()
    vector = np.array([float(x) for x in entries.split(",")])
    assert vector.shape == (int(size),)
    return vector


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("set t.d_s -0.01", "t.d_s = -0.01 m: must be finite and >= 0"),
        ("set t.d_s 2", "t.d_s = 2 m: must be at most 1 m"),
        ("set t.d_i 1e300", "t.d_i = 1e+300 m: must be at most 1 m"),
        ("set t.d_i [2](0.1,0.2)", "t.d_i must be a number, got [2](0.1,0.2)"),
        ("set t.xi 0", "t.xi = 0.0 m/s: must be finite and > 0"),
        ("set t.xi 11", "t.xi = 11 m/s: must be at most 10 m/s"),
        ("set t.maxPairs 0", "t.maxPairs = 0: must be an integer >= 1"),
        ("set t.maxPairs 2.5", "t.maxPairs = 2.5: must be an integer >= 1"),
        ("set t.maxPairs 1001", "t.maxPairs = 1001: must be an integer in [1, 1000]"),
        ("set t.maxPairs 1e300", "t.maxPairs = 1e+300: must be an integer in [1, 1000]"),
        ("set t.legPairs 2", "t.legPairs = 2: must be 1 (rows between the legs) or 0"),
        ("set t.legPairs yes", "t.legPairs = yes: must be 1 (rows between the legs) or 0"),
        (
            "set t.q [1](0)",
            "t.q takes no value: the reference configuration the loop integrates (the device's q)",
        ),
        ("t.pairs 3", "takes 0 argument(s) (pairs), got 1"),
    ],
)
def test_bad_settings_are_refused_naming_them(line, expected):
    session = ScriptSession()
    session.execute("new TaskSelfCollision t")
    with pytest.raises(SessionError) as caught:
        session.execute(line)
    assert str(caught.value) == f"{line}: {expected}"


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
@pytest.mark.parametrize("setting", ["d_s", "d_i", "xi", "maxPairs", "legPairs"])
def test_a_non_finite_setting_made_in_python_is_refused_naming_it(setting, value):
    """The parser reads no NaN or infinity; a command made in Python may hold one."""
    session = ScriptSession()
    session.execute("new TaskSelfCollision t")
    with pytest.raises(SessionError, match=rf"t\.{setting} = -?(nan|inf)"):
        session.execute(Set(Signal("t", setting), value))


def test_d_i_not_above_d_s_is_refused_at_the_build_naming_both_and_the_line():
    session = ScriptSession()
    session.run_script("new TaskSelfCollision t\nset t.d_s 0.05\nset t.d_i 0.05", source="s.sot")
    with pytest.raises(SessionError) as caught:
        session.execute("sot.push t")
    assert str(caught.value) == (
        "sot.push t: building 't' (TaskSelfCollision) (s.sot, line 1: new TaskSelfCollision t): "
        "'t': activation distance d_i = 0.05 m: must be > the safety margin d_s = 0.05 m"
    )


def test_settings_act_before_the_build_only_and_read_back():
    session = ScriptSession()
    session.run_script(
        "new TaskSelfCollision t\nset t.d_s 0.02\nset t.d_i 0.07\nset t.xi 0.5\nset t.maxPairs 4\n"
        "set t.legPairs 0"
    )
    assert "parameter maxPairs" in session.execute("t.help") and "pairs" in session.execute("t.help")
    assert session.execute("pool.listTask") == "t"
    assert "TaskSelfCollision: " in session.execute("pool.listClass")
    session.execute("sot.push t")
    read = {
        s: parse_value(session.execute(f"get t.{s}")) for s in ("d_s", "d_i", "xi", "maxPairs", "legPairs")
    }
    assert read == {"d_s": 0.02, "d_i": 0.07, "xi": 0.5, "maxPairs": 4, "legPairs": 0}
    task = session.system("t")
    assert (task.d_s, task.d_i, task.GetOutputPort("distances").size()) == (0.02, 0.07, 4)
    feet = {("l_foot", "r_foot"), ("r_foot", "l_foot")}
    assert not feet & {(p.body_a, p.body_b) for p in task.candidate_pairs}  # legPairs 0: no leg-leg pair
    with pytest.raises(SessionError, match="set t.d_s is a build-time command"):
        session.execute("set t.d_s 0.01")


def test_the_solver_is_the_hqp_with_the_task_and_stays_the_svd_without():
    """The SVD solver refuses an inequality task; a script that makes one gets the HQP, the others
    keep the SVD solver."""
    with_task = ScriptSession()
    with_task.run_script("new FeatureCoM f\nnew Task c\nc.add f\nnew TaskSelfCollision t\nsot.push t")
    assert with_task.built.sot.solver == "hqp"
    task = with_task.system("t")  # nothing set: add_self_collision_task's defaults
    assert (task.d_s, task.d_i, task.GetOutputPort("distances").size()) == (0.01, 0.05, 16)
    without = ScriptSession()
    without.run_script("new FeatureCoM f\nnew Task c\nc.add f\nsot.push c")
    assert without.built.sot.solver == "svd"


SETTINGS = {
    "d_s": (0.0, MAX_COLLISION_DISTANCE),
    "d_i": (0.0, MAX_COLLISION_DISTANCE),
    "xi": (0.0, MAX_APPROACH_SPEED),
    "maxPairs": (1, MAX_COLLISION_PAIRS),
    "legPairs": (0, 1),
}
anything = st.one_of(
    st.floats(),
    st.integers(),
    st.integers(0, 6000).map(lambda digits: 10**digits),  # past Python's 4300-digit text, from Python
    st.builds(Name, st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}", fullmatch=True)),
    st.text(max_size=8),
    st.text(st.characters(categories=["Cs"]), min_size=1, max_size=3),  # lone surrogates
    st.builds(
        Vector, st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=3).map(tuple)
    ),
)


@pytest.fixture(scope="module")
def unbuilt_session() -> ScriptSession:
    session = ScriptSession()
    session.execute("new TaskSelfCollision t")
    return session


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(sorted(SETTINGS)), anything)
def test_any_setting_is_taken_within_its_bounds_or_refused_naming_it(unbuilt_session, setting, value):
    """The fuzz of the class's settings: a value is kept within its bounds, or refused with the
    command and the setting named; nothing else is raised."""
    command = Set(Signal("t", setting), value)
    try:
        unbuilt_session.execute(command)
    except SessionError as error:
        assert str(error).startswith(f"{command}: t.{setting}")
        return
    low, high = SETTINGS[setting]
    kept = unbuilt_session.entity("t").get_parameter(setting, None)
    assert low <= kept <= high and np.isfinite(kept)
    assert not unbuilt_session.is_built


@pytest.fixture(scope="module")
def built_session() -> ScriptSession:
    session = ScriptSession()
    session.run_script("new TaskSelfCollision t\nsot.push t")
    return session


@settings(max_examples=50, deadline=None)
@given(st.lists(anything, min_size=1, max_size=3).map(tuple))
def test_the_pairs_command_takes_no_argument(built_session, args):
    """The fuzz of the class's run-time command: with arguments it is refused naming it."""
    command = Call("t", "pairs", args)
    with pytest.raises(SessionError) as caught:
        built_session.execute(command)
    assert str(caught.value) == f"{command}: takes 0 argument(s) (pairs), got {len(args)}"
