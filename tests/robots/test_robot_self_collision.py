"""Self-collision avoidance (drake_sot.systems.self_collision) on every robot: the distance
Jacobian against finite differences of Drake's signed distance, the rows against the distances
of every pair, a hand driven into the torso that stops at the margin (kinematics only), the
task as a level of the stack and in the builder, and its parameters refused by name."""

from __future__ import annotations

import numpy as np
import pytest
from collision_queries import random_configuration
from pydrake.multibody.tree import JacobianWrtVariable
from robot_data import robot_or_skip

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.hqp import solve_hqp
from drake_sot.models import half_sitting_configuration
from drake_sot.robots import make_robot_control_model
from drake_sot.signals import TaskSignal
from drake_sot.systems.self_collision import SelfCollisionAvoidance, make_collision_model
from drake_sot.systems.sot import StackOfTasks

ROBOTS = ("embedded", "talos", "g1")


class Distances:
    """Signed distances of the robot's pairs of shapes, on a model of its own (not the task's)."""

    def __init__(self, robot, fixed_base: bool = False) -> None:
        self.model = make_collision_model(robot, fixed_base=fixed_base)
        self.plant, scene_graph = self.model.plant, self.model.scene_graph
        self.context = self.model.diagram.CreateDefaultContext()
        self.plant_context = self.plant.GetMyMutableContextFromRoot(self.context)
        self.port = scene_graph.get_query_output_port()
        self.scene_context = scene_graph.GetMyContextFromRoot(self.context)
        inspector = scene_graph.model_inspector()
        self.candidates = [
            (inspector.GetName(a), inspector.GetName(b), a, b) for a, b in inspector.GetCollisionCandidates()
        ]
        self.ids = {
            name: g for name_a, name_b, a, b in self.candidates for name, g in ((name_a, a), (name_b, b))
        }

    def pair(self, q: np.ndarray, a: str, b: str) -> float:
        self.plant.SetPositions(self.plant_context, q)
        query = self.port.Eval(self.scene_context)
        return query.ComputeSignedDistancePairClosestPoints(self.ids[a], self.ids[b]).distance

    def least(self, q: np.ndarray) -> float:
        """The least signed distance of the pairs closer than 1 m."""
        self.plant.SetPositions(self.plant_context, q)
        return min(
            p.distance
            for p in self.port.Eval(self.scene_context).ComputeSignedDistancePairwiseClosestPoints(1.0)
        )

    def every_pair(self, q: np.ndarray) -> dict[frozenset, float]:
        """Each candidate pair's signed distance, asked pair by pair."""
        return {frozenset((a, b)): self.pair(q, a, b) for a, b, _, _ in self.candidates}


def rows(task, q):
    context = task.CreateDefaultContext()
    task.GetInputPort("q").FixValue(context, q)
    return task.GetOutputPort("task").Eval(context), task.pairs(context)


@pytest.mark.parametrize("name", ROBOTS)
def test_distance_jacobian_matches_finite_differences(name):
    """``J_d v`` against ``(d(q + h v) - d(q - h v)) / 2h`` on random configurations, for every
    pair at positive distance. Drake's distances between boxes and other shapes (GJK) carry a
    noise of up to about 1e-5 m, and near-parallel shapes a large curvature: a row agrees when
    one of three steps h gives the derivative within 2e-3 m/s for a unit v (a wrong row is off
    by the whole rate, ~0.1 m/s)."""
    robot = robot_or_skip(name)
    task = SelfCollisionAvoidance(robot, d_s=0.0, d_i=0.3, max_pairs=400)
    distances = Distances(robot)
    plant, context = distances.plant, distances.plant_context
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(2):
        q = random_configuration(plant, rng)
        signal, pairs = rows(task, q)
        plant.SetPositions(context, q)
        for row, (a, b, d) in enumerate(pairs):
            if not d > 0.005:
                continue
            v = rng.normal(size=plant.num_velocities())
            v /= np.linalg.norm(v)
            qdot = plant.MapVelocityToQDot(context, v)
            rate = signal.jacobian[row] @ v
            misses = [
                abs(
                    (distances.pair(q + h * qdot, a, b) - distances.pair(q - h * qdot, a, b)) / (2 * h) - rate
                )
                for h in (1e-2, 3e-3, 1e-3)
            ]
            assert min(misses) < 2e-3, (name, a, b, d, rate, misses)
            checked += 1
    assert checked >= 50, checked  # the check saw many pairs


