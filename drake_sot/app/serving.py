"""Serve a built diagram: the host that owns the simulator, beside its command server.

Design (and why). The network never touches a context (a thread that wrote into one would race
the simulator's step). The socket thread
(:class:`~drake_sot.remote.network.NetworkThread`) only queues requests; the diagram's
:class:`~drake_sot.systems.command_server.RemoteCommandServer` takes them at each control tick, in
arrival order, in its own periodic event, and applies there what a Drake system may change:
its own outputs — the stack commands, a batch the ``StackOfTasks`` applies at that tick, and
the signals the diagram declared writable, output ports wired into what they drive (a 6D task's
desired position ``TASK.position_des`` among them): each write acts at the tick that takes it.

A Drake event cannot change another system's context, so the rest is the host's: the thread
that owns the simulator, here :class:`Serving`, ``simulate``'s ``progress`` hook run one
control period per step (:func:`serve_run`), so that a served run handles timed commands,
signals, a failure and a fall as any run does. After each tick it answers the requests the
server took at that tick: the stack commands with the solver's ``command_results``, reads
and subscriptions with the values at the tick (any vector output port, ``<system>.<port>``:
``sot.errors``, ``dyn.com``, ``device.q``…; beside the values of a solver's ``errors``, its
tasks' rows, ``layout``; beside those of a self-collision task's ``distances`` and
``pair_indices``, each row's pair of shapes and their bodies, ``pairs``, named from the task's
``candidate_pairs``, one entry per row: at most ``max_pairs``), and it applies the script lines
that set another system's parameter — the run-time commands of a scenario's tasks and pattern
generator as the script dialect has them (``taskRH.controlGain 5``, ``pg.parsecmd :stepseq …``),
and, when a script is served, all its run-time lines through
:meth:`~drake_sot.diagrams.script_session.ScriptSession.execute` (``set`` too), each as the server
parsed it. Those act at the next tick and are answered after it (the server holds what came after
them until then, so that the changes act in arrival order). Then it sleeps to hold ``realtime`` ×
real time. Before it answers, it publishes the values of the :data:`WATCHED` signals read last
(and within :data:`WATCH_EXPIRY` s of wall time) to the socket thread, which answers a later
``read`` of one of them at once with that value of the last tick — the same value the next
tick's answer would carry, without waiting a control period for it — unless that connection
still waits for a reply (then the read queues behind it, in order).

A written value must be of the declared size, finite and within the declared bounds (one check,
:meth:`~drake_sot.systems.command_server.Writable.check`, of one
:class:`~drake_sot.systems.command_server.Writable` type, in the server); only the signals declared
on the server can be written.

**Paced by its client** (``paced=True``; the two-process tele-cooperation's slave). A client
that simulates too (the master site) writes timed values (``at``, applied at that simulated time
by the server) with a ``horizon`` (:mod:`~drake_sot.remote.protocol`). The run then starts when
the first horizon arrived and, before each tick, waits until the client's horizon is beyond it,
so that every write due at the tick is in the queue when the server takes it: what the run
receives, and when, no longer depends on the two processes' pace (conservative lookahead, as in
parallel discrete-event simulation: each side simulates ahead of the other by up to the link's
delay). The wait fails the run, naming the tick and the horizon, after :data:`CLIENT_TIMEOUT` s of
wall time without progress or at once when that client disconnects; it waits in slices, so a
signal (Ctrl-C, SIGTERM) stops it.
"""

from __future__ import annotations

import math
import subprocess
import sys
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Context, Diagram, LeafSystem, PortDataType, System

