"""The remote command server: the JSON-lines protocol (pure), and ``drake-sot serve reach``
driven by a client in another process (push, read, write, subscribe, malformed lines, token),
and ``drake-sot shell``."""

import itertools
import json
import math
import os
import queue
import random
import re
import subprocess
import time

import numpy as np
import pytest
from collision_queries import Query
from served import DRAKE_SOT, REPO
from served import start as _start
from served import stop as _stop

from drake_sot.remote import Client, RemoteError
from drake_sot.remote.network import NetworkThread
from drake_sot.remote.protocol import (
    MAX_LINE,
    PairRow,
    ProtocolError,
    decode_vector,
    encode,
    parse_request,
)
from drake_sot.remote.shell import execute

TOKEN = "s3cret-token"
STACK_OF_REACH = (
    "taskJL",
    "taskSelfCollision",
    "taskLF",
    "taskRF",
    "taskCom",
    "taskRH",
    "taskPosture",
)  # its docstring


# --- the protocol, pure --------------------------------------------------------------------


@pytest.mark.parametrize(
    "line, named",
    [
        (b"\xff\xfe{", "not UTF-8"),
        (b'{"id": 1, "op": "read"', "invalid JSON"),
        (b"[1, 2]", "JSON object"),
        (b'{"id": 1, "op": "exec", "cmd": "x"}', "'exec'"),
        (b'{"id": 1, "op": "read"}', "'signal'"),
        (b'{"id": 1, "op": "write", "signal": "a.b", "value": [1, "x"]}', "value[1]"),
        (b'{"id": 1, "op": "subscribe", "signal": "a.b", "period": "fast"}', "period"),
        (b'{"id": [1], "op": "list"}', "id"),
        (b"x" * MAX_LINE, "at most"),
    ],
)
def test_a_malformed_line_is_a_protocol_error_naming_the_bad_part(line, named):
    with pytest.raises(ProtocolError, match=re.escape(named)):
        parse_request(line)


def test_a_request_keeps_its_id_and_fields():
    request = parse_request(
        b'{"id": "a", "op": "write", "signal": "taskRH.position_des", "value": [1, 2.5, -3]}'
    )
    assert (request.id, request.op, request.signal, request.value) == (
        "a",
        "write",
        "taskRH.position_des",
        (1, 2.5, -3),
    )
    assert parse_request(b'{"op": "list"}').id is None


def test_non_finite_numbers_travel_as_null_and_come_back_as_nan():
    line = encode({"signal": "sot.errors", "t": 0.5, "value": np.array([1.0, np.nan, -np.inf])})
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    message = json.loads(line)  # standard JSON: no NaN literal
    assert message["value"] == [1.0, None, None]
    back = decode_vector(message["value"])
    assert back[0] == 1.0 and math.isnan(back[1]) and math.isnan(back[2])


# --- the network thread alone: what it queues for the serving loop ------------------------


@pytest.fixture
def network():
    thread = NetworkThread("127.0.0.1", 0, rate=50.0, burst=5)
    thread.start()
    yield thread
    thread.close()


def _queued(thread, wait=0.5):
    deadline, items = time.monotonic() + wait, []
    while time.monotonic() < deadline:
        try:
            items.append(thread.requests.get(timeout=0.05))
        except queue.Empty:
            pass
    return items


def test_a_client_that_disconnects_mid_line_queues_nothing(network):
    with Client(*network.address) as client:
        client.send_raw(b'{"id": 1, "op": "run", "cmd": "sot.clear"')
    items = _queued(network)
    assert [request for _, request in items] == [None]  # only the disconnection


def test_requests_beyond_the_rate_are_refused_and_not_queued(network):
    with Client(*network.address) as client:
        client.send_raw(b'{"id": 1, "op": "list"}\n' * 20)  # at once: the burst of 5 passes
        refused = [client.receive() for _ in range(15)]
        assert all("rate limit" in r["error"] for r in refused)
        assert len([r for _, r in _queued(network) if r is not None]) == 5
        time.sleep(0.2)  # 50 per second: 10 more allowed
        client.send_raw(b'{"id": 2, "op": "list"}\n')
        assert [r.id for _, r in _queued(network)] == [2]


