"""A self-collision task's rows read remotely by name, served in process: a read (and a
subscription) of ``taskSelfCollision.distances`` or ``.pair_indices`` carries ``pairs``, the
shapes and bodies of each row, the same as Drake's signed-distance query on a collision model of
the test's own at the task's q of that tick; a server without the task names the signal it has
not; the client refuses a reply whose ``pairs`` is malformed."""

import math
import re

import numpy as np
import pytest
from collision_queries import Query
from served import FakeNetwork, ticks

from drake_sot.app.serving import Serving
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.remote.protocol import (
    PAIR_FIELDS,
    PairRow,
    ProtocolError,
    Request,
    decode_pairs,
    decode_vector,
)

D_I = 0.055  # [m] activation distance: standing, the soles' pairs are 4, 5 and 6 cm apart
TASK = "taskSelfCollision"


def _served(max_pairs: int, self_collision: bool = True):
    b = HumanoidSoTBuilder()
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_posture_task("taskPosture", gain=1.0)
    stack = ("taskLF", "taskRF", "taskPosture")
    if self_collision:
        b.add_self_collision_task(TASK, d_i=D_I, max_pairs=max_pairs)
        stack = (TASK, *stack)
    built = b.build(stack=stack, solver="hqp", command_server=True)
    simulator = built.create_simulator()
    network = FakeNetwork()
    return built, simulator, Serving(simulator, built.remote, network, realtime=1e9), network


@pytest.fixture(scope="module")
def query():
    return Query("embedded")


@pytest.mark.parametrize("max_pairs", [2, 8])
def test_a_read_of_the_rows_names_the_pairs_drakes_query_finds_at_that_tick(query, max_pairs):
    """Standing, 6 pairs of the soles' shapes are within 5.5 cm: 2 at 4 cm, 4 at 5 cm. With 8 rows,
    all 6 are named, closest first, and the 2 rows left are null; with 2 rows, the 2 closest."""
    built, simulator, serving, network = _served(max_pairs)
    ticks(simulator, serving, 2)
    network.put(
        Request("read", 1, signal=f"{TASK}.distances"),
        Request("read", 2, signal=f"{TASK}.pair_indices"),
        Request("subscribe", 3, signal=f"{TASK}.distances", period=serving.period),
    )
    ticks(simulator, serving, 1)  # taken at this tick, answered after it, at its values
    task = built.tasks[TASK]
    q = task.GetInputPort("q").Eval(task.GetMyContextFromRoot(simulator.get_context()))
    near = query.near(q, D_I)  # the test's own query: shapes -> (distance, shape -> (body, point))
    assert sorted(round(d, 3) for d, _ in near.values()) == [0.04] * 2 + [0.05] * 4  # the docstring's
    distances_reply, indices_reply = network.reply(1), network.reply(2)
    assert len(distances_reply["pairs"]) == max_pairs  # one entry per row: bounded by the task
    assert indices_reply["pairs"] == distances_reply["pairs"]  # both read at the same tick
    rows = decode_pairs(distances_reply["pairs"], decode_vector(distances_reply["result"]))
    assert len(rows) == min(6, max_pairs)
    assert distances_reply["pairs"][len(rows) :] == [None] * (max_pairs - len(rows))
    expected = sorted(d for d, _ in near.values())[:max_pairs]
    np.testing.assert_allclose([row.distance for row in rows], expected, atol=1e-9)
    # the task's own report of that tick, row by row (closest first, ties in the task's order)
    closest = task.GetOutputPort("closest_pairs").Eval(task.GetMyContextFromRoot(simulator.get_context()))
    assert [({r.shape_a, r.shape_b}, r.distance) for r in rows] == [
        ({p.shape_a, p.shape_b}, p.distance) for p in closest
    ]
    for row in rows:
        distance, shapes = near[frozenset((row.shape_a, row.shape_b))]
        assert row.shape_a < row.shape_b  # alphabetical
        assert row.distance == pytest.approx(distance, abs=1e-9)
        assert (row.body_a, row.body_b) == (shapes[row.shape_a][0], shapes[row.shape_b][0])
    # a subscription's message names them too; so does the value published for reads answered at once
    stream = next(m for m in network.sent if m.get("signal") == f"{TASK}.distances")
    assert stream["pairs"] == distances_reply["pairs"] and stream["t"] == distances_reply["t"]
    ticks(simulator, serving, 1)  # published after the next tick, with its stream message
    t, values, beside = network.published[f"{TASK}.distances"]
    stream = [m for m in network.sent if m.get("signal") == f"{TASK}.distances"][-1]
    assert t == stream["t"] > distances_reply["t"] and beside == {"pairs": stream["pairs"]}


