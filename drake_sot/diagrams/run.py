"""Run a built diagram with timed commands (the paper's script lines, issued at given times).

:func:`simulate` advances the simulator to each command's time, applies it to the
root context (push/rm on the stack, a new target...), reports progress, and on
Ctrl-C or a failure stops cleanly and says so, so that whatever was simulated can
still be written out.
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context


@dataclass(frozen=True)
class Command:
    """A command applied to the root context at ``time`` [s]; ``label`` is what the logs show."""

    time: float
    label: str
    apply: Callable[[Context], None]


@dataclass
class RunResult:
    """How a run ended.

    Attributes:
        end_time: simulated time reached [s].
        wall_time: wall-clock duration [s].
        events: ``(time, label)`` of every command applied.
        not_reached: ``(time, label)`` of the commands scheduled after the run's end.
        interrupted: True when stopped by Ctrl-C.
        failure: the exception that stopped the run, if any.
    """

    end_time: float = 0.0
    wall_time: float = 0.0
    events: list[tuple[float, str]] = field(default_factory=list)
    not_reached: list[tuple[float, str]] = field(default_factory=list)
    interrupted: bool = False
    failure: BaseException | None = None

    @property
    def completed(self) -> bool:
        return not self.interrupted and self.failure is None

    @property
    def realtime_factor(self) -> float:
        return self.end_time / self.wall_time if self.wall_time > 0 else float("nan")


Progress = Callable[[float, float, float], None]
"""Called with (simulated time, duration, wall time) as the run advances."""


def simulate(
    simulator: Simulator,
    duration: float,
    commands: Sequence[Command] = (),
    *,
    progress: Progress | None = None,
    chunk: float = 0.1,
) -> RunResult:
    """Advance ``simulator`` to ``duration`` [s], applying ``commands`` at their times.

    Never raises for what happens inside the run: Ctrl-C sets ``interrupted`` and an
    exception is stored in ``failure``, so the caller can save the partial logs.
    """
    if duration <= 0.0:
        raise ValueError(f"duration {duration} must be > 0")
    late = [c for c in commands if c.time > duration]
    pending = sorted((c for c in commands if c.time <= duration), key=lambda c: c.time)
    result = RunResult()
    context = simulator.get_mutable_context()
    start = wallclock.perf_counter()
    try:
        t = context.get_time()
        while t < duration - 1e-12:
            while pending and pending[0].time <= t + 1e-12:
                command = pending.pop(0)
                command.apply(context)
                result.events.append((t, command.label))
            target = min(duration, t + chunk, pending[0].time if pending else duration)
            simulator.AdvanceTo(target)
            t = context.get_time()
            if progress:
                progress(t, duration, wallclock.perf_counter() - start)
        while pending:  # commands due exactly at the end
            command = pending.pop(0)
            command.apply(context)
            result.events.append((t, command.label))
    except KeyboardInterrupt:
        result.interrupted = True
    except Exception as exc:  # noqa: BLE001 - reported to the caller with the partial logs
        result.failure = exc
    result.end_time = context.get_time()
    result.wall_time = wallclock.perf_counter() - start
    result.not_reached = [(c.time, c.label) for c in late + pending]
    return result
