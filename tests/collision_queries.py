"""Shared by the collision tests: Drake's signed-distance query asked on a collision model of the
test's own (not the task's), and random configurations within the joint limits."""

from __future__ import annotations

import numpy as np

from drake_sot.systems.self_collision import make_collision_model


class Query:
    """Drake's signed-distance query on a collision model of ``robot`` built for the test."""

    def __init__(self, robot, fixed_base: bool = False) -> None:
        model = make_collision_model(robot, fixed_base=fixed_base)
        self.plant, scene_graph = model.plant, model.scene_graph
        self.context = model.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.port = scene_graph.get_query_output_port()
        self.scene_context = scene_graph.GetMyContextFromRoot(self.context)
        self.inspector = scene_graph.model_inspector()

    def body(self, geometry) -> str:
        """The name of the body ``geometry`` is on."""
        return self.plant.GetBodyFromFrameId(self.inspector.GetFrameId(geometry)).name()

    def candidates(self) -> set[frozenset]:
        """Every pair of shapes the collision filters leave, by the shapes' names."""
        name = self.inspector.GetName
        return {frozenset((name(a), name(b))) for a, b in self.inspector.GetCollisionCandidates()}

    def near(self, q: np.ndarray, d_i: float) -> dict[frozenset, tuple[float, dict]]:
        """The pairs closer than ``d_i`` at ``q``: shapes' names -> (signed distance, shape ->
        (its body, its witness point in world)). None is within 1e-6 m of ``d_i`` (whether the
        query keeps a pair at its ``max_distance`` exactly varies from one model to another)."""
        self.plant.SetPositions(self.plant_context, q)
        query = self.port.Eval(self.scene_context)
        found = {}
        for p in query.ComputeSignedDistancePairwiseClosestPoints(max_distance=d_i + 0.01):
            assert abs(p.distance - d_i) > 1e-6, p.distance
            if p.distance > d_i:
                continue
            a, b = self.inspector.GetName(p.id_A), self.inspector.GetName(p.id_B)
            points = {
                a: (self.body(p.id_A), query.GetPoseInWorld(p.id_A) @ p.p_ACa),
                b: (self.body(p.id_B), query.GetPoseInWorld(p.id_B) @ p.p_BCb),
            }
            found[frozenset((a, b))] = (p.distance, points)
        return found


def random_configuration(plant, rng) -> np.ndarray:
    """Joint angles uniform within their limits, the base where the model puts it."""
    q = plant.GetPositions(plant.CreateDefaultContext())
    low, high = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    bounded = np.isfinite(low) & np.isfinite(high)
    q[bounded] = rng.uniform(low[bounded], high[bounded])
    return q
