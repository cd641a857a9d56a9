"""Bounded logs: a long run keeps the last :data:`LOG_WINDOW` seconds of every log in memory.

Drake's ``VectorLogSink`` keeps every sample it is given (the embedded humanoid's walk logs about
2 kB per 5 ms control tick: ~1.4 GB per simulated hour). :class:`LogWindow` watches the sinks of a
diagram as a run advances (:func:`~drake_sot.diagrams.run.simulate` calls :meth:`LogWindow.trim`
between its steps, never per physics step) and, once a sink holds more than 1.5 windows, drops
its older samples so that it holds the last window. The logs written at the end of a run (the
``.npz``) then cover the last one to two windows of it; what a long run keeps is therefore:

- the logs: the last :data:`LOG_WINDOW` s (up to twice that), every logger alike;
- the stack's history (:class:`~drake_sot.systems.stack_history.StackHistory`): its last
  :data:`~drake_sot.systems.stack_history.MAX_CHANGES` changes;
- the pattern generator's samples: the executed ones are dropped as it walks;
- the Meshcat replay (a recording cannot drop its first frames): the run's first
  :data:`REPLAY_WINDOWS` windows (ten minutes by default), after which recording stops
  (``LogWindow.replay_until`` says when; the live view goes on).

A run shorter than the window is never trimmed: its logs are whole.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.geometry import MeshcatVisualizer
from pydrake.systems.framework import Context, System
from pydrake.systems.primitives import VectorLogSink

from drake_sot.systems.search import systems_of_type
from drake_sot.validation import positive

#: [s] of simulated time every log of a run keeps (five minutes).
LOG_WINDOW = 300.0

#: A replay records this many windows of a run's start, then stops.
REPLAY_WINDOWS = 2

#: A sink is looked at again once it holds this many times the samples it held when last looked
#: at (its sample times are read only then: reading them copies them).
_GROWTH = 1.25
#: [s] simulated between two looks at the sinks (or a tenth of the window, if shorter): a served
#: run calls :meth:`LogWindow.trim` after every 5 ms tick, and the looks cost two Drake calls a sink.
LOOK_EVERY = 0.1


class LogWindow:
    """Keeps the ``VectorLogSink`` logs of ``diagram`` within the last ``window`` [s] (see the
    module docstring).

    Args:
        diagram: the run's diagram; its sinks are found through nested diagrams.
        window: [s] finite and > 0; samples older than ``window`` before the newest are dropped
            once a log spans more than 1.5 windows.

    Raises:
        ValueError: ``window`` NaN, infinite or <= 0.
    """

    def __init__(self, diagram: System, window: float = LOG_WINDOW) -> None:
        self.window = positive("log window", window, unit="s")
        self._sinks = systems_of_type(diagram, VectorLogSink)
        self._visualizers = systems_of_type(diagram, MeshcatVisualizer)
        self._next_look = {id(sink): 1 for sink in self._sinks}
        self._next_time = -math.inf  # [s] simulated: no look at the sinks before it
        self.trimmed = 0  # samples dropped so far, every sink together
        self.replay_until: float | None = None  # [s] when the replay's recording was stopped

    def trim(self, root_context: Context) -> None:
        """Drop what each sink holds beyond the window (cheap when nothing needs dropping), and
        stop the replay's recording past :data:`REPLAY_WINDOWS` windows."""
        t = root_context.get_time()
        if t < self._next_time:
            return  # a served run trims after every tick: its sinks are looked at every LOOK_EVERY
        self._next_time = t + min(LOOK_EVERY, 0.1 * self.window)
        if self._visualizers and self.replay_until is None and t > REPLAY_WINDOWS * self.window:
            for visualizer in self._visualizers:
                visualizer.StopRecording()
            self.replay_until = t
        for sink in self._sinks:
            log = sink.FindLog(root_context)
            count = log.num_samples()
            if count < self._next_look[id(sink)]:
                continue
            times = log.sample_times()
            if times[-1] - times[0] > 1.5 * self.window:
                keep = times > times[-1] - self.window
                data = log.data()[:, keep]
                log.Clear()
                for t, sample in zip(times[keep], data.T, strict=True):
                    log.AddData(t, sample)
                self.trimmed += count - int(np.count_nonzero(keep))
                count = log.num_samples()
            self._next_look[id(sink)] = max(int(_GROWTH * count), count + 1)
