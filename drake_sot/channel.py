"""An emulated network link: delay, jitter and packet loss on a sampled signal (pure numpy).

The tele-cooperation of Evrard et al. 2009 couples a master site (Munich) and a slave site
(Tsukuba) through an intercontinental link of about 280 ms round trip. :class:`Link` is one
direction of such a link, sampled at the control period:

- every :meth:`Link.send` is one packet, numbered ``k = 0, 1, 2 ...`` in sending order;
- packet ``k`` is lost with probability ``loss``; otherwise it arrives at
  ``t_send + delay + j_k``, with the jitter ``j_k`` uniform in ``[-jitter, +jitter]``
  (the arrival is never before the sending time: ``delay + j_k`` is clipped at 0);
- the receiver holds the value of the newest packet (by sending order) that has arrived:
  a packet overtaken by a newer one is discarded when it arrives late, and a lost packet
  leaves the last value held (zero-order hold, as a UDP receiver does).

A link whose sender and receiver are in two processes (the two-process tele-cooperation) splits
this in two: the sender's :meth:`Link.send` draws each packet's arrival time (on the sender's
clock, which both processes share: simulated time), and the receiver's link takes the packet
with that arrival time decided (:meth:`Link.carry`), so it delivers at the same ticks as one
link in one process would, whatever the order and the wall time in which packets reach it.

Randomness is reproducible and independent of when the link is read: the jitter and the
loss of packet ``k`` are drawn from ``numpy.random.default_rng((seed, k))``, so two links
with the same seed (e.g. the one-process and the two-process runs) lose the same packets
and jitter them the same way.

A :class:`Link` is immutable: :meth:`Link.send` and :meth:`Link.receive` return a new
link, so a Drake abstract state holds it without copies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from drake_sot import validation
from drake_sot.immutable import Immutable

__all__ = ["MAX_DELAY", "DEFAULT_DELAY", "LinkConfig", "Link"]

#: [s] the largest one-way delay a link accepts: 0-300 ms covers the Munich-Tsukuba link's 140 ms
#: (Evrard et al. 2009) with room to spare.
MAX_DELAY = 0.3
#: [s] the default one-way delay: half of the Munich-Tsukuba round trip of Evrard et al. 2009.
DEFAULT_DELAY = 0.14


@dataclass(frozen=True)
class LinkConfig:
    """The parameters of one direction of a link.

    Attributes:
        delay: [s] nominal one-way delay, in [0, ``MAX_DELAY``].
        jitter: [s] half-width of the uniform jitter added to each packet's delay, in
            [0, ``MAX_DELAY`` - ``delay``] (the worst delay stays within ``MAX_DELAY``).
        loss: probability in [0, 1) that a packet is lost.
        seed: seed of the packets' jitter and loss draws (an int >= 0).
    """

    delay: float = DEFAULT_DELAY
    jitter: float = 0.0
    loss: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        delay = validation.bounded("LinkConfig.delay", self.delay, 0.0, MAX_DELAY, unit="s")
        jitter = validation.bounded("LinkConfig.jitter", self.jitter, 0.0, MAX_DELAY - delay, unit="s")
        loss = validation.finite("LinkConfig.loss", self.loss)
        if not (0.0 <= loss < 1.0):
            raise ValueError(f"LinkConfig.loss = {self.loss!r}: must be in [0, 1)")
        seed = validation.positive_int("LinkConfig.seed", self.seed, minimum=0)
        object.__setattr__(self, "delay", delay)
        object.__setattr__(self, "jitter", jitter)
        object.__setattr__(self, "loss", loss)
        object.__setattr__(self, "seed", seed)

    def packet(self, k: int) -> tuple[float, bool]:
        """``(delay [s], lost)`` of packet ``k``: a pure function of ``(seed, k)``."""
        if self.jitter == 0.0 and self.loss == 0.0:
            return self.delay, False
        u_jitter, u_loss = np.random.default_rng((self.seed, k)).random(2)
        delay = max(self.delay + self.jitter * (2.0 * u_jitter - 1.0), 0.0)
        return delay, bool(u_loss < self.loss)

    @property
    def min_delay(self) -> float:
        """[s] the shortest delay a packet can have: ``delay - jitter`` (>= 0)."""
        return self.delay - self.jitter


#: Arrival times within this of "now" count as arrived [s] (sampled times are sums of floats).
_EPS = 1e-9


@dataclass(frozen=True)
class Link(Immutable):
    """One direction of a link: packets in flight and the value the receiver holds.

    Make one with :meth:`start`. Attributes:
        config: delay, jitter, loss, seed; None for a receiving end whose packets come with
            their arrival time decided by the sender's link (:meth:`carry` only).
        value: (n,) the value the receiver holds.
        sent_at: [s] sending time of the held value (``-inf`` for the initial value).
        sent: number of packets sent so far (the index of the next one).
        in_flight: ``(arrival time, sending time, value)`` of the packets not yet arrived,
            in sending order.
        last_arrival: [s] the arrival time of the last packet sent (``inf``: it was lost;
            NaN before the first).
    """

    config: LinkConfig | None
    value: np.ndarray
    sent_at: float = -math.inf
    sent: int = 0
    in_flight: tuple[tuple[float, float, np.ndarray], ...] = field(default=())
    last_arrival: float = math.nan

    @classmethod
    def start(cls, config: LinkConfig | None, initial) -> Link:
        """A link whose receiver holds ``initial`` (n,) until a first packet arrives (``config``
        None: a receiving end, see :meth:`carry`)."""
        if not (config is None or isinstance(config, LinkConfig)):
            raise TypeError(f"config must be a LinkConfig or None, got {type(config).__name__}")
        value = validation.vector("initial", initial)
        value.setflags(write=False)
        return cls(config=config, value=value)

    @property
    def size(self) -> int:
        """Length of the carried vector."""
        return self.value.shape[0]

    def age(self, now: float) -> float:
        """[s] how old the held value is at ``now`` (``inf`` before the first arrival)."""
        return now - self.sent_at

    def send(self, now: float, value) -> Link:
        """The link after sending ``value`` (n,) at time ``now`` [s] (one packet, its delay and
        loss drawn from the config; the packet's arrival is :attr:`last_arrival`)."""
        if self.config is None:
            raise ValueError("send: a receiving end (config None) only carries packets: see carry()")
        now = validation.finite("now", now)
        delay, lost = self.config.packet(self.sent)
        return self.carry(now, math.inf if lost else now + delay, value)

    def carry(self, sent_at: float, arrival: float, value) -> Link:
        """The link after a packet sent at ``sent_at`` [s] whose arrival time [s] another link
        drew (``inf``: it was lost): the receiving end of a link split across processes."""
        sent_at = validation.finite("sent_at", sent_at)
        if math.isnan(arrival) or arrival < sent_at:
            raise ValueError(f"arrival = {arrival!r}: a time [s] >= sent_at = {sent_at!r} (inf: lost)")
        v = validation.vector("value", value, self.size).copy()
        v.setflags(write=False)
        lost = math.isinf(arrival)
        flying = self.in_flight if lost else (*self.in_flight, (float(arrival), sent_at, v))
        return replace(self, sent=self.sent + 1, in_flight=flying, last_arrival=float(arrival))

    def receive(self, now: float) -> Link:
        """The link at time ``now`` [s] (finite: ValueError otherwise): every packet due by then
        has arrived; the receiver holds the newest of them (by sending time) if newer than what
        it held."""
        now = validation.finite("now", now)
        arrived = [p for p in self.in_flight if p[0] <= now + _EPS]
        if not arrived:
            return self
        flying = tuple(p for p in self.in_flight if p[0] > now + _EPS)
        _, sent_at, value = max(arrived, key=lambda p: p[1])
        if sent_at > self.sent_at:
            return replace(self, value=value, sent_at=sent_at, in_flight=flying)
        return replace(self, in_flight=flying)

    def step(self, now: float, value) -> Link:
        """:meth:`send` then :meth:`receive` at ``now``: one sample of a sampled link."""
        return self.send(now, value).receive(now)