@pytest.mark.parametrize("name", ROBOTS)
def test_rows_are_the_pairs_closer_than_the_activation_distance(name):
    """At half-sitting and at a random configuration, every pair's distance asked on its own:
    the task has one row per pair closer than d_i, closest first, with the bound
    ``-ξ (d - d_s) / (d_i - d_s)``; no other row bounds anything. With fewer rows than such
    pairs, the rows hold the closest ones."""
    robot = robot_or_skip(name)
    d_s, d_i, xi = 0.01, 0.12, 0.3
    task = SelfCollisionAvoidance(robot, d_s=d_s, d_i=d_i, xi=xi, max_pairs=60)
    few = SelfCollisionAvoidance(robot, d_s=d_s, d_i=d_i, xi=xi, max_pairs=3)
    distances = Distances(robot)
    plant = distances.plant
    rng = np.random.default_rng(3)
    for q in (plant.GetPositions(plant.CreateDefaultContext()), random_configuration(plant, rng)):
        every = distances.every_pair(q)
        near = sorted(d for d in every.values() if d < d_i)
        assert 3 < len(near) < 60, len(near)
        assert any(d > d_i for d in every.values())
        signal, pairs = rows(task, q)
        bounded = np.isfinite(signal.lower)
        assert bounded.sum() == len(near) and bounded[: len(near)].all()
        np.testing.assert_allclose([d for _, _, d in pairs], near, atol=1e-7)
        for a, b, d in pairs:
            assert every[frozenset((a, b))] == pytest.approx(d, abs=1e-7)
        np.testing.assert_allclose(
            signal.lower[bounded], -xi * (np.array(near) - d_s) / (d_i - d_s), atol=1e-6
        )
        assert not signal.jacobian[~bounded].any() and np.isposinf(signal.upper).all()
        np.testing.assert_allclose(
            signal.error, [min(d - d_s, 0.0) for d in near] + [0.0] * (60 - len(near)), atol=1e-7
        )
        _, closest = rows(few, q)
        np.testing.assert_allclose([d for _, _, d in closest], near[:3], atol=1e-7)


def test_a_hand_driven_into_the_torso_stops_at_the_margin():
    """Kinematics only (q̇ integrated over 100 ticks of 10 ms, no physics), the embedded humanoid
    on a fixed base reaching with its right arm (the arm's six joints, at most 0.4 of their
    velocity limits, a level above the rest): a task pulls the hand to the torso's centre.
    Alone it drives the hand through the torso's surface; with the self-collision task a level
    above the reach, no pair of shapes comes closer than d_s - 1 mm and the hand stays short of
    the target."""
    d_s, period, gain = 0.02, 0.01, 3.0
    task = SelfCollisionAvoidance("embedded", fixed_base=True, d_s=d_s, d_i=0.08, xi=0.3)
    distances = Distances("embedded", fixed_base=True)
    plant, context = distances.plant, distances.plant_context
    arm = [
        plant.GetJointByName(f"r_{joint}")
        for joint in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_yaw", "wrist_pitch")
    ]
    columns = [joint.velocity_start() for joint in arm]
    speed = 0.4 * np.array([joint.velocity_upper_limits()[0] for joint in arm])
    hand = plant.GetFrameByName(distances.model.info.frames["right_hand"])
    start = half_sitting_configuration(plant, distances.model.info)
    plant.SetPositions(context, start)
    target = plant.GetBodyByName("torso").EvalPoseInWorld(context).translation()
    assert distances.least(start) > d_s  # every pair starts clear of the margin

    def reach(with_task: bool) -> tuple[float, float]:
        """(the least distance of any pair over the motion, the hand's last distance to the target)."""
        q = start.copy()
        least = np.inf
        for _ in range(100):
            plant.SetPositions(context, q)
            p = plant.CalcPointsPositions(context, hand, np.zeros(3), plant.world_frame())[:, 0]
            J = plant.CalcJacobianTranslationalVelocity(
                context, JacobianWrtVariable.kV, hand, np.zeros(3), plant.world_frame(), plant.world_frame()
            )
            levels = [(np.eye(len(arm)), -speed, speed), (J[:, columns], -gain * (p - target))]
            if with_task:
                signal, _ = rows(task, q)
                levels.insert(1, (signal.jacobian[:, columns], signal.lower, signal.upper))
            v = np.zeros(plant.num_velocities())
            v[columns] = solve_hqp(levels).qdot
            q = q + period * plant.MapVelocityToQDot(context, v)
            least = min(least, distances.least(q))
        plant.SetPositions(context, q)
        p = plant.CalcPointsPositions(context, hand, np.zeros(3), plant.world_frame())[:, 0]
        return least, float(np.linalg.norm(p - target))

    free_least, free_left = reach(False)
    assert free_least < -0.03 and free_left < 0.06  # 3 cm through a surface, near the torso's centre
    least, left = reach(True)
    assert least >= d_s - 1e-3, least
    assert left > 0.1, left  # held outside, short of the target