def test_a_read_of_a_published_signal_is_answered_at_once_unless_the_connection_waits(network):
    """The socket thread answers a read from the values the serving loop published after the last
    tick, without queueing it, once per tick and connection (a second read of the same value waits
    for the next tick: a polling loop is paced by the ticks); a connection with a request still
    unanswered queues its read behind it (its order kept); a signal not published is queued. The
    fields naming the rows (a stacked signal's layout, a self-collision task's pairs) go with it."""
    pair = {"shape_a": "a::hand", "shape_b": "a::torso", "body_a": "hand", "body_b": "torso"}
    network.publish(
        {
            "dyn.com": (1.25, [0.1, float("nan"), 0.6], {}),
            "sot.errors": (1.25, [1.0, 2.0], {"layout": {"a": [0, 2]}}),
            "taskSelfCollision.distances": (1.25, [0.03, float("nan")], {"pairs": [pair, None]}),
        }
    )
    with Client(*network.address) as client:
        com = client.read("dyn.com")
        assert com[0] == 0.1 and math.isnan(com[1]) and client.t == 1.25
        assert client.read_stacked("sot.errors") == {"a": [1.0, 2.0]}
        assert client.read_pairs("taskSelfCollision") == [PairRow(**pair, distance=0.03)]
        assert _queued(network, wait=0.2) == []  # none reached the serving loop
        network.publish({"sot.errors": (1.255, [3.0, 4.0], {"layout": {"a": [0, 2]}})})  # the next tick
        assert client.read_stacked("sot.errors") == {"a": [3.0, 4.0]} and client.t == 1.255
        client.send_raw(b'{"id": 0, "op": "read", "signal": "sot.errors"}\n')
        assert [r.id for _, r in _queued(network)] == [0]  # the same tick's value again: waits a tick
    network.publish({"dyn.com": (1.26, [0.2, 0.0, 0.6], {})})
    with Client(*network.address) as client:
        client.send_raw(b'{"id": 1, "op": "list"}\n{"id": 2, "op": "read", "signal": "dyn.com"}\n')
        assert [r.id for _, r in _queued(network)] == [1, 2]  # the list waits: the read queues after it
    with Client(*network.address) as client:
        client.send_raw(b'{"id": 3, "op": "read", "signal": "dyn.q"}\n')
        assert [r.id for _, r in _queued(network)] == [3]  # not published: the loop answers it
    network.publish({})
    with Client(*network.address) as client:
        client.send_raw(b'{"id": 4, "op": "read", "signal": "dyn.com"}\n')
        assert [r.id for _, r in _queued(network)] == [4]  # nothing published: queued


def test_the_socket_thread_reports_each_signal_it_answered_from_the_published_values(network):
    """So that the serving loop keeps publishing a signal its clients read only from them; a read
    that reached the loop is no such hit (the loop sees that one)."""
    network.take_hits()  # whatever the tests before left
    network.publish({"dyn.com": (1.0, [0.1, 0.0, 0.6], {}), "sot.errors": (1.0, [1.0], {})})
    with Client(*network.address) as client:
        client.read("dyn.com")
        client.read("sot.errors")
        client.send_raw(b'{"id": 7, "op": "read", "signal": "dyn.q"}\n')  # not published: queued
        assert [r.id for _, r in _queued(network)] == [7]
    assert network.take_hits() == {"dyn.com", "sot.errors"}
    assert network.take_hits() == set()  # taken once


def test_the_client_refuses_a_reply_whose_pairs_are_malformed_or_missing(network):
    pair = {"shape_a": "a::hand", "shape_b": "a::torso", "body_a": "hand", "body_b": "torso"}
    network.publish(
        {
            "taskSelfCollision.distances": (1.0, [0.03, 0.04], {"pairs": [pair]}),  # 1 entry, 2 rows
            "taskRH.distances": (1.0, [0.03], {}),  # a signal that names no pairs
        }
    )
    with Client(*network.address) as client:
        with pytest.raises(ProtocolError, match=re.escape("pairs: a list of 2 entries (one per row), got 1")):
            client.read_pairs("taskSelfCollision")
        with pytest.raises(ValueError, match="'taskRH' is not a self-collision task"):
            client.read_pairs("taskRH")


