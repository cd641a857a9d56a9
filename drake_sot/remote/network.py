"""The network side of the command server: a thread of its own that reads request lines,
answers malformed ones and authenticates, and queues the others for the serving loop.

It never touches a context (a thread that wrote into one would race the simulator's step): it
only puts ``(connection, Request)`` in
:attr:`NetworkThread.requests` and sends the messages the serving loop hands to
:meth:`NetworkThread.send`. Standard library only (``selectors``, ``socket``).

Limits per connection: a line is at most :data:`~drake_sot.remote.protocol.MAX_LINE`
bytes (a longer one gets one error reply and is skipped up to its newline); at most
``rate`` requests per second (a token bucket of ``burst``; the others get an error
reply); a client that leaves more than :data:`MAX_OUTBOX` bytes of replies unread is
disconnected; a partial line left when the client disconnects is dropped, so it changes nothing.
A client that half-closes (``shutdown(SHUT_WR)`` after its last request) still gets the replies
of the requests it sent: the connection is closed once they are all sent.
At most :data:`MAX_CONNECTIONS` authenticated connections at once (without a token, every connection
is); one more is answered with an error line. With a token, the connections that have not
authenticated yet are counted apart, so that no number of them keeps a token holder out: at most
:data:`MAX_UNAUTHENTICATED` wait at once (a newer one takes the place of the oldest, which is
closed), and each has :data:`AUTH_TIMEOUT` s (checked every :data:`_SWEEP` s) to send a matching
``auth``, after which it is closed. A connection refused or closed so gets its error line, then
the end of the stream (``shutdown``), and what it still sends is read and discarded for at most
:data:`LINGER` s before the socket is closed: closing a socket with unread input makes the kernel
reset the connection, and a reset loses the refusal line before the client reads it (at most
:data:`MAX_LINGERING` such sockets at once, the oldest closed first).
When ``accept`` fails (no file descriptor left: EMFILE, ENFILE), the listener rests
:data:`ACCEPT_BACKOFF` s and tries again (the client waits in the backlog); the connections
open are served meanwhile. Whatever a line holds, it gets an error reply
(:func:`~drake_sot.remote.protocol.parse_request` raises nothing but ProtocolError); should
handling a connection raise all the same, that connection gets an error line naming the
exception and is closed, and the thread serves the others on.
With a token, nothing but ``{"op": "auth"}`` is accepted until it matches (compared with
``hmac.compare_digest``, in constant time).

The ``horizon`` of the writes (a client that paces the served run, see
:mod:`~drake_sot.remote.protocol`) is kept as they are queued: :meth:`NetworkThread.wait_horizon`
tells the serving loop when it may simulate a tick, which happens only after the writes due by
then are in the queue.
"""

from __future__ import annotations

import hmac
import ipaddress
import math
import queue
import selectors
import socket
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from drake_sot.remote.protocol import MAX_LINE, ProtocolError, Request, encode, error, ok, parse_request

#: Bytes read from a socket at once.
_CHUNK = 65536
#: Bytes waiting for a client beyond which it is disconnected (it reads nothing).
MAX_OUTBOX = 16 * 1024 * 1024
#: Authenticated connections open at once (every connection without a token); one more gets an
#: error line and is closed.
MAX_CONNECTIONS = 64
#: Connections waiting to authenticate at once (a server with a token); a newer one closes the oldest.
MAX_UNAUTHENTICATED = 64
#: [s] a connection to a server with a token has to authenticate before it is closed.
AUTH_TIMEOUT = 10.0
#: [s] a refused connection's input is read and discarded after its error line, before the close.
LINGER = 2.0
#: Refused connections lingering so at once; one more closes the oldest at once.
MAX_LINGERING = 64
#: The refusal of a connection beyond :data:`MAX_CONNECTIONS`.
_TOO_MANY = f"too many connections: at most {MAX_CONNECTIONS} authenticated at once"
#: [s] how often the deadlines of the connections waiting to authenticate, or lingering, are checked.
_SWEEP = 0.25
#: [s] the listener rests after ``accept`` failed for want of a descriptor (EMFILE, ENFILE...).
ACCEPT_BACKOFF = 0.2


@dataclass
class _Connection:
    sock: socket.socket
    authed: bool
    inbox: bytearray = field(default_factory=bytearray)
    outbox: bytearray = field(default_factory=bytearray)
    skipping: bool = False  # inside a line over the limit: drop up to its newline
    ended: bool = False  # the client half-closed (sent EOF): closed once its replies are sent
    unanswered: int = 0  # requests queued for the serving loop and not answered yet
    answered: dict = field(default_factory=dict)  # signal -> the tick whose value it was sent at once
    watched: int = selectors.EVENT_READ  # the events the selector watches (0: unregistered)
    allowance: float = 0.0
    last: float = field(default_factory=time.monotonic)
    opened: float = field(default_factory=time.monotonic)  # when it was accepted [s, monotonic]


