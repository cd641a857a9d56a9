"""``telecoop_master``: the master site of the tele-cooperation (Evrard et al. 2009, IV) in a
diagram of its own, the client of a served ``telecoop_slave`` in another process
(``drake-sot run telecoop_master --connect HOST:PORT``).

The diagram: :class:`~drake_sot.systems.master.MasterSite` and
:class:`~drake_sot.systems.master.Operator` wired as in ``telecooperation``
(:func:`~drake_sot.diagrams.telecooperation.add_master_site`), and a
:class:`~drake_sot.systems.remote_link.RemoteLink` where the one-diagram version has its
``Channel``, with the same delay, jitter, loss and seeds: at each control tick it draws the
arrival time of the master's packet and writes it at once, by name, to the slave's signals
(``telecoop_slave.WRITTEN``), a timed write the slave applies at that arrival; it receives the
slave's hands by name (``telecoop_slave.HANDS``, subscribed every control period, stamped with
the slave's time) and delivers them through the emulated delay of the other direction. The
network runs in the threads of a :class:`~drake_sot.remote.peer.Peer`.

Clocks and pacing (conservative lookahead). Both sides tick at the same simulated times from 0.
Before its tick ``t`` this side waits until it has every slave packet that can arrive by ``t``
(:meth:`~drake_sot.systems.remote_link.RemoteLink.await_peer`); the slave waits likewise for the
master's horizon. Each runs up to the one-way delay ahead of the other, and what each receives,
and at which tick, is exactly what a ``Channel`` delivers in one diagram: the two processes
compute the one-process run (``tests/test_telecoop_two_process.py``). The delay (less the
jitter) must be at least one control period (refused otherwise, naming it). ``realtime`` paces
this side besides (the slave holds its own ``--realtime``).
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink

from drake_sot import validation
from drake_sot.channel import DEFAULT_DELAY
from drake_sot.diagrams import telecooperation
from drake_sot.diagrams.artifacts import Artefacts, output_directory, write_npz
from drake_sot.diagrams.run import Progress, RunResult, SignalGuard, simulate
from drake_sot.diagrams.telecoop_slave import HANDS, WRITTEN
from drake_sot.parameters import Parameter
from drake_sot.remote.peer import Peer
from drake_sot.systems.remote_link import RemoteLink

#: The control period of both sides [s] (the slave's, HumanoidSoTBuilder's default).
PERIOD = 0.005
#: [s] of wall time to wait for the slave's next message before the run fails.
SLAVE_TIMEOUT = 60.0


@dataclass
class MasterOutput:
    """How the master's run ended, its logs (``time`` and one array per log name), its files and
    those that could not be written (a full disk: file → why)."""

    result: RunResult
    arrays: dict[str, np.ndarray]
    files: dict[str, Path]
    unwritten: dict[str, str] = field(default_factory=dict)


def build_master(
    leader: str = "operator",
    delay: float = DEFAULT_DELAY,
    jitter: float = 0.0,
    loss: float = 0.0,
    config: telecooperation.TelecooperationConfig = telecooperation.DEFAULT_CONFIG,
) -> tuple[Diagram, RemoteLink, dict[str, VectorLogSink]]:
    """The master's diagram, its link (unattached: see :meth:`RemoteLink.attach`) and its loggers
    by name; ``delay`` [s] one way, both directions (one control period to 0.3), ``jitter`` [s]
    and ``loss`` as :func:`telecooperation.link_configs` takes them; ``config`` the master
    site's constants (the slave's must be the same)."""
    leader, delay = telecooperation.LEADER.check(leader), telecooperation.DELAY.check(delay)
    forward0, hands0 = telecooperation.initial_link_values(config)
    # telecooperation's Channel's configurations and seeds
    forward, backward = telecooperation.link_configs(delay, jitter, loss)
    builder = DiagramBuilder()
    side = telecooperation.add_master_site(builder, hands0, leader, True, PERIOD, config)
    link = builder.AddSystem(
        RemoteLink(
            None,
            WRITTEN,
            HANDS,
            forward=forward,
            backward=backward,
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
    jitter: float = 0.0,
    loss: float = 0.0,
    duration: float = telecooperation.DEFAULT_CONFIG.duration,
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
    diagram, link, loggers = build_master(leader, delay, jitter, loss)
    simulator = Simulator(diagram)
    simulator.Initialize()
    # Connected last: the slave starts its clock at this connection.
    read = [signal for signal, _ in HANDS]
    with Peer(host, port, read=read, period=PERIOD, token=token, timeout=SLAVE_TIMEOUT) as peer:
        link.attach(peer)

        def paced(t: float, end: float, wall: float) -> None:
            if t < end - 1e-9:
                link.await_peer(t, SLAVE_TIMEOUT)
            ahead = t / realtime - wall
            if ahead > 0:
                wallclock.sleep(ahead)
            if progress is not None:
                progress(t, end, wall)

        with SignalGuard() as guard:
            result = simulate(simulator, duration, progress=paced, chunk=PERIOD, guard=guard, check=False)
            context = simulator.get_context()
            arrays: dict[str, np.ndarray] = {}
            for name, logger in loggers.items():
                log = logger.FindLog(context)
                arrays.setdefault("time", log.sample_times().copy())
                arrays[name] = log.data().T.copy()
            artefacts = Artefacts()
            artefacts.write("npz", out / "telecoop_master.npz", lambda path: write_npz(arrays, path))
    return MasterOutput(result, arrays, artefacts.files, artefacts.unwritten)


@dataclass(frozen=True)
class PeerScenario:
    """A scenario run as the client of a served one (``drake-sot run NAME --connect HOST:PORT``):
    ``run(host, port, out_dir, duration=, progress=, token=, **parameters)``."""

    name: str
    description: str
    run: Callable[..., MasterOutput]
    parameters: tuple[Parameter, ...] = ()


SCENARIO = PeerScenario(
    name="telecoop_master",
    description="telecooperation's master site, the client of a served telecoop_slave (--connect HOST:PORT)",
    run=run_master,
    parameters=(telecooperation.LEADER, telecooperation.DELAY, telecooperation.JITTER, telecooperation.LOSS),
)