def test_a_non_loopback_address_needs_a_token():
    with pytest.raises(ValueError, match="0.0.0.0"):
        NetworkThread("0.0.0.0", 0)
    with pytest.raises(ValueError, match="empty"):
        NetworkThread("127.0.0.1", 0, token="")


def test_a_token_of_bytes_that_are_not_utf8_is_refused_by_name():
    """``DRAKE_SOT_TOKEN`` or ``--token`` holding a byte that is not UTF-8 (Python gives it as a lone
    surrogate): the refusal names the token and where it came from, not the codec."""
    with pytest.raises(ValueError, match="token: not Unicode text"):
        NetworkThread("127.0.0.1", 0, token="secret\udcff")
    env = {**os.environ, "DRAKE_SOT_TOKEN": "secret\udcff"}
    proc = _serve_to_the_end("reach", "--port", "0", env=env)
    assert proc.returncode == 2 and "serving on" not in proc.stdout
    assert "token: not Unicode text" in proc.stderr and "DRAKE_SOT_TOKEN" in proc.stderr


# --- a served scenario, from another process ----------------------------------------------


@pytest.fixture(scope="module")
def server():
    proc, host, port = _start("--port", "0", "--duration", "120")
    yield proc, host, port
    _stop(proc)


def test_serve_prints_its_loopback_address_first(server):
    proc, host, port = server
    assert host == "127.0.0.1" and 0 < port < 65536
    assert re.fullmatch(
        r"live view \(stack and task errors in the controls\): http://localhost:\d+\n", proc.view
    )


def test_a_pushed_task_gets_its_error_at_a_later_tick(server):
    _, host, port = server
    with Client(host, port) as client:
        rows = slice(*client.list()["error_slices"]["sot"]["taskLH"])
        stack = client.run("sot.list").split()
        if "taskLH" in stack:  # the scenario's own script pushes it at 3 s
            pytest.fail(f"the test came too late (t = {client.t} s): taskLH is already in {stack}")
        before = np.array(client.read("sot.errors"))[rows]
        assert np.isnan(before).all()
        client.run("sot.push taskLH")
        pushed_at = client.t
        assert client.run("sot.list").split()[-1] == "taskLH"
        for _ in range(200):
            after = np.array(client.read("sot.errors"))[rows]
            if not np.isnan(after).any():
                break
        assert not np.isnan(after).any() and client.t > pushed_at
        # the task's error is the left hand's position error (Mansard et al. 2009: e = s - s*)
        feature = np.array(client.read("featureLH.error"))
        assert np.allclose(feature[:3], after[:3], atol=0.02)
        client.run("sot.rm taskLH")
        assert "taskLH" not in client.run("sot.list").split()


def test_a_read_of_the_stacked_errors_says_whose_rows_are_which(server):
    """``read sot.errors`` answers with the layout beside the values: the rows of each task, the
    same as ``list``'s ``error_slices`` and as each task's own error output."""
    _, host, port = server
    with Client(host, port) as client:
        slices = client.list()["error_slices"]["sot"]
        named = client.read_stacked("sot.errors")
        assert list(named) == list(slices)
        assert [len(named[task]) for task in slices] == [stop - start for start, stop in slices.values()]
        for task, feature_name in (("taskRH", "featureRH"), ("taskCom", "featureCom")):  # in the stack
            feature = np.array(client.read(f"{feature_name}.error"))  # its rows: its feature's error
            assert np.allclose(named[task], feature, atol=0.02), task
        with pytest.raises(ValueError, match="'dyn.com' is not a stacked signal"):
            client.read_stacked("dyn.com")


