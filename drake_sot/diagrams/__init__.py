"""Scenarios: diagrams that compose the systems around the embedded humanoid, one per module."""

from drake_sot.diagrams import reach, walk, walk_then_interact
from drake_sot.diagrams.scenario import Scenario

SCENARIOS: dict[str, Scenario] = {s.name: s for s in (reach.SCENARIO, walk.SCENARIO, walk_then_interact.SCENARIO)}

__all__ = ["SCENARIOS", "Scenario"]
