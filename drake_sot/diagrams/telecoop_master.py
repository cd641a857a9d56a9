"""``telecoop_master``: the master site of the tele-cooperation (Evrard et al. 2009, IV) in a
diagram of its own, the client of a served ``telecoop_slave`` in another process
(``drake-sot run telecoop_master --connect HOST:PORT``).

The diagram: :class:`~drake_sot.systems.master.MasterSite` and
:class:`~drake_sot.systems.master.Operator` wired as in ``telecooperation``
(:func:`~drake_sot.diagrams.telecooperation.add_master_site`), and a
:class:`~drake_sot.systems.remote_link.RemoteLink` where the one-diagram version has its
``Channel``: at each control tick it sends the master's vector through the emulated delay and
writes what is delivered to the slave's ``remote.master``; it receives the slave's hands from a
subscription to ``hand_positions.positions`` (every control period), each stamped with the
slave's time, through the emulated delay of the other direction. The network runs in the
threads of a :class:`~drake_sot.remote.peer.Peer`.

Clocks and pacing. The slave waits for this client before it starts, so both clocks start
together (within the connection's set-up; the subscription is sent first, so the slave's
first ticks are streamed too). This side runs at ``realtime`` × real time, and never ahead of the
slave's stamps: after reaching ``t`` it waits for the slave's message of time ``t``, so it follows
the slave when the slave is slower than real time (0.3-0.4 × here). The backward direction is
then exact to a tick (stamped on the slave's clock). A forward write acts at the slave's first
tick after it arrives: it lands while the slave steps from the tick it was meant for, so it is
mostly one period late, which the forward link's delay compensates (:data:`FORWARD_LATENCY`);
the rest is jitter of the transport and of the two processes' scheduling (measured on loopback,
2 busy cores, two runs: 68-73 % of the writes act at the one-diagram ``Channel``'s tick,
15-21 % a tick early, 10-12 % 1-6 ticks late; ``tests/test_telecoop_two_process.py``). With
``delay`` below one period the forward link cannot compensate: the writes are then a tick late.
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink

from drake_sot import validation
from drake_sot.channel import DEFAULT_DELAY, LinkConfig
from drake_sot.diagrams import telecooperation
from drake_sot.diagrams.artifacts import output_directory, write_npz
from drake_sot.diagrams.run import Progress, RunResult, SignalGuard, simulate
from drake_sot.diagrams.telecoop_slave import HANDS, WRITTEN
from drake_sot.remote.peer import Peer
from drake_sot.systems.remote_link import RemoteLink
from drake_sot.systems.telecoop import MASTER_SIZE

#: The control period of both sides [s] (the slave's, HumanoidSoTBuilder's default).
PERIOD = 0.005
#: [s] a write's latency on the slave's clock: it lands while the slave steps from the tick it
#: was meant for, and acts at the next tick (measured: 68-73 % of the writes one period late, see
#: the module docstring).
FORWARD_LATENCY = PERIOD
#: [s] of wall time to wait for the slave's next message before the run fails.
SLAVE_TIMEOUT = 60.0


@dataclass
class MasterOutput:
    """How the master's run ended, its logs (``time`` and one array per log name) and its files."""

    result: RunResult
    arrays: dict[str, np.ndarray]
    files: dict[str, Path]


