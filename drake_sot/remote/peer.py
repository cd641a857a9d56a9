"""``Peer``: a diagram's network link to a served diagram, in threads of its own.

The two-process tele-cooperation (Evrard et al. 2009) runs its master site as a client of the
slave's ``drake-sot serve``. A LeafSystem of the master's diagram
(:class:`~drake_sot.systems.remote_link.RemoteLink`) must not block on a socket and the network
must never touch a context (DESIGN.md), so the I/O lives here, in two threads, each on its own
connection (a :class:`~drake_sot.remote.client.Client` is not thread-safe):

- the **reader** subscribes to one signal of the server and queues its stream messages
  ``(t, value)`` (``t`` the server's simulated time) for :meth:`Peer.take`; the subscription is
  sent as soon as its connection is open, before the writer's connection (a served run that waits
  for its first client starts at that connection: its first ticks are then streamed too);
- the **writer** sends the newest value given to :meth:`Peer.post` with the protocol's ``write``
  at once, without waiting for the reply of the previous one (a reply leaves the server after
  the tick that applied the write, one control period or more later: waiting for it would delay
  every other write by a tick); values posted while one is being sent replace each other;
- the **acknowledger** reads the replies on the writer's connection, and keeps the first refusal.

A failure of either thread (refused write, lost connection) is kept and raised by the next
:meth:`Peer.take`, :meth:`Peer.post` or :meth:`Peer.wait_until`, in the simulator's thread.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

from drake_sot import validation
from drake_sot.remote.client import Client, RemoteError
from drake_sot.remote.protocol import decode_vector, encode


class PeerError(RuntimeError):
    """The link to the served diagram failed (the message says which thread and why)."""


class Peer:
    """Connects twice to ``host:port``: subscribes to ``read`` every ``period`` [s] and writes
    ``write``; :meth:`close` ends the threads. ``token``: the server's token, if it has one.

    Raises:
        PeerError: the connection could not be made (the address and why).
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        read: str,
        write: str,
        period: float,
        token: str | None = None,
        timeout: float = 30.0,
    ) -> None:
        self.period = validation.positive("period", period, unit="s")
        self._read, self._write = read, write
        self._lock = threading.Condition()
        self._received: list[tuple[float, tuple[float, ...]]] = []
        self._latest = float("-inf")  # server time of the newest stream message [s]
        self._outgoing: tuple[float, ...] | None = None
        self._failure: str | None = None
        self._closing = False
        try:
            self._reader_client = Client(host, port, token=token, timeout=timeout)
            self._reader_client.send_raw(
                encode({"id": "subscribe", "op": "subscribe", "signal": read, "period": period})
            )
            self._writer_client = Client(host, port, token=token, timeout=timeout)
        except OSError as exc:
            raise PeerError(f"cannot connect to {host}:{port}: {exc}") from exc
        self._threads = [
            threading.Thread(target=target, name=f"drake-sot-peer-{name}", daemon=True)
            for name, target in (("read", self._reader), ("write", self._writer), ("ack", self._acks))
        ]
        for thread in self._threads:
            thread.start()

    def __enter__(self) -> Peer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop both threads and close both connections."""
        with self._lock:
            self._closing = True
            self._lock.notify_all()
        for client in (self._reader_client, self._writer_client):
            client.close()
        for thread in self._threads:
            thread.join(timeout=5.0)

    @property
    def latest(self) -> float:
        """[s] the server's time of the newest message received (-inf before the first)."""
        with self._lock:
            return self._latest

    def take(self) -> list[tuple[float, tuple[float, ...]]]:
        """The stream messages ``(t, value)`` received since the last call, in order."""
        with self._lock:
            self._raise()
            taken, self._received = self._received, []
            return taken

    def post(self, value: Sequence[float]) -> None:
        """Write ``value`` (it replaces a value posted and not yet sent)."""
        with self._lock:
            self._raise()
            self._outgoing = tuple(float(x) for x in value)
            self._lock.notify_all()

    def wait_until(self, t: float, timeout: float) -> bool:
        """Wait (at most ``timeout`` [s] of wall time) until a message of server time >= ``t``
        arrived; whether it did."""
        with self._lock:
            self._lock.wait_for(lambda: self._latest >= t or self._failure is not None, timeout)
            self._raise()
            return self._latest >= t

    def _raise(self) -> None:
        if self._failure is not None:
            raise PeerError(self._failure)

    def _fail(self, where: str, exc: Exception) -> None:
        with self._lock:
            if not self._closing and self._failure is None:
                self._failure = f"{where} {self._read if where == 'reading' else self._write}: {exc}"
            self._lock.notify_all()

    def _reader(self) -> None:
        try:
            while True:
                message = self._reader_client.receive()
                if "ok" in message and not message["ok"]:
                    raise RemoteError(message.get("error"))
                if message.get("signal") == self._read and "value" in message:
                    with self._lock:
                        self._received.append((float(message["t"]), tuple(decode_vector(message["value"]))))
                        self._latest = float(message["t"])
                        self._lock.notify_all()
        except Exception as exc:  # noqa: BLE001 - kept, raised in the simulator's thread
            self._fail("reading", exc)

    def _writer(self) -> None:
        """Send each posted value as one ``write`` line (the socket is only written here; the
        acknowledger only reads it)."""
        request_id = 0
        try:
            while True:
                with self._lock:
                    self._lock.wait_for(lambda: self._outgoing is not None or self._closing)
                    if self._closing:
                        return
                    value, self._outgoing = self._outgoing, None
                request_id += 1
                self._writer_client.send_raw(
                    encode({"id": request_id, "op": "write", "signal": self._write, "value": list(value)})
                )
        except Exception as exc:  # noqa: BLE001 - kept, raised in the simulator's thread
            self._fail("writing", exc)

    def _acks(self) -> None:
        try:
            while True:
                reply = self._writer_client.receive()
                if not reply.get("ok", False):
                    raise RemoteError(reply.get("error", f"unexpected message {reply!r}"))
        except Exception as exc:  # noqa: BLE001 - kept, raised in the simulator's thread
            self._fail("writing", exc)
