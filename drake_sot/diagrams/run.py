"""Run a built diagram with timed commands (the paper's script lines, issued at given times).

:func:`simulate` advances the simulator to each command's time, applies it to the
root context (push/rm on the stack, a new target...), reports progress, and on
Ctrl-C (SIGINT), SIGTERM, a failure or a fall (seen by a
:class:`~drake_sot.systems.fall_monitor.FallMonitor` of the diagram) stops cleanly and
says so, so that whatever was simulated can still be written out. :class:`SignalGuard`
is how signals are handled: the first signal stops the simulation; later ones wait until
the artefacts of the simulated part are written.
"""

from __future__ import annotations

import math
import signal
import threading
import time as wallclock
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import FrameType, TracebackType

from pydrake.systems.analysis import Simulator, SimulatorStatus
from pydrake.systems.framework import Context, System

from drake_sot.diagrams.log_window import LOG_WINDOW, LogWindow
from drake_sot.errors import DrakeSotError
from drake_sot.systems.fall_monitor import Fall, FallMonitor
from drake_sot.systems.search import systems_of_type
from drake_sot.systems.sot import StackOfTasks
from drake_sot.validation import bounded, positive

#: The signals that stop a run: Ctrl-C and the polite "terminate" of ``kill``, job schedulers, systemd.
STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)
#: The longest run [s] of simulated time: one day. What a run keeps in memory is bounded (the logs
#: keep their last window: :mod:`drake_sot.diagrams.log_window`), and at the walk's real-time
#: factor (0.25-0.65) a simulated day takes days of wall time: a longer value is a typo
#: (``--duration 1e300`` ran until it was killed).
MAX_DURATION = 86400.0


def check_duration(name: str, value: float) -> float:
    """``value`` as a run's duration [s]: finite, > 0 and at most :data:`MAX_DURATION`.

    Raises:
        ValueError: naming ``name``, the value and the bound it breaks.
    """
    return bounded(name, positive(name, value, unit="s"), 0.0, MAX_DURATION, unit="s")


@dataclass(frozen=True)
class TimedCommand:
    """A command applied to the root context at ``time`` [s]; ``label`` is what the logs show."""

    time: float
    label: str
    apply: Callable[[Context], None]


class Interrupted(KeyboardInterrupt):
    """A run stopped by a signal; ``signum`` says which (SIGINT or SIGTERM).

    A subclass of KeyboardInterrupt, so code that handles Ctrl-C handles SIGTERM the same way.
    """

    def __init__(self, signum: int) -> None:
        self.signum = signal.Signals(signum)
        super().__init__(self.signum.name)


class SignalGuard:
    """What SIGINT and SIGTERM do while a run simulates and then writes what it simulated.

    Use ``with SignalGuard() as guard:`` around :func:`simulate` (pass it ``guard=guard``) and the
    writing of the artefacts:

    - *stopping* (from the start): the first SIGINT or SIGTERM raises :class:`Interrupted`, which
      :func:`simulate` turns into an interrupted :class:`RunResult`. The guard then holds.
    - *holding* (after that signal, or once :meth:`hold` is called — :func:`simulate` calls it
      when its loop ends): signals are recorded and nothing else, so no file is cut short.
    - on exit the previous handlers are restored, then the first held signal is delivered again
      (``signal.raise_signal``: Ctrl-C raises KeyboardInterrupt, an unhandled SIGTERM ends the
      process), unless it repeats the signal that already stopped the run (a second Ctrl-C asks
      for the stop that is under way) or an exception is already leaving the ``with`` block.

    Handlers are installed only in the main thread (the only one Python delivers signals to);
    elsewhere the guard changes nothing. A signal ignored by the caller (``SIG_IGN``, as a shell
    does for SIGINT in a background job) stays ignored; one whose handler is not a Python
    callable (installed by C code) is left alone.
    """

    def __init__(self, signals: Sequence[signal.Signals] = STOP_SIGNALS) -> None:
        self._signals = tuple(signals)
        self._previous: dict[signal.Signals, Callable | int] = {}
        self._stopping = True
        self.stopped_by: signal.Signals | None = None
        self.held: list[signal.Signals] = []

    def __enter__(self) -> SignalGuard:
        if threading.current_thread() is threading.main_thread():
            for signum in self._signals:
                previous = signal.getsignal(signum)
                if previous is None or previous == signal.SIG_IGN:
                    continue
                self._previous[signum] = previous
                signal.signal(signum, self._handle)
        return self

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self._stopping:
            self._stopping = False
            self.stopped_by = signal.Signals(signum)
            raise Interrupted(signum)
        self.held.append(signal.Signals(signum))

    def hold(self) -> None:
        """From now on, hold the signals until the guard exits."""
        self._stopping = False

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        for signum, previous in self._previous.items():
            signal.signal(signum, previous)
        self._previous.clear()
        late = [s for s in self.held if s != self.stopped_by]
        if late and error is None:
            signal.raise_signal(late[0])


