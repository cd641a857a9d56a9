"""HipStrategy alone (no physics): it waits while the DCM is inside, leans the trunk's
reference towards the side the DCM left by, reports it (output and log), gives the
reference's angular velocity, and comes back upright to wait again."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator
from scipy.spatial.transform import Rotation

from drake_sot.recovery import LeanProfile
from drake_sot.systems.hip_strategy import HipStrategy

PROFILE = LeanProfile(angle=0.3, rise=0.2, hold=0.3, back=0.5, threshold=0.005)
INITIAL = RigidTransform(RollPitchYaw(0.0, 0.0, 0.4), [0.0, 0.0, 0.65])


def _hip(excess):
    hip = HipStrategy(INITIAL, profile=PROFILE, period=0.005)
    simulator = Simulator(hip)
    context = simulator.get_mutable_context()
    hip.GetInputPort("dcm_excess").FixValue(context, np.asarray(excess, dtype=float))
    return hip, simulator, context


def _outputs(hip, context):
    return (
        hip.GetOutputPort("waist").Eval(context),
        hip.GetOutputPort("waist_vel").Eval(context),
        hip.GetOutputPort("lean").Eval(context),
    )


def test_inside_or_within_the_threshold_it_holds_the_initial_pose(caplog):
    hip, simulator, context = _hip([0.0, 0.004])
    with caplog.at_level(logging.INFO):
        simulator.AdvanceTo(0.5)
    pose, velocity, lean = _outputs(hip, context)
    assert pose.IsExactlyEqualTo(INITIAL)
    np.testing.assert_array_equal(velocity, np.zeros(6))
    np.testing.assert_array_equal(lean, np.zeros(3))
    assert not caplog.records


def test_past_the_threshold_it_leans_the_top_that_way_and_says_so(caplog):
    hip, simulator, context = _hip([0.0, 0.02])  # the DCM left by the left (+y) edge
    with caplog.at_level(logging.INFO):
        simulator.AdvanceTo(0.2 + 1e-4)  # fired at the tick at t = 0: the lean has risen
    assert len(caplog.records) == 1 and "left the support polygon by 0.020 m" in caplog.records[0].message
    pose, velocity, lean = _outputs(hip, context)
    np.testing.assert_allclose(lean, [0.3, 0.0, 1.0], atol=1e-9)
    # The trunk's vertical axis tilted by 0.3 rad towards +y, its yaw kept.
    R = pose.rotation().matrix()
    np.testing.assert_allclose(R[:, 2], [0.0, math.sin(0.3), math.cos(0.3)], atol=1e-12)
    R0 = INITIAL.rotation().matrix()
    np.testing.assert_allclose(R @ R0.T, Rotation.from_rotvec([-0.3, 0.0, 0.0]).as_matrix(), atol=1e-12)
    np.testing.assert_array_equal(pose.translation(), INITIAL.translation())
    np.testing.assert_allclose(velocity, np.zeros(6), atol=1e-9)  # held: no rate


def test_the_velocity_reference_is_the_rate_of_the_pose_reference():
    """At a tick mid-rise, against the central difference of the poses held one tick before
    and one tick after (each output holds its tick's value)."""
    hip, simulator, context = _hip([0.01, -0.01])
    period = 0.005
    poses, velocities = [], []
    for k in (15, 16, 17):  # ticks at 0.075, 0.08, 0.085 s: the lean fired at the tick at 0
        simulator.AdvanceTo(k * period + 1e-4)
        poses.append(hip.GetOutputPort("waist").Eval(context).rotation().matrix())
        velocities.append(hip.GetOutputPort("waist_vel").Eval(context).copy())
    rate = Rotation.from_matrix(poses[2] @ poses[0].T).as_rotvec() / (2 * period)
    np.testing.assert_allclose(velocities[1][3:], rate, rtol=2e-3, atol=1e-9)
    np.testing.assert_array_equal(velocities[1][:3], 0.0)
    assert np.linalg.norm(rate) > 1.0  # mid-rise: the lean is moving


def test_it_comes_back_upright_and_waits_again(caplog):
    hip, simulator, context = _hip([0.0, 0.02])
    simulator.AdvanceTo(PROFILE.duration - 0.01)
    assert 0.0 < hip.GetOutputPort("lean").Eval(context)[0] < 0.01
    hip.GetInputPort("dcm_excess").FixValue(context, np.zeros(2))
    simulator.AdvanceTo(PROFILE.duration + 0.1)
    pose, velocity, lean = _outputs(hip, context)
    assert pose.IsExactlyEqualTo(INITIAL) and lean[0] == 0.0
    with caplog.at_level(logging.INFO):
        hip.GetInputPort("dcm_excess").FixValue(context, np.array([0.0, -0.03]))
        simulator.AdvanceTo(PROFILE.duration + 0.2)
    assert len(caplog.records) == 1  # armed again: a second lean, the other way
    np.testing.assert_allclose(hip.GetOutputPort("lean").Eval(context)[1:], [0.0, -1.0])


def test_refuses_bad_arguments_by_name():
    with pytest.raises(ValueError, match="profile = 0.3: must be a LeanProfile"):
        HipStrategy(INITIAL, profile=0.3)
    with pytest.raises(ValueError, match="initial = None"):
        HipStrategy(None)
    with pytest.raises(ValueError, match="period = 0.0 s"):
        HipStrategy(INITIAL, period=0.0)
