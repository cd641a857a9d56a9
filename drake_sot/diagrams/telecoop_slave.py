"""Scenario ``telecoop_slave``: the slave side of the tele-cooperation (Evrard et al. 2009), to be
served (``drake-sot serve telecoop_slave``) for a master in another process
(``drake-sot run telecoop_master --connect HOST:PORT``, :mod:`drake_sot.diagrams.telecoop_master`).

The diagram is ``telecooperation``'s without its master site and channel: the humanoid, its
seven tasks, the board and the co-operator. What the master sends is the command server's
writable signal ``remote.master`` (9,): ``[forces right (3,), left (3,) [N]; head yaw, pitch
(2,) [rad]; gripper aperture (1,) [rad]]`` (:data:`~drake_sot.systems.telecoop.MASTER_LAYOUT`),
applied at the control tick after it arrives and held until the next write. What the slave
sends back is readable and subscribable: ``hand_positions.positions`` (6,) [m], the hands
``[right; left]`` in the world.

The delay, jitter and loss of the link are emulated on the master's side (both directions), so
this side takes no ``delay``. Served by ``drake-sot serve``, the run waits for its master's
connection before it starts (``extras["wait_for_client"]``), so that both sides start their
clocks together.
"""

from __future__ import annotations

from collections.abc import Sequence

from pydrake.geometry import Meshcat

from drake_sot.diagrams import telecooperation
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import Scenario, ScenarioSetup

#: What the master writes (``<server>.<name>``) and subscribes to, on the slave's server.
WRITTEN = f"remote.{telecooperation.MASTER_WRITABLE}"
HANDS = "hand_positions.positions"


def build(
    meshcat: Meshcat | None = None, leader: str = "operator", pushes: Sequence[ExternalPush] = ()
) -> ScenarioSetup:
    """The slave side of ``telecooperation`` (``leader`` decides the co-operator's part: the
    lead, or following 1 s behind through a softer impedance)."""
    return telecooperation.build(meshcat, leader=leader, pushes=pushes, remote=True)


SCENARIO = Scenario(
    name="telecoop_slave",
    description="telecooperation's slave side, to serve: the master (telecoop_master) writes its forces",
    build=build,
    parameters=("leader",),
)