@dataclass
class RunResult:
    """How a run ended, in one of four states:

    - **completed** (``completed``): simulated up to the requested duration, standing.
    - **interrupted** (``interrupted``): stopped by a signal, ``interrupted_by`` says which —
      SIGINT (Ctrl-C, or a KeyboardInterrupt raised by a command) or SIGTERM.
    - **failed** (``failure`` is not None): an exception stopped the run; ``end_time`` says when.
    - **fell** (``fell`` is not None): a ``FallMonitor`` of the diagram detected a fall
      (time, pelvis height, tilt); the run went on for the monitor's ``stop_after`` (or
      up to the duration, if sooner) and stopped. An exception raised in that time (a
      controller that gives up on a robot lying on the ground) ends it sooner and is kept in
      ``after_fall``: the run still fell, it did not fail.

    In every state ``end_time`` is the simulated time reached and the simulator's context
    holds the logs up to it. The ``drake-sot`` command exits with 0, 130 (SIGINT), 143
    (SIGTERM), 1 (failed) or 3 (fell); a signal or a failure takes precedence over a fall.

    Attributes:
        end_time: simulated time reached [s].
        wall_time: wall-clock duration [s].
        events: ``(time, label)`` of every command applied (a served run: the last of its clients'
            requests, a stream of writes as one; ``drake_sot.app.served_events``).
        requests_applied: a served run: its clients' requests that changed the context, all of them.
        not_reached: ``(time, label)`` of the commands scheduled after the run's end.
        interrupted_by: the signal that stopped the run, None when it was not interrupted.
        failure: the exception that stopped the run, if any.
        fell: the fall, if the robot fell (the earliest, if several monitors saw one).
        after_fall: the exception that ended the run after the fall was detected, if any.
        errors_before_fall: when the robot fell, ``(time, ((task, ‖e‖), ...))``: the task errors
            of the diagram's stacks of tasks (largest first, in each task's units) recorded last
            before the fall, at the end of a step of the run and at most 0.05 s apart (within one
            step of 0.1 s and 0.05 s of the fall) — what the controller was failing to achieve
            (a target out of reach, a stance foot lifted), so that a fall names its cause.
        replay_until: [s] when a long run stopped recording its replay (the replay covers the
            run up to it; see :mod:`drake_sot.diagrams.log_window`), None when it recorded all.
    """

    end_time: float = 0.0
    wall_time: float = 0.0
    events: list[tuple[float, str]] = field(default_factory=list)
    not_reached: list[tuple[float, str]] = field(default_factory=list)
    requests_applied: int = 0
    interrupted_by: signal.Signals | None = None
    failure: BaseException | None = None
    fell: Fall | None = None
    after_fall: BaseException | None = None
    errors_before_fall: tuple[float, tuple[tuple[str, float], ...]] | None = None
    replay_until: float | None = None

    @property
    def interrupted(self) -> bool:
        """True when a signal (Ctrl-C, SIGTERM) stopped the run."""
        return self.interrupted_by is not None

    @property
    def completed(self) -> bool:
        """True when the run reached its duration and the robot did not fall."""
        return not self.interrupted and self.failure is None and self.fell is None

    @property
    def realtime_factor(self) -> float:
        return self.end_time / self.wall_time if self.wall_time > 0 else float("nan")


