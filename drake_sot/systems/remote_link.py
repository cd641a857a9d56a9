"""``RemoteLink``: a link to a diagram in another process, with the same delay, jitter and loss
emulation as :class:`~drake_sot.systems.channel.Channel`, both directions drawn on this side.

The network is not this system's: it talks to a *peer* (duck-typed, e.g.
:class:`~drake_sot.remote.peer.Peer`) whose threads do the I/O; this system only takes what the
peer received and gives it what to send, in its own periodic event (the network never
touches a context: only a system's own event changes what a tick computes). What crosses the
processes is named: the other side's writable signals
(``forward_signals``) and readable ones (``backward_signals``), each with its size. At each
period ``t`` (ticks ``k·period`` from 0, the same on both sides: simulated time):

- **outgoing** (``forward``, this side → the other): the input is one packet, its delay and loss
  drawn by a :class:`~drake_sot.channel.Link` (packet ``k`` as a ``Channel``'s packet ``k``, same
  seed); it is posted at once, split into the named signals, stamped with its sending time
  ``t``, its arrival time (``inf`` when lost) and the *horizon* ``t + period + (delay − jitter)``
  before which no later packet can arrive. The other side applies it at its tick at or after
  the arrival (a timed write) and simulates no tick at or past the horizon before it knows the
  next one: it delivers at the ticks a ``Channel`` delivers at, whatever the processes' pace;
- **incoming** (``backward``, the other side → this one): each packet the peer received is the
  named signals of one tick of the other side, stamped with its time there; it enters the
  backward ``Link`` as sent at that time (delay and loss drawn here, as a ``Channel`` draws
  them), so it is delivered at the tick a ``Channel`` delivers it. The other side's stream
  starts at its first tick after 0 (a subscription answers after the tick that took it): its
  packet of ``t = 0`` is ``backward_initial``, its initial value. A packet missing from the
  sequence (a gap in the stamps) fails the tick, naming the times.

Before simulating the tick ``t`` the host calls :meth:`RemoteLink.await_peer`, which blocks until
the peer received every packet that can be delivered by ``t`` (those sent up to
``t − (delay − jitter)``): each side simulates up to the delay ahead of the other without
waiting (conservative lookahead, as in parallel discrete-event simulation). This needs both
directions' shortest delay ``delay − jitter`` to be at least one period (refused otherwise, with
the values): with less, a packet could be due at the tick it is sent, before the other side
could know it.
"""

from __future__ import annotations

import math
import time as wallclock
from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import Context, State

from drake_sot import validation
from drake_sot.channel import Link, LinkConfig
from drake_sot.systems.leaf import SotLeafSystem

#: Times within this of a tick count as that tick [s].
_EPS = 1e-9


class LinkPeer(Protocol):
    """What :class:`RemoteLink` needs of the network side."""

    def take(self) -> list[tuple[float, dict[str, tuple[float, ...]]]]:
        """The packets ``(sender's time [s], {signal: value})`` received since the last call, in order."""
        ...

    def post(self, t: float, at: float, horizon: float, values: Mapping[str, Sequence[float]]) -> None:
        """Send the named values sent at ``t``, due at ``at`` (inf: lost), before ``horizon`` (no block)."""
        ...

    def wait_beyond(self, t: float, timeout: float) -> bool:
        """Wait at most ``timeout`` [s] for a packet of the sender's time > ``t``; whether one came."""
        ...


def _signals(label: str, signals: Sequence[tuple[str, int]]) -> tuple[tuple[str, int], ...]:
    checked = tuple(
        (str(name), validation.positive_int(f"{label} {name!r}: size", size)) for name, size in signals
    )
    names = [name for name, _ in checked]
    if not checked or len(set(names)) != len(names):
        raise ValueError(f"{label}: one or more signals, each name once; got {names}")
    return checked