def test_the_task_is_a_level_of_the_hqp_stack():
    """Plugged into ``StackOfTasks(solver="hqp")`` above a task that pulls two shapes together,
    the stack's q̇ keeps every row of the task: ``J_d q̇ >= -ξ (d - d_s) / (d_i - d_s)``."""
    task = SelfCollisionAvoidance("embedded", d_s=0.01, d_i=0.12, xi=0.3, max_pairs=40)
    plant = task.model.plant
    q = plant.GetPositions(plant.CreateDefaultContext())
    signal, _ = rows(task, q)
    bounded = np.flatnonzero(np.isfinite(signal.lower))
    pull = TaskSignal("pull", np.zeros(1), signal.jacobian[bounded[:1]], np.array([-1.0]))  # ḋ = -1 m/s
    sot = StackOfTasks(
        plant.num_velocities(),
        {task.get_name(): task.dimension, "pull": 1},
        stack=(task.get_name(), "pull"),
        solver="hqp",
    )
    context = sot.CreateDefaultContext()
    sot.GetInputPort(task.get_name()).FixValue(context, signal)
    sot.GetInputPort("pull").FixValue(context, pull)
    context.SetDiscreteState(sot.EvalUniquePeriodicDiscreteUpdate(context))
    qdot = sot.GetOutputPort("qdot").Eval(context)
    assert (signal.jacobian[bounded] @ qdot >= signal.lower[bounded] - 1e-9).all()
    assert signal.jacobian[bounded[0]] @ qdot == pytest.approx(
        signal.lower[bounded[0]], abs=1e-9
    )  # held at its bound


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"d_s": float("nan")}, "safety margin d_s = nan m: must be finite and >= 0"),
        ({"d_s": -0.01}, "safety margin d_s = -0.01 m: must be finite and >= 0"),
        ({"d_i": 0.01}, "activation distance d_i = 0.01 m: must be > the safety margin d_s = 0.01 m"),
        ({"d_i": float("nan")}, "activation distance d_i = nan: must be a finite number"),
        ({"xi": -0.2}, "ξ = -0.2 m/s: must be finite and > 0"),
        ({"xi": float("inf")}, "ξ = inf m/s: must be finite and > 0"),
        ({"max_pairs": 0}, "max_pairs = 0: must be an integer >= 1"),
        ({"recovery": float("nan")}, "recovery = nan 1/s: must be finite and > 0"),
        ({"recovery": 0.0}, "recovery = 0.0 1/s: must be finite and > 0"),
    ],
)
def test_bad_parameters_are_refused_naming_the_value(arguments, message):
    with pytest.raises(ValueError, match=f"'arms': {message}"):
        SelfCollisionAvoidance("embedded", name="arms", **arguments)


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("fixed_base", [False, True])
def test_the_collision_model_has_the_control_models_coordinates(name, fixed_base):
    """The task reads the controller's q: its model has the same joints at the same places."""
    robot = robot_or_skip(name)
    control, _ = make_robot_control_model(robot, fixed_base=fixed_base)
    plant = make_collision_model(robot, fixed_base=fixed_base).plant

    def layout(p):
        joints = (p.get_joint(i) for i in p.GetJointIndices())
        return sorted((j.name(), j.position_start(), j.velocity_start(), j.num_positions()) for j in joints)

    assert (plant.num_positions(), plant.num_velocities()) == (
        control.num_positions(),
        control.num_velocities(),
    )
    assert layout(plant) == layout(control)


def test_the_builder_wires_the_task_to_the_reference_configuration():
    """``HumanoidSoTBuilder.add_self_collision_task``: in the built diagram, the task's rows at
    the initial configuration are those of the task alone at ``q0``. (d_i is clear of the pairs'
    distances at half-sitting, 4, 5 and 6 cm: whether Drake's query keeps a pair exactly at its
    ``max_distance`` varies from one model to another, with the order of its broadphase tree.)"""
    b = HumanoidSoTBuilder()
    b.add_self_collision_task("taskSelfCollision", d_s=0.01, d_i=0.055, xi=0.3)
    b.add_posture_task("taskPosture")
    built = b.build(stack=["taskSelfCollision", "taskPosture"], solver="hqp")
    task = built.tasks["taskSelfCollision"]
    wired = task.GetOutputPort("task").Eval(task.GetMyContextFromRoot(built.diagram.CreateDefaultContext()))
    alone, _ = rows(SelfCollisionAvoidance("embedded", d_s=0.01, d_i=0.055, xi=0.3), built.q0)
    assert np.isfinite(alone.lower).sum() >= 2  # the feet's pairs, 4-5 cm apart at half-sitting
    for got, expected in zip(
        (wired.jacobian, wired.lower, wired.error), (alone.jacobian, alone.lower, alone.error), strict=True
    ):
        np.testing.assert_array_equal(got, expected)
