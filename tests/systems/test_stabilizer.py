"""BalanceStabilizer: the measured DCM of the plant state, the measured support polygon, the
corrected CoM reference and the saturation flag, on the controller's model (no physics)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_sot.models import half_sitting_configuration, make_control_model
from drake_sot.models.humanoid import SOLE
from drake_sot.stabilization import StabilizerGains
from drake_sot.systems.stabilizer import BalanceStabilizer


def _tick(foot_forces, base_velocity):
    """One tick (at t = 0) of a stabilizer whose references are the robot at rest in its
    half-sitting posture, the measured robot moving as a whole at ``base_velocity`` [m/s]."""
    plant, info = make_control_model()
    q0 = half_sitting_configuration(plant, info)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q0)
    com = plant.CalcCenterOfMassPositionInWorld(context)
    soles = tuple(info.frames[f"{side}_foot"] for side in ("left", "right"))
    feet = [plant.GetFrameByName(name).CalcPoseInWorld(context).translation() for name in soles]
    stabilizer = BalanceStabilizer(plant, soles, SOLE)
    simulator = Simulator(stabilizer)
    sc = simulator.get_mutable_context()
    v = np.zeros(plant.num_velocities())
    v[3:6] = base_velocity  # a translation of the whole robot: every body, hence the CoM, at this velocity
    for name, value in (
        ("com_ref", com),
        ("com_vel_ref", np.zeros(3)),
        ("zmp_ref", com[:2]),
        ("zmp", com[:2]),
        ("foot_forces", foot_forces),
        ("state", np.concatenate((q0, v))),
    ):
        stabilizer.GetInputPort(name).FixValue(sc, value)
    simulator.AdvanceTo(1e-4)
    out = {
        name: stabilizer.GetOutputPort(name).Eval(sc)
        for name in ("com", "dcm", "zmp_desired", "saturated", "dcm_excess")
    }
    return out, com, feet


def test_at_rest_on_its_reference_the_reference_passes_through():
    out, com, _ = _tick([280.0, 280.0], np.zeros(3))
    np.testing.assert_allclose(out["com"], com, atol=1e-12)
    np.testing.assert_allclose(out["dcm"], com[:2], atol=1e-12)
    np.testing.assert_array_equal(out["saturated"], [0.0, 0.0])
    np.testing.assert_array_equal(out["dcm_excess"], [0.0, 0.0])


def test_a_sideways_velocity_moves_the_dcm_and_the_desired_zmp_to_the_loaded_sole_edge():
    margin = StabilizerGains().margin
    # both feet loaded: the support polygon spans both soles, its left edge on the left sole
    out, com, (left, right) = _tick([280.0, 280.0], [0.0, 0.4, 0.0])
    omega = math.sqrt(9.81 / com[2])  # the pendulum of the reference's height
    np.testing.assert_allclose(out["dcm"], com[:2] + [0.0, 0.4 / omega], atol=1e-9)
    assert out["saturated"][0] == 1.0
    assert out["zmp_desired"][1] == pytest.approx(left[1] + SOLE[1] / 2 - margin, abs=1e-9)
    assert out["zmp_desired"][0] == pytest.approx(com[0], abs=1e-9)
    # only the right foot carries the robot: the desired ZMP stays on the right sole
    out, _, _ = _tick([0.0, 560.0], [0.0, 0.4, 0.0])
    assert out["zmp_desired"][1] == pytest.approx(right[1] + SOLE[1] / 2 - margin, abs=1e-9)


@pytest.mark.parametrize("foot_forces", [[280.0, 280.0], [0.0, 560.0]])
def test_the_dcm_excess_is_measured_from_both_soles_loaded_or_not(foot_forces):
    """ξ past the left sole's outer edge by the velocity over ω; with the robot on its right
    foot alone (rocking), a ξ between the feet is not out."""
    out, com, (left, _) = _tick(foot_forces, [0.0, 0.8, 0.0])
    omega = math.sqrt(9.81 / com[2])
    edge = left[1] + SOLE[1] / 2
    np.testing.assert_allclose(out["dcm_excess"], [0.0, com[1] + 0.8 / omega - edge], atol=1e-9)
    assert out["dcm_excess"][1] > 0.05
    out, _, _ = _tick(foot_forces, [0.0, 0.2, 0.0])  # ξ 5.7 cm left of the middle: inside
    np.testing.assert_array_equal(out["dcm_excess"], [0.0, 0.0])


def test_refuses_bad_arguments_by_name():
    plant, info = make_control_model()
    soles = (info.frames["left_foot"], info.frames["right_foot"])
    with pytest.raises(ValueError, match="contact_force = -1.0 N: must be finite and > 0"):
        BalanceStabilizer(plant, soles, SOLE, contact_force=-1.0)
    with pytest.raises(ValueError, match="gains = 3.0: must be a StabilizerGains"):
        BalanceStabilizer(plant, soles, SOLE, gains=3.0)
    with pytest.raises(ValueError, match="period = nan s"):
        BalanceStabilizer(plant, soles, SOLE, period=float("nan"))