from drake_sot.app.live_plot import LivePlot
from drake_sot.app.served_events import ServedEvents
from drake_sot.app.status import MeshcatStatus, TaskErrorSampler
from drake_sot.blas import limit_blas_threads
from drake_sot.diagrams.run import Progress, RunResult, SignalGuard, TimedCommand, simulate
from drake_sot.diagrams.scenario import NotServable, Runner, ScenarioSetup
from drake_sot.diagrams.script_entities import (
    Entity,
    PatternGeneratorEntity,
    Phase,
    SelfCollisionEntity,
    StackedEntity,
    TaskEntity,
)
from drake_sot.diagrams.script_session import ScriptSession
from drake_sot.errors import UnknownNameError
from drake_sot.remote.network import NetworkThread
from drake_sot.remote.protocol import PAIR_FIELDS, Request, error, ok
from drake_sot.script import Call, Get, Statement
from drake_sot.stack import VERBS
from drake_sot.systems.command_server import DONE, STACK, RemoteCommandServer, TakenRequest, Writable
from drake_sot.systems.inequalities import InequalityTask
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.systems.search import systems_of_type
from drake_sot.systems.self_collision import SelfCollisionAvoidance
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task
from drake_sot.validation import positive

#: Subscriptions a connection may hold at once.
MAX_SUBSCRIPTIONS = 16
#: How many signals, the ones read last, are published after each tick for the network thread to
#: answer a ``read`` at once (one port evaluation each per tick).
WATCHED = 32
#: [s] of wall time without a ``read`` after which a signal is no longer published: a signal read
#: once does not cost a port evaluation every tick for the rest of the run.
WATCH_EXPIRY = 10.0
#: [s] of wall time a run paced by its client waits for the client's horizon before it fails.
CLIENT_TIMEOUT = 60.0
#: Times within this of a tick count as that tick [s].
_EPS = 1e-9


@dataclass
class _Subscription:
    period: float
    due: float


