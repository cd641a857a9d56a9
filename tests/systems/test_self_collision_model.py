"""The self-collision task's collision model: obstacles of the environment, the legs' pairs left
out, and the builder's default level just below the joint limits (embedded robot, no physics)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.tasks import SELF_COLLISION_TASK
from drake_sot.robots.description_file import load_description
from drake_sot.robots.draft import draft_description
from drake_sot.systems.self_collision import Obstacle, SelfCollisionAvoidance, make_collision_model

TABLE = Obstacle("table", (0.4, 0.4, 0.04), RigidTransform([0.5, 0.0, 0.7]))


def _pairs(model) -> set[frozenset[str]]:
    inspector = model.scene_graph.model_inspector()
    return {
        frozenset((inspector.GetName(a), inspector.GetName(b))) for a, b in inspector.GetCollisionCandidates()
    }


def _shapes_of(model, frame_key: str) -> set[str]:
    body = model.plant.GetFrameByName(model.info.frames[frame_key]).body()
    inspector = model.scene_graph.model_inspector()
    return {inspector.GetName(g) for g in model.plant.GetCollisionGeometriesForBody(body)}


def test_an_obstacle_pairs_with_every_shape_but_the_feet():
    plain, with_table = make_collision_model(), make_collision_model(obstacles=(TABLE,))
    shapes = {name for pair in _pairs(plain) for name in pair}
    feet = _shapes_of(plain, "left_foot") | _shapes_of(plain, "right_foot")
    table = next(name for pair in _pairs(with_table) for name in pair if name.endswith("table_collision"))
    added = _pairs(with_table) - _pairs(plain)
    assert added == {frozenset((table, shape)) for shape in shapes - feet}
    assert feet and shapes - feet


def test_without_leg_pairs_no_shape_of_one_leg_pairs_with_the_other():
    all_pairs, no_legs = _pairs(make_collision_model()), _pairs(make_collision_model(leg_pairs=False))
    left_foot = _shapes_of(make_collision_model(), "left_foot")
    removed = all_pairs - no_legs
    assert no_legs < all_pairs and removed
    # the feet's pairs go, a foot against the other foot among them; an arm's against a leg stay
    assert any(set(pair) & left_foot for pair in removed)
    assert all(not any("arm" in name or "hand" in name for name in pair) for pair in removed)


def test_an_obstacle_is_refused_naming_its_size():
    with pytest.raises(ValueError, match=r"obstacle 'box': size = \(0.1, 0.0, 0.1\)"):
        Obstacle("box", (0.1, 0.0, 0.1), RigidTransform())
    with pytest.raises(ValueError, match="size = "):
        Obstacle("box", (0.1, float("nan"), 0.1), RigidTransform())


def test_the_builder_puts_the_task_just_below_the_joint_limits_or_leaves_the_stack():
    b = HumanoidSoTBuilder()
    b.add_joint_position_limits_task("taskJL")
    b.add_posture_task("taskPosture")
    assert b.below_joint_limits(("taskJL", "taskPosture"), False) == ("taskJL", "taskPosture")
    assert SELF_COLLISION_TASK not in b.tasks
    assert b.below_joint_limits(("taskJL", "taskPosture")) == ("taskJL", SELF_COLLISION_TASK, "taskPosture")
    assert SELF_COLLISION_TASK in b.tasks
    other = HumanoidSoTBuilder()
    other.add_posture_task("taskPosture")
    with pytest.raises(ValueError, match="below the joint limits"):
        other.below_joint_limits(("taskPosture",))


def test_a_robot_with_no_pair_that_may_collide_gets_no_row(tmp_path):
    """The draft of the shipped URDF gives the soles' contact spheres only: without the legs'
    pairs nothing may collide, and the task's rows (all ``max_pairs`` of them) bound nothing."""
    example = Path(__file__).resolve().parents[2] / "examples" / "robot"
    shutil.copy(example / "humanoid.urdf", tmp_path / "drafted.urdf")
    (tmp_path / "drafted.toml").write_text(draft_description(tmp_path / "drafted.urdf").text)
    robot = load_description(tmp_path / "drafted.toml")
    task = SelfCollisionAvoidance(robot, leg_pairs=False, max_pairs=4)
    assert not _pairs(task.model)  # nothing may collide
    context = task.CreateDefaultContext()
    task.GetInputPort("q").FixValue(
        context, task.model.plant.GetPositions(task.model.plant.CreateDefaultContext())
    )
    rows = task.GetOutputPort("task").Eval(context)
    assert rows.jacobian.shape[0] == 4 and not rows.jacobian.any()
    assert np.isneginf(rows.lower).all() and np.isposinf(rows.upper).all()