class RunFailed(DrakeSotError, RuntimeError):
    """A run that :func:`simulate` checked failed (an exception stopped it) or fell.

    Attributes:
        result: the run's :class:`RunResult`, as ``simulate(..., check=False)`` returns it (the
            simulator's context still holds the logs up to ``result.end_time``).
    """

    def __init__(self, result: RunResult) -> None:
        self.result = result
        if result.failure is not None:
            failure = result.failure
            what = f"the run failed at t = {result.end_time:.3f} s: {type(failure).__name__}: {failure}"
        else:
            what = "; ".join(
                [f"the robot {result.fell} (the run stopped at t = {result.end_time:.3f} s)"]
                + fall_causes(result)
            )
        super().__init__(what)


Progress = Callable[[float, float, float], None]
"""Called with (simulated time, duration, wall time) as the run advances."""


def simulate(
    simulator: Simulator,
    duration: float,
    commands: Sequence[TimedCommand] = (),
    *,
    progress: Progress | None = None,
    chunk: float = 0.1,
    guard: SignalGuard | None = None,
    log_window: float | None = LOG_WINDOW,
    check: bool = True,
) -> RunResult:
    """Advance ``simulator`` to ``duration`` [s], applying ``commands`` at their times.

    With ``check`` (the default), a run that failed or fell raises :class:`RunFailed` once it
    has stopped (its ``result`` is the :class:`RunResult`), so that a script does not carry on
    as if the run had finished. With ``check=False`` it never raises for what happens inside
    the run, and the caller reads the :class:`RunResult`: an exception is stored in
    ``failure`` and a fall (seen by a ``FallMonitor`` of the diagram) in ``fell``, so the
    caller can save the partial logs. SIGINT (Ctrl-C) or SIGTERM sets ``interrupted_by``
    either way (the run stops, nothing raises). An
    exception raised once a fall was detected is stored in ``after_fall`` instead: the run
    ended as a fall. A
    monitor that asks the simulator to stop ends the run there; another system that does
    is a failure naming it. Signals are handled by ``guard`` (a :class:`SignalGuard` the caller has
    entered and keeps while it writes the artefacts), else by a guard of this call alone.

    Args:
        simulator: an initialized simulator.
        duration: the simulated time to reach [s], finite, > 0 and at most :data:`MAX_DURATION`.
        commands: applied when the simulation reaches their time; those after ``duration``
            are listed in ``not_reached``.
        progress: called after each step of at most ``chunk`` [s] (finite, > 0), at the multiples
            of ``chunk`` (and at the commands' times).
        log_window: [s] the diagram's logs keep their last ``log_window`` seconds (up to twice
            that; see :mod:`drake_sot.diagrams.log_window`); None keeps every sample.
        check: raise :class:`RunFailed` when the run failed or fell (else return the result).

    Raises:
        ValueError: ``duration`` or ``chunk`` NaN, infinite or <= 0, or ``duration`` above
            :data:`MAX_DURATION` (checked before Drake sees it: a Drake assertion ends the
            interpreter).
        RunFailed: with ``check``, the run failed (an exception stopped it: a command naming an
            unknown task, a controller that gave up) or the robot fell; raised from the failure.
    """
    duration = check_duration("duration", duration)
    chunk = positive("chunk", chunk, unit="s")
    if guard is None:
        with SignalGuard() as own:
            return simulate(
                simulator,
                duration,
                commands,
                progress=progress,
                chunk=chunk,
                guard=own,
                log_window=log_window,
                check=check,
            )
    late = [c for c in commands if c.time > duration]
    pending = sorted((c for c in commands if c.time <= duration), key=lambda c: c.time)
    result = RunResult()
    context = simulator.get_mutable_context()
    watch = _FallWatch(simulator.get_system())
    logs = None if log_window is None else LogWindow(simulator.get_system(), log_window)
    start = wallclock.perf_counter()
    try:
        t = context.get_time()
        while t < duration - 1e-12:
            while pending and pending[0].time <= t + 1e-12:
                command = pending.pop(0)
                command.apply(context)
                result.events.append((t, command.label))
            # steps end at multiples of chunk (not at sums of them, which drift past a periodic
            # event's time k * period by a rounding, so that a step would sometimes handle it)
            boundary = (math.floor(t / chunk + 1e-9) + 1) * chunk
            target = min(duration, boundary, pending[0].time if pending else duration)
            status = simulator.AdvanceTo(target)
            t = context.get_time()
            watch.step(context)
            if logs is not None:
                logs.trim(context)
            if progress:
                progress(t, duration, wallclock.perf_counter() - start)
            if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
                if not isinstance(status.system(), FallMonitor):
                    raise RuntimeError(status.FormatMessage())
                break
        while pending and t >= duration - 1e-12:  # commands due exactly at the end (not after a stop)
            command = pending.pop(0)
            command.apply(context)
            result.events.append((t, command.label))
    except KeyboardInterrupt as exc:
        result.interrupted_by = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
    except Exception as exc:  # noqa: BLE001 - reported to the caller with the partial logs
        result.failure = exc
    finally:
        guard.hold()  # from here on, a signal waits until the caller has written the artefacts
    result.end_time = context.get_time()
    result.replay_until = None if logs is None else logs.replay_until
    result.wall_time = wallclock.perf_counter() - start
    result.not_reached = [(c.time, c.label) for c in late + pending]
    result.fell = watch.fall(context)
    if result.fell is not None:
        result.errors_before_fall = watch.errors_before
    if result.fell is not None and result.failure is not None:
        # the monitor's state holds the fall only from a completed step on: it came first
        result.after_fall, result.failure = result.failure, None
    if check and (result.failure is not None or result.fell is not None):
        raise RunFailed(result) from result.failure
    return result


