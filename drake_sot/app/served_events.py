"""The requests a served run applied, as the run's events: bounded, writes of a stream as one.

A served run's events (``RunResult.events``: the ``.npz``'s ``event_time``/``event_label`` and the
marks of the task-error plot) name what its clients changed and when. A client that streams a
signal — a teleoperated hand target written at every control tick, the tele-cooperation master's
packets — applies 200 writes a second: one event each would grow without bound over hours of
serving, and mark the plot 200 times a second. So:

- the writes of one signal with at most :data:`STREAM_GAP` simulated seconds between them are one
  event, at the first, labelled with their count and the time of the last
  (``write taskRH.position_des ×3718 to t = 20.055 s``);
- the run keeps its last :data:`MAX_EVENTS` events (as it keeps the last window of its logs);
  :attr:`ServedEvents.applied` counts every request applied.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

#: [s] of simulated time: writes of one signal at most this far apart are one event (a stream).
STREAM_GAP = 0.1
#: The events a served run keeps, the last ones.
MAX_EVENTS = 1000


@dataclass(eq=False)
class _Stream:
    """Writes of one signal, from ``start`` to ``last`` [s], ``count`` of them; ``serial``: its
    place among the events appended."""

    signal: str
    start: float
    last: float
    serial: int
    count: int = 1

    def label(self) -> str:
        if self.count == 1:
            return f"write {self.signal}"
        return f"write {self.signal} ×{self.count} to t = {self.last:.3f} s"


class ServedEvents:
    """The events of a served run: commands one by one, writes by stream, the last
    :data:`MAX_EVENTS` of them."""

    def __init__(self) -> None:
        self._events: deque[tuple[float, str] | _Stream] = deque(maxlen=MAX_EVENTS)
        self._streams: dict[str, _Stream] = {}  # each signal's last stream
        self._appended = 0  # events appended, those dropped included
        self.applied = 0  # every request applied (commands and writes)

    def command(self, t: float, label: str) -> None:
        """A command (a script or stack line) applied at ``t`` [s]."""
        self._append((t, label))
        self.applied += 1

    def write(self, t: float, signal: str) -> None:
        """A write of ``signal`` applied at ``t`` [s]: its stream's, when the last write of it was at
        most :data:`STREAM_GAP` before and that stream is still kept; else a new stream."""
        stream = self._streams.get(signal)
        kept = stream is not None and stream.serial >= self._appended - len(self._events)
        if kept and 0.0 <= t - stream.last <= STREAM_GAP:
            stream.last, stream.count = t, stream.count + 1
        else:
            self._streams[signal] = stream = _Stream(signal, t, t, self._appended)
            self._append(stream)
        self.applied += 1

    def _append(self, event: tuple[float, str] | _Stream) -> None:
        self._events.append(event)  # the oldest dropped beyond MAX_EVENTS
        self._appended += 1

    @property
    def events(self) -> list[tuple[float, str]]:
        """``(time, label)`` of the kept events, in the order applied (a stream at its first write)."""
        return [(e.start, e.label()) if isinstance(e, _Stream) else e for e in self._events]
