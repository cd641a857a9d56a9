"""Bad arguments to the torque-level family (Liu, Lober, Padois 2016) are refused with a
ValueError (or TypeError) naming them: the controller, its task and contact records, the
priority schedule and the statics helpers. NaN, inf and out-of-range values included."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drake_sot.models import half_sitting_configuration, make_control_model, sole_corner_points
from drake_sot.statics import contact_torques, zmp_from_wrenches
from drake_sot.systems.features import FeaturePosture
from drake_sot.systems.generalized_controller import (
    ContactPoints,
    ForceTask,
    GeneralizedHierarchyController,
    MotionTask,
)
from drake_sot.systems.priority_schedule import PrioritySchedule
from drake_sot.systems.task import Task

NAN, INF = math.nan, math.inf


@pytest.fixture(scope="module")
def robot():
    """(plant, info, q0, posture task) of the fixed-base humanoid."""
    plant, info = make_control_model(fixed_base=True)
    q0 = half_sitting_configuration(plant, info)
    task = Task("taskPosture")
    task.add(FeaturePosture(plant, list(info.actuated_joints), name="f_posture", desired=q0))
    return plant, info, q0, task


def _controller(robot, **kwargs):
    plant, info, q0, task = robot
    args = {"motion_tasks": [MotionTask(task, 16.0, 8.0)], "q_posture": q0, **kwargs}
    return GeneralizedHierarchyController(plant, info.actuated_joints, **args)


def test_the_fixture_builds(robot):
    assert _controller(robot).task_names == ("taskPosture",)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"period": NAN}, r"period = nan s: must be finite and > 0"),
        ({"period": INF}, r"period = inf s: must be finite and > 0"),
        ({"period": 0.0}, r"period = 0.0 s: must be finite and > 0"),
        ({"period": -0.005}, r"period = -0.005 s"),
        ({"regularization": NAN}, r"regularization = nan: must be finite and > 0"),
        ({"regularization": 0.0}, r"regularization = 0.0"),
        ({"fallback_gains": (NAN, 10.0)}, r"fallback_gains\[0\] \(kp\) = nan N·m/rad"),
        ({"fallback_gains": (200.0, -1.0)}, r"fallback_gains\[1\] \(kd\) = -1.0 N·m·s/rad"),
        ({"fallback_gains": (200.0,)}, r"fallback_gains = \(200.0,\): must be a pair"),
        ({"effort_limits": NAN}, r"(?s)effort_limits = .*every value must be finite and > 0 \(or \+inf\)"),
        ({"effort_limits": -1.0}, r"(?s)effort_limits = .*entry 0 is not"),
        ({"effort_limits": 0.0}, r"(?s)effort_limits = .*finite and > 0"),
        ({"effort_limits": np.ones(3)}, r"effort_limits must be a scalar or 30 values, got 3"),
        ({"shortfall_threshold": NAN}, r"shortfall_threshold = nan: must be finite and > 0"),
        ({"shortfall_threshold": 0.0}, r"shortfall_threshold = 0.0"),
        ({"wrench_floor": INF}, r"wrench_floor = inf N or N·m"),
        ({"q_posture": np.zeros(3)}, r"q_posture must have shape \(30,\), got shape \(3,\)"),
        ({"q_posture": np.full(30, NAN)}, r"(?s)q_posture = .*contains NaN"),
        ({"weights": {"taskPosture": NAN}}, r"weights\['taskPosture'\] = nan: must be finite and > 0"),
        ({"weights": {"taskPosture": 0.0}}, r"weights\['taskPosture'\] = 0.0"),
        (
            {"weights": {"taskHead": 1.0}},
            r"weights for unknown tasks \['taskHead'\]; tasks: \['taskPosture'\]",
        ),
    ],
)
def test_controller_arguments_are_refused_by_name(robot, kwargs, match):
    with pytest.raises(ValueError, match=match):
        _controller(robot, **kwargs)


def test_controller_refuses_unknown_joints_duplicate_tasks_and_wrong_records(robot):
    plant, info, q0, task = robot
    with pytest.raises(ValueError, match=r"actuated_joints: no joint named \['r_knees'\]"):
        GeneralizedHierarchyController(
            plant,
            ["r_knees", *info.actuated_joints[1:]],
            motion_tasks=[MotionTask(task, 1.0, 1.0)],
            q_posture=q0,
        )
    with pytest.raises(ValueError, match=r"task names must be unique: \['taskPosture', 'taskPosture'\]"):
        _controller(robot, motion_tasks=[MotionTask(task, 1.0, 1.0), MotionTask(task, 2.0, 1.0)])
    with pytest.raises(TypeError, match=r"force_tasks must hold ForceTasks, got \['MotionTask'\]"):
        _controller(robot, force_tasks=[MotionTask(task, 1.0, 1.0)])
    with pytest.raises(ValueError, match=r"motion_tasks and force_tasks are both empty"):
        _controller(robot, motion_tasks=[])
    with pytest.raises(ValueError, match=r"ContactPoints\('nowhere'\): no frame of that name"):
        _controller(robot, contacts=[ContactPoints("nowhere", sole_corner_points())])


@pytest.mark.parametrize("field", ["kp", "kd"])
@pytest.mark.parametrize("value", [NAN, INF, -1.0])
def test_motion_task_gains(robot, field, value):
    task = robot[3]
    gains = {"kp": 1.0, "kd": 1.0, field: value}
    with pytest.raises(ValueError, match=rf"MotionTask\('taskPosture'\).{field} = {value}"):
        MotionTask(task, **gains)


@pytest.mark.parametrize("field", ["kp", "ki"])
@pytest.mark.parametrize("value", [NAN, INF, -1.0])
def test_force_task_gains(robot, field, value):
    task = robot[3]
    gains = {"kp": 1.0, "ki": 1.0, field: value}
    with pytest.raises(ValueError, match=rf"ForceTask\('taskPosture'\).{field} = {value}"):
        ForceTask(task, **gains)


def test_task_records_need_a_task_with_rows():
    with pytest.raises(TypeError, match=r"MotionTask\('\?'\).task must be a drake_sot Task, got str"):
        MotionTask("taskPosture", 1.0, 1.0)
    with pytest.raises(ValueError, match=r"task 'empty' has no feature \(dimension 0\)"):
        ForceTask(Task("empty"), 1.0, 1.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"mu": NAN}, r"ContactPoints\('l_sole'\).mu = nan: must be finite and >= 0"),
        ({"mu": -0.1}, r"ContactPoints\('l_sole'\).mu = -0.1"),
        ({"facets": 2}, r"ContactPoints\('l_sole'\).facets = 2: must be an integer >= 3"),
        ({"facets": 4.5}, r"ContactPoints\('l_sole'\).facets = 4.5"),
        ({"min_normal_force": INF}, r"ContactPoints\('l_sole'\).min_normal_force = inf N"),
        ({"min_normal_force": -1.0}, r"ContactPoints\('l_sole'\).min_normal_force = -1.0 N"),
        (
            {"points": np.zeros((4, 2))},
            r"ContactPoints\('l_sole'\).points must be a matrix of shape \(n, 3\)",
        ),
        (
            {"points": np.full((4, 3), NAN)},
            r"ContactPoints\('l_sole'\).points of shape \(4, 3\) contains NaN",
        ),
        ({"points": np.zeros((0, 3))}, r"ContactPoints\('l_sole'\).points: needs at least one point"),
    ],
)
def test_contact_points(kwargs, match):
    args = {"frame": "l_sole", "points": sole_corner_points(), **kwargs}
    with pytest.raises(ValueError, match=match):
        ContactPoints(**args)


def test_priority_schedule_needs_an_alpha_schedule():
    with pytest.raises(TypeError, match=r"PrioritySchedule needs an AlphaSchedule, got ndarray"):
        PrioritySchedule(np.zeros((2, 2)))


def test_statics_helpers():
    g, J = np.zeros(12), np.zeros((6, 12))
    with pytest.raises(ValueError, match=r"weights = .*finite and >= 0"):
        contact_torques(g, J, 6, np.array([-1.0]))
    with pytest.raises(ValueError, match=r"weights = \[nan\]"):
        contact_torques(g, J, 6, np.array([NAN]))
    with pytest.raises(ValueError, match=r"tau_id = .*contains NaN"):
        contact_torques(np.full(12, NAN), J)
    with pytest.raises(ValueError, match=r"J_contacts must be a matrix of shape \(n, 12\)"):
        contact_torques(g, np.zeros((6, 11)))
    with pytest.raises(ValueError, match=r"J_contacts has 5 rows \(6 per contact\)"):
        contact_torques(g, np.zeros((5, 12)))
    with pytest.raises(ValueError, match=r"min_force = nan N"):
        zmp_from_wrenches(np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), NAN)
