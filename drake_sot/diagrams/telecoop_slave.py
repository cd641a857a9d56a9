"""Scenario ``telecoop_slave``: the slave side of the tele-cooperation (Evrard et al. 2009), to be
served (``drake-sot serve telecoop_slave``) for a master in another process
(``drake-sot run telecoop_master --connect HOST:PORT``, :mod:`drake_sot.diagrams.telecoop_master`).

The diagram is ``telecooperation``'s without its master site and channel: the humanoid, its
seven tasks, the board and the co-operator. What the master sends are the command server's
writable signals, one per quantity (:data:`~drake_sot.systems.telecoop.MASTER_SIGNALS`):
``remote.right_hand_force``, ``remote.left_hand_force`` (3,) [N, world axes], ``remote.head``
(2,) [rad, yaw then pitch], ``remote.gripper`` (1,) [rad, the gripper joints' angle]; a write
of another name or size is refused, naming it. What the slave sends back is readable and
subscribable by name: ``hand_positions.right`` and ``hand_positions.left`` (3,) [m, world].

The delay, jitter and loss of the link are drawn on the master's side (both directions), so
this side takes no ``delay``: each write is timed (applied at the tick the master's emulated
link makes it arrive at) and the run is paced by its master (``extras.paced_by_client``):
it starts with the master's first write and never simulates a tick before it holds every
write due at it (:mod:`drake_sot.app.serving`). The two processes then compute what one
``telecooperation`` diagram computes, whatever their pace.
"""

from __future__ import annotations

from collections.abc import Sequence

from pydrake.geometry import Meshcat

from drake_sot.diagrams import telecooperation
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.scenario import SELF_COLLISION, Scenario, ScenarioSetup
from drake_sot.systems.telecoop import MASTER_SIGNALS

#: What the master writes on the slave's server (``<server>.<name>``, size), in the order of
#: the master's vector.
WRITTEN = tuple((f"remote.{name}", size) for name, (size, _) in MASTER_SIGNALS.items())
#: What the master subscribes to (size), the hands ``[right; left]`` it receives.
HANDS = (("hand_positions.right", 3), ("hand_positions.left", 3))


def build(
    meshcat: Meshcat | None = None,
    leader: str = "operator",
    pushes: Sequence[ExternalPush] = (),
    command_server: bool = True,
    self_collision: bool = True,
) -> ScenarioSetup:
    """The slave side of ``telecooperation`` (``leader`` decides the co-operator's part: the
    lead, or following 1 s behind through a softer impedance); it always has its command server
    (what the master writes reaches it there), whatever ``command_server`` says;
    ``self_collision``: the self-collision task just below the joint limits, as in
    ``telecooperation`` (the master has no robot, hence no such parameter).

    Raises:
        ValueError: ``leader`` is not one of ``telecooperation.LEADERS`` (naming it)."""
    return telecooperation.build(
        meshcat, leader=leader, pushes=pushes, remote=True, self_collision=self_collision
    )


SCENARIO = Scenario(
    name="telecoop_slave",
    description="telecooperation's slave side, to serve: the master (telecoop_master) writes its forces",
    build=build,
    parameters=(telecooperation.LEADER, SELF_COLLISION),
    servable=True,
)
