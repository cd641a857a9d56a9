"""Serve a built scenario: the loop that owns the context and applies remote requests.

Design (and why). DESIGN.md: the network never touches a context. A Drake LeafSystem's
event can only change its own context, and the commands of the coshell (``sot.push
taskLH``, a new desired pose, a source's value) change other systems' contexts. So the
thread that owns the simulator applies them between control ticks, the way
:func:`~drake_sot.diagrams.run.simulate` applies timed commands; in fact :class:`Serving` is
``simulate``'s ``progress`` hook, run one control period per step (:func:`serve_run`), so a
served run handles timed commands, signals, a failure and a fall as any run does. After each
tick the hook replies to the requests applied before that tick (with the simulated time
reached), sends the subscriptions that are due, sleeps to hold ``realtime`` × real time, then
applies the requests the :class:`~drake_sot.remote.network.NetworkThread` queued since, in
arrival order (those of one socket read together). Reads evaluate output
ports on the root context in that thread, after the tick: the value at the last tick.

Signals are ``<system>.<port>``: every vector-valued output port of every system of the
diagram can be read (``sot.errors``, ``dyn.com``, ``device.q``…). Only the allowlist given
when the server is made (:class:`Writable`) can be written; a written value must be
finite and of the declared size. ``run`` takes one script line of the run phase:
``SOT.push|rm|up|down NAME``, ``SOT.pop``, ``SOT.clear``, ``SOT.list``, ``get SIGNAL``,
``help``. The scenario's own timed commands still apply at their times.

There is no RemoteCommandServer LeafSystem: a writable signal is a parameter or a source
value of the diagram's own systems (a 6D task's desired position, ``force_active`` of
``walk_then_interact --decision remote``), set by the loop that owns the context. The
allowlist is fixed when the scenario is built (:func:`writables`).
"""

from __future__ import annotations

import math
import subprocess
import sys
import time as wallclock
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram, PortDataType, System

from drake_sot.diagrams.run import Progress, RunResult, SignalGuard, simulate
from drake_sot.diagrams.scenario import Runner, ScenarioSetup
from drake_sot.remote.network import NetworkThread
from drake_sot.remote.protocol import Request, error, ok
from drake_sot.remote.status import MeshcatStatus
from drake_sot.script import Call, Get, Name, parse_line
from drake_sot.systems.features import FeaturePoint6d
from drake_sot.systems.sot import StackOfTasks
from drake_sot.validation import positive

#: Subscriptions a connection may hold at once.
MAX_SUBSCRIPTIONS = 16

_SOT_COMMANDS = ("push", "rm", "up", "down", "pop", "clear", "list")


@dataclass(frozen=True)
class Writable:
    """A signal clients may write: its name, size, units, and how a value is applied to the
    root context (called by the serving loop only)."""

    signal: str
    size: int
    units: str
    apply: Callable[[Context, np.ndarray], None]


@dataclass
class _Subscription:
    period: float
    due: float