class Serving:
    """The host side of a served diagram: answers what ``server`` took at each tick.

    :meth:`after_tick` is the ``progress`` hook of :func:`~drake_sot.diagrams.run.simulate`
    run with ``chunk`` = the control period (so at most one tick per step). After each tick it
    sends the replies of the requests applied before it; answers the requests the server took
    at the tick in their order — the stack commands with the solver's ``command_results``, the
    writes the server applied, reads, ``list`` and subscriptions with the values at the tick —
    and applies the script lines that change the context (a task's ``controlGain``, lines through
    ``session``), answered after the next tick, when they acted; then calls
    ``on_tick``, sends the subscriptions that are due, and sleeps to hold ``realtime`` × real
    time (not when the diagram is slower). What arrives meanwhile is taken at the next tick.

    Args:
        simulator: an initialized simulator of a diagram holding ``server``.
        server: the diagram's command server, attached to ``network`` here.
        network: the socket thread whose requests are served.
        realtime: the pace, > 0 (inf: as fast as possible).
        on_tick: called with the root context after each tick (e.g. a
            :class:`~drake_sot.app.status.MeshcatStatus` update).
        session: the script session of a served script: ``run`` lines it executes (set, get,
            task.controlGain, pg.parsecmd...); None: a scenario (stack commands, get, help).
        paced: simulate no tick before the client's horizon is beyond it (see the module
            docstring; :meth:`await_client`).
    """

    def __init__(
        self,
        simulator: Simulator,
        server: RemoteCommandServer,
        network: NetworkThread,
        *,
        realtime: float = 1.0,
        on_tick: Callable[[Context], None] | None = None,
        session: ScriptSession | None = None,
        paced: bool = False,
    ) -> None:
        self._simulator = simulator
        self._paced = paced
        self._server = server
        self._on_tick = on_tick
        self._network = network
        self._session = session
        self.period = server.period
        self._realtime = positive("realtime", realtime)
        diagram = simulator.get_system()
        self._readable = _readable_ports(diagram)
        self._sots = {s.get_name(): s for s in systems_of_type(diagram, StackOfTasks)}
        #: The stacked signals' layouts, sent beside their values: each solver's ``errors``, by task.
        self._layouts = {
            f"{name}.errors": {task: [rows.start, rows.stop] for task, rows in sot.error_slices().items()}
            for name, sot in self._sots.items()
        }
        #: The signals whose rows are pairs of collision shapes, sent by name: each self-collision
        #: task's ``distances`` and ``pair_indices``, by the task.
        self._paired = {
            f"{task.get_name()}.{port}": task
            for task in systems_of_type(diagram, SelfCollisionAvoidance)
            for port in ("distances", "pair_indices")
        }
        commanded = [s for s in self._sots.values() if s.HasInputPort("commands")]
        if not commanded:
            raise ValueError(
                "no StackOfTasks of the diagram takes the server's commands (commands_input=True)"
            )
        self._sot = commanded[0]
        self._entities = {} if session is not None else _scenario_entities(diagram)
        self._subscriptions: dict[int, dict[str, _Subscription]] = {}
        self._answers: list[tuple[int, Any, Any, str | None]] = []
        # the signals read last → wall time [s] of that read, oldest first
        self._watched: dict[str, float] = {}
        self._seen = server.taken(simulator.get_context()).serial
        self.events = ServedEvents()  # the requests that changed the context
        server.attach(network.drain)

    @property
    def context(self) -> Context:
        return self._simulator.get_mutable_context()

    def after_tick(self, t: float, duration: float, wall: float) -> None:
        """The ``progress`` hook of ``simulate`` (simulated time, duration, wall time since the start)."""
        context = self.context
        now = context.get_time()
        # the signals read lately, for the network thread to answer at once (before the replies)
        self._expire_watched()
        self._network.publish(
            {signal: (now, self._read(signal), self._beside(signal)) for signal in self._watched}
        )
        for cid, request_id, result, message in self._answers:
            self._reply(cid, request_id, result, message, now)
        self._answers = []
        taken = self._server.taken(context)
        if taken.serial != self._seen:
            self._seen = taken.serial
            for item in taken.requests:
                self._answer(item, context, taken.time, now)
        if self._on_tick is not None:
            self._on_tick(context)
        for cid, subscriptions in self._subscriptions.items():
            for signal, sub in subscriptions.items():
                if now >= sub.due - 1e-9:
                    sub.due += sub.period * max(1, math.floor((now - sub.due) / sub.period + 1e-9) + 1)
                    self._network.send(
                        cid, {"signal": signal, "t": now, "value": self._read(signal), **self._beside(signal)}
                    )
        ahead = now / self._realtime - wall
        if ahead > 0:  # paced: wait first, so that what arrives meanwhile is taken at the next tick
            wallclock.sleep(ahead)
        if self._paced and now < duration - _EPS:
            self.await_client(now)

    def await_client(self, t: float) -> None:
        """Return once the client's horizon is beyond the tick ``t`` [s] (every write due at it is
        queued); raise TimeoutError after :data:`CLIENT_TIMEOUT` s of wall time, or
        ConnectionError when the client that sent horizons disconnected before."""
        deadline = wallclock.monotonic() + CLIENT_TIMEOUT
        while True:
            remaining = deadline - wallclock.monotonic()
            horizon, left = self._network.wait_horizon(t + _EPS, min(0.5, max(remaining, 0.0)))
            if horizon > t + _EPS:
                return
            if left:
                raise ConnectionError(
                    f"the client pacing the run disconnected with its horizon at {horizon:.6f} s, "
                    f"before the tick of t = {t:.6f} s"
                )
            if remaining <= 0:
                raise TimeoutError(
                    f"paced by its client: no write moved its horizon ({horizon:.6f} s) beyond the "
                    f"tick of t = {t:.6f} s within {CLIENT_TIMEOUT:g} s"
                )

    def finish(self) -> None:
        """Answer the requests the run ended before applying in a tick: an error saying so; and
        detach the server from the network."""
        self._server.attach(None)
        self._network.publish({})  # no value of this run is answered after it
        for cid, request_id, _, _ in self._answers:
            self._network.send(cid, error(request_id, "the run ended before the next tick"))
        self._answers = []
        for cid, request in [*self._server.held(self.context), *self._network.drain()]:
            if request is not None:
                self._network.send(cid, error(request.id, "the run ended before the next tick"))

    def _reply(
        self,
        cid: int,
        request_id: Any,
        result: Any,
        message: str | None,
        now: float,
        *,
        beside: dict[str, Any] | None = None,
    ) -> None:
        if message is not None:
            reply = error(request_id, message)
        else:
            reply = {**ok(request_id, _resolve(result), now), **(beside or {})}
        self._network.send(cid, reply)

    def _answer(self, item: TakenRequest, context: Context, tick: float, now: float) -> None:
        cid, request = item.connection, item.request
        if request is None:
            self._subscriptions.pop(cid, None)
            return
        if item.kind == DONE:
            if item.error is None:
                self.events.write(tick, request.signal)
            self._reply(cid, request.id, request.signal, item.error, now)
            return
        if item.kind == STACK:
            results = self._sot.GetOutputPort("command_results").Eval(self._sot.GetMyContextFromRoot(context))
            applied, text = results.results[item.index]
            if applied:
                self.events.command(tick, request.cmd.strip())
            self._reply(cid, request.id, text, None if applied else text, now)
            return
        try:
            result, acts = self._apply(cid, request, item.statement, context)
        except Exception as exc:  # noqa: BLE001 - a remote request must not end the served run
            self._reply(cid, request.id, None, f"{type(exc).__name__}: {exc}", now)
            return
        if acts:  # it changed the context: answered after the tick it acts at
            self.events.command(now, request.cmd.strip())
            self._answers.append((cid, request.id, result, None))
        else:
            beside = self._beside(request.signal) if request.op == "read" else None
            self._reply(cid, request.id, result, None, now, beside=beside)

    def _apply(
        self, cid: int, request: Request, statement: Statement | None, context: Context
    ) -> tuple[Any, bool]:
        """The result of ``request`` (a callable: evaluated when answered), and whether it changed
        the context; ValueError (or the session's error) when it is refused. ``statement``: a
        ``run`` line as the server parsed it."""
        if request.op == "read":
            self._port(request.signal)
            self._watch(request.signal)
            return self._read(request.signal), False
        if request.op == "run":
            return self._run(request.cmd, statement, context)
        if request.op == "list":
            return self._list(), False
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
            return request.signal, False
        if request.op == "unsubscribe":
            if request.signal not in self._subscriptions.get(cid, {}):
                raise ValueError(f"unsubscribe: {request.signal!r} is not subscribed")
            del self._subscriptions[cid][request.signal]
            return request.signal, False
        raise ValueError(f"op = {request.op!r}: not served")

    def _watch(self, signal: str) -> None:
        """Keep ``signal`` among the :data:`WATCHED` read last, published after each tick."""
        self._watched.pop(signal, None)
        self._watched[signal] = wallclock.monotonic()
        while len(self._watched) > WATCHED:
            del self._watched[next(iter(self._watched))]

    def _expire_watched(self) -> None:
        """The watched signals read since the last tick from the published values are read again;
        those no client read for :data:`WATCH_EXPIRY` s are no longer published."""
        for signal in self._network.take_hits():
            if signal in self._watched:
                self._watch(signal)
        now = wallclock.monotonic()
        for signal in [s for s, read in self._watched.items() if not now - read <= WATCH_EXPIRY]:
            del self._watched[signal]

    def _beside(self, signal: str) -> dict[str, Any]:
        """The fields sent beside the value of ``signal`` that name its rows at the last tick: a
        stacked signal's ``layout``, a self-collision task's ``pairs`` (the pair of each of its
        rows, None for a row without one); none for another signal."""
        if signal in self._layouts:
            return {"layout": self._layouts[signal]}
        task = self._paired.get(signal)
        if task is None:
            return {}
        indices = task.GetOutputPort("pair_indices").Eval(task.GetMyContextFromRoot(self.context))
        pairs = [None if k < 0 else task.candidate_pairs[int(k)] for k in indices]
        return {"pairs": [None if p is None else {f: getattr(p, f) for f in PAIR_FIELDS} for p in pairs]}

    def _port(self, signal: str):
        if signal not in self._readable:
            raise UnknownNameError("vector output", signal, self._readable)
        return self._readable[signal]

    def _read(self, signal: str) -> list[float]:
        system, port = self._port(signal)
        return port.Eval(system.GetMyContextFromRoot(self.context)).tolist()

    def _run(self, cmd: str, statement: Statement | None, context: Context) -> tuple[Any, bool]:
        if cmd.strip() == "help":
            return self._help(), False
        if statement is None:  # a blank or comment line
            return "", False
        command = statement.command
        if self._session is not None:
            if isinstance(command, Get) or (
                isinstance(command, Call) and command.command in ("list", "help")
            ):
                return self._session.execute(statement, context, served=True), False
            return self._session.execute(statement, context, served=True), True
        if isinstance(command, Get):
            signal = f"{command.signal.entity}.{command.signal.name}"
            self._port(signal)
            return " ".join(f"{x:.6g}" for x in self._read(signal)), False
        if isinstance(command, Call) and command.entity in self._entities:
            return self._entity_command(command, context), True
        if isinstance(command, Call) and command.entity in self._sots and command.command == "list":
            if command.args:
                raise ValueError(f"{cmd!r}: {command.entity}.list takes no argument")
            return " ".join(self._sots[command.entity].list(context)), False
        if isinstance(command, Call) and command.command == "help":
            return self._help(), False
        raise ValueError(f"{cmd!r}: not a run-time command here; {self._help()}")

    def _entity_command(self, command: Call, context: Context) -> str:
        """A run-time command of a task or the pattern generator of a served scenario
        (``taskRH.controlGain 5``, ``pg.parsecmd :stepseq …``), as the script dialect runs it."""
        entity = self._entities[command.entity]
        runnable = _runnable(entity)
        if command.command not in runnable:
            raise ValueError(
                f"{command.entity}.{command.command}: not a run-time command of {entity.describe()} "
                f"(those are: {', '.join(runnable)})"
            )
        return entity.run_command(command.command, command.args, context)

    def _help(self) -> str:
        sots = ", ".join(self._sots) or "none"
        if self._session is not None:
            dialect = "the script's run-time commands (set, get, E.COMMAND ...)"
        else:
            kinds: dict[str, list[str]] = {}
            for name, entity in self._entities.items():
                label = "TASK" if isinstance(entity, StackedEntity) else "PG"
                kinds.setdefault(f"{label}.{'|'.join(_runnable(entity))}", []).append(name)
            dialect = "; ".join(
                [
                    *(f"{usage} ({usage.split('.')[0]}: {', '.join(n)})" for usage, n in kinds.items()),
                    "get SYSTEM.PORT",
                ]
            )
        stack = ", ".join(f"SOT.{verb.usage}" for verb in VERBS.values())
        return f"commands: {stack}, SOT.list (SOT: {sots}); {dialect}; help"

    def _list(self) -> dict[str, Any]:
        return {
            "systems": sorted({name.split(".")[0] for name in self._readable}),
            "readable": {name: port.size() for name, (_, port) in self._readable.items()},
            "writable": {name: _listed(w) for name, w in self._server.writables.items()},
            "commands": self._help(),
            "error_slices": {name: self._layouts[f"{name}.errors"] for name in self._sots},
            "period": self.period,
        }


