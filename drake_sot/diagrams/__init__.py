"""Scenarios: diagrams that compose the systems around the embedded humanoid, one per module."""

from drake_sot.diagrams import (
    alpha_sweep,
    delay_sweep_plots,
    gain_sweep_plots,
    look_and_reach,
    priority_switching,
    push_recovery_plots,
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

#: What writes the figures of a study of ``drake-sot study`` from its table's rows, by study name:
#: ``write(study, rows, out_dir)`` -> name -> file.
STUDY_FIGURES = {
    "alpha_sweep": alpha_sweep.write_figures,
    "push_recovery": push_recovery_plots.write_figures,
    "gain_sweep": gain_sweep_plots.write_figures,
    "delay_sweep": delay_sweep_plots.write_figures,
}

__all__ = ["PEERS", "SCENARIOS", "STUDIES", "STUDY_FIGURES", "Scenario"]