def test_a_server_without_a_self_collision_task_names_the_signal_it_has_not():
    built, simulator, serving, network = _served(8, self_collision=False)
    network.put(Request("read", 1, signal=f"{TASK}.distances"))
    ticks(simulator, serving, 2)
    reply = network.reply(1)
    assert not reply["ok"] and f"unknown vector output '{TASK}.distances'" in reply["error"]


PAIR = {"shape_a": "r::hand", "shape_b": "r::torso", "body_a": "hand", "body_b": "torso"}


def test_decoded_pairs_are_the_named_rows_in_order():
    assert decode_pairs([PAIR, None, None], [0.02, math.nan, math.nan]) == [PairRow(**PAIR, distance=0.02)]
    assert decode_pairs([{**PAIR, "later": 1}], [-0.001]) == [
        PairRow(**PAIR, distance=-0.001)
    ]  # a field added


@pytest.mark.parametrize(
    "pairs, distances, named",
    [
        (None, [0.02], "pairs: a list of 1 entries (one per row), got null"),
        ([PAIR], [0.02, math.nan], "pairs: a list of 2 entries (one per row), got 1 entries"),
        ([[PAIR["shape_a"], PAIR["shape_b"]]], [0.02], "pairs[0] = "),
        (
            [None, {k: v for k, v in PAIR.items() if k != "body_b"}],
            [math.nan, 0.02],
            "pairs[1].body_b = null",
        ),
        ([{**PAIR, "shape_a": 3}], [0.02], "pairs[0].shape_a = 3: a name"),
        ([{**PAIR, "shape_b": "\ud800"}], [0.02], "pairs[0].shape_b"),
        ([PAIR], [math.nan], "pairs[0] names a pair, but its distance is nan"),
    ],
    ids=["null", "length", "list", "missing", "number", "surrogate", "nan"],
)
def test_a_malformed_pairs_field_is_refused_naming_the_bad_entry(pairs, distances, named):
    with pytest.raises(ProtocolError, match=re.escape(named)):
        decode_pairs(pairs, distances)
    assert set(PAIR) == set(PAIR_FIELDS)


def test_a_served_scenarios_task_runs_the_scripts_pairs_command(query):
    """``run taskSelfCollision.pairs`` on a served diagram (no script session) prints the rows the
    read names, one line each, with their distances; ``help`` lists the command for the task."""
    built, simulator, serving, network = _served(8)
    ticks(simulator, serving, 2)
    network.put(
        Request("run", 1, cmd=f"{TASK}.pairs"),
        Request("read", 2, signal=f"{TASK}.distances"),
        Request("run", 3, cmd="help"),
    )
    ticks(simulator, serving, 2)
    text = network.reply(1)["result"]
    reply = network.reply(2)
    rows = decode_pairs(reply["pairs"], decode_vector(reply["result"]))
    lines = text.splitlines()
    assert len(lines) == len(rows) == 6, text
    for row in rows:
        line = next(line for line in lines if row.shape_a in line and row.shape_b in line)
        assert row.body_a in line and row.body_b in line
        assert float(re.search(r": (\S+) m$", line).group(1)) == pytest.approx(row.distance, abs=1e-9)
    assert f"TASK.pairs (TASK: {TASK})" in network.reply(3)["result"]
