"""Who gets a place on the server: peers that never authenticate cannot keep a token holder out,
wait at most a bounded time, and a refused client reads its refusal line (never a reset)."""

import json
import os
import socket
import time

import numpy as np
import pytest
from served import start, stop

from drake_sot.remote import Client, RemoteError
from drake_sot.remote.network import MAX_CONNECTIONS, MAX_UNAUTHENTICATED, NetworkThread

TOKEN = "admission-token"
IDLE = 200  # idle peers held open at once: three times the places they may take


def _to_the_end(sock: socket.socket, timeout: float = 10.0) -> list[dict]:
    """Every line the server sends ``sock`` up to its end of stream (a reset raises)."""
    sock.settimeout(timeout)
    with sock.makefile("rb") as stream:
        return [json.loads(line) for line in stream.read().splitlines()]


@pytest.fixture
def token_thread():
    thread = NetworkThread("127.0.0.1", 0, token=TOKEN, auth_timeout=1.0)
    thread.start()
    yield thread
    thread.close()


def test_a_peer_that_does_not_authenticate_in_time_gets_a_line_then_the_end(token_thread):
    with socket.create_connection(token_thread.address, timeout=10) as idle:
        started = time.monotonic()
        (line,) = _to_the_end(idle)
        waited = time.monotonic() - started
    assert not line["ok"] and line["error"] == "closing: not authenticated within 1 s"
    assert 0.9 < waited < 5.0  # the deadline, checked every quarter second (and a loaded machine)


def test_an_authenticated_client_is_not_closed_at_the_deadline(token_thread):
    with Client(*token_thread.address, token=TOKEN) as friend:
        time.sleep(1.6)
        friend.send_raw(b'{"id": 7, "op": "list"}\n')
        cid, request = token_thread.requests.get(timeout=5)
        assert request.id == 7


def test_the_oldest_peer_waiting_to_authenticate_makes_room_and_reads_why(token_thread):
    idle = [
        socket.create_connection(token_thread.address, timeout=10) for _ in range(MAX_UNAUTHENTICATED + 3)
    ]
    try:
        for sock in idle[:3]:  # the three oldest: closed with a line, then the end
            (line,) = _to_the_end(sock)
            assert f"at most {MAX_UNAUTHENTICATED} connections wait to authenticate" in line["error"]
        with Client(*token_thread.address, token=TOKEN) as friend:  # in, though all wait still
            friend.send_raw(b'{"id": 1, "op": "list"}\n')
            assert token_thread.requests.get(timeout=5)[1].id == 1
    finally:
        for sock in idle:
            sock.close()


def test_one_authentication_beyond_the_cap_is_refused_with_its_line():
    thread = NetworkThread("127.0.0.1", 0, token=TOKEN)
    thread.start()
    friends = []
    try:
        friends = [Client(*thread.address, token=TOKEN) for _ in range(MAX_CONNECTIONS)]
        with pytest.raises(
            RemoteError, match=f"too many connections: at most {MAX_CONNECTIONS} authenticated"
        ):
            Client(*thread.address, token=TOKEN)
        friends.pop().close()
        deadline = time.monotonic() + 10
        while True:  # once the server saw the close, a place is free again
            try:
                Client(*thread.address, token=TOKEN).close()
                break
            except RemoteError:
                assert time.monotonic() < deadline
                time.sleep(0.05)
    finally:
        for friend in friends:
            friend.close()
        thread.close()


def test_a_client_past_the_cap_that_sent_a_line_reads_its_refusal_not_a_reset():
    """Without a token every connection counts; those past the cap send a request at once: the
    server reads and discards it after the refusal line, so the kernel does not reset the stream."""
    thread = NetworkThread("127.0.0.1", 0)
    thread.start()
    held = [socket.create_connection(thread.address, timeout=10) for _ in range(MAX_CONNECTIONS)]
    try:
        for _ in range(20):
            with socket.create_connection(thread.address, timeout=10) as late:
                late.sendall(b'{"id": 1, "op": "list"}\n' * 100)
                time.sleep(0.01)  # the refusal and the close cross the request
                (line,) = _to_the_end(late)
                assert not line["ok"] and "too many connections" in line["error"]
    finally:
        for sock in held:
            sock.close()
        thread.close()


def test_two_hundred_idle_peers_leave_a_token_holder_free_to_read_and_write():
    proc, host, port = start("--port", "0", "--duration", "120", env={**os.environ, "DRAKE_SOT_TOKEN": TOKEN})
    idle = []
    try:
        for _ in range(IDLE):
            idle.append(socket.create_connection((host, port), timeout=30))
        started = time.monotonic()
        with Client(host, port, token=TOKEN, timeout=30) as friend:
            assert len(friend.read("dyn.com")) == 3
            friend.write("taskRH.position_des", [0.3, -0.2, 0.9])
            before = np.array(friend.read("featureRH.error"))[:3]
            friend.write("taskRH.position_des", [0.3, -0.2, 0.8])
            after = np.array(friend.read("featureRH.error"))[:3]
            # e = p - p*: 10 cm lower a target is 10 cm more error upwards (the hand moves little in a tick)
            assert np.allclose(after - before, [0.0, 0.0, 0.1], atol=0.01), after - before
        assert time.monotonic() - started < 20
        for sock in idle[: IDLE - MAX_UNAUTHENTICATED]:  # each closed with its line, none reset
            (line,) = _to_the_end(sock)
            assert "connections wait to authenticate" in line["error"]
    finally:
        for sock in idle:
            sock.close()
        stop(proc)
