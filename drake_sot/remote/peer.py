"""``Peer``: a diagram's network link to a served diagram, in threads of its own.

The two-process tele-cooperation (Evrard et al. 2009) runs its master site as a client of the
slave's ``drake-sot serve``. A LeafSystem of the master's diagram
(:class:`~drake_sot.systems.remote_link.RemoteLink`) must not block on a socket and the network
must never touch a context (a thread that wrote into one would race the simulator's step), so
the I/O lives here, in two threads sharing one
connection (one only writes to the socket, the other only reads it):

- the **reader** takes the stream of the subscriptions to the served signals ``read`` (each
  ``(t, value)``, ``t`` the server's simulated time) and puts together, per ``t``, one *packet*
  ``(t, {signal: value})`` once every signal of that tick came, for :meth:`Peer.take`; it also
  reads the replies to the writes and keeps the first refusal;
- the **writer** sends, in order, the timed writes of each packet given to :meth:`Peer.post`
  (one ``write`` per named signal, all stamped with the packet's ``t``, ``at`` and
  ``horizon``: see :mod:`~drake_sot.remote.protocol`). Nothing is dropped or merged: the served
  side needs every packet, each in its place, to apply it at its time.

The subscriptions are sent first on the connection, before any write, so the server takes them at
its first tick and streams every tick after it.

A failure of either thread (refused write, lost connection) is kept and raised by the next
:meth:`Peer.take`, :meth:`Peer.post` or :meth:`Peer.wait_beyond`, in the simulator's thread.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Mapping, Sequence

from drake_sot import validation
from drake_sot.errors import DrakeSotError
from drake_sot.remote.client import Client, RemoteError
from drake_sot.remote.protocol import decode_vector, encode

Packet = tuple[float, dict[str, tuple[float, ...]]]
"""``(the sender's simulated time [s], {signal: value})``."""


class PeerError(DrakeSotError, RuntimeError):
    """The link to the served diagram failed (the message says which thread and why)."""


class Peer:
    """Connects to ``host:port``, subscribes to each signal of ``read`` every ``period`` [s],
    and writes what :meth:`post` is given; :meth:`close` ends the threads. ``token``: the
    server's token, if it has one; ``timeout`` [s]: of silence from the server before the
    reader fails.

    Raises:
        PeerError: the connection could not be made (the address and why).
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        read: Sequence[str],
        period: float,
        token: str | None = None,
        timeout: float = 30.0,
    ) -> None:
        self.period = validation.positive("period", period, unit="s")
        if not read:
            raise ValueError("read: at least one signal to subscribe to")
        self._read = tuple(read)
        self._lock = threading.Condition()
        self._partial: dict[float, dict[str, tuple[float, ...]]] = {}
        self._received: list[Packet] = []
        self._latest = -math.inf  # server time of the newest complete packet [s]
        self._outgoing: deque[bytes] = deque()
        self._failure: str | None = None
        self._closing = False
        self._request_id = 0
        try:
            self._client = Client(host, port, token=token, timeout=timeout)
            for signal in self._read:
                self._client.send_raw(
                    encode(
                        {"id": f"subscribe {signal}", "op": "subscribe", "signal": signal, "period": period}
                    )
                )
        except OSError as exc:
            raise PeerError(f"cannot connect to {host}:{port}: {exc}") from exc
        self._threads = [
            threading.Thread(target=target, name=f"drake-sot-peer-{name}", daemon=True)
            for name, target in (("read", self._reader), ("write", self._writer))
        ]
        for thread in self._threads:
            thread.start()

    def __enter__(self) -> Peer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Send what was posted, stop both threads and close the connection."""
        with self._lock:
            self._closing = True
            self._lock.notify_all()
        self._threads[1].join(timeout=5.0)  # the writer sends what is left first
        self._client.close()
        self._threads[0].join(timeout=5.0)

    @property
    def latest(self) -> float:
        """[s] the server's time of the newest complete packet received (-inf before the first)."""
        with self._lock:
            return self._latest

    def take(self) -> list[Packet]:
        """The packets completed since the last call, in order of time."""
        with self._lock:
            self._raise()
            taken, self._received = self._received, []
            return taken

    def post(self, t: float, at: float, horizon: float, values: Mapping[str, Sequence[float]]) -> None:
        """Write each ``{signal: value}`` as sent at ``t`` [s], to be applied at ``at`` [s]
        (``inf``: lost, never applied), no later packet being due before ``horizon`` [s]."""
        lines = []
        for signal, value in values.items():
            self._request_id += 1
            message = {"id": self._request_id, "op": "write", "signal": signal, "value": list(value)}
            lines.append(encode({**message, "t": t, "at": at, "horizon": horizon}))  # at inf: null
        with self._lock:
            self._raise()
            self._outgoing.append(b"".join(lines))
            self._lock.notify_all()

    def wait_beyond(self, t: float, timeout: float) -> bool:
        """Wait (at most ``timeout`` [s] of wall time) until a packet of server time > ``t``
        [s] is complete; whether one is."""
        with self._lock:
            self._lock.wait_for(lambda: self._latest > t or self._failure is not None, timeout)
            self._raise()
            return self._latest > t

    def _raise(self) -> None:
        if self._failure is not None:
            raise PeerError(self._failure)

    def _fail(self, where: str, exc: Exception) -> None:
        with self._lock:
            if not self._closing and self._failure is None:
                self._failure = f"{where}: {type(exc).__name__}: {exc}"
            self._lock.notify_all()

    def _reader(self) -> None:
        try:
            while True:
                message = self._client.receive()
                if "ok" in message:
                    if not message["ok"]:
                        raise RemoteError(f"request {message.get('id')!r}: {message.get('error')}")
                    continue
                signal = message.get("signal")
                if signal in self._read and "value" in message:
                    self._receive(float(message["t"]), signal, tuple(decode_vector(message["value"])))
        except Exception as exc:  # noqa: BLE001 - kept, raised in the simulator's thread
            self._fail(f"reading {', '.join(self._read)}", exc)

    def _receive(self, t: float, signal: str, value: tuple[float, ...]) -> None:
        with self._lock:
            parts = self._partial.setdefault(t, {})
            parts[signal] = value
            if len(parts) == len(self._read):
                del self._partial[t]
                self._received.append((t, {name: parts[name] for name in self._read}))
                self._latest = t
                self._lock.notify_all()

    def _writer(self) -> None:
        """Send the posted packets in order (the socket is only written here)."""
        try:
            while True:
                with self._lock:
                    self._lock.wait_for(lambda: self._outgoing or self._closing)
                    if not self._outgoing:
                        return
                    data = b"".join(self._outgoing)
                    self._outgoing.clear()
                self._client.send_raw(data)
        except Exception as exc:  # noqa: BLE001 - kept, raised in the simulator's thread
            self._fail("writing", exc)