def test_the_self_collision_rows_are_read_and_streamed_by_name(server):
    """``read_pairs`` names each row's pair of shapes, closest first, among the pairs the collision
    filters leave (a collision model of the test's own); standing, the soles' shapes are 4 cm
    apart, within the activation distance (5 cm); a task with no such rows is refused by name."""
    _, host, port = server
    candidates = Query("embedded").candidates()
    with Client(host, port) as client:
        stream = client.subscribe_pairs("taskSelfCollision", period=0.05)
        read = [client.read_pairs("taskSelfCollision"), *(rows for _, rows in itertools.islice(stream, 3))]
        stream.close()  # unsubscribes
        with pytest.raises(RemoteError, match="'taskSelfCollision.distances' is not subscribed"):
            client.request("unsubscribe", signal="taskSelfCollision.distances")
        for rows in read:
            distances = [row.distance for row in rows]
            assert rows and distances == sorted(distances) and max(distances) < 0.05, rows
            assert all(frozenset((row.shape_a, row.shape_b)) in candidates for row in rows), rows
        with pytest.raises(RemoteError, match=re.escape("unknown vector output 'taskRH.distances'")):
            client.read_pairs("taskRH")
        client.send_raw(b'{"id": "i", "op": "read", "signal": "taskSelfCollision.pair_indices"}\n')
        reply = client.receive()
        named = [i for i, pair in zip(reply["result"], reply["pairs"], strict=True) if pair is not None]
        assert named and all(i >= 0 for i in named)  # a row named is a row with a pair


def _hold_the_right_hand(client):
    """Make the right hand's target where the hand is, once the scenario's own new target (t = 1 s)
    is set; its position. e = p - p* (position rows), so a written p* and the error read after it
    give the hand position p (twice: p* = p then holds it)."""
    client.read("dyn.com")
    while client.t < 1.05:
        time.sleep(0.05)
        client.read("dyn.com")
    target = np.array([0.3, -0.25, 0.9])
    for _ in range(2):
        client.write("taskRH.position_des", target.tolist())
        target = np.array(client.read("featureRH.error"))[:3] + target
    return target


def test_a_written_target_changes_the_error_then_the_motion(server):
    _, host, port = server
    with Client(host, port) as client:
        # a step of p* is a step of the error (e = p - p*, position rows)
        p = _hold_the_right_hand(client)
        assert 0.5 < p[2] < 1.5  # a hand of a standing humanoid
        step = np.array([0.05, 0.0, -0.10])  # the new target: 5 cm ahead of the hand, 10 cm below
        client.write("taskRH.position_des", (p + step).tolist())
        e1 = np.array(client.read("featureRH.error"))[:3]
        assert np.allclose(e1, -step, atol=0.01), e1
        written_at = client.t
        while client.t < written_at + 1.5:  # 1.5 simulated seconds, 3.75 time constants at gain 2.5
            time.sleep(0.1)
            e2 = np.array(client.read("featureRH.error"))[:3]
        assert np.linalg.norm(e2) < 0.5 * np.linalg.norm(e1), (written_at, client.t, e2)


@pytest.mark.parametrize(
    "signal, value, named",
    [
        ("taskRH.position_des", [0.1, 0.2], "2 values, expected 3"),
        ("taskRH.position_des", [0.1, float("nan"), 0.3], "value[1]"),
        ("dyn.com", [0.0, 0.0, 0.8], "unknown writable signal 'dyn.com'; known: "),
        ("sot.nothing", [1.0], "unknown writable signal 'sot.nothing'; known: "),
    ],
)
def test_a_bad_write_is_refused_and_names_why(server, signal, value, named):
    _, host, port = server
    with Client(host, port) as client:
        with pytest.raises(RemoteError, match=re.escape(named)):
            client.write(signal, value)
        assert len(client.read("dyn.com")) == 3


def test_a_task_gain_set_remotely_sets_the_decay_rate_of_its_error(server):
    """ė* = -λ e (Mansard et al. 2009, eq. 3): after a step of the target, the hand's error decays as
    exp(-λ t); with λ = 10 1/s it is at exp(-2.5) = 8 % after 0.25 s, against 54 % at the
    scenario's λ = 2.5 (the margin: the motion of the tasks above it and a tick's delay)."""
    _, host, port = server
    with Client(host, port) as client:
        with pytest.raises(RemoteError, match=r"gain = -1.0 1/s: must be finite and > 0"):
            client.run("taskRH.controlGain -1")
        with pytest.raises(RemoteError, match=r"taskRH.add: not a run-time command"):
            client.run("taskRH.add featureLH")
        client.run("taskRH.controlGain 10")
        try:
            p = _hold_the_right_hand(client)
            step = np.array([0.0, 0.0, 0.06])  # up: the test before leaves the hand 10 cm lower
            client.write("taskRH.position_des", (p + step).tolist())
            e1 = np.array(client.read("featureRH.error"))[:3]
            start = client.t
            while client.t < start + 0.25:
                e2 = np.array(client.read("featureRH.error"))[:3]
            assert np.linalg.norm(e2) < 0.3 * np.linalg.norm(e1), (client.t - start, e1, e2)
        finally:
            client.run("taskRH.controlGain 2.5")


