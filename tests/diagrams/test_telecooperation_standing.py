"""The ``telecooperation`` scenario standing, in physics (Evrard et al. 2009): the leader lifts the
board by 5 cm and sets it back, at 0, 140 and 300 ms one way with the operator leading, and at
140 ms with the co-operator leading. Each run is simulated once per module."""

import numpy as np
import pytest
from telecoop_runs import STANDING, check_standing, run_standing

from drake_sot.diagrams import telecooperation as tc

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module", params=[0.0, 0.14, 0.3], ids=lambda d: f"{1000 * d:.0f}ms")
def standing(request, tmp_path_factory):
    return run_standing(tmp_path_factory, "operator", request.param, STANDING)


@pytest.fixture(scope="module")
def standing_cooperator(tmp_path_factory):
    return run_standing(tmp_path_factory, "cooperator", 0.14, 8.0)


def test_standing_the_robot_stays_up_holds_the_board_and_its_hands_follow_the_operators(standing):
    check_standing(standing)


def test_standing_with_the_cooperator_leading(standing_cooperator):
    check_standing(standing_cooperator)


def test_the_coupling_stays_bounded_and_does_not_oscillate_across_delay(standing):
    """At 0, 140 and 300 ms one way: the energy the operator puts into the coupling stays bounded
    (each lift puts in and takes back about f · 5 cm) and the hands' motion dies out after the
    lift instead of growing."""
    a = standing.arrays
    t = a["time"]
    dt = np.diff(t, prepend=t[0])
    power = np.sum(a["operator_forces"] * np.gradient(a["operator_hands"], t, axis=0), axis=1)
    energy = np.cumsum(power * dt)
    assert np.abs(energy).max() < 2.0  # [J]
    speed = np.linalg.norm(np.gradient(a["robot_hands"], t, axis=0), axis=1)
    late, settling = speed[t > 15.0], speed[(t > 5.0) & (t < 10.0)]
    assert late.max() <= max(settling.max(), 0.005)
    assert late.max() < 0.01  # [m/s]


def test_gripper_and_head_follow_their_references(standing):
    a = standing.arrays
    delay = standing.setup.extras.delay
    t = a["time"]
    plant, instance = standing.setup.built.plant, standing.setup.built.info.model_instance
    received = np.column_stack([np.interp(t - delay, t, a["head_grip_ref"][:, j]) for j in range(3)])
    settled = t > 2.5
    for joint in tc.GRIPPERS:
        q = np.zeros(plant.num_positions())
        q[plant.GetJointByName(joint, instance).position_start()] = 1.0
        index = int(np.argmax(plant.GetPositionsFromArray(instance, q)))
        assert np.abs(a["q"][settled, index] - received[settled, 2]).max() < 0.05
    context = plant.CreateDefaultContext()
    head = plant.GetFrameByName(standing.setup.built.info.frames["head"], instance)
    errors = []
    for k in np.flatnonzero(settled)[::20]:
        plant.SetPositions(context, instance, a["q"][k])
        R = head.CalcPoseInWorld(context).rotation().matrix()
        errors.append([np.arcsin(-R[2, 0]) - received[k, 1], np.arctan2(R[1, 0], R[0, 0]) - received[k, 0]])
    assert np.abs(errors).max() < 0.05  # [rad] pitch and yaw