class RemoteLink(SotLeafSystem):
    """Both directions of an emulated link to a peer process (see the module docstring).

    Input ports:
        forward_in: (n_forward,) what this side sends, sampled each period: the
            ``forward_signals`` one after the other, in their order and units.
    Output ports (held between periods; they depend on the state only):
        forward_out: (n_forward,) what the other side holds at this tick (the newest packet
            delivered by now), the same values the other side applies.
        backward_out: (n_backward,) what this side receives: the newest packet delivered, the
            ``backward_signals`` one after the other.
        forward_age, backward_age: (1,) [s] how old each held value is on the sender's clock
            (1e9 before the first packet).

    Args:
        peer: the network side (:class:`LinkPeer`); None: nothing is sent or received (the
            outputs hold their initial values) until :meth:`attach` gives one.
        forward_signals: ``(name, size)`` of each signal the other side writes, e.g.
            ``("remote.right_hand_force", 3)``.
        backward_signals: ``(name, size)`` of each signal of the other side this side reads.
        forward, backward: each direction's :class:`~drake_sot.channel.LinkConfig`;
            ``delay - jitter`` >= ``period``.
        period: [s] the sampling period (the control period, the same on both sides).
        forward_initial, backward_initial: the values held before the first packet (the
            latter is also the other side's packet of t = 0).
        name: the system's name.
    """

    def __init__(
        self,
        peer: LinkPeer | None,
        forward_signals: Sequence[tuple[str, int]],
        backward_signals: Sequence[tuple[str, int]],
        *,
        forward: LinkConfig,
        backward: LinkConfig,
        period: float,
        forward_initial: np.ndarray,
        backward_initial: np.ndarray,
        name: str = "remote_link",
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._peer = peer
        self._out = _signals("forward_signals", forward_signals)
        self._in = _signals("backward_signals", backward_signals)
        n_f = sum(size for _, size in self._out)
        n_b = sum(size for _, size in self._in)
        self._period = validation.positive("period", period, unit="s")
        for label, config in (("forward", forward), ("backward", backward)):
            if not (config.min_delay >= self._period - 1e-12):
                raise ValueError(
                    f"{label}: delay - jitter = {config.delay:g} - {config.jitter:g} = "
                    f"{config.min_delay:g} s: the two-process link needs at least one period "
                    f"({self._period:g} s), so that no packet is due at the tick it is sent"
                )
        self._backward_min = backward.min_delay
        b0 = validation.vector("backward_initial", backward_initial, n_b)
        links = (
            Link.start(forward, validation.vector("forward_initial", forward_initial, n_f)),
            Link.start(backward, b0).send(0.0, b0),  # the other side's packet of t = 0
        )
        self._links = self.DeclareAbstractState(Value[object](links))
        self._forward = self.DeclareVectorInputPort("forward_in", n_f)
        ticket = {self.abstract_state_ticket(self._links)}
        for i, (direction, size) in enumerate((("forward", n_f), ("backward", n_b))):
            self.DeclareVectorOutputPort(
                f"{direction}_out",
                size,
                lambda c, out, i=i: out.SetFromVector(self._state(c)[i].value),
                prerequisites_of_calc=ticket,
            )
            self.DeclareVectorOutputPort(
                f"{direction}_age",
                1,
                lambda c, out, i=i: out.SetFromVector([min(self._state(c)[i].age(c.get_time()), 1e9)]),
                prerequisites_of_calc={self.time_ticket(), *ticket},
            )
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._tick)

    def attach(self, peer: LinkPeer | None) -> None:
        """Send to and receive from ``peer`` from the next period on (None: stop)."""
        self._peer = peer

    def await_peer(self, t: float, timeout: float) -> None:
        """Block until the peer received every packet that can be delivered by the tick ``t``
        [s] (call before simulating it). Waits in slices of 0.5 s (a signal stops it).

        Raises:
            TimeoutError: nothing new within ``timeout`` [s] of wall time (the times it waited for).
        """
        beyond = t - self._period - self._backward_min + _EPS  # a packet sent after it is due after t
        if self._peer is None or beyond < 0.0:  # the packet of t = 0 is known
            return
        deadline = wallclock.monotonic() + timeout
        while not self._peer.wait_beyond(beyond, min(0.5, max(deadline - wallclock.monotonic(), 0.0))):
            if wallclock.monotonic() >= deadline:
                raise TimeoutError(
                    f"{self.get_name()}: no packet of the other side sent after t = {beyond:.6f} s "
                    f"within {timeout:g} s (needed before the tick of t = {t:.6f} s)"
                )

    def _state(self, context: Context) -> tuple[Link, Link]:
        return context.get_abstract_state(self._links).get_value()

    def _split(self, value: np.ndarray) -> dict[str, np.ndarray]:
        starts = np.cumsum([0, *(size for _, size in self._out)])
        return {name: value[a:b] for (name, _), a, b in zip(self._out, starts[:-1], starts[1:], strict=True)}

    def _join(self, t: float, values: Mapping[str, Sequence[float]]) -> np.ndarray:
        parts = []
        for name, size in self._in:
            if name not in values or len(values[name]) != size:
                got = {n: len(v) for n, v in values.items()}
                raise ValueError(
                    f"{self.get_name()}: packet of t = {t:.6f} s: expected {name!r} ({size}), got {got}"
                )
            parts.append(np.asarray(values[name], dtype=float))
        return np.concatenate(parts)

    def _tick(self, context: Context, state: State) -> None:
        now = context.get_time()
        forward, backward = self._state(context)
        value = validation.vector(f"{self.get_name()}.forward_in", self._forward.Eval(context))
        sent = forward.send(now, value)
        if self._peer is not None:
            horizon = now + self._period + forward.config.min_delay
            self._peer.post(now, sent.last_arrival, horizon, self._split(value))
            for t, values in self._peer.take():
                expected = backward.sent * self._period
                if not math.isclose(t, expected, rel_tol=0.0, abs_tol=1e-6 * self._period):
                    raise RuntimeError(
                        f"{self.get_name()}: the other side's packet of t = {expected:.6f} s is missing "
                        f"(the next one received is of t = {t:.6f} s)"
                    )
                backward = backward.send(t, self._join(t, values))
        state.get_mutable_abstract_state(self._links).set_value((sent.receive(now), backward.receive(now)))