def test_a_nan_literal_is_refused_as_not_finite(server):
    _, host, port = server
    with Client(host, port) as client:
        client.send_raw(b'{"id": 7, "op": "write", "signal": "taskRH.position_des", "value": [0, NaN, 1]}\n')
        reply = client.receive()
        assert reply["id"] == 7 and not reply["ok"] and "not finite" in reply["error"]


def _malformed(rng: random.Random, i: int) -> bytes:
    kind = i % 5
    if kind == 0:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 200))).replace(b"\n", b"") + b"\n"
    if kind == 1:
        return b'{"id": %d, "op": "read", "signal": ' % i + b"\n"
    if kind == 2:
        return b'{"id": %d, "op": "read", "signal": "' % i + b"a" * (MAX_LINE + 10) + b'"}\n'
    if kind == 3:
        return (
            json.dumps({"id": i, "op": rng.choice(["exec", "eval", "", "READ"]), "cmd": "x"}).encode() + b"\n"
        )
    return json.dumps({"id": i, "op": rng.choice(["run", "read", "write", "subscribe"])}).encode() + b"\n"


def test_a_thousand_malformed_lines_each_get_an_error_and_the_server_serves_on(server):
    _, host, port = server
    rng = random.Random(11)
    with Client(host, port) as client:
        for i in range(1000):
            client.send_raw(_malformed(rng, i))
        replies = [client.receive() for _ in range(1000)]
        assert all(not r["ok"] and r["error"] for r in replies)
        assert len(client.read("dyn.com")) == 3
    with Client(host, port) as other:
        other.send_raw(b'{"id": 1, "op": "read", "signal": "dyn.co')  # then disconnects mid-line
    with Client(host, port) as client:
        assert len(client.read("dyn.com")) == 3


def test_a_subscription_streams_at_its_period_with_increasing_time(server):
    _, host, port = server
    with Client(host, port) as client:
        times = []
        stream = client.subscribe("dyn.com", period=0.05)
        for t, value in stream:
            times.append(t)
            assert len(value) == 3
            if t - times[0] >= 1.0:
                break
        stream.close()
        span = times[-1] - times[0]
        assert np.all(np.diff(times) > 0)
        assert (len(times) - 1) / span >= 15
        assert np.allclose(np.diff(times), 0.05, atol=0.006)
        with pytest.raises(RemoteError, match="control period"):
            client.request("subscribe", signal="dyn.com", period=0.0001)


def test_the_shell_runs_script_lines_and_its_own_commands(server):
    _, host, port = server
    proc = subprocess.run(
        [*DRAKE_SOT, "shell", "--port", str(port)],
        input="sot.list\nread dyn.com\nwrite dyn.com 1 2 3\nget nothing.here\nhelp\n"
        "pairs taskSelfCollision\npairs taskRH\nquit\n",
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].split()[:4] == list(STACK_OF_REACH[:4])
    com = [float(x) for x in lines[1].split()]
    assert len(com) == 3 and 0.5 < com[2] < 1.0  # the CoM of a standing humanoid, about 0.8 m up
    assert lines[2].startswith("error:") and "unknown writable signal" in lines[2]
    assert lines[3].startswith("error:") and "nothing.here" in lines[3]
    assert "SOT.push" in proc.stdout.split("server:")[1] and "(SOT: sot)" in proc.stdout  # help: both
    # pairs: one line per row, "DISTANCE m  SHAPE_A (BODY_A)  SHAPE_B (BODY_B)", then the refusal
    assert "taskRH.distances" in lines[-1] and lines[-1].startswith("error:")
    rows = [re.fullmatch(r"(\S+) m  (\S+) \((\S+)\)  (\S+) \((\S+)\)", line) for line in lines[:-1]]
    rows = [row for row in rows if row is not None]
    # within d_i = 5 cm (printed to 6 digits: 0.049999999999999996 shows as 0.05), shapes in order
    assert rows and all(float(row.group(1)) <= 0.05 and row.group(2) < row.group(4) for row in rows)