def _scenario_entities(diagram: Diagram) -> dict[str, Entity]:
    """The tasks, self-collision tasks and pattern generators of a scenario's diagram as the
    script's entities (their run-time commands: ``controlGain``, ``pairs``, ``parsecmd``...), by
    system name. They have no session: a served scenario has none, and those commands need only
    their system (a self-collision task's ``pairs`` also its ``d_i``, taken from the system)."""
    kinds = {
        Task: TaskEntity,
        PatternGenerator: PatternGeneratorEntity,
        SelfCollisionAvoidance: SelfCollisionEntity,
    }
    entities = {}
    for system in systems_of_type(diagram, LeafSystem):
        kind = kinds.get(type(system))
        if kind is not None:
            entity = kind(None, system.get_name(), None)
            entity.system = system
            if isinstance(entity, SelfCollisionEntity):  # its settings are the built task's
                entity.settings.update(d_s=system.d_s, d_i=system.d_i)
            entities[system.get_name()] = entity
    return entities


def _runnable(entity: Entity) -> list[str]:
    """The commands of ``entity`` that act on a built diagram's context."""
    return [name for name, spec in type(entity)._commands.items() if spec.phase in (Phase.RUN, Phase.BOTH)]


def _listed(writable: Writable) -> dict[str, Any]:
    """A writable as ``list`` shows it (its radius, its reach and anchor, when it has them)."""
    listed = {"size": writable.size, "units": writable.units, "bound": writable.bound}
    for name in ("radius", "reach", "anchor"):
        if getattr(writable, name) is not None:
            listed[name] = getattr(writable, name)
    return listed