@dataclass
class _Lingering:
    """A refused connection: its error line is sent, then the end of the stream; its input is read
    and discarded until the client closes or ``until`` [s, monotonic]."""

    sock: socket.socket
    outbox: bytes
    until: float


class NetworkThread:
    """Accepts connections on ``host:port`` (``port`` 0: a free one, see :attr:`address`).

    Args:
        host: the address to bind, IPv4 or IPv6 (``::1``) or a name; anything but a loopback
            address (127.0.0.0/8, ``::1``, or the name ``localhost``) requires ``token``.
        port: the TCP port, 0 for a free one.
        token: the shared secret clients send with ``auth``; None: no authentication.
        rate: requests per second accepted from a connection (sustained), > 0.
        burst: requests accepted at once from a connection, >= 1.
        auth_timeout: [s] how long a connection may wait before it authenticates (with a token),
            > 0 (:data:`AUTH_TIMEOUT` by default).

    Raises:
        ValueError: a non-loopback ``host`` without a token, or an empty token or one that is not
            Unicode text (a lone surrogate: bytes of argv or the environment that are not UTF-8).
        OSError: the address cannot be bound.
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        token: str | None = None,
        rate: float = 1000.0,
        burst: int = 2000,
        auth_timeout: float = AUTH_TIMEOUT,
    ) -> None:
        if token is not None and not token:
            raise ValueError("token: empty (give a secret, or none for loopback only)")
        if token is None and not _is_loopback(host):
            raise ValueError(
                f"host = {host!r}: not loopback, so a token is required (--token or DRAKE_SOT_TOKEN)"
            )
        try:
            self._token = token.encode() if token is not None else None
        except UnicodeEncodeError:  # a byte of argv or the environment that is not UTF-8
            raise ValueError(
                "token: not Unicode text (a byte that is not UTF-8 in --token or DRAKE_SOT_TOKEN)"
            ) from None
        self._rate, self._burst = float(rate), float(burst)
        if not (0.0 < auth_timeout < math.inf):
            raise ValueError(f"auth_timeout = {auth_timeout!r} s: must be finite and > 0")
        self._auth_timeout = float(auth_timeout)
        self._listener = socket.create_server((host, port), family=_family(host))
        self._listener.setblocking(False)
        self.address: tuple[str, int] = self._listener.getsockname()[:2]
        self.requests: queue.Queue[tuple[int, Request | None]] = queue.Queue()
        self._selector = selectors.DefaultSelector()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._pending: deque[tuple[int, bytes]] = deque()
        self._connections: dict[int, _Connection] = {}  # in the order they were accepted
        self._lingering: dict[int, _Lingering] = {}  # refused connections, oldest first
        self._swept = time.monotonic()  # when the deadlines were last checked
        self._next_id = 0
        self._stop = threading.Event()
        self.connected = threading.Event()  # set at the first connection
        self._batch = threading.Lock()  # held while the lines of one read are queued
        self._thread = threading.Thread(target=self._loop, name="drake-sot-remote", daemon=True)
        self._paced = threading.Condition()  # guards the two below
        self._horizons: dict[int, float] = {}  # connection -> the largest horizon it wrote [s]
        self._pacer_left: int | None = None  # a connection that wrote a horizon, then closed
        self._resting_until: float | None = None  # accept failed: the listener is back at this time
        #: signal -> (t, values, the fields naming its rows) at the last tick, answered here
        #: (see :meth:`publish`)
        self._snapshot: dict[str, tuple[float, list, dict[str, Any]]] = {}
        #: the signals whose reads were answered from the snapshot, for the serving loop
        #: (:meth:`take_hits`; a deque: appended here, emptied there, without a lock)
        self._hits: deque[str] = deque()

    def start(self) -> None:
        self._selector.register(self._listener, selectors.EVENT_READ, "listen")
        self._selector.register(self._wake_r, selectors.EVENT_READ, "wake")
        self._thread.start()

    def close(self) -> None:
        """Stop the thread, close every connection and the listening socket."""
        self._stop.set()
        self._wake()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        for conn in list(self._connections.values()):
            conn.sock.close()
        for lingering in list(self._lingering.values()):
            lingering.sock.close()
        self._listener.close()
        self._wake_r.close()
        self._wake_w.close()

    def publish(self, snapshot: dict[str, tuple[float, list, dict[str, Any]]]) -> None:
        """Replace the values this thread answers a ``read`` with, without the serving loop: signal
        → ``(t, values, beside)`` at the last tick (``beside``: the reply's fields naming the
        rows, a stacked signal's ``layout`` or a self-collision task's ``pairs``; empty for others).
        A read of a signal in it, from a connection with no request waiting for the loop, is
        answered at once (the same value as after the next tick's wait, a tick earlier; a
        connection that waits for a reply keeps its order: its read queues behind), once per
        tick and connection (the next read of that value waits for the next tick). The loop
        publishes before it sends the replies of a tick, so that a client that got a reply reads
        its effect."""
        self._snapshot = snapshot  # one reference: atomic under the GIL

    def take_hits(self) -> set[str]:
        """The signals of which this thread answered a ``read`` from the published values since
        the last call: read by a client, though the serving loop never saw the request (it keeps
        publishing them)."""
        hits = set()
        while self._hits:
            hits.add(self._hits.popleft())
        return hits

    def send(self, connection: int, message: dict[str, Any]) -> None:
        """Queue ``message`` (the reply of a request the connection sent, or a stream message) for
        ``connection`` (from any thread); dropped if it is gone."""
        self._pending.append((connection, encode(message), "ok" in message))
        self._wake()

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"\0")
        except (BlockingIOError, OSError):
            pass  # already awake, or closing

    def _loop(self) -> None:
        while not self._stop.is_set():
            resting = self._resting_until is not None
            for key, events in self._selector.select(timeout=ACCEPT_BACKOFF if resting else _SWEEP):
                if key.data == "listen":
                    self._accept()
                elif key.data == "wake":
                    try:
                        self._wake_r.recv(4096)
                    except BlockingIOError:
                        pass
                elif isinstance(key.data, tuple):  # ("linger", id): a refused connection
                    self._linger(key.data[1], events)
                else:
                    self._guarded(key.data, events)
            while self._pending:
                cid, data, reply = self._pending.popleft()
                conn = self._connections.get(cid)
                if conn is not None:
                    conn.outbox += data
                    conn.unanswered -= reply
                    self._guarded(cid, selectors.EVENT_WRITE)
            if self._resting_until is not None and time.monotonic() >= self._resting_until:
                self._resting_until = None
                self._selector.register(self._listener, selectors.EVENT_READ, "listen")
            if time.monotonic() - self._swept >= _SWEEP:
                self._sweep()

    def _sweep(self) -> None:
        """Close the connections that did not authenticate within the timeout, and the refused
        ones whose lingering is over."""
        now = self._swept = time.monotonic()
        if self._token is not None:
            late = [
                cid
                for cid, conn in self._connections.items()
                if not conn.authed and not now - conn.opened < self._auth_timeout
            ]
            for cid in late:
                self._refuse(cid, f"closing: not authenticated within {self._auth_timeout:g} s")
        for lid in [lid for lid, lingering in self._lingering.items() if not now < lingering.until]:
            self._end_lingering(lid)

    def _guarded(self, cid: int, events: int) -> None:
        """Read from and write to connection ``cid``; should that raise, tell the client and close it."""
        try:
            if events & selectors.EVENT_READ:
                self._read(cid)
            if events & selectors.EVENT_WRITE and cid in self._connections:
                self._flush(cid)
        except Exception as exc:  # noqa: BLE001 - one connection must not end the thread serving all
            conn = self._connections.get(cid)
            if conn is not None:
                try:
                    conn.sock.send(
                        encode(error(None, f"closing the connection: {type(exc).__name__}: {exc}"))
                    )
                except OSError:
                    pass
                self._drop(cid)

    def _accept(self) -> None:
        try:
            sock, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError, ConnectionAbortedError):
            return
        except OSError:  # no descriptor left (EMFILE, ENFILE) or no buffer: rest, then try again
            self._selector.unregister(self._listener)
            self._resting_until = time.monotonic() + ACCEPT_BACKOFF
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        if self._token is None and len(self._connections) >= MAX_CONNECTIONS:
            self._linger_socket(sock, encode(error(None, _TOO_MANY)))
            return
        if self._token is not None:  # the oldest waiting to authenticate makes room for this one
            waiting = [cid for cid, conn in self._connections.items() if not conn.authed]
            if len(waiting) >= MAX_UNAUTHENTICATED:
                self._refuse(
                    waiting[0],
                    f"closing: not authenticated, and at most {MAX_UNAUTHENTICATED} connections wait "
                    "to authenticate at once (a newer one took this place)",
                )
        cid, self._next_id = self._next_id, self._next_id + 1
        self._connections[cid] = _Connection(sock, authed=self._token is None, allowance=self._burst)
        self._selector.register(sock, selectors.EVENT_READ, cid)
        self.connected.set()

    def _refuse(self, cid: int, message: str) -> None:
        """Close connection ``cid`` with the error line ``message`` after the replies it has (a
        connection the serving loop never heard of: not authenticated, or refused at ``auth``)."""
        conn = self._connections.pop(cid)
        if conn.watched:
            self._selector.unregister(conn.sock)
        self._linger_socket(conn.sock, bytes(conn.outbox) + encode(error(None, message)))

    def _linger_socket(self, sock: socket.socket, outbox: bytes) -> None:
        """Send ``outbox``, end the stream, and read what the client still sends until it closes or
        :data:`LINGER` s have passed: then close (see the module docstring)."""
        if len(self._lingering) >= MAX_LINGERING:
            self._end_lingering(next(iter(self._lingering)))
        lid, self._next_id = self._next_id, self._next_id + 1
        self._lingering[lid] = _Lingering(sock, outbox, time.monotonic() + LINGER)
        self._selector.register(sock, selectors.EVENT_READ, ("linger", lid))
        self._linger(lid, selectors.EVENT_WRITE)

    def _linger(self, lid: int, events: int) -> None:
        lingering = self._lingering[lid]
        try:
            if events & selectors.EVENT_READ:
                try:
                    if not lingering.sock.recv(_CHUNK):
                        self._end_lingering(lid)  # the client closed: nothing can be reset any more
                        return
                except BlockingIOError:
                    pass
            if events & selectors.EVENT_WRITE and lingering.outbox:
                try:
                    sent = lingering.sock.send(lingering.outbox)
                except BlockingIOError:
                    sent = 0
                lingering.outbox = lingering.outbox[sent:]
                if not lingering.outbox:
                    lingering.sock.shutdown(socket.SHUT_WR)
            wanted = selectors.EVENT_READ | (selectors.EVENT_WRITE if lingering.outbox else 0)
            self._selector.modify(lingering.sock, wanted, ("linger", lid))
        except OSError:  # reset by the client, or gone
            self._end_lingering(lid)

    def _end_lingering(self, lid: int) -> None:
        lingering = self._lingering.pop(lid)
        self._selector.unregister(lingering.sock)
        lingering.sock.close()

    def _drop(self, cid: int) -> None:
        conn = self._connections.pop(cid, None)
        if conn is None:
            return
        if conn.watched:
            self._selector.unregister(conn.sock)
        conn.sock.close()
        self.requests.put((cid, None))  # the serving loop forgets its subscriptions
        self._sends_no_more(cid)

    def _sends_no_more(self, cid: int) -> None:
        """Connection ``cid`` will send no more requests (EOF, or closed): a client that paced the
        run has left, since its horizon cannot move on."""
        with self._paced:
            if cid in self._horizons and self._pacer_left is None:
                self._pacer_left = cid
            self._paced.notify_all()

    def _read(self, cid: int) -> None:
        conn = self._connections[cid]
        try:
            data = conn.sock.recv(_CHUNK)
        except BlockingIOError:
            return
        except OSError:
            data = b""
        if not data:  # the client closed, or half-closed: answer what it sent, then close
            conn.ended = True
            conn.inbox.clear()  # a partial line is dropped: it changes nothing
            self._sends_no_more(cid)
            self._close_when_answered(cid)
            return
        conn.inbox += data
        with self._batch:  # the requests of one read reach the serving loop together
            self._lines(cid, conn)

    def drain(self) -> list[tuple[int, Request | None]]:
        """Every queued ``(connection, request)`` (None: it disconnected), in arrival order; the
        requests that arrived in one read of a socket are all in one drain."""
        items = []
        with self._batch:
            while True:
                try:
                    items.append(self.requests.get_nowait())
                except queue.Empty:
                    return items

    def _lines(self, cid: int, conn: _Connection) -> None:
        while True:
            end = conn.inbox.find(b"\n")
            if end < 0:
                if len(conn.inbox) >= MAX_LINE and not conn.skipping:
                    self._reply(cid, error(None, f"line over {MAX_LINE} bytes: skipped up to its newline"))
                    conn.skipping = True
                if conn.skipping:
                    conn.inbox.clear()
                return
            if cid not in self._connections:
                return  # dropped while replying: the rest of its input is ignored
            line = bytes(conn.inbox[:end])
            del conn.inbox[: end + 1]
            if conn.skipping:
                conn.skipping = False
                continue
            self._line(cid, conn, line.rstrip(b"\r"))

    def _line(self, cid: int, conn: _Connection, line: bytes) -> None:
        now = time.monotonic()
        conn.allowance = min(self._burst, conn.allowance + (now - conn.last) * self._rate)
        conn.last = now
        if conn.allowance < 1.0:
            self._reply(cid, error(None, f"rate limit: at most {self._rate:g} requests per second"))
            return
        conn.allowance -= 1.0
        try:
            request = parse_request(line)
        except ProtocolError as exc:
            message = (
                str(exc) if conn.authed else 'not authenticated: send {"op": "auth", "token": ...} first'
            )
            self._reply(cid, error(exc.request_id if conn.authed else None, message))
            return
        if request.op == "auth":
            if self._token is None:
                self._reply(cid, ok(request.id, "no token required", float("nan")))
            elif hmac.compare_digest(request.token.encode(), self._token):
                if sum(c.authed for c in self._connections.values()) >= MAX_CONNECTIONS:
                    self._refuse(cid, _TOO_MANY)
                    return
                conn.authed = True
                self._reply(cid, ok(request.id, "authenticated", float("nan")))
            else:
                self._reply(cid, error(request.id, "auth: wrong token"))
            return
        if not conn.authed:
            self._reply(cid, error(None, 'not authenticated: send {"op": "auth", "token": ...} first'))
            return
        if request.op == "read" and conn.unanswered == 0:
            held = self._snapshot.get(request.signal)
            # once per tick: a second read of the same value waits for the next tick, so that a
            # client polling in a loop is paced by the ticks (not stopped by the rate limit)
            if held is not None and conn.answered.get(request.signal) != held[0]:
                t, values, beside = held
                conn.answered[request.signal] = t
                self._hits.append(request.signal)
                self._reply(cid, {**ok(request.id, values, t), **beside})
                return
        conn.unanswered += 1
        self.requests.put((cid, request))
        if request.horizon is not None:
            with self._paced:
                self._horizons[cid] = max(self._horizons.get(cid, -math.inf), request.horizon)
                self._paced.notify_all()

    def wait_horizon(self, t: float, timeout: float) -> tuple[float, bool]:
        """Wait at most ``timeout`` [s] until a client's ``horizon`` is beyond ``t`` [s] (the
        writes due by ``t`` are then queued) or a client that sent one disconnected; the largest
        horizon (``-inf``: none yet) and whether such a client disconnected."""
        with self._paced:
            self._paced.wait_for(
                lambda: max(self._horizons.values(), default=-math.inf) > t or self._pacer_left is not None,
                timeout,
            )
            return max(self._horizons.values(), default=-math.inf), self._pacer_left is not None

    def _reply(self, cid: int, message: dict[str, Any]) -> None:
        conn = self._connections.get(cid)
        if conn is not None:
            conn.outbox += encode(message)
            self._flush(cid)

    def _flush(self, cid: int) -> None:
        conn = self._connections[cid]
        try:
            sent = conn.sock.send(conn.outbox) if conn.outbox else 0
        except BlockingIOError:
            sent = 0
        except OSError:
            self._drop(cid)
            return
        del conn.outbox[:sent]
        if len(conn.outbox) > MAX_OUTBOX:
            self._drop(cid)  # a client that does not read its replies and streams
            return
        if conn.ended:
            self._close_when_answered(cid)
            return
        self._watch(cid, conn)

    def _watch(self, cid: int, conn: _Connection) -> None:
        """Watch ``conn`` for reading until its client's EOF, and for writing while replies wait."""
        events = (0 if conn.ended else selectors.EVENT_READ) | (selectors.EVENT_WRITE if conn.outbox else 0)
        if events == conn.watched:
            return
        if not conn.watched:
            self._selector.register(conn.sock, events, cid)
        elif not events:
            self._selector.unregister(conn.sock)
        else:
            self._selector.modify(conn.sock, events, cid)
        conn.watched = events

    def _close_when_answered(self, cid: int) -> None:
        """A connection whose client sent EOF: closed once every reply is sent."""
        conn = self._connections[cid]
        if conn.unanswered <= 0 and not conn.outbox:
            self._drop(cid)
        else:
            self._watch(cid, conn)


def _is_loopback(host: str) -> bool:
    """True for a loopback address, read as an address (``127.0.0.0/8``, ``::1``), or the name
    ``localhost``; any other name (``127.example.com``) is not."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _family(host: str) -> socket.AddressFamily:
    """The socket family that binds ``host``: IPv6 for an IPv6 address, else IPv4."""
    try:
        return socket.AF_INET6 if ipaddress.ip_address(host).version == 6 else socket.AF_INET
    except ValueError:
        return socket.AF_INET  # a name: create_server resolves it