def test_the_shell_says_so_when_no_row_of_the_task_has_a_pair():
    class NoPairs:  # what the shell uses of a Client: read_pairs, and t of the last reply
        t = 2.5

        def read_pairs(self, task):
            return []

    assert execute(NoPairs(), "pairs taskSelfCollision") == (
        "taskSelfCollision: no pair within its activation distance at t = 2.500 s"
    )


# --- the token --------------------------------------------------------------------------


def _serve_to_the_end(*args, env=None):
    """``drake-sot serve ARGS`` run to its end (a refusal): the completed process."""
    return subprocess.run(
        [*DRAKE_SOT, "serve", *args], capture_output=True, text=True, cwd=REPO, env=env, timeout=300
    )


def test_another_address_without_a_token_refuses_to_start():
    env = {k: v for k, v in os.environ.items() if k != "DRAKE_SOT_TOKEN"}
    proc = _serve_to_the_end("reach", "--host", "0.0.0.0", "--port", "0", env=env)
    assert proc.returncode == 2 and proc.stdout == ""
    assert "token" in proc.stderr and "0.0.0.0" in proc.stderr


def test_a_scenario_without_a_command_server_is_refused():
    proc = _serve_to_the_end("table_pounding", "--port", "0")
    assert proc.returncode == 2 and "serving on" not in proc.stdout
    assert "table_pounding cannot be served" in proc.stderr and "RemoteCommandServer" in proc.stderr
    proc = _serve_to_the_end("no_such_thing", "--port", "0")
    assert proc.returncode == 2 and "'no_such_thing' is neither a scenario (" in proc.stderr


def test_with_a_token_an_unauthenticated_client_gets_nothing_but_errors():
    env = {**os.environ, "DRAKE_SOT_TOKEN": TOKEN}
    proc, host, port = _start("--port", "0", "--duration", "60", env=env)
    try:
        with Client(host, port) as stranger:
            with pytest.raises(RemoteError, match="not authenticated"):
                stranger.read("dyn.com")
            with pytest.raises(RemoteError, match="not authenticated"):
                stranger.run("sot.clear")
            with pytest.raises(RemoteError, match="wrong token"):
                stranger.request("auth", token=TOKEN + "x")
            with pytest.raises(RemoteError, match="not authenticated"):
                stranger.list()
        with Client(host, port, token=TOKEN) as friend:
            assert "taskPosture" in friend.run("sot.list").split()  # nothing was cleared
    finally:
        _stop(proc)


# --- the live view's controls -------------------------------------------------------------


def test_the_meshcat_controls_show_the_task_errors_on_a_log_scale_per_unit_and_the_stack():
    from drake_sot.app.status import LOG_MIN, MeshcatStatus, TaskErrorSampler, slider_name
    from drake_sot.diagrams.reach import build
    from drake_sot.diagrams.world import loopback_meshcat

    meshcat = loopback_meshcat()
    built = build(meshcat).built
    simulator = built.create_simulator()
    units = {name: task.units for name, task in built.tasks.items()}
    sampler = TaskErrorSampler(built.sot, period=0.1, units=units)
    status = MeshcatStatus(meshcat, sampler.names)
    context = simulator.get_mutable_context()
    built.sot.push(context, "taskLH")
    simulator.AdvanceTo(0.05)
    status.show(sampler.sample(context))
    for task in ("taskRH", "taskLH"):  # the feature's own output: e of the last tick, to a tick's motion
        feature = built.features[task]
        error = feature.GetOutputPort("error").Eval(feature.GetMyContextFromRoot(context))
        # a 6D pose task: its position rows [m] and its orientation rows [rad], each on its slider
        for unit, rows in (("m", slice(0, 3)), ("rad", slice(3, 6))):
            expected = np.log10(max(np.linalg.norm(error[rows]), 10.0**LOG_MIN))
            assert meshcat.GetSliderValue(slider_name(task, unit)) == pytest.approx(expected, abs=0.02)
    with pytest.raises(RuntimeError):  # one slider per unit the task has, none for another
        meshcat.GetSliderValue(slider_name("taskRH", "?"))
    stack = [*STACK_OF_REACH, "taskLH"]
    for i, name in enumerate(stack):
        assert meshcat.GetButtonClicks(f"stack {i + 1}: {name}") == 0  # raises if there is no such button
    built.sot.rm(context, "taskLH")
    simulator.AdvanceTo(0.14)
    assert sampler.sample(context) is None  # 0.1 s apart: not due at 0.14 s
    simulator.AdvanceTo(0.2)
    status.show(sampler.sample(context))
    assert meshcat.GetSliderValue(slider_name("taskLH", "m")) == LOG_MIN  # out of the stack: NaN error
    with pytest.raises(RuntimeError):
        meshcat.GetButtonClicks(f"stack {len(stack)}: taskLH")


