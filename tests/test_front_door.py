"""The front door hardened: what a script line, a served request or a Python argument may hold
(integers beyond float range, 1e400) gives the documented error, never an OverflowError; from a
``drake-sot script`` run and from a client of ``drake-sot serve`` (another process) too."""

import json
import math
import os
import re
import resource
import select
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from served import DRAKE_SOT, REPO, start, stop

from drake_sot import validation
from drake_sot.app import serving
from drake_sot.diagrams.script_session import MAX_INCLUDE_DEPTH, SessionError, load_script
from drake_sot.remote import Client, RemoteError
from drake_sot.remote.network import ACCEPT_BACKOFF, MAX_CONNECTIONS, NetworkThread, _is_loopback
from drake_sot.script import ScriptError, parse_line, stack_command
from drake_sot.stack import MAX_TRANSITION, Push, StackError
from drake_sot.systems import command_server as server_module
from drake_sot.systems.command_server import RemoteCommandServer

HUGE = "1" + "0" * 400  # 10**400: an int Python reads, beyond float range (max ~1.8e308)
assert math.isinf(float("1e400")) and int(HUGE).bit_length() > 1024


# --- the script parser ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "before, number",
    [
        ("run ", HUGE),
        ("sot.push taskLH ", HUGE),
        ("sot.push taskLH ", "-" + HUGE),
        ("sot.push taskLH ", "1e400"),
        ("pg.parsecmd :stepseq ", HUGE),
        ("set featureComDes.errorIN ", HUGE),
        ("set featureComDes.errorIN [3](0,", HUGE + ",0.64)"),
        ("run ", "1e400"),
    ],
)
def test_a_number_beyond_float_range_is_a_script_error_at_its_column(before, number):
    with pytest.raises(ScriptError, match="float range|finite number") as raised:
        parse_line(before + number)
    assert raised.value.column == len(before) + 1  # where the number starts


def test_the_largest_float_is_still_a_number():
    largest = int(np.finfo(float).max)  # 309 digits: what float() still reads
    command = parse_line(f"x.y {largest}")
    assert command.args == (largest,) and float(command.args[0]) == np.finfo(float).max
    with pytest.raises(ScriptError, match="float range"):
        parse_line(f"x.y {largest * 2}")


# --- validation: every helper raises its ValueError ------------------------------------------


@pytest.mark.parametrize(
    "check",
    [
        lambda v: validation.finite("g", v),
        lambda v: validation.positive("g", v),
        lambda v: validation.nonnegative("g", v),
        lambda v: validation.bounded("g", v, 0.0, 1.0),
        lambda v: validation.vector("g", [0.0, v]),
        lambda v: validation.matrix("g", [[v]]),
        lambda v: validation.per_axis("g", v, 3),
        lambda v: validation.bounds("g", [0.0], [v], 1),
        lambda v: validation.bounds("g", [-v], [0.0], 1),
    ],
)
@pytest.mark.parametrize("value", [10**400, -(10**400), 10**5000], ids=["1e400", "-1e400", "1e5000"])
def test_every_validation_helper_refuses_an_integer_beyond_float_range_with_its_value_error(check, value):
    with pytest.raises(ValueError, match="float range") as raised:
        check(value)
    assert type(raised.value) is ValueError
    assert len(str(raised.value)) < 200  # the value shown by its number of digits, not written out


def test_the_message_shows_a_huge_integer_by_its_number_of_digits():
    with pytest.raises(ValueError, match=r"g = an integer of ~401 digits: must be a number within float"):
        validation.positive("g", 10**400)
    with pytest.raises(ValueError, match=r"n = -an integer of ~5001 digits: must be an integer >= 1"):
        validation.positive_int("n", -(10**5000))


# --- drake-sot script: one line, exit 2 -------------------------------------------------------


