"""MasterSite and Operator: eq. 8 against the analytic second-order response, eq. 9, the base."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.master import BaseLimits, base_placement
from drake_sot.systems.master import MasterSite, Operator

DT = 0.005
HANDS = np.array([0.35, -0.2, 0.9, 0.35, 0.2, 0.9])  # right, left [m]


def _step_response(m, b, k, f, t):
    """x(t) of m ẍ + b ẋ + k x = f from rest, underdamped (the textbook solution)."""
    wn = math.sqrt(k / m)
    zeta = b / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    return (
        f
        / k
        * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)))
    )


def test_eq8_the_offset_is_the_analytic_step_response_of_the_admittance():
    m, b, k, f = 2.0, 8.0, 200.0, 10.0
    master = MasterSite(HANDS, mass=m, damping=b, stiffness=k, period=DT)
    simulator = Simulator(master)
    context = simulator.get_mutable_context()
    master.GetInputPort("slave_hands").FixValue(context, HANDS)
    master.GetInputPort("handle_forces").FixValue(context, [f, 0, 0, 0, 0, -2 * f])
    times = np.arange(1, 301) * DT
    offsets = []
    for t in times:
        simulator.AdvanceTo(t)
        offsets.append(master.GetOutputPort("offsets").Eval(context).copy())
    offsets = np.array(offsets)
    np.testing.assert_allclose(offsets[:, 0], _step_response(m, b, k, f, times), atol=1e-9)
    np.testing.assert_allclose(offsets[:, 5], _step_response(m, b, k, -2 * f, times), atol=1e-9)
    np.testing.assert_allclose(offsets[:, [1, 2, 3, 4]], 0.0, atol=1e-12)


def test_eq9_desired_is_offset_plus_slave_minus_platform_displacement_and_the_base_follows():
    limits = BaseLimits(speed=0.3, acceleration=0.4)
    master = MasterSite(HANDS, base_limits=limits, period=DT)
    simulator = Simulator(master)
    context = simulator.get_mutable_context()
    start = master.GetOutputPort("base").Eval(context).copy()
    np.testing.assert_allclose(
        start, base_placement(HANDS[3:], HANDS[:3], shoulder_half_width=0.25, r_opt=0.45)
    )
    moved = HANDS + np.tile([1.0, 0.0, 0.0], 2)  # the slave's hands 1 m further
    master.GetInputPort("slave_hands").FixValue(context, moved)
    master.GetInputPort("handle_forces").FixValue(context, np.zeros(6))
    previous, speeds = start, []
    for t in np.arange(1, 1601) * DT:
        simulator.AdvanceTo(t)
        base = master.GetOutputPort("base").Eval(context).copy()
        speeds.append(np.linalg.norm(base[:2] - previous[:2]) / DT)
        previous = base
        x_b = np.r_[base[:2] - start[:2], 0.0]
        desired = master.GetOutputPort("desired").Eval(context)
        np.testing.assert_allclose(
            desired, master.GetOutputPort("offsets").Eval(context) + moved - np.tile(x_b, 2)
        )
    assert max(speeds) <= limits.speed + 1e-9
    np.testing.assert_allclose(previous, start + [1.0, 0.0, 0.0], atol=2e-3)
    # The handles stay where the slave's hands are (no force, no offset): x_B + x_d = x_S.
    np.testing.assert_allclose(master.GetOutputPort("hands").Eval(context), moved, atol=1e-12)


def test_the_operator_pulls_the_handle_to_the_intention_through_the_admittance():
    """Slave held still: the loop is m ẍ + (b + b_h) ẋ + (k + k_h) x = k_h (x_i - x_S) (the
    operator's force sampled one period late: within 3 % of the step)."""
    m, b, k, k_h, b_h, step = 2.0, 4.0, 100.0, 100.0, 4.0, 0.1
    intention = HANDS + np.r_[step, 0, 0, 0, 0, 0]
    builder = DiagramBuilder()
    master = builder.AddSystem(MasterSite(HANDS, mass=m, damping=b, stiffness=k, period=DT))
    operator = builder.AddSystem(
        Operator(
            lambda t: (intention, np.zeros(6)),
            lambda t: (np.zeros(3), np.zeros(3)),
            stiffness=k_h,
            damping=b_h,
        )
    )
    builder.Connect(master.GetOutputPort("hands"), operator.GetInputPort("hands"))
    builder.Connect(master.GetOutputPort("hand_velocities"), operator.GetInputPort("hand_velocities"))
    builder.Connect(operator.GetOutputPort("forces"), master.GetInputPort("handle_forces"))
    builder.ExportInput(master.GetInputPort("slave_hands"), "slave")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    diagram.GetInputPort("slave").FixValue(root, HANDS)
    context = master.GetMyContextFromRoot(root)
    times = np.arange(1, 401) * DT
    x = []
    for t in times:
        simulator.AdvanceTo(t)
        x.append(master.GetOutputPort("offsets").Eval(context)[0])
    expected = _step_response(m, b + b_h, k + k_h, k_h * step, times - DT)
    np.testing.assert_allclose(x, expected, atol=0.03 * step)
    assert x[-1] == pytest.approx(k_h * step / (k + k_h), abs=1e-3)


def test_bad_arguments_are_refused_by_name():
    with pytest.raises(ValueError, match="mass"):
        MasterSite(HANDS, mass=0.0)
    with pytest.raises(ValueError, match="slave_hands"):
        MasterSite(HANDS[:3])
    with pytest.raises(ValueError, match="stiffness"):
        Operator(lambda t: (HANDS, np.zeros(6)), lambda t: (np.zeros(3), np.zeros(3)), stiffness=float("nan"))