def test_the_log_scale_holds_its_ends_and_reads_nan_as_out_of_the_stack():
    from drake_sot.app.status import LOG_MAX, LOG_MIN, log_norm

    assert log_norm(np.array([3.0, 4.0])) == pytest.approx(np.log10(5.0))
    assert log_norm(np.array([1e-3, 0.0])) == pytest.approx(-3.0)
    assert log_norm(np.array([np.nan, 1.0])) == LOG_MIN
    assert log_norm(np.zeros(3)) == LOG_MIN and log_norm(np.array([1e-9])) == LOG_MIN
    assert log_norm(np.array([1e3])) == LOG_MAX and log_norm(np.array([np.inf])) == LOG_MAX


def _served_logs(out, malformed):
    proc, host, port = _start("--port", "0", "--duration", "1.5", "--out", str(out))
    if malformed:
        rng = random.Random(5)
        with Client(host, port) as client:
            for i in range(1000):
                client.send_raw(_malformed(rng, i))
            assert all(not client.receive()["ok"] for _ in range(1000))
            assert len(client.read("dyn.com")) == 3
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    with np.load(out / "reach.npz") as npz:
        return {key: npz[key] for key in npz.files}


def test_malformed_lines_leave_the_recorded_run_identical(tmp_path):
    clean = _served_logs(tmp_path / "clean", malformed=False)
    attacked = _served_logs(tmp_path / "attacked", malformed=True)
    assert clean.keys() == attacked.keys() and len(clean["time"]) > 100
    for key in clean:
        assert np.array_equal(clean[key], attacked[key], equal_nan=clean[key].dtype.kind == "f"), key


# --- limits, SIGTERM, the command server in the diagram, a served script -----------------------


def test_the_seventeenth_subscription_of_a_connection_is_refused_naming_the_limit(server):
    _, host, port = server
    with Client(host, port) as client:
        readable = sorted(client.list()["readable"])
        assert len(readable) > 17
        for signal in readable[:16]:
            assert client.request("subscribe", signal=signal, period=10.0) == signal
        with pytest.raises(RemoteError, match="at most 16 subscriptions per connection"):
            client.request("subscribe", signal=readable[16], period=10.0)
        assert client.request("unsubscribe", signal=readable[0]) == readable[0]
        assert client.request("subscribe", signal=readable[16], period=10.0) == readable[16]  # room again
    with Client(host, port) as other:  # the limit is per connection
        assert other.request("subscribe", signal=readable[0], period=10.0) == readable[0]


def test_stack_commands_go_through_the_diagrams_command_server(server):
    _, host, port = server
    with Client(host, port) as client:
        listed = client.list()
        assert "remote.commands" not in listed["writable"]
        assert "taskRH.position_des" in listed["writable"]
        with pytest.raises(RemoteError, match="takes 1 task name"):
            client.run("sot.push")
        with pytest.raises(RemoteError, match="unknown task 'nothing'"):
            client.run("sot.push nothing")
        stack = client.run("sot.list").split()
        # removed and pushed back at one tick (one batch, in order): the lowest task is where it was
        assert stack[-1] == "taskPosture"
        removed_and_pushed = [
            {"op": "run", "cmd": "sot.rm taskPosture"},
            {"op": "run", "cmd": "sot.push taskPosture"},
        ]
        assert client.batch(removed_and_pushed) == ["", ""]
        assert client.run("sot.list").split() == stack


