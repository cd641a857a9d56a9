"""What the self-collision avoidance reports (drake_sot.systems.self_collision): its pairs by
name, distance and witness points on ``closest_pairs``, and the fixed-size ``distances`` and
``pair_indices`` against a list of named candidates, each against Drake's signed-distance query
asked on a collision model of the test's own, on every robot."""

from __future__ import annotations

import numpy as np
import pytest
from collision_queries import Query, random_configuration
from robot_data import robot_or_skip

from drake_sot.systems.self_collision import SelfCollisionAvoidance

ROBOTS = ("embedded", "talos", "g1")


@pytest.mark.parametrize("name", ROBOTS)
def test_the_reported_pairs_are_those_of_the_query_by_name(name):
    """At half-sitting and at a random configuration: ``closest_pairs`` holds every pair closer
    than d_i (fewer than max_pairs here), closest first, with its shapes' and bodies' names, its
    distance and its witness points in world as the query gives them; ``distances`` and
    ``pair_indices`` say the same, row by row, through ``candidate_pairs``, which names every
    pair the filters leave, once."""
    robot = robot_or_skip(name)
    d_i, rows = 0.12, 80
    task = SelfCollisionAvoidance(robot, d_s=0.01, d_i=d_i, max_pairs=rows)
    query = Query(robot)
    assert {frozenset((p.shape_a, p.shape_b)) for p in task.candidate_pairs} == query.candidates()
    assert len(task.candidate_pairs) == len(query.candidates())
    context = task.CreateDefaultContext()
    rng = np.random.default_rng(3)
    for q in (
        query.plant.GetPositions(query.plant.CreateDefaultContext()),
        random_configuration(query.plant, rng),
    ):
        near = query.near(q, d_i)
        assert 3 < len(near) < rows, len(near)
        task.GetInputPort("q").FixValue(context, q)
        pairs = task.GetOutputPort("closest_pairs").Eval(context)
        assert {frozenset((p.shape_a, p.shape_b)) for p in pairs} == set(near)
        np.testing.assert_allclose(
            [p.distance for p in pairs], sorted(d for d, _ in near.values()), atol=1e-9
        )
        for p in pairs:
            distance, points = near[frozenset((p.shape_a, p.shape_b))]
            assert p.distance == pytest.approx(distance, abs=1e-9)
            for shape, body, point in ((p.shape_a, p.body_a, p.p_WCa), (p.shape_b, p.body_b, p.p_WCb)):
                assert body == points[shape][0]
                np.testing.assert_allclose(point, points[shape][1], atol=1e-9)
        distances = task.GetOutputPort("distances").Eval(context)
        indices = task.GetOutputPort("pair_indices").Eval(context)
        np.testing.assert_array_equal(distances[: len(pairs)], [p.distance for p in pairs])
        assert np.isnan(distances[len(pairs) :]).all() and (indices[len(pairs) :] == -1).all()
        for p, k in zip(pairs, indices, strict=False):
            named = task.candidate_pairs[int(k)]
            assert {named.shape_a, named.shape_b} == {p.shape_a, p.shape_b}
            assert {named.body_a, named.body_b} == {p.body_a, p.body_b}
            assert p.index == k


def test_two_contexts_each_get_the_rows_of_their_own_configuration():
    """The task keeps one scratch model and one cached query per context: a context whose query
    is cached while another context has moved the scratch model to another q still gets the rows
    (Jacobians, bounds) and the witness points of its own q, as a task of its own would (at the
    configurations of the test above, where no pair is at d_i)."""
    task = SelfCollisionAvoidance("embedded", d_s=0.01, d_i=0.12, max_pairs=40)
    plant = task.model.plant
    qs = [
        plant.GetPositions(plant.CreateDefaultContext()),
        random_configuration(plant, np.random.default_rng(3)),
    ]
    contexts = [task.CreateDefaultContext() for _ in qs]
    for context, q in zip(contexts, qs, strict=True):
        task.GetInputPort("q").FixValue(context, q)
    task.GetOutputPort("distances").Eval(contexts[0])  # the first context's query cached
    task.GetOutputPort("task").Eval(contexts[1])  # the scratch model moved to the second q
    for q, context in zip(qs, contexts, strict=True):
        alone = SelfCollisionAvoidance("embedded", d_s=0.01, d_i=0.12, max_pairs=40)
        alone_context = alone.CreateDefaultContext()
        alone.GetInputPort("q").FixValue(alone_context, q)
        expected, got = (
            alone.GetOutputPort("task").Eval(alone_context),
            task.GetOutputPort("task").Eval(context),
        )
        assert np.isfinite(expected.lower).sum() > 3
        np.testing.assert_array_equal(got.jacobian, expected.jacobian)
        np.testing.assert_array_equal(got.lower, expected.lower)
        pairs = task.GetOutputPort("closest_pairs").Eval(context)
        assert pairs == alone.GetOutputPort("closest_pairs").Eval(alone_context)