class Serving:
    """Serves the diagram of ``simulator`` through ``network``: :meth:`after_tick` is the
    ``progress`` hook of :func:`~drake_sot.diagrams.run.simulate` run with ``chunk`` = the
    control period, so that the timed commands, the signals, a failure and a fall are handled
    as in any run.

    After each tick :meth:`after_tick` replies to the requests applied before that tick (with
    the simulated time reached), calls ``on_tick``, sends the subscriptions that are due, sleeps
    to hold ``realtime`` × real time (not when the diagram is slower), then applies the
    requests queued since, in arrival order (they act in the next tick).

    Args:
        simulator: an initialized simulator.
        network: the socket thread whose requests are served.
        period: the control period [s]: one tick.
        writable: the allowlist of signals clients may write.
        realtime: the pace, > 0 (inf: as fast as possible).
        on_tick: called with the root context after each tick (e.g. a
            :class:`~drake_sot.remote.status.MeshcatStatus` update).
    """

    def __init__(
        self,
        simulator: Simulator,
        network: NetworkThread,
        *,
        period: float,
        writable: Sequence[Writable] = (),
        realtime: float = 1.0,
        on_tick: Callable[[Context], None] | None = None,
    ) -> None:
        self._simulator = simulator
        self._on_tick = on_tick
        self._network = network
        self.period = positive("period", period, unit="s")
        self._realtime = positive("realtime", realtime)
        self._writable = {w.signal: w for w in writable}
        diagram = simulator.get_system()
        self._readable = _readable_ports(diagram)
        self._sots = {s.get_name(): s for s in _systems(diagram) if isinstance(s, StackOfTasks)}
        self._subscriptions: dict[int, dict[str, _Subscription]] = {}
        self._answers: list[tuple[int, Any, Any, str | None]] = []
        self.events: list[tuple[float, str]] = []  # the requests that changed the context

    @property
    def context(self) -> Context:
        return self._simulator.get_mutable_context()

    def after_tick(self, t: float, duration: float, wall: float) -> None:
        """The ``progress`` hook of ``simulate`` (simulated time, duration, wall time since the start)."""
        context = self.context
        now = context.get_time()
        for cid, request_id, result, message in self._answers:
            reply = (
                error(request_id, message) if message is not None else ok(request_id, _resolve(result), now)
            )
            self._network.send(cid, reply)
        self._answers = []
        if self._on_tick is not None:
            self._on_tick(context)
        for cid, subscriptions in self._subscriptions.items():
            for signal, sub in subscriptions.items():
                if now >= sub.due - 1e-9:
                    sub.due += sub.period * max(1, math.floor((now - sub.due) / sub.period + 1e-9) + 1)
                    self._network.send(cid, {"signal": signal, "t": now, "value": self._read(signal)})
        ahead = now / self._realtime - wall
        if ahead > 0:  # paced: wait first, so that what arrives meanwhile acts at the next tick
            wallclock.sleep(ahead)
        for cid, request in self._network.drain():
            if request is None:
                self._subscriptions.pop(cid, None)
                continue
            try:
                self._answers.append((cid, request.id, self._apply(cid, request, context), None))
            except Exception as exc:  # noqa: BLE001 - a remote request must not end the served run
                self._answers.append((cid, request.id, None, f"{type(exc).__name__}: {exc}"))

    def finish(self) -> None:
        """Answer the requests the run ended before applying in a tick: an error saying so."""
        for cid, request_id, _, _ in self._answers:
            self._network.send(cid, error(request_id, "the run ended before the next tick"))
        self._answers = []

    def _apply(self, cid: int, request: Request, context: Context) -> Any:
        """The result of ``request`` (a callable: evaluated after the tick), or ValueError."""
        if request.op == "read":
            self._port(request.signal)
            return lambda: self._read(request.signal)
        if request.op == "write":
            return self._write(request.signal, request.value, context)
        if request.op == "run":
            return self._run(request.cmd, context)
        if request.op == "list":
            return self._list()
        if request.op == "subscribe":
            self._port(request.signal)
            if not (request.period >= self.period) or math.isinf(request.period):
                raise ValueError(
                    f"period = {request.period!r}: finite and >= the control period {self.period:g} s"
                )
            subscriptions = self._subscriptions.setdefault(cid, {})
            if request.signal not in subscriptions and len(subscriptions) >= MAX_SUBSCRIPTIONS:
                raise ValueError(f"subscribe: at most {MAX_SUBSCRIPTIONS} subscriptions per connection")
            subscriptions[request.signal] = _Subscription(request.period, context.get_time())
            return request.signal
        if request.op == "unsubscribe":
            if request.signal not in self._subscriptions.get(cid, {}):
                raise ValueError(f"unsubscribe: {request.signal!r} is not subscribed")
            del self._subscriptions[cid][request.signal]
            return request.signal
        raise ValueError(f"op = {request.op!r}: not served")

    def _port(self, signal: str):
        if signal not in self._readable:
            raise ValueError(f"signal = {signal!r}: no such vector output (see op 'list')")
        return self._readable[signal]

    def _read(self, signal: str) -> list[float]:
        system, port = self._port(signal)
        return port.Eval(system.GetMyContextFromRoot(self.context)).tolist()

    def _write(self, signal: str, value: tuple[float, ...], context: Context) -> str:
        writable = self._writable.get(signal)
        if writable is None:
            allowed = ", ".join(self._writable) or "none"
            raise ValueError(f"signal = {signal!r}: not writable (writable: {allowed})")
        if len(value) != writable.size:
            raise ValueError(f"{signal}: {len(value)} values, expected {writable.size}")
        bad = [i for i, x in enumerate(value) if not math.isfinite(x)]
        if bad:
            raise ValueError(f"{signal}[{bad[0]}] = {value[bad[0]]!r}: not finite")
        writable.apply(context, np.array(value))
        self.events.append((context.get_time(), f"write {signal}"))
        return signal

    def _run(self, cmd: str, context: Context) -> str:
        if cmd.strip() == "help":
            return self._help()
        command = parse_line(cmd, source="<remote>")
        if command is None:
            return ""
        if isinstance(command, Get):
            signal = f"{command.signal.entity}.{command.signal.name}"
            self._port(signal)
            return lambda: " ".join(f"{x:.6g}" for x in self._read(signal))
        if isinstance(command, Call) and command.entity in self._sots and command.command in _SOT_COMMANDS:
            sot = self._sots[command.entity]
            names = [a.text if isinstance(a, Name) else a for a in command.args]
            takes_name = command.command in ("push", "rm", "up", "down")
            if len(names) != int(takes_name) or (takes_name and not isinstance(names[0], str)):
                raise ValueError(
                    f"{cmd!r}: {command.entity}.{command.command} takes {int(takes_name)} task name(s)"
                )
            result = getattr(sot, command.command)(context, *names)
            self.events.append((context.get_time(), cmd.strip()))
            if command.command == "list":
                return " ".join(result)
            return result if isinstance(result, str) else ""
        if isinstance(command, Call) and command.command == "help":
            return self._help()
        raise ValueError(f"{cmd!r}: not a run-time command here; {self._help()}")

    def _help(self) -> str:
        sots = ", ".join(self._sots) or "none"
        return (
            f"commands: SOT.push|rm|up|down TASK, SOT.pop, SOT.clear, SOT.list (SOT: {sots}); "
            "get SYSTEM.PORT; help"
        )

    def _list(self) -> dict[str, Any]:
        return {
            "systems": sorted({name.split(".")[0] for name in self._readable}),
            "readable": {name: port.size() for name, (_, port) in self._readable.items()},
            "writable": {w.signal: {"size": w.size, "units": w.units} for w in self._writable.values()},
            "commands": self._help(),
            "error_slices": {
                name: {task: [rows.start, rows.stop] for task, rows in sot.error_slices().items()}
                for name, sot in self._sots.items()
            },
            "period": self.period,
        }