def test_sigterm_stops_serve_with_143_and_writes_the_usual_artefacts(tmp_path):
    proc, host, port = _start("--port", "0", "--duration", "120", "--out", str(tmp_path))
    try:
        with Client(host, port) as client:
            client.read("dyn.com")
            while client.t < 0.5:
                time.sleep(0.05)
                client.read("dyn.com")
            reached = client.t
        proc.send_signal(15)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, stderr
    for name in ("reach.npz", "reach.html", "reach.svg", "reach.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    with np.load(tmp_path / "reach.npz") as npz:
        assert reached - 1e-9 <= npz["time"][-1] < 120.0  # up to where it was stopped, not the duration


def test_serve_reports_the_wall_time_and_the_pace_it_kept():
    """The last line says how long the run took and the pace it kept beside the one asked: 1 s of
    ``reach`` paced at 0.5 × real time cannot take less than 2 s, nor longer than the process."""
    began = time.monotonic()
    proc, _, _ = _start("--port", "0", "--duration", "1", "--realtime", "0.5")
    try:
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        _stop(proc)
    process_wall = time.monotonic() - began
    assert proc.returncode == 0, stderr
    last = stdout.strip().splitlines()[-1]
    match = re.fullmatch(
        r"served up to t = 1\.000 s; 0 requests applied; (\S+) s of wall time "
        r"\(real-time factor (\S+), paced at 0\.5\)",
        last,
    )
    assert match is not None, last
    wall, factor = float(match[1]), float(match[2])
    assert 2.0 - 0.05 <= wall < process_wall
    assert factor == pytest.approx(1.0 / wall, abs=0.01 + 0.05 / wall**2)  # both printed rounded


SERVED_SCRIPT = """\
new FeatureGeneric featureCom
plug dyn.com featureCom.errorIN
plug dyn.Jcom featureCom.jacobianIN
set featureCom.selec 110
new FeatureGeneric featureComDes
set featureComDes.errorIN [3](0,0,0.64)
set featureCom.sdes featureComDes
new Task taskCom
taskCom.add featureCom
taskCom.controlGain 3
new PatternGenerator pg
sot.push taskCom
"""


def test_serve_a_script_and_run_its_dialect_remotely(tmp_path):
    script = tmp_path / "served.sot"
    script.write_text(SERVED_SCRIPT)
    proc = subprocess.Popen(
        [*DRAKE_SOT, "serve", str(script), "--port", "0", "--duration", "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )
    try:
        first = proc.stdout.readline()
        assert first.startswith("serving on 127.0.0.1:"), (first, proc.stderr.read() if proc.poll() else "")
        with Client("127.0.0.1", int(first.strip().rsplit(":", 1)[1])) as client:
            assert client.run("sot.list") == "taskCom"
            assert float(client.run("get taskCom.controlGain")) == 3.0
            client.run("taskCom.controlGain 2")
            assert float(client.run("get taskCom.controlGain")) == 2.0
            client.run("set featureComDes.errorIN [3](0.01,-0.02,0.64)")
            # e = s - s* on the selected rows (x, y) of the CoM: against dyn.com, read at the same tick
            error, com = client.batch(
                [{"op": "read", "signal": "featureCom.error"}, {"op": "read", "signal": "dyn.com"}]
            )
            assert np.allclose(error, np.array(com[:2]) - [0.01, -0.02], atol=1e-12)
            assert client.run("pg.parsecmd :singlesupporttime 0.7") == ""
            with pytest.raises(RemoteError, match="build-time command"):
                client.run("new Task taskOther")
            with pytest.raises(RemoteError, match="unknown entity 'nobody'"):
                client.run("nobody.controlGain 1")
            client.run("sot.rm taskCom")
            assert client.run("sot.list") == ""
    finally:
        _stop(proc)