def build_master(
    leader: str = "operator", delay: float = DEFAULT_DELAY
) -> tuple[Diagram, RemoteLink, dict[str, VectorLogSink]]:
    """The master's diagram, its link (unattached: see :meth:`RemoteLink.attach`) and its loggers
    by name; ``delay`` [s] one way, both directions (0-0.3)."""
    if leader not in telecooperation.LEADERS:
        raise ValueError(f"leader = {leader!r}: one of {', '.join(telecooperation.LEADERS)}")
    delay = validation.bounded("delay", delay, 0.0, 0.3, unit="s")
    forward0, hands0 = telecooperation.initial_link_values()
    builder = DiagramBuilder()
    side = telecooperation.add_master_site(builder, hands0, leader, True, PERIOD)
    link = builder.AddSystem(
        RemoteLink(
            None,
            MASTER_SIZE,
            6,
            # telecooperation's Channel's seeds; the forward delay less the transport's latency
            forward=LinkConfig(delay=max(delay - FORWARD_LATENCY, 0.0), seed=0),
            backward=LinkConfig(delay=delay, seed=1),
            period=PERIOD,
            forward_initial=forward0,
            backward_initial=hands0,
        )
    )
    builder.Connect(side.sent.get_output_port(), link.GetInputPort("forward_in"))
    builder.Connect(link.GetOutputPort("backward_out"), side.master.GetInputPort("slave_hands"))
    logs = (
        *telecooperation.master_logs(side),
        ("sent_to_slave", link.GetOutputPort("forward_out")),
        ("received_by_master", link.GetOutputPort("backward_out")),
        ("delay_forward", link.GetOutputPort("forward_age")),
        ("delay_backward", link.GetOutputPort("backward_age")),
    )
    loggers = {name: LogVectorOutput(port, builder, PERIOD) for name, port in logs}
    return builder.Build(), link, loggers


def run_master(
    host: str,
    port: int,
    out_dir: str | Path,
    *,
    leader: str = "operator",
    delay: float = DEFAULT_DELAY,
    duration: float = telecooperation.DURATION,
    realtime: float = 1.0,
    token: str | None = None,
    progress: Progress | None = None,
) -> MasterOutput:
    """Connect to the slave served at ``host:port``, run the master site for ``duration`` [s]
    paced as the module docstring says, and write ``telecoop_master.npz`` (the logs) in
    ``out_dir``. The run's failures (a lost or refused link, a slave silent for
    ``SLAVE_TIMEOUT`` s) are in the result, as a run's are."""
    duration = validation.positive("duration", duration, unit="s")
    realtime = validation.positive("realtime", realtime)
    out = output_directory(out_dir)
    diagram, link, loggers = build_master(leader, delay)
    simulator = Simulator(diagram)
    simulator.Initialize()
    # Connected last: the slave starts its clock at this connection.
    with Peer(host, port, read=HANDS, write=WRITTEN, period=PERIOD, token=token) as peer:
        link.attach(peer)

        def paced(t: float, end: float, wall: float) -> None:
            if t < end - 1e-9 and not peer.wait_until(t - 1e-9, SLAVE_TIMEOUT):
                raise TimeoutError(
                    f"no message from the slave for {SLAVE_TIMEOUT:g} s (master at t = {t:.3f} s)"
                )
            ahead = t / realtime - wall
            if ahead > 0:
                wallclock.sleep(ahead)
            if progress is not None:
                progress(t, end, wall)

        with SignalGuard() as guard:
            result = simulate(simulator, duration, progress=paced, chunk=PERIOD, guard=guard)
            context = simulator.get_context()
            arrays: dict[str, np.ndarray] = {}
            for name, logger in loggers.items():
                log = logger.FindLog(context)
                arrays.setdefault("time", log.sample_times().copy())
                arrays[name] = log.data().T.copy()
            files = {"npz": out / "telecoop_master.npz"}
            write_npz(arrays, files["npz"])
    return MasterOutput(result, arrays, files)


@dataclass(frozen=True)
class PeerScenario:
    """A scenario run as the client of a served one (``drake-sot run NAME --connect HOST:PORT``):
    ``run(host, port, out_dir, duration=, progress=, token=, **parameters)``."""

    name: str
    description: str
    run: Callable[..., MasterOutput]
    parameters: tuple[str, ...] = ()


SCENARIO = PeerScenario(
    name="telecoop_master",
    description="telecooperation's master site, the client of a served telecoop_slave (--connect HOST:PORT)",
    run=run_master,
    parameters=("leader", "delay"),
)
