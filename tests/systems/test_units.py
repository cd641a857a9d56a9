"""The units of a task's error components, from its features' kinds and both selections: what
splits a study's largest final errors into metres and radians."""

import pytest
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import PrismaticJoint, RevoluteJoint, SpatialInertia

from drake_sot.systems.features import FeatureCoM, FeatureGeneric, FeaturePoint6d, FeaturePosture
from drake_sot.systems.inequalities import CoMInSupportPolygon, JointPositionLimits, JointVelocityLimits
from drake_sot.systems.task import Task


@pytest.fixture(scope="module")
def hinge_and_slider() -> MultibodyPlant:
    """A plant with a revolute joint ``hinge`` and a prismatic joint ``slider``, both limited."""
    plant = MultibodyPlant(0.0)
    inertia = SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1)
    arm, carriage = plant.AddRigidBody("arm", inertia), plant.AddRigidBody("carriage", inertia)
    hinge = plant.AddJoint(
        RevoluteJoint("hinge", plant.world_frame(), arm.body_frame(), [0.0, 0.0, 1.0], -1.0, 1.0)
    )
    slider = plant.AddJoint(
        PrismaticJoint("slider", arm.body_frame(), carriage.body_frame(), [1.0, 0.0, 0.0], -0.5, 0.5)
    )
    for joint in (hinge, slider):
        joint.set_velocity_limits([-2.0], [2.0])
    plant.Finalize()
    return plant


def test_a_6d_feature_is_metres_then_radians_through_its_selection_and_its_tasks():
    feature = FeaturePoint6d(selection="110011", name="hand")
    assert feature.units == ("m", "m", "rad", "rad")
    task = Task("taskHand")
    task.add(feature, selection="1001")  # x and the last rotation component
    assert task.units == ("m", "rad")
    com = FeatureCoM(selection="110", name="com")
    both = Task("taskBoth")
    both.add(com)
    both.add(feature)
    assert both.units == ("m", "m", "m", "m", "rad", "rad")


def test_a_generic_feature_has_no_unit():
    assert FeatureGeneric(2, name="signal").units == ("", "")


def test_joints_are_radians_on_a_revolute_joint_and_metres_on_a_prismatic_one(hinge_and_slider):
    plant = hinge_and_slider
    assert FeaturePosture(plant, ["slider", "hinge"], name="posture").units == ("m", "rad")
    assert FeaturePosture(plant, ["slider", "hinge"], selection="01", name="p2").units == ("rad",)
    assert JointPositionLimits(plant, period=0.005, joints=["hinge", "slider"]).units == ("rad", "m")
    assert JointVelocityLimits(plant, joints=["slider", "hinge"]).units == ("m/s", "rad/s")


def test_a_support_polygon_task_is_in_metres():
    assert CoMInSupportPolygon(max_vertices=6).units == ("m",) * 6