@pytest.mark.parametrize(
    "line", [f"run {HUGE}", f"sot.push taskLH {HUGE}", "run 1e400"], ids=["run", "push", "run-float"]
)
def test_drake_sot_script_with_a_number_beyond_float_range_says_so_in_one_line(tmp_path, line):
    script = tmp_path / "huge.sot"
    script.write_text(f"# a number no float holds\n{line}\n")
    proc = subprocess.run(
        [*DRAKE_SOT, "script", str(script), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "huge.sot, line 2" in proc.stderr and ("float range" in proc.stderr or "finite" in proc.stderr)


# --- a served run: an error reply, and the run goes on ----------------------------------------


@pytest.fixture(scope="module")
def server():
    proc, host, port = start("--port", "0", "--duration", "300")
    yield proc, host, port
    stop(proc)


def _stack(client: Client) -> list[str]:
    """The stack without taskLH, which the reach scenario's own script pushes at 3 s, removes at 5 s."""
    return [task for task in client.run("sot.list").split() if task != "taskLH"]


@pytest.mark.parametrize(
    "cmd",
    [f"run {HUGE}", f"sot.push taskLH {HUGE}", "sot.push taskLH 1e400", f"taskRH.controlGain {HUGE}"],
    ids=["run", "push", "push-float", "gain"],
)
def test_a_served_line_with_a_number_beyond_float_range_is_refused_and_the_run_goes_on(server, cmd):
    proc, host, port = server
    with Client(host, port) as client:
        stack = _stack(client)
        with pytest.raises(RemoteError, match="float range|finite"):
            client.run(cmd)
        assert _stack(client) == stack
        before = client.t
        while client.t < before + 0.1:  # the simulation goes on, and answers
            assert len(client.read("dyn.com")) == 3
    assert proc.poll() is None


# --- the network thread: nothing a client sends ends it ----------------------------------------


def _answered(host, port, token=None):
    """A fresh client is answered (the network thread lives) with the simulated time going on."""
    with Client(host, port, token=token) as client:
        return len(client.read("dyn.com")) == 3 and client.t > 0


@pytest.mark.parametrize(
    "line, named",
    [
        (
            b'{"id": 1, "op": "write", "signal": "taskRH.position_des", "value": [1' + b"0" * 5000 + b"]}",
            "more than 4300 digits",
        ),
        (b'{"id": 1' + b"0" * 5000 + b', "op": "list"}', "more than 4300 digits"),
        (
            b'{"id": 2, "op": "write", "signal": "taskRH.position_des", "value": [0, 1'
            + b"0" * 400
            + b", 0]}",
            "value[1]: a number, got an integer of 401 digits, beyond float range",
        ),
        (b'{"id": 3, "op": "subscribe", "signal": "dyn.com", "period": 1' + b"0" * 400 + b"}", "period"),
        (b'{"id": 4, "op": "run", "cmd": "sot.push \\ud800"}', "cmd: a lone surrogate"),
        (b'{"id": "\\udfff", "op": "list"}', "id: a lone surrogate"),
        (b"[" * 60000 + b"]" * 5000, "invalid JSON"),
        (b'{"id": 5, "op": ["list"]}', 'op = ["list"]: unknown'),  # unhashable: a TypeError before
    ],
    ids=[
        "json-int-5000-digits",
        "id-5000-digits",
        "int-beyond-float",
        "period-beyond-float",
        "surrogate-cmd",
        "surrogate-id",
        "deep-nesting",
        "op-a-list",
    ],
)
def test_a_line_the_json_reader_or_the_floats_cannot_hold_gets_an_error_and_the_server_serves_on(
    server, line, named
):
    _, host, port = server
    with Client(host, port) as client:
        client.send_raw(line + b"\n")
        reply = client.receive()
        assert not reply["ok"] and named in reply["error"], reply
        assert len(client.read("dyn.com")) == 3  # the same connection is served on
    assert _answered(host, port)


def test_a_lone_surrogate_token_is_refused_and_the_token_server_serves_on():
    token = "s3cret"
    proc, host, port = start("--port", "0", "--duration", "120", env={**os.environ, "DRAKE_SOT_TOKEN": token})
    try:
        with Client(host, port) as stranger:
            stranger.send_raw(b'{"id": 1, "op": "auth", "token": "\\ud800"}\n')
            reply = stranger.receive()
            assert not reply["ok"] and "not authenticated" in reply["error"]
            with pytest.raises(RemoteError, match="wrong token"):
                stranger.request("auth", token="s3cret\u00e9")  # encodable, wrong
        assert _answered(host, port, token=token)
    finally:
        stop(proc)


def test_connections_beyond_the_cap_are_refused_with_an_error_and_the_others_served(server):
    _, host, port = server
    with Client(host, port) as first:
        first.read("dyn.com")
        extra = []
        try:
            for _ in range(MAX_CONNECTIONS + 5):
                extra.append(socket.create_connection((host, port), timeout=30))
            # the first MAX_CONNECTIONS - 1 others are served, the rest get one error line then the end
            refused = []
            for sock in extra[MAX_CONNECTIONS - 1 :]:
                data = sock.makefile("rb").read()  # up to the server's close
                refused.append(json.loads(data))
            assert len(refused) == 6
            assert all(not r["ok"] and f"at most {MAX_CONNECTIONS}" in r["error"] for r in refused)
            assert len(first.read("dyn.com")) == 3
        finally:
            for sock in extra:
                sock.close()
    deadline = time.monotonic() + 30
    while True:  # the server saw the closes: a new client is served again
        try:
            assert _answered(host, port)
            break
        except ConnectionError:
            assert time.monotonic() < deadline


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc to count a process's descriptors")
def test_accept_failing_for_want_of_descriptors_leaves_the_connected_clients_served(server):
    """The server's descriptor limit is lowered (prlimit) to what it has open + 1: the second of two
    new clients makes ``accept`` fail with EMFILE; the connected client is answered meanwhile, and
    the waiting one once a descriptor is free again."""
    proc, host, port = server
    first = Client(host, port)
    soft, hard = resource.prlimit(proc.pid, resource.RLIMIT_NOFILE)
    try:
        first.read("dyn.com")
        time.sleep(0.5)
        resource.prlimit(
            proc.pid, resource.RLIMIT_NOFILE, (len(os.listdir(f"/proc/{proc.pid}/fd")) + 1, hard)
        )
        second = Client(host, port)  # takes the last descriptor
        assert len(second.read("dyn.com")) == 3
        third = socket.create_connection((host, port), timeout=60)  # in the backlog: accept fails
        third.sendall(b'{"id": 3, "op": "read", "signal": "dyn.com"}\n')
        for _ in range(5):  # across several of the listener's rests
            time.sleep(ACCEPT_BACKOFF)
            assert len(first.read("dyn.com")) == 3 and len(second.read("dyn.com")) == 3
        assert not select.select([third], [], [], 0.0)[0]  # not accepted: no reply yet
        second.close()  # frees a descriptor: the third is accepted and answered
        with third, third.makefile("rb") as replies:
            reply = json.loads(replies.readline())
        assert reply["id"] == 3 and reply["ok"] and len(reply["result"]) == 3
    finally:
        resource.prlimit(proc.pid, resource.RLIMIT_NOFILE, (soft, hard))
        first.close()
    assert _answered(host, port)


# --- the server, smaller: half-close, timed host writes, up/down at the ends, bounds -----------


def test_a_request_followed_by_a_half_close_still_gets_its_reply(server):
    _, host, port = server
    with socket.create_connection((host, port), timeout=60) as sock:
        sock.sendall(
            b'{"id": 1, "op": "read", "signal": "dyn.com"}\n'
            b'{"id": 2, "op": "run", "cmd": "sot.list"}\n'  # answered by the host after the tick
            b'{"id": 3, "op": "run", "cmd": "sot.list"'  # a partial line: dropped, changes nothing
        )
        sock.shutdown(socket.SHUT_WR)
        with sock.makefile("rb") as replies:
            received = [json.loads(line) for line in replies]  # up to the server's close
    assert [r["id"] for r in received] == [1, 2] and all(r["ok"] for r in received), received
    assert len(received[0]["result"]) == 3 and "taskPosture" in received[1]["result"].split()


def test_up_of_the_top_task_and_down_of_the_bottom_one_are_refused_and_change_nothing(server):
    _, host, port = server
    with Client(host, port) as client:
        stack = _stack(client)  # taskLH, when pushed, is raised above the bottom at once
        with pytest.raises(RemoteError, match=rf"up {stack[0]}: already at the top of the stack"):
            client.run(f"sot.up {stack[0]}")
        with pytest.raises(RemoteError, match=rf"down {stack[-1]}: already at the bottom of the stack"):
            client.run(f"sot.down {stack[-1]}")
        assert _stack(client) == stack


def test_an_absurd_transition_time_is_refused_naming_the_bound(server):
    assert MAX_TRANSITION == 60.0
    with pytest.raises(StackError, match=r"^push: transition = 1e\+308 s: must be in \[0, 60\] s$"):
        stack_command(parse_line("sot.push taskLH 1e308"))
    assert stack_command(parse_line("sot.push taskLH 60")) == Push("taskLH", transition=60.0)
    _, host, port = server
    with Client(host, port) as client:
        stack = _stack(client)
        with pytest.raises(RemoteError, match=r"push: transition = 1e\+308 s: must be in \[0, 60\] s"):
            client.run("sot.push taskLH 1e308")
        with pytest.raises(RemoteError, match=r"rm: transition = 1e\+308 s: must be in \[0, 60\] s"):
            client.run("sot.rm taskRH 1e308")
        assert "taskRH" in stack and _stack(client) == stack


def _nested_scripts(directory: Path, depth: int) -> Path:
    """``s0.sot`` runs ``s1.sot``, which runs ... ``s{depth}.sot`` (a comment): ``depth`` nested runs."""
    for k in range(depth):
        (directory / f"s{k}.sot").write_text(f"run s{k + 1}.sot\n")
    (directory / f"s{depth}.sot").write_text("# the innermost script\n")
    return directory / "s0.sot"


def test_nested_run_file_includes_have_a_depth_bound_named_in_the_error(tmp_path):
    assert load_script(_nested_scripts(tmp_path, MAX_INCLUDE_DEPTH)).statements == ()
    deeper = tmp_path / "deeper"
    deeper.mkdir()
    with pytest.raises(
        SessionError, match=rf"nested {MAX_INCLUDE_DEPTH + 1} deep .*at most {MAX_INCLUDE_DEPTH}"
    ):
        load_script(_nested_scripts(deeper, MAX_INCLUDE_DEPTH + 1))
    proc = subprocess.run(
        [*DRAKE_SOT, "script", str(_nested_scripts(deeper, 200)), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert f"at most {MAX_INCLUDE_DEPTH}" in proc.stderr


@pytest.mark.parametrize(
    "host, loopback",
    [
        ("127.0.0.1", True),
        ("127.5.6.7", True),
        ("::1", True),
        ("localhost", True),
        ("127.example.com", False),
        ("127.0.0.1.nip.io", False),
        ("0.0.0.0", False),
        ("::", False),
        ("10.0.0.1", False),
    ],
)
def test_loopback_is_decided_by_reading_the_address(host, loopback):
    assert _is_loopback(host) is loopback
    if not loopback:
        with pytest.raises(ValueError, match="token is required"):
            NetworkThread(host, 0)


def _ipv6_loopback() -> bool:
    try:
        socket.create_server(("::1", 0), family=socket.AF_INET6).close()
    except OSError:
        return False
    return True


@pytest.mark.skipif(not _ipv6_loopback(), reason="this machine cannot bind ::1 (no IPv6 loopback)")
def test_serve_on_the_ipv6_loopback_binds_and_answers():
    proc, host, port = start("--host", "::1", "--port", "0", "--duration", "60")
    try:
        assert host == "::1"
        with Client(host, port) as client:
            assert len(client.read("dyn.com")) == 3
    finally:
        stop(proc)


def test_the_token_option_says_it_shows_in_ps_and_names_the_environment_variable():
    for command in (["serve", "--help"], ["shell", "--help"]):
        proc = subprocess.run([*DRAKE_SOT, *command], capture_output=True, text=True, cwd=REPO, timeout=120)
        assert proc.returncode == 0, proc.stderr
        token_help = " ".join(proc.stdout.split("\n  --token T", 1)[1].split("\n\n")[0].split())
        assert "$DRAKE_SOT_TOKEN" in token_help and "`ps`" in token_help, token_help


def test_a_token_on_the_command_line_gets_one_warning_line_naming_the_environment_variable():
    warning = (
        "drake-sot: warning: --token shows in /proc/PID/cmdline (`ps`) to every user of this machine; "
        "give it in $DRAKE_SOT_TOKEN instead"
    )
    with socket.socket() as unused:  # a port nobody listens on: the shell cannot connect
        unused.bind(("127.0.0.1", 0))
        port = unused.getsockname()[1]
    given = subprocess.run(
        [*DRAKE_SOT, "shell", "--port", str(port), "--token", "T"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
        stdin=subprocess.DEVNULL,
    )
    assert given.returncode == 1
    assert given.stderr.splitlines()[0] == warning and given.stderr.count("--token shows") == 1
    assert "cannot connect" in given.stderr.splitlines()[1]
    quiet = subprocess.run(  # the same token from the environment: no warning
        [*DRAKE_SOT, "shell", "--port", str(port)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
        stdin=subprocess.DEVNULL,
        env={**os.environ, "DRAKE_SOT_TOKEN": "T"},
    )
    assert quiet.returncode == 1 and "--token shows" not in quiet.stderr
    proc, host, port = start("--port", "0", "--duration", "60", "--token", "T")
    stop(proc)
    assert proc.stderr.read().count(warning) == 1  # serve says it too, once


# --- every writable declares its bounds; one Writable type, one check ---------------------------


@pytest.mark.parametrize(
    "value, named",
    [
        ([1e300, 0.0, 0.0], "value[0] = 1e+300: beyond the bound |x| <= 10 (m, world frame)"),
        ([0.3, -10.5, 0.9], "value[1] = -10.5: beyond the bound |x| <= 10 (m, world frame)"),
        ([0.3, 0.1, 1e3], "value[2] = 1000.0: beyond the bound |x| <= 10 (m, world frame)"),
    ],
    ids=["1e300", "10.5m", "1km"],
)
def test_a_target_position_beyond_the_reach_bound_is_refused_naming_it(server, value, named):
    _, host, port = server
    with Client(host, port) as client:
        assert client.list()["writable"]["taskRH.position_des"] == {
            "size": 3,
            "units": "m, world frame",
            "bound": validation.REACH_BOUND,
            "radius": validation.WORKSPACE_RADIUS,
        }
        with pytest.raises(RemoteError, match=re.escape(f"taskRH.position_des: {named}")):
            client.write("taskRH.position_des", value)
        assert len(client.read("dyn.com")) == 3


def test_a_stance_foot_target_lifted_over_the_server_is_refused_naming_the_value(server):
    """The reach's feet hold the robot up: a target 1.5 m over where a foot stands is refused with
    the value, the robot stands on; the reach is the robot's stride, from where the foot stood."""
    _, host, port = server
    from drake_sot.diagrams.humanoid import HumanoidSoTBuilder

    builder = HumanoidSoTBuilder()
    stride = builder.robot.step_limits.max_stride
    with Client(host, port) as client:
        writable = client.list()["writable"]
        assert "reach" not in writable["taskRH.position_des"]  # a hand goes where it is sent
        for task, frame in (("taskLF", "left_foot"), ("taskRF", "right_foot")):
            stood = builder.initial_pose(frame).translation()
            assert writable[f"{task}.position_des"]["reach"] == stride == 0.35
            np.testing.assert_allclose(writable[f"{task}.position_des"]["anchor"], stood, atol=1e-12)
            lifted = stood + [0.0, 0.0, 1.5]
            with pytest.raises(RemoteError) as refused:
                client.write(f"{task}.position_des", lifted.tolist())
            message = str(refused.value)
            assert message.startswith(f"{task}.position_des: value = [") and "1.5 from [" in message
            assert f"{lifted[2]:.4g}]" in message and "beyond the reach 0.35 (m, world frame)" in message
            with pytest.raises(RemoteError, match="beyond the reach"):  # just past a stride, sideways
                client.write(f"{task}.position_des", (stood + [0.0, 1.001 * stride, 0.0]).tolist())
            client.write(f"{task}.position_des", stood.tolist())  # where it stands: accepted
        pelvis_height = client.read("dyn.com")[2]
        assert 0.5 < pelvis_height  # the CoM of a robot that stands


def test_a_served_run_whose_stance_foot_was_sent_up_ends_standing_with_exit_0():
    from drake_sot.diagrams.humanoid import HumanoidSoTBuilder

    stood = HumanoidSoTBuilder().initial_pose("left_foot").translation()
    proc, host, port = start("--port", "0", "--duration", "2")
    try:
        with Client(host, port) as client:
            try:
                client.write("taskLF.position_des", (stood + [0.0, 0.0, 1.5]).tolist())
                refusal = None
            except RemoteError as refused:
                refusal = str(refused)
        out, err = proc.communicate(timeout=120)
    finally:
        stop(proc)
    assert proc.returncode == 0, err  # 3 when the lifted foot threw the robot down
    assert out.splitlines()[-1].startswith("served up to t = 2.000 s; 0 requests applied"), out
    assert refusal.startswith("taskLF.position_des: value = [") and "beyond the reach" in refusal


def test_a_reach_is_measured_from_its_anchor_and_needs_one():
    writable = server_module.Writable(3, "m", 10.0, reach=0.5, anchor=(1.0, 0.0, 0.0))
    assert writable.check("s", (1.0, 0.3, 0.4)) is None  # 0.5 from the anchor: the reach itself
    assert writable.check("s", (1.0, 0.3, 0.41)) == (
        f"s: value = [1, 0.3, 0.41]: {math.sqrt(0.3**2 + 0.41**2):g} from [1, 0, 0], "
        "beyond the reach 0.5 (m) of that anchor"
    )
    with pytest.raises(ValueError, match="give both or neither"):
        server_module.Writable(3, "m", 10.0, reach=0.5)
    with pytest.raises(ValueError, match="Writable.reach = nan m"):
        server_module.Writable(3, "m", 10.0, reach=float("nan"), anchor=(0.0, 0.0, 0.0))


def test_a_declared_writable_has_a_bound_checked_by_the_one_check():
    assert validation.REACH_BOUND == 10.0
    assert serving.Writable is server_module.Writable  # one type: the host's and the server's
    builder = DiagramBuilder()
    remote = builder.AddSystem(RemoteCommandServer(0.005))
    with pytest.raises(TypeError, match="bound"):
        remote.declare_writable("gain", 2, "1/s")  # a writable without its bound is not declared
    with pytest.raises(ValueError, match=r"Writable.bound = nan 1/s: must be finite and > 0"):
        remote.declare_writable("gain", 2, "1/s", bound=float("nan"))
    with pytest.raises(
        ValueError, match=r"initial: value\[1\] = 200.0: beyond the bound \|x\| <= 100 \(1/s\)"
    ):
        remote.declare_writable("gain", 2, "1/s", np.array([1.0, 200.0]), bound=100.0)
    remote.declare_writable("gain", 2, "1/s", bound=100.0)
    writable = remote.writables["remote.gain"]
    assert writable.check("remote.gain", (100.0, -100.0)) is None  # the bound itself is allowed
    assert writable.check("remote.gain", (100.0, -100.5)) == (
        "remote.gain: value[1] = -100.5: beyond the bound |x| <= 100 (1/s)"
    )


@pytest.mark.parametrize("gain", ["1e300", "1e4", "201"])
def test_a_remote_gain_beyond_the_control_periods_bound_is_refused_and_the_gain_kept(server, gain):
    # At the 5 ms control period, e_(k+1) = (1 - λ dt) e_k overshoots from λ dt > 1: λ <= 200 1/s.
    _, host, port = server
    with Client(host, port) as client:
        with pytest.raises(RemoteError, match=r"taskRH.*λ·period = [0-9.e+]+ must be <= 1"):
            client.run(f"taskRH.controlGain {gain}")
        client.run("taskRH.controlGain 200")  # the bound itself: λ dt = 1, the goal in one period
        client.run("taskRH.controlGain 1")
        assert len(client.read("dyn.com")) == 3  # served on


def test_a_nested_include_error_names_each_location_once(tmp_path):
    """a.sot runs b.sot, which runs c.sot, which runs a missing d.sot: the innermost line that
    failed, and the outermost line that ran it, each named once."""
    for name, runs in (("a", "b"), ("b", "c"), ("c", "d")):
        (tmp_path / f"{name}.sot").write_text(f"# {name}\nrun {runs}.sot\n")
    with pytest.raises(SessionError) as raised:
        load_script(tmp_path / "a.sot")
    message = str(raised.value)
    missing = tmp_path / "d.sot"
    assert message.startswith(f"c.sot, line 2: run d.sot: cannot read the script {str(missing)!r}: ")
    assert message.endswith(" (run from a.sot, line 2)")
    assert [message.count(f"{name}.sot, line") for name in "abc"] == [1, 0, 1]