def _resolve(result: Any) -> Any:
    return result() if callable(result) else result


def _systems(system: System) -> list[System]:
    if isinstance(system, Diagram):
        return [s for sub in system.GetSystems() for s in _systems(sub)]
    return [system]


def _readable_ports(diagram: Diagram) -> dict[str, tuple[System, Any]]:
    ports = {}
    for system in _systems(diagram):
        for i in range(system.num_output_ports()):
            port = system.get_output_port(i)
            if port.get_data_type() == PortDataType.kVectorValued and port.size() > 0:
                ports[f"{system.get_name()}.{port.get_name()}"] = (system, port)
    return ports


def desired_position_writables(features: dict[str, System]) -> list[Writable]:
    """The allowlist of a scenario: ``TASK.position_des`` [3] (m, world frame) of each
    ``FeaturePoint6d``; a write moves the target, keeping its orientation (refused, with the
    feature's reason, when its desired pose is fed by another system)."""

    def setter(feature: FeaturePoint6d) -> Callable[[Context, np.ndarray], None]:
        def apply(context: Context, p: np.ndarray) -> None:
            X = feature.desired(context)
            feature.set_desired(context, RigidTransform(X.rotation(), p))

        return apply

    return [
        Writable(f"{task}.position_des", 3, "m, world frame", setter(feature))
        for task, feature in features.items()
        if isinstance(feature, FeaturePoint6d)
    ]


