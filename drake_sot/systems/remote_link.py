"""``RemoteLink``: a link to a diagram in another process, with the same delay, jitter and loss
emulation as :class:`~drake_sot.systems.channel.Channel`, both directions on this side.

The network is not this system's: it talks to a *peer* (duck-typed, e.g.
:class:`~drake_sot.remote.peer.Peer`) whose threads do the I/O; this system only takes what the
peer received and gives it what to send, in its own periodic event (DESIGN.md: the network never
touches a context). At each period ``t``:

- **outgoing** (``forward``, this side → the other): the input is sent as one packet into a
  :class:`~drake_sot.channel.Link`; when a packet is delivered by ``t`` (sent at ``t − delay``
  or before, jitter and loss included), its value is posted to the peer, which writes it;
- **incoming** (``backward``, the other side → this one): each message the peer received is one
  packet *stamped with the other side's simulated time* (not the arrival time here), so that the
  delay is counted on the sender's clock as in one diagram; the output holds the newest packet
  delivered by ``t``.

With the two clocks aligned (the other side starts when this one connects, and this side's run
does not get ahead of the other's stamps), the delays are those of a ``Channel``; what remains is
the transport's latency on the outgoing side (a write acts at the other side's tick after it
arrives).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import Context, LeafSystem, State

from drake_sot import validation
from drake_sot.channel import Link, LinkConfig


class LinkPeer(Protocol):
    """What :class:`RemoteLink` needs of the network side."""

    def take(self) -> list[tuple[float, tuple[float, ...]]]:
        """The messages ``(sender's time [s], value)`` received since the last call, in order."""
        ...

    def post(self, value: np.ndarray) -> None:
        """Send ``value`` (without blocking)."""
        ...


class RemoteLink(LeafSystem):
    """Both directions of an emulated link to a peer process (see the module docstring).

    Input ports:
        forward_in: (n_forward,) what this side sends, sampled each period.
    Output ports (held between periods; they depend on the state only):
        forward_out: (n_forward,) the value delivered to the peer last (what it was sent).
        backward_out: (n_backward,) what this side receives: the newest packet delivered.
        forward_age, backward_age: (1,) [s] how old each held value is on the sender's clock
            (1e9 before the first packet).

    Args:
        peer: the network side (:class:`LinkPeer`); None: nothing is sent or received (the
            outputs hold their initial values) until :meth:`attach` gives one.
        forward_size, backward_size: the vectors' lengths (>= 1).
        forward, backward: each direction's :class:`~drake_sot.channel.LinkConfig`.
        period: [s] the sampling period (the control period).
        forward_initial, backward_initial: the values held before the first packet.
        name: the system's name.
    """

    def __init__(
        self,
        peer: LinkPeer | None,
        forward_size: int,
        backward_size: int,
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
        n_f = validation.positive_int("forward_size", forward_size)
        n_b = validation.positive_int("backward_size", backward_size)
        self._period = validation.positive("period", period, unit="s")
        links = (
            Link.start(forward, validation.vector("forward_initial", forward_initial, n_f)),
            Link.start(backward, validation.vector("backward_initial", backward_initial, n_b)),
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

    def _state(self, context: Context) -> tuple[Link, Link]:
        return context.get_abstract_state(self._links).get_value()

    def _tick(self, context: Context, state: State) -> None:
        now = context.get_time()
        forward, backward = self._state(context)
        sent = forward.step(
            now, validation.vector(f"{self.get_name()}.forward_in", self._forward.Eval(context))
        )
        if self._peer is not None:
            if sent.sent_at != forward.sent_at:  # a newer packet was delivered
                self._peer.post(sent.value)
            for t, value in self._peer.take():
                backward = backward.send(t, value)
        state.get_mutable_abstract_state(self._links).set_value((sent, backward.receive(now)))
