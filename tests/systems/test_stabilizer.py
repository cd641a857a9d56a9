"""BalanceStabilizer: the measured DCM of the plant state, the measured support polygon, the
corrected CoM reference and the saturation flag, on the controller's model (no physics)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_sot.models import half_sitting_configuration, make_control_model
from drake_sot.models.humanoid import SOLE
from drake_sot.stabilization import GRAVITY, StabilizerGains
from drake_sot.systems.stabilizer import BalanceStabilizer

HANDS = ("left", "right")


def _stabilizer(foot_forces, base_velocity, *, zmp=None, hands=False, hand_wrenches=None):
    """A stabilizer whose references are the robot at rest in its half-sitting posture, the
    measured robot moving as a whole at ``base_velocity`` [m/s], its measured ZMP ``zmp`` (None:
    under the CoM); ``hands``: the stabilizer has the ``hand_wrenches`` port, fixed to
    ``hand_wrenches`` unless None. Returns it, its simulator, the CoM and the soles' positions."""
    plant, info = make_control_model()
    q0 = half_sitting_configuration(plant, info)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q0)
    com = plant.CalcCenterOfMassPositionInWorld(context)
    soles = tuple(info.frames[f"{side}_foot"] for side in ("left", "right"))
    feet = [plant.GetFrameByName(name).CalcPoseInWorld(context).translation() for name in soles]
    hand_frames = tuple(info.frames[f"{side}_hand"] for side in HANDS) if hands else None
    stabilizer = BalanceStabilizer(plant, soles, SOLE, hands=hand_frames)
    simulator = Simulator(stabilizer)
    sc = simulator.get_mutable_context()
    v = np.zeros(plant.num_velocities())
    v[3:6] = base_velocity  # a translation of the whole robot: every body, hence the CoM, at this velocity
    for name, value in (
        ("com_ref", com),
        ("com_vel_ref", np.zeros(3)),
        ("zmp_ref", com[:2]),
        ("zmp", com[:2] if zmp is None else zmp),
        ("foot_forces", foot_forces),
        ("state", np.concatenate((q0, v))),
    ):
        stabilizer.GetInputPort(name).FixValue(sc, value)
    if hand_wrenches is not None:
        stabilizer.GetInputPort("hand_wrenches").FixValue(sc, hand_wrenches)
    return stabilizer, simulator, com, feet


def _tick(foot_forces, base_velocity, *, duration=1e-4, **kw):
    """The outputs of :func:`_stabilizer` (same arguments) after ``duration`` [s] of ticks from t = 0."""
    stabilizer, simulator, com, feet = _stabilizer(foot_forces, base_velocity, **kw)
    simulator.AdvanceTo(duration)
    sc = simulator.get_context()
    out = {
        name: stabilizer.GetOutputPort(name).Eval(sc)
        for name in ("com", "com_vel", "offset", "dcm", "zmp_desired", "saturated", "dcm_excess")
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


# --- the hands' external wrenches (the inverted pendulum with external forces) ----------------
#: [τ; f] on the left, then the right hand: a forward pull of 14 N, a board's weight, torques.
PULL = np.array([-0.3, 0.5, 0.0, 7.5, -0.5, -4.0, 0.4, -0.8, 0.1, 7.0, 1.5, -6.0])


def _cop_of_the_statics(wrenches):
    """(2,) the centre of pressure of the robot at rest in half-sitting with ``wrenches`` (12,) at
    its hand frames: Newton-Euler of the whole robot (each body's weight at its CoM) about the
    world origin gives the ground's wrench, whose moment is vertical at the CoP."""
    plant, info = make_control_model()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    force, moment = np.zeros(3), np.zeros(3)
    for index in plant.GetBodyIndices(info.model_instance):
        body = plant.get_body(index)
        X = body.EvalPoseInWorld(context)
        weight = np.array([0.0, 0.0, -GRAVITY * body.default_mass()])
        force += weight
        moment += np.cross(X @ body.default_com(), weight)
    for side, wrench in zip(HANDS, wrenches.reshape(2, 6), strict=True):
        h = plant.GetFrameByName(info.frames[f"{side}_hand"]).CalcPoseInWorld(context).translation()
        force += wrench[3:]
        moment += np.cross(h, wrench[3:]) + wrench[:3]
    ground_force, ground_moment = -force, -moment
    return np.array([-ground_moment[1], ground_moment[0]]) / ground_force[2]


def test_with_the_hands_port_unconnected_or_not_finite_nothing_changes():
    """The stabilizer with the ``hand_wrenches`` port, unconnected or fed NaN (a faulty sensor):
    the same outputs as without the port, over 0.5 s of a sideways push's velocity."""
    without, _, _ = _tick([280.0, 280.0], [0.0, 0.3, 0.0], duration=0.5)
    for wrenches in (None, np.full(12, np.nan)):
        out, _, _ = _tick([280.0, 280.0], [0.0, 0.3, 0.0], duration=0.5, hands=True, hand_wrenches=wrenches)
        for name, value in without.items():
            np.testing.assert_array_equal(out[name], value, err_msg=name)


def test_the_zmp_the_hands_wrenches_cause_is_expected_and_does_not_move_the_offset():
    """The robot at rest on its reference, its measured ZMP where the hands' pull puts it (the
    statics of the whole robot, computed here): with the wrenches the desired ZMP is that ZMP and
    the offset stays at zero over 1 s; without them the offset drives the CoM forward, towards
    the pull."""
    cop = _cop_of_the_statics(PULL)
    out, com, _ = _tick([280.0, 280.0], np.zeros(3), duration=1.0, zmp=cop, hands=True, hand_wrenches=PULL)
    assert cop[0] - com[0] > 0.01  # the pull (at the hands of half-sitting, low) moved the ZMP forward
    np.testing.assert_allclose(out["zmp_desired"], cop, atol=1e-9)
    np.testing.assert_allclose(out["offset"], 0.0, atol=1e-9)
    np.testing.assert_allclose(out["com"], com, atol=1e-9)
    blind, _, _ = _tick([280.0, 280.0], np.zeros(3), duration=1.0, zmp=cop, hands=True)
    assert blind["offset"][0] > 0.005


def test_a_wrench_that_starts_reaches_the_desired_zmp_through_the_wrench_filter():
    """Zero wrenches, then from 0.5 s the pull: a time constant later the desired ZMP is the
    statics' CoP under (1 − e⁻¹) of the pull (a first-order filter), and the pull's whole shift
    once it settled."""
    tau = StabilizerGains().wrench_filter
    stabilizer, simulator, com, _ = _stabilizer(
        [280.0, 280.0], np.zeros(3), hands=True, hand_wrenches=np.zeros(12)
    )
    sc = simulator.get_mutable_context()
    simulator.AdvanceTo(0.5 - 1e-4)
    np.testing.assert_allclose(stabilizer.GetOutputPort("zmp_desired").Eval(sc), com[:2], atol=1e-12)
    stabilizer.GetInputPort("hand_wrenches").FixValue(sc, PULL)
    simulator.AdvanceTo(0.5 + tau - 1e-4)
    share = 1.0 - math.exp(-1.0)
    desired = stabilizer.GetOutputPort("zmp_desired").Eval(sc)
    np.testing.assert_allclose(desired, _cop_of_the_statics(share * PULL), atol=2e-4)
    simulator.AdvanceTo(0.5 + 10 * tau)
    np.testing.assert_allclose(
        stabilizer.GetOutputPort("zmp_desired").Eval(sc), _cop_of_the_statics(PULL), atol=1e-5
    )
