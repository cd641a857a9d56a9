"""Scenarios: diagrams that compose the systems around the embedded humanoid, one per module."""

from drake_sot.diagrams import (
    alpha_sweep,
    look_and_reach,
    priority_switching,
    reach,
    table_pounding,
    telecoop_master,
    telecoop_slave,
    telecooperation,
    walk,
    walk_long,
    walk_random,
    walk_then_interact,
)
from drake_sot.diagrams.scenario import Scenario

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        reach.SCENARIO,
        walk.SCENARIO,
        walk_long.SCENARIO,
        walk_random.SCENARIO,
        walk_then_interact.SCENARIO,
        look_and_reach.SCENARIO,
        priority_switching.SCENARIO,
        table_pounding.SCENARIO,
        telecooperation.SCENARIO,
        telecoop_slave.SCENARIO,
    )
}

#: Scenarios run as the client of a served one (``drake-sot run NAME --connect HOST:PORT``).
PEERS: dict[str, telecoop_master.PeerScenario] = {s.name: s for s in (telecoop_master.SCENARIO,)}

#: Batches of simulations (the ``drake-sot run`` command accepts them like scenarios).
STUDIES: dict[str, alpha_sweep.Study] = {s.name: s for s in (alpha_sweep.STUDY,)}

__all__ = ["PEERS", "SCENARIOS", "STUDIES", "Scenario"]
