"""``StanceAnchor`` alone, its inputs fixed: at lift-off it measures the drift on the stance
sole and maps the swing footprint so that, seen from the robot's stance sole, the reference's
target is the planned footprint (checked with 4×4 homogeneous matrices)."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.systems.stance_anchor import StanceAnchor

PERIOD = 0.005


def _pose(x, y, yaw, z=0.0):
    return RigidTransform(RotationMatrix.MakeZRotation(yaw), [x, y, z])


@pytest.fixture
def rig():
    """Two free foot bodies whose sole frames sit 7 cm under them and 2 cm forward."""
    plant = MultibodyPlant(time_step=1e-3)
    X_BF = RigidTransform(RollPitchYaw(0.0, 0.0, 0.3), [0.02, 0.0, -0.07])
    bodies = {}
    for side in ("left", "right"):
        bodies[side] = plant.AddRigidBody(
            f"{side}_foot_body", SpatialInertia.SolidBoxWithMass(1, 0.2, 0.1, 0.05)
        )
        plant.AddFrame(FixedOffsetFrame(f"{side}_sole", bodies[side].body_frame(), X_BF))
    plant.Finalize()
    builder = DiagramBuilder()
    anchor = builder.AddSystem(
        StanceAnchor(
            plant,
            bodies["left"].model_instance(),
            {"left": "left_sole", "right": "right_sole"},
            period=PERIOD,
        )
    )
    simulator = Simulator(builder.Build())
    context = anchor.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    return plant, anchor, simulator, context, bodies, X_BF


def test_the_swing_target_is_the_footprint_seen_from_the_measured_stance_sole(rig):
    plant, anchor, simulator, context, bodies, X_BF = rig
    planned = {"left": _pose(0.0, 0.1, 0.0), "right": _pose(0.2, -0.1, 0.2)}  # right: the next footprint
    measured_left = _pose(0.013, 0.095, 0.02)  # where the robot's left sole stands
    reference_left = _pose(-0.004, 0.101, -0.01)  # where the reference's left sole stands
    poses = [RigidTransform() for _ in range(plant.num_bodies())]
    poses[int(bodies["left"].index())] = measured_left @ X_BF.inverse()
    poses[int(bodies["right"].index())] = _pose(5.0, 5.0, 1.0)  # in the air: never read
    anchor.GetInputPort("body_poses").FixValue(context, poses)
    anchor.GetInputPort("left_foot_reference").FixValue(context, reference_left)
    anchor.GetInputPort("right_foot_reference").FixValue(context, _pose(9.0, 9.0, 0.0))
    for side in ("left", "right"):
        anchor.GetInputPort(f"{side}_foot").FixValue(context, planned[side])
        anchor.GetInputPort(f"{side}_foot_vel").FixValue(context, np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.5]))
    com = np.array([0.1, 0.0, 0.8])
    anchor.GetInputPort("com").FixValue(context, com)
    anchor.GetInputPort("com_vel").FixValue(context, np.array([0.3, 0.0, 0.0]))
    anchor.GetInputPort("waist").FixValue(context, _pose(0.1, 0.0, 0.1, z=0.8))
    phase = anchor.GetInputPort("phase")
    phase.FixValue(context, [0.0])
    simulator.AdvanceTo(0.02)
    # Before any lift-off every reference passes through unchanged.
    out = anchor.GetOutputPort("right_foot").Eval(context)
    np.testing.assert_allclose(out.GetAsMatrix4(), planned["right"].GetAsMatrix4(), atol=1e-12)
    phase.FixValue(context, [1.0])  # left support: the right foot swings
    simulator.AdvanceTo(0.5)  # past the 0.2 s blend
    M = measured_left.GetAsMatrix4()
    H = reference_left.GetAsMatrix4() @ np.linalg.inv(M)  # Δ, in homogeneous matrices
    target = anchor.GetOutputPort("right_foot").Eval(context).GetAsMatrix4()
    # From the robot's stance sole, the reference's swing target is the footprint.
    seen = M @ np.linalg.inv(reference_left.GetAsMatrix4()) @ target
    np.testing.assert_allclose(seen, planned["right"].GetAsMatrix4(), atol=1e-12)
    np.testing.assert_allclose(
        anchor.GetOutputPort("drift").Eval(context),
        [H[0, 3], H[1, 3], math.atan2(H[1, 0], H[0, 0])],
        atol=1e-12,
    )
    # The stance foot keeps its reference; the CoM goes through Δ (height kept), velocities turn.
    left = anchor.GetOutputPort("left_foot").Eval(context).GetAsMatrix4()
    np.testing.assert_allclose(left, planned["left"].GetAsMatrix4(), atol=1e-12)
    np.testing.assert_allclose(anchor.GetOutputPort("com").Eval(context), (H @ [*com, 1.0])[:3], atol=1e-12)
    vel = anchor.GetOutputPort("right_foot_vel").Eval(context)
    np.testing.assert_allclose(vel[:3], H[:3, :3] @ [1.0, 0.0, 0.0], atol=1e-12)
    assert vel[5] == 0.5


@pytest.mark.parametrize("blend_time", [0.3, float("nan"), 0.0])
def test_refuses_a_blend_that_would_not_end_before_touch_down(rig, blend_time):
    """Longer than the shortest single support (0.2 s), NaN or zero."""
    plant, _, _, _, bodies, _ = rig
    with pytest.raises(ValueError, match="blend_time"):
        StanceAnchor(
            plant,
            bodies["left"].model_instance(),
            {"left": "left_sole", "right": "right_sole"},
            period=PERIOD,
            blend_time=blend_time,
        )
