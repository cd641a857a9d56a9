"""``Client``: the remote command protocol from Python (see :mod:`drake_sot.remote.protocol`).

Example::

    with Client("127.0.0.1", port) as c:
        c.run("sot.push taskLH")
        errors = c.read("sot.errors")
        for row in c.read_pairs("taskSelfCollision"):  # the closest pairs of collision shapes
            print(row.shape_a, row.shape_b, row.distance)
        for t, value in c.subscribe("dyn.com", period=0.05):
            ...
"""

from __future__ import annotations

import json
import socket
from collections import deque
from collections.abc import Iterator, Sequence
from contextlib import closing
from typing import Any

from drake_sot.errors import DrakeSotError
from drake_sot.remote.protocol import PairRow, decode_pairs, decode_vector, encode


class RemoteError(DrakeSotError, RuntimeError):
    """The server refused a request; the message is its ``error``."""


class Client:
    """A connection to a ``drake-sot serve`` server; sends ``auth`` first when given a token.

    Every call waits for its reply; stream messages that arrive meanwhile are kept for
    :meth:`subscribe`. Not thread-safe.
    """

    def __init__(
        self, host: str = "127.0.0.1", port: int = 7777, *, token: str | None = None, timeout: float = 30.0
    ) -> None:
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._file = self._sock.makefile("rb")
        self._next_id = 0
        self._streams: deque[dict[str, Any]] = deque()
        self.t = float("nan")  # simulated time of the last reply [s]
        if token is not None:
            self.request("auth", token=token)

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._file.close()
        self._sock.close()

    def send_raw(self, data: bytes) -> None:
        """Send bytes as they are (for tests of malformed input)."""
        self._sock.sendall(data)

    def receive(self) -> dict[str, Any]:
        """The next message from the server (a reply or a stream message)."""
        line = self._file.readline()
        if not line:
            raise ConnectionError("the server closed the connection")
        return json.loads(line)

    def request(self, op: str, **fields: Any) -> Any:
        """Send one request, wait for its reply; its ``result``, or RemoteError."""
        return self._reply(op, **fields)["result"]

    def _reply(self, op: str, **fields: Any) -> dict[str, Any]:
        """Send one request, wait for its reply; the whole reply, or RemoteError."""
        self._next_id += 1
        request_id = self._next_id
        self._sock.sendall(encode({"id": request_id, "op": op, **fields}))
        while True:
            message = self.receive()
            if "signal" in message and "ok" not in message:
                self._streams.append(message)
                continue
            if message.get("id") not in (request_id, None):
                continue
            if not message["ok"]:
                raise RemoteError(message["error"])
            if message.get("t") is not None:
                self.t = message["t"]
            return message

    def batch(self, requests: Sequence[dict[str, Any]]) -> list[Any]:
        """Send several requests at once (each ``{"op": ..., fields}``), so that those that reach
        the server before a tick are applied at that tick, in order; their results, in order.

        Raises:
            RemoteError: the first refused request (the others were applied).
        """
        ids = list(range(self._next_id + 1, self._next_id + 1 + len(requests)))
        self._next_id += len(requests)
        self._sock.sendall(b"".join(encode({"id": i, **r}) for i, r in zip(ids, requests, strict=True)))
        replies: dict[Any, dict[str, Any]] = {}
        while len(replies) < len(ids):
            message = self.receive()
            if "signal" in message and "ok" not in message:
                self._streams.append(message)
            elif message.get("id") in ids:
                replies[message["id"]] = message
        refused = [replies[i]["error"] for i in ids if not replies[i]["ok"]]
        if refused:
            raise RemoteError(refused[0])
        self.t = replies[ids[-1]]["t"]
        return [replies[i]["result"] for i in ids]

    def run(self, cmd: str) -> str:
        """Run one script line (``sot.push taskLH``, ``get dyn.com``); its output text."""
        return self.request("run", cmd=cmd)

    def read(self, signal: str) -> list[float]:
        """The value of ``signal`` (``system.port``) at the last tick; NaN where not finite."""
        return decode_vector(self.request("read", signal=signal))

    def read_stacked(self, signal: str) -> dict[str, list[float]]:
        """A stacked signal's value (a solver's ``errors``) by name, at the last tick: each task's
        rows, in the order of the signal (NaN for a task out of the stack).

        Raises:
            RemoteError: ``signal`` is refused (unknown, ...).
            ValueError: the server sends no layout for ``signal`` (it is not stacked).
        """
        reply = self._reply("read", signal=signal)
        if "layout" not in reply:
            raise ValueError(f"{signal!r} is not a stacked signal: its reply has no layout (use read)")
        values = decode_vector(reply["result"])
        return {name: values[start:stop] for name, (start, stop) in reply["layout"].items()}

    def read_pairs(self, task: str) -> list[PairRow]:
        """The rows of the self-collision task ``task`` at the last tick, by name: each row's pair
        of collision shapes, their bodies and signed distance [m], closest first (the rows
        without a pair left out); one read of ``TASK.distances``, whose reply names the pairs.

        Raises:
            RemoteError: ``TASK.distances`` is refused (no such task: the message names the signal).
            ValueError: its reply names no pairs (``task`` is not a self-collision task).
            ProtocolError: the reply's ``pairs`` is malformed
                (:func:`~drake_sot.remote.protocol.decode_pairs`).
        """
        signal = f"{task}.distances"
        reply = self._reply("read", signal=signal)
        if "pairs" not in reply:
            raise ValueError(f"{signal!r} names no pairs: {task!r} is not a self-collision task (use read)")
        return decode_pairs(reply["pairs"], decode_vector(reply["result"]))

    def write(self, signal: str, value: Sequence[float]) -> None:
        """Write an allowlisted signal; applied at the next control tick."""
        self.request("write", signal=signal, value=[float(x) for x in value])

    def list(self) -> dict[str, Any]:
        """Systems, readable and writable signals with their sizes, commands."""
        return self.request("list")

    def subscribe(self, signal: str, period: float) -> Iterator[tuple[float, list[float]]]:
        """``(t, value)`` of ``signal`` every ``period`` simulated seconds, until the iterator
        is closed (then it unsubscribes)."""
        with closing(self._stream(signal, period)) as messages:  # closed with this iterator
            for message in messages:
                yield message["t"], decode_vector(message["value"])

    def subscribe_pairs(self, task: str, period: float) -> Iterator[tuple[float, list[PairRow]]]:
        """``(t, rows)`` of the self-collision task ``task`` every ``period`` simulated seconds,
        the rows as :meth:`read_pairs` returns them, until the iterator is closed (then it
        unsubscribes).

        Raises:
            RemoteError: ``TASK.distances`` is refused (no such task: the message names the signal).
            ProtocolError: a stream message names no pairs or malformed ones
                (:func:`~drake_sot.remote.protocol.decode_pairs`).
        """
        with closing(self._stream(f"{task}.distances", period)) as messages:  # closed with this iterator
            for message in messages:
                yield message["t"], decode_pairs(message.get("pairs"), decode_vector(message["value"]))

    def _stream(self, signal: str, period: float) -> Iterator[dict[str, Any]]:
        """The stream messages of ``signal`` every ``period`` simulated seconds, until the
        iterator is closed (then it unsubscribes)."""
        self.request("subscribe", signal=signal, period=period)
        try:
            while True:
                message = self._streams.popleft() if self._streams else self.receive()
                if message.get("signal") == signal and "value" in message:
                    yield message
        finally:
            self.request("unsubscribe", signal=signal)
