"""Whole-body collision geometry: every listed link collides, neighbours do not collide with
each other, the rest do, and standing the soles alone touch the ground."""

import itertools

import pytest
from pydrake.geometry import SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from drake_sot.diagrams.world import add_humanoid_plant
from drake_sot.models import add_body_collision, half_sitting_configuration, load_humanoid
from drake_sot.models.humanoid import FOOT_GUARD

#: Pairs of links whose shapes may touch as the joints between them move: the hip, the knee,
#: the ankle, the chest, the neck, the shoulders, the elbows, the wrists; a finger and its
#: forearm (the gripper folds on the wrist).
NEIGHBOURS = {
    ("pelvis", "r_thigh"), ("pelvis", "l_thigh"), ("r_thigh", "r_shank"), ("l_thigh", "l_shank"),
    ("r_shank", "r_foot"), ("l_shank", "l_foot"), ("pelvis", "torso"), ("torso", "head"),
    ("torso", "r_upper_arm"), ("torso", "l_upper_arm"), ("r_upper_arm", "r_forearm"),
    ("l_upper_arm", "l_forearm"), ("r_forearm", "r_hand"), ("l_forearm", "l_hand"),
    ("r_forearm", "r_finger"), ("l_forearm", "l_finger"), ("r_hand", "r_finger"), ("l_hand", "l_finger"),
}  # fmt: skip
#: Pairs that meet in a fall or a clumsy motion, and must collide.
NOT_NEIGHBOURS = [
    ("torso", "r_forearm"), ("torso", "l_hand"), ("r_thigh", "r_hand"), ("r_thigh", "l_thigh"),
    ("r_shank", "l_shank"), ("r_foot", "l_foot"), ("head", "r_upper_arm"), ("pelvis", "r_hand"),
    ("pelvis", "r_shank"), ("r_hand", "l_hand"), ("head", "l_hand"),
]  # fmt: skip
LINKS = sorted({link for pair in NEIGHBOURS for link in pair})


@pytest.fixture(scope="module")
def world():
    builder = DiagramBuilder()
    plant, scene_graph, info = add_humanoid_plant(builder)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, half_sitting_configuration(plant, info))
    return plant, info, plant_context


def _query(plant, context):
    return plant.get_geometry_query_input_port().Eval(context)


def test_each_link_of_the_body_collides(world):
    plant, info, _ = world
    for link in LINKS:
        assert plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link, info.model_instance)), link


def test_neighbours_are_filtered_the_others_are_not(world):
    plant, info, context = world
    inspector = _query(plant, context).inspector()

    def ids(link):
        return plant.GetCollisionGeometriesForBody(plant.GetBodyByName(link, info.model_instance))

    for a, b in itertools.combinations(LINKS, 2):
        filtered = {inspector.CollisionFiltered(g, h) for g in ids(a) for h in ids(b)}
        expected = (a, b) in NEIGHBOURS or (b, a) in NEIGHBOURS
        if expected or (a, b) in NOT_NEIGHBOURS or (b, a) in NOT_NEIGHBOURS:
            assert filtered == {expected}, (a, b)


def test_standing_only_the_sole_spheres_touch_the_ground(world):
    plant, _, context = world
    query = _query(plant, context)
    inspector = query.inspector()
    touching = {
        inspector.GetName(g) for pair in query.ComputePointPairPenetration() for g in (pair.id_A, pair.id_B)
    }
    assert touching == {"ground_collision"} | {
        f"sot_humanoid::{side}_sole_contact_{i}" for side in "rl" for i in range(4)
    }
    # No other shape within a centimetre of the ground or of another shape, save the
    # raised foot guards (FOOT_GUARD above the ground).
    near = [
        (inspector.GetName(p.id_A), inspector.GetName(p.id_B), p.distance)
        for p in query.ComputeSignedDistancePairwiseClosestPoints(max_distance=0.0101)
        if "sole_contact" not in inspector.GetName(p.id_A) + inspector.GetName(p.id_B)
    ]
    assert sorted(round(d, 6) for _, _, d in near) == [FOOT_GUARD, FOOT_GUARD], near


def test_misuse_is_refused():
    plant = MultibodyPlant(0.0)
    info = load_humanoid(plant)
    with pytest.raises(RuntimeError, match="SceneGraph"):
        add_body_collision(plant, SceneGraph(), info)
    plant.Finalize()
    with pytest.raises(RuntimeError, match="finalized"):
        add_body_collision(plant, SceneGraph(), info)