def writables(setup: ScenarioSetup) -> list[Writable]:
    """The allowlist of a scenario: its 6D tasks' ``position_des`` and what it lists in
    ``extras["writable"]`` (name → (size, units, apply(root context, value)))."""
    declared = setup.extras.get("writable", {})
    return desired_position_writables(setup.built.features) + [
        Writable(name, size, units, apply) for name, (size, units, apply) in declared.items()
    ]


def serve_run(
    setup: ScenarioSetup,
    simulator: Simulator,
    network: NetworkThread,
    duration: float,
    *,
    realtime: float = 1.0,
    progress: Progress | None = None,
    guard: SignalGuard | None = None,
    on_ready: Callable[[tuple[str, int]], None] | None = None,
) -> RunResult:
    """Simulate ``setup`` to ``duration`` [s] while serving through ``network`` (started here,
    closed at the end); ``on_ready(address)`` is called once it listens. When the scenario was
    built with a Meshcat, its controls show the stack and the task errors. The requests that
    changed the context are in the result's ``events`` with the timed commands."""
    built = setup.built
    status = MeshcatStatus(built.meshcat, built.sot) if built.meshcat is not None else None
    serving = Serving(
        simulator,
        network,
        period=built.sot.period,
        writable=writables(setup),
        realtime=realtime,
        on_tick=status.update if status is not None else None,
    )

    def hook(t: float, end: float, wall: float) -> None:
        serving.after_tick(t, end, wall)
        if progress is not None:
            progress(t, end, wall)

    network.start()
    try:
        if on_ready is not None:
            on_ready(network.address)
        result = simulate(
            simulator, duration, setup.commands, progress=hook, chunk=serving.period, guard=guard
        )
        serving.finish()
    finally:
        network.close()
    result.events = sorted(result.events + serving.events, key=lambda event: event[0])
    return result


def decision_runner(*, realtime: float = 1.0, connect_timeout: float = 60.0) -> Runner:
    """A :data:`~drake_sot.diagrams.scenario.Runner` for a scenario built with a remote decision
    layer: serves on a free loopback port, starts ``python -m drake_sot.remote.decision`` with
    the scenario's ``extras["decision"]`` (``signal``, ``period``, ``run`` lines, ``write`` items),
    waits until it connects, then simulates at ``realtime`` × real time while serving."""

    def run(
        setup: ScenarioSetup,
        simulator: Simulator,
        duration: float,
        *,
        progress: Progress | None = None,
        guard: SignalGuard | None = None,
    ) -> RunResult:
        decision = setup.extras["decision"]
        network = NetworkThread("127.0.0.1", 0)
        processes: list[subprocess.Popen] = []

        def start_client(address: tuple[str, int]) -> None:
            command = [sys.executable, "-m", "drake_sot.remote.decision", "--port", str(address[1])]
            command += ["--signal", decision["signal"], "--period", str(decision["period"])]
            command += [f"--run={line}" for line in decision["run"]]
            command += [f"--write={item}" for item in decision["write"]]
            processes.append(subprocess.Popen(command))
            if not network.connected.wait(connect_timeout):
                raise RuntimeError(f"the decision client did not connect within {connect_timeout:g} s")

        try:
            return serve_run(
                setup,
                simulator,
                network,
                duration,
                realtime=realtime,
                progress=progress,
                guard=guard,
                on_ready=start_client,
            )
        finally:
            for process in processes:
                if process.poll() is None:
                    process.terminate()
                process.wait()

    return run