def fall_causes(result: RunResult, *, tasks: int = 3) -> list[str]:
    """What a fallen run was doing before the fall, in lines for a person: the last command
    applied before it and the ``tasks`` largest task errors of the last step before it (a target
    out of reach leaves its task's error large). Empty when the robot did not fall."""
    if result.fell is None:
        return []
    lines = []
    before = [(t, label) for t, label in result.events if t <= result.fell.time]
    if before:
        t, label = before[-1]
        lines.append(f"the last command before the fall: {label!r} at t = {t:.3f} s")
    if result.errors_before_fall is not None and result.errors_before_fall[1]:
        when, errors = result.errors_before_fall
        largest = ", ".join(f"{task} {norm:.3g}" for task, norm in errors[:tasks])
        lines.append(f"the largest task errors ‖e‖ at t = {when:.3f} s, before the fall: {largest}")
    return lines


#: [s] of simulated time between two records of the task errors before a fall.
_ERRORS_EVERY = 0.05


class _FallWatch:
    """Watches a run for a fall, keeping the stacks' task errors of the last step before it."""

    def __init__(self, diagram: System) -> None:
        self._monitors = systems_of_type(diagram, FallMonitor)
        self._stacks = systems_of_type(diagram, StackOfTasks) if self._monitors else []
        self.errors_before: tuple[float, tuple[tuple[str, float], ...]] | None = None

    def fall(self, context: Context) -> Fall | None:
        """The earliest fall the monitors have latched, None when none has."""
        falls = [m.fall(m.GetMyContextFromRoot(context)) for m in self._monitors]
        return min((f for f in falls if f is not None), key=lambda f: f.time, default=None)

    def step(self, context: Context) -> None:
        """After a step of the run: the task errors, kept while no fall is latched (at most every
        :data:`_ERRORS_EVERY` of simulated time: a served run steps every control period)."""
        if not self._stacks:
            return
        if self.errors_before is not None and context.get_time() < self.errors_before[0] + _ERRORS_EVERY:
            return
        if self.fall(context) is not None:
            return
        errors = [pair for sot in self._stacks for pair in sot.task_errors(sot.GetMyContextFromRoot(context))]
        self.errors_before = (context.get_time(), tuple(sorted(errors, key=lambda pair: -pair[1])))
