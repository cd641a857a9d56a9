"""Bounds of a feature's desired value, checked where it enters (constructor, ``set_desired``, the
desired-value port) with the value named: a position within 10 m of its frame's origin, a posture
within the joint limits widened by half a turn. A finite but absurd target (1e300 m, 1e3 m) would
otherwise reach Drake as a q̇ of that size."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix

from drake_sot.models import make_control_model
from drake_sot.signals import OperationalPoint
from drake_sot.systems.features import FeatureCoM, FeaturePoint6d, FeaturePoint6dRelative, FeaturePosture


def test_a_pose_target_beyond_10_m_is_refused_at_construction_and_at_set_desired_naming_it():
    far = RigidTransform(RotationMatrix(), [1000.0, 0.0, 1.0])
    with pytest.raises(
        ValueError, match=r"'h': desired position = \[1000, 0, 1\] m: 1000 m from the world origin"
    ):
        FeaturePoint6d(name="h", desired=far)
    feature = FeaturePoint6d(name="h")
    context = feature.CreateDefaultContext()
    near = RigidTransform(RotationMatrix(), [6.0, 8.0, 0.0])  # 10 m exactly (6-8-10): accepted
    feature.set_desired(context, near)
    lifted = RigidTransform(RotationMatrix(), [0.0, 0.0, 1e300])
    with pytest.raises(ValueError, match=r"1e\+300 m from the world origin; must be within 10 m of it"):
        feature.set_desired(context, lifted)
    assert feature.desired(context).IsExactlyEqualTo(near)  # the refused target changed nothing


def test_a_relative_pose_is_bounded_around_its_reference_frame():
    with pytest.raises(ValueError, match=r"'feet': .* 11 m from the origin of the reference frame"):
        FeaturePoint6dRelative(name="feet", desired=RigidTransform([0.0, 11.0, 0.0]))


def test_a_com_target_is_bounded_and_a_huge_one_does_not_overflow_past_the_check():
    feature = FeatureCoM(name="com")
    context = feature.CreateDefaultContext()
    for bad in ([1e300, 0.0, 0.64], [1e200, 1e200, 0.0]):  # the squares overflow: still refused
        with pytest.raises(ValueError, match="'com': desired CoM = .* must be within 10 m"):
            feature.set_desired(context, bad)
    feature.set_desired(context, [0.1, 0.0, 0.8])


def test_a_desired_value_from_the_port_is_checked_when_it_changes_naming_feature_port_and_time():
    feature = FeaturePoint6d(name="h")
    context = feature.CreateDefaultContext()
    context.SetTime(0.25)
    feature.GetInputPort("frame").FixValue(context, _frame_at_origin())
    feature.GetInputPort("position_des").FixValue(context, RigidTransform([0.0, 0.0, 1e3]))
    with pytest.raises(
        RuntimeError, match=r"'h': .* 1000 m .*\(on input port 'position_des' at t = 0.2500 s\)"
    ):
        feature.GetOutputPort("feature").Eval(context)
    feature.GetInputPort("position_des").FixValue(context, RigidTransform([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(feature.GetOutputPort("feature").Eval(context).error[:3], [0.0, 0.0, -1.0])


def _frame_at_origin() -> OperationalPoint:
    """A frame at the world origin, its Jacobian of one (zero) column."""
    return OperationalPoint(np.eye(3), np.zeros(3), np.zeros((6, 1)))


def test_a_posture_target_is_bounded_by_the_joint_limits_widened_by_half_a_turn():
    plant, info = make_control_model()
    joint = plant.GetJointByName("r_hip_yaw")
    lower, upper = joint.position_lower_limits()[0], joint.position_upper_limits()[0]
    assert np.isfinite([lower, upper]).all()
    feature = FeaturePosture(plant, ["r_hip_yaw"], name="posture")
    context = feature.CreateDefaultContext()
    q = plant.GetPositions(plant.CreateDefaultContext())
    index = joint.position_start()
    q[index] = upper + 0.9 * math.pi  # outside the range, within half a turn: a pull a limit task holds
    feature.set_desired(context, q)
    q[index] = upper + 1.1 * math.pi
    with pytest.raises(
        ValueError, match=r"'posture': desired configuration: joint 'r_hip_yaw' = .*: must be in"
    ):
        feature.set_desired(context, q)
    q[index] = -1e300
    with pytest.raises(ValueError, match=rf"must be in \[{lower - math.pi:g}, {upper + math.pi:g}\]"):
        feature.set_desired(context, q)
