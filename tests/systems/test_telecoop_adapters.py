"""The slave side's port adapters: what the master sends, split by name; the hands as a vector."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw

from drake_sot.systems.telecoop import MASTER_SIGNALS, MASTER_SIZE, HandPositions, SlaveReferences


def test_the_master_signals_become_wrenches_head_pose_and_gripper_posture(control_model):
    plant, _, q0 = control_model
    refs = SlaveReferences(plant, q0, ("r_gripper", "l_gripper"))
    context = refs.CreateDefaultContext()
    sent = {
        "right_hand_force": [1.0, 2.0, 3.0],
        "left_hand_force": [-4.0, -5.0, -6.0],
        "head": [0.3, -0.2],
        "gripper": [0.45],
    }
    assert {name: size for name, (size, _) in MASTER_SIGNALS.items()} == {k: len(v) for k, v in sent.items()}
    assert MASTER_SIZE == 9
    for name, value in sent.items():
        assert refs.GetInputPort(name).size() == len(value)
        refs.GetInputPort(name).FixValue(context, value)
    np.testing.assert_array_equal(refs.GetOutputPort("wrench_ref_right").Eval(context), [0, 0, 0, 1, 2, 3])
    np.testing.assert_array_equal(refs.GetOutputPort("wrench_ref_left").Eval(context), [0, 0, 0, -4, -5, -6])
    rpy = RollPitchYaw(refs.GetOutputPort("head_pose").Eval(context).rotation())
    assert (rpy.roll_angle(), rpy.pitch_angle(), rpy.yaw_angle()) == pytest.approx((0.0, -0.2, 0.3))
    posture = refs.GetOutputPort("posture").Eval(context)
    for joint in ("r_gripper", "l_gripper"):
        assert posture[plant.GetJointByName(joint).position_start()] == 0.45
    others = np.ones(q0.size, dtype=bool)
    others[[plant.GetJointByName(j).position_start() for j in ("r_gripper", "l_gripper")]] = False
    np.testing.assert_array_equal(posture[others], q0[others])


def test_hand_positions_are_right_then_left():
    system = HandPositions()
    context = system.CreateDefaultContext()
    system.GetInputPort("right_hand").FixValue(context, RigidTransform([1.0, -2.0, 3.0]))
    system.GetInputPort("left_hand").FixValue(context, RigidTransform([4.0, 5.0, 6.0]))
    np.testing.assert_array_equal(system.GetOutputPort("positions").Eval(context), [1, -2, 3, 4, 5, 6])
    np.testing.assert_array_equal(system.GetOutputPort("right").Eval(context), [1, -2, 3])
    np.testing.assert_array_equal(system.GetOutputPort("left").Eval(context), [4, 5, 6])
