"""Scenarios: diagrams that compose the systems around the embedded humanoid, one per module."""

from drake_sot.diagrams import (
    alpha_sweep,
    look_and_reach,
    priority_switching,
    reach,
    reach_around,
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
from drake_sot.diagrams.study_session import STUDY_FIGURES

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        reach.SCENARIO,
        reach_around.SCENARIO,
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

#: Studies the ``drake-sot run`` command accepts like scenarios (``drake-sot study`` runs every
#: study of :data:`drake_sot.studies.catalog.STUDIES`, the figures of each in ``STUDY_FIGURES``).
STUDIES: dict[str, alpha_sweep.StudyScenario] = {s.name: s for s in (alpha_sweep.STUDY,)}

__all__ = ["PEERS", "SCENARIOS", "STUDIES", "STUDY_FIGURES", "Scenario"]
