"""Serve a built scenario: the loop that owns the context and applies remote requests.

Design (and why). DESIGN.md: the network never touches a context. A Drake LeafSystem's
event can only change its own context, and the commands of the coshell (``sot.push
taskLH``, a new desired pose) change other systems' contexts. So the thread that owns the
simulator applies them, between control ticks, as :func:`~drake_sot.diagrams.run.simulate`
applies timed commands: :meth:`Serving.tick` takes the requests the
:class:`~drake_sot.remote.network.NetworkThread` queued, applies them in arrival order at
the current tick, advances the simulator one control period (paced at ``realtime`` × real
time by :meth:`Serving.serve`), then replies with the simulated time reached and sends the
subscriptions that are due. Reads evaluate output ports on the root context in that same
thread, after the tick: the value at the last tick.

Signals are ``<system>.<port>``: every vector-valued output port of every system of the
diagram can be read (``sot.errors``, ``dyn.com``, ``device.q``…). Only the allowlist given
when the server is made (:class:`Writable`) can be written; a written value must be
finite and of the declared size. ``run`` takes one script line of the run phase:
``SOT.push|rm|up|down NAME``, ``SOT.pop``, ``SOT.clear``, ``SOT.list``, ``get SIGNAL``,
``help``. The scenario's own timed commands still apply at their times.

Not done here (yet): a RemoteCommandServer LeafSystem with writable output ports; writes
set parameters of the diagram's systems (a feature's desired pose) instead.
"""

from __future__ import annotations

import math
import queue
import time as wallclock
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram, PortDataType, System

from drake_sot.diagrams.run import Command
from drake_sot.diagrams.scenario import ScenarioSetup
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
    """Serves ``diagram`` through ``network`` while ``simulator`` advances.

    Args:
        simulator: an initialized simulator of ``diagram``.
        period: the control period [s]: one tick of the serving loop.
        writable: the allowlist of signals clients may write.
        commands: timed commands of the scenario, applied at their times.
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
        commands: Sequence[Command] = (),
        on_tick: Callable[[Context], None] | None = None,
    ) -> None:
        self._simulator = simulator
        self._on_tick = on_tick
        self._network = network
        self._period = positive("period", period, unit="s")
        self._writable = {w.signal: w for w in writable}
        self._pending = sorted(commands, key=lambda c: c.time)
        diagram = simulator.get_system()
        self._readable = _readable_ports(diagram)
        self._sots = {s.get_name(): s for s in _systems(diagram) if isinstance(s, StackOfTasks)}
        self._subscriptions: dict[int, dict[str, _Subscription]] = {}
        self.events: list[tuple[float, str]] = []

    @property
    def context(self) -> Context:
        return self._simulator.get_mutable_context()

    def serve(self, duration: float, realtime: float = 1.0) -> None:
        """Tick until ``duration`` [s] simulated, at ``realtime`` × real time (as fast as possible
        when the diagram is slower)."""
        duration = positive("duration", duration, unit="s")
        realtime = positive("realtime", realtime)
        start_wall, start_t = wallclock.perf_counter(), self.context.get_time()
        while self.context.get_time() < duration - 1e-9:
            self.tick(min(duration, self.context.get_time() + self._period))
            ahead = start_wall + (self.context.get_time() - start_t) / realtime - wallclock.perf_counter()
            if ahead > 0:
                wallclock.sleep(ahead)

    def tick(self, target: float) -> None:
        """Apply the due timed commands and the queued requests, advance to ``target`` [s],
        then reply and stream."""
        context = self.context
        t = context.get_time()
        while self._pending and self._pending[0].time <= t + 1e-12:
            command = self._pending.pop(0)
            command.apply(context)
            self.events.append((t, command.label))
        answers: list[tuple[int, Any, Any, str | None]] = []
        while True:
            try:
                cid, request = self._network.requests.get_nowait()
            except queue.Empty:
                break
            if request is None:
                self._subscriptions.pop(cid, None)
                continue
            try:
                answers.append((cid, request.id, self._apply(cid, request, context), None))
            except Exception as exc:  # noqa: BLE001 - a remote request must not end the served run
                answers.append((cid, request.id, None, f"{type(exc).__name__}: {exc}"))
        self._simulator.AdvanceTo(target)
        now = context.get_time()
        if self._on_tick is not None:
            self._on_tick(context)
        for cid, request_id, result, message in answers:
            reply = (
                error(request_id, message) if message is not None else ok(request_id, _resolve(result), now)
            )
            self._network.send(cid, reply)
        for cid, subscriptions in self._subscriptions.items():
            for signal, sub in subscriptions.items():
                if now >= sub.due - 1e-9:
                    sub.due += sub.period * max(1, math.floor((now - sub.due) / sub.period + 1e-9) + 1)
                    self._network.send(cid, {"signal": signal, "t": now, "value": self._read(signal)})

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
            if not (request.period >= self._period) or math.isinf(request.period):
                raise ValueError(
                    f"period = {request.period!r}: finite and >= the control period {self._period:g} s"
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
            "period": self._period,
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


def serve_scenario(
    setup: ScenarioSetup,
    network: NetworkThread,
    *,
    duration: float | None = None,
    realtime: float = 1.0,
    on_ready: Callable[[tuple[str, int]], None] | None = None,
) -> Serving:
    """Serve a built scenario: start ``network``, call ``on_ready(address)``, tick up to
    ``duration`` [s] (the scenario's own when None) at ``realtime`` × real time, stop the network.
    When the scenario was built with a Meshcat, its controls show the stack and the task errors."""
    built = setup.built
    simulator = built.create_simulator()
    status = MeshcatStatus(built.meshcat, built.sot) if built.meshcat is not None else None
    serving = Serving(
        simulator,
        network,
        period=built.sot.period,
        writable=desired_position_writables(built.features),
        commands=setup.commands,
        on_tick=status.update if status is not None else None,
    )
    network.start()
    try:
        if on_ready is not None:
            on_ready(network.address)
        serving.serve(setup.duration if duration is None else duration, realtime)
    finally:
        network.close()
    return serving