def _resolve(result: Any) -> Any:
    return result() if callable(result) else result


def _readable_ports(diagram: Diagram) -> dict[str, tuple[System, Any]]:
    ports = {}
    for system in systems_of_type(diagram, LeafSystem):
        for i in range(system.num_output_ports()):
            port = system.get_output_port(i)
            if port.get_data_type() == PortDataType.kVectorValued and port.size() > 0:
                ports[f"{system.get_name()}.{port.get_name()}"] = (system, port)
    return ports


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
    live_plot: LivePlot | None = None,
) -> RunResult:
    """Simulate ``setup`` to ``duration`` [s] while serving through ``network`` (started here,
    closed at the end); ``on_ready(address)`` is called once it listens. When the scenario was
    built with a Meshcat, its controls show the stack and the task errors; so does ``live_plot``
    (the caller's, which it serves and closes), over time. The requests that
    changed the context are in the result's ``events`` with the timed commands (the last
    :data:`~drake_sot.app.served_events.MAX_EVENTS`, a stream of writes as one:
    :mod:`drake_sot.app.served_events`), and counted, all, in its ``requests_applied``. A scenario whose
    ``extras.paced_by_client`` is true is paced by its client (module docstring): the run
    starts when the client's first horizon is beyond its first tick."""
    limit_blas_threads(1)  # small matrices: one BLAS thread (drake_sot.blas says why)
    built = setup.built
    if getattr(built, "remote", None) is None:
        raise NotServable(
            "the diagram has no RemoteCommandServer (build it with command_server=True: "
            "drake_sot.diagrams.scenario.build_scenario)"
        )
    units = {
        name: task.units for name, task in built.tasks.items() if isinstance(task, Task | InequalityTask)
    }
    sampler = TaskErrorSampler(built.sot, units=units)
    views: list[MeshcatStatus | LivePlot] = [] if live_plot is None else [live_plot]
    if built.meshcat is not None:
        views.append(MeshcatStatus(built.meshcat, sampler.names))

    def show(context: Context) -> None:
        sample = sampler.sample(context)
        if sample is not None:
            for view in views:
                view.show(sample)

    serving = Serving(
        simulator,
        built.remote,
        network,
        realtime=realtime,
        on_tick=show if views else None,
        session=setup.extras.session,
        paced=setup.extras.paced_by_client,
    )
    start = simulator.get_context().get_time()
    first = (  # the run starts when the client's first horizon is beyond its first tick
        [
            TimedCommand(
                start, "paced by its client: its first write came", lambda _: serving.await_client(start)
            )
        ]
        if setup.extras.paced_by_client
        else []
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
            simulator,
            duration,
            [*first, *setup.commands],
            progress=hook,
            chunk=serving.period,
            guard=guard,
            check=False,
        )
        serving.finish()
    finally:
        network.close()
    result.events = sorted(result.events + serving.events.events, key=lambda event: event[0])
    result.requests_applied = serving.events.applied
    return result


def decision_runner(*, realtime: float = 1.0, connect_timeout: float = 60.0) -> Runner:
    """A :data:`~drake_sot.diagrams.scenario.Runner` for a scenario built with a remote decision
    layer: serves on a free loopback port, starts ``python -m drake_sot.remote.decision`` with
    the scenario's ``extras.decision`` (``signal``, ``period``, ``run`` lines, ``write`` items),
    waits until it connects, then simulates at ``realtime`` × real time while serving."""

    def run(
        setup: ScenarioSetup,
        simulator: Simulator,
        duration: float,
        *,
        progress: Progress | None = None,
        guard: SignalGuard | None = None,
    ) -> RunResult:
        decision = setup.extras.decision
        network = NetworkThread("127.0.0.1", 0)
        processes: list[subprocess.Popen] = []

        def start_client(address: tuple[str, int]) -> None:
            command = [sys.executable, "-m", "drake_sot.remote.decision", "--port", str(address[1])]
            command += ["--signal", decision.signal, "--period", str(decision.period)]
            command += [f"--run={line}" for line in decision.run]
            command += [f"--write={item}" for item in decision.write]
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
