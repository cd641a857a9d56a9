"""Partner forces on a one-body plant; the stack history and its change labels."""

import numpy as np
import pytest
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.systems.partner import ConstantForce, Hold, Partner
from drake_sot.systems.stack_history import StackHistory, stack_changes

MASS = 2.0
RADIUS = 0.05


def _floating_ball(script, points=None):
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    plant.AddRigidBody("ball", SpatialInertia.SolidSphereWithMass(MASS, RADIUS))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    plant.Finalize()
    partner = builder.AddSystem(Partner(plant, script, points=points))
    builder.Connect(plant.get_body_poses_output_port(), partner.GetInputPort("body_poses"))
    builder.Connect(
        plant.get_body_spatial_velocities_output_port(), partner.GetInputPort("body_spatial_velocities")
    )
    builder.Connect(partner.GetOutputPort("spatial_forces"), plant.get_applied_spatial_force_input_port())
    simulator = Simulator(builder.Build())
    return plant, partner, simulator


def _position(plant, simulator):
    context = plant.GetMyContextFromRoot(simulator.get_context())
    return plant.GetBodyByName("ball").EvalPoseInWorld(context).translation()


def test_constant_force_accelerates_the_body_by_f_over_m():
    plant, partner, simulator = _floating_ball({"ball": [ConstantForce(0.1, 0.6, (4.0, 0.0, 0.0))]})
    simulator.AdvanceTo(0.6)
    # 4 N on 2 kg for 0.5 s: x = a t² / 2 = 0.25 m (forces held per 5 ms tick: within 2 %).
    assert _position(plant, simulator)[0] == pytest.approx(0.5 * 2.0 * 0.5**2, rel=0.02)
    simulator.AdvanceTo(1.0)
    np.testing.assert_array_equal(
        partner.GetOutputPort("forces").Eval(partner.GetMyContextFromRoot(simulator.get_context())), 0.0
    )


def test_a_force_off_the_origin_turns_the_body_by_its_moment():
    point, force, duration = np.array([0.0, 0.0, 0.1]), np.array([0.2, 0.0, 0.0]), 0.1
    plant, _, simulator = _floating_ball({"ball": [ConstantForce(0.0, duration, force)]}, {"ball": point})
    simulator.AdvanceTo(duration)
    context = plant.GetMyContextFromRoot(simulator.get_context())
    V = plant.GetBodyByName("ball").EvalSpatialVelocityInWorld(context)
    inertia = 0.4 * MASS * RADIUS**2  # solid sphere
    # Euler: I ω̇ = p × F (the ball turns by 0.05 rad: the moment arm shrinks by < 0.1 %; the
    # force, held per control tick, starts one 1 ms physics step late: -1 %).
    np.testing.assert_allclose(
        V.rotational(), np.cross(point, force) / inertia * duration, rtol=0.02, atol=1e-9
    )
    np.testing.assert_allclose(V.translational(), force / MASS * duration, rtol=0.02, atol=1e-9)


def test_points_must_name_bodies_of_the_script():
    with pytest.raises(ValueError, match=r"points for \['wall'\], which the script does not name"):
        _floating_ball({"ball": [ConstantForce(0.0, 1.0, (1, 0, 0))]}, {"wall": (0, 0, 0)})


def test_hold_pulls_the_body_to_the_moving_grip():
    script = {
        "ball": [Hold(0.0, 5.0, ((0.0, (0, 0, 0)), (1.0, (0.1, -0.05, 0.0))), stiffness=200.0, damping=40.0)]
    }
    plant, partner, simulator = _floating_ball(script)
    simulator.AdvanceTo(4.0)
    np.testing.assert_allclose(_position(plant, simulator), [0.1, -0.05, 0.0], atol=2e-3)


def test_overlapping_segments_are_refused():
    with pytest.raises(ValueError, match="overlap"):
        _floating_ball({"ball": [ConstantForce(0.0, 1.0, (1, 0, 0)), ConstantForce(0.5, 2.0, (1, 0, 0))]})


def test_stack_change_labels():
    history = ((0.0, ("a", "b")), (1.0, ("a", "b", "c")), (2.0, ("b", "a", "c")), (3.0, ("b", "d")))
    assert stack_changes(history) == [(1.0, "+c"), (2.0, "reordered"), (3.0, "+d −a −c")]


@pytest.mark.parametrize(
    "args, message",
    [
        ((np.nan, 1.0, (1, 0, 0)), "ConstantForce.start = nan: must be a finite number"),
        ((0.0, np.inf, (1, 0, 0)), "ConstantForce.end = inf: must be a finite number"),
        ((0.0, 1.0, (1, np.nan, 0)), r"ConstantForce.force = .*contains NaN or Inf \(entry \[1\]\)"),
        ((0.0, 1.0, (1, 0)), r"ConstantForce.force must have shape \(3,\)"),
    ],
)
def test_a_constant_force_refuses_non_finite_values(args, message):
    with pytest.raises(ValueError, match=message):
        ConstantForce(*args)


def test_stack_history_records_each_change_and_checks_its_input():
    history = StackHistory(period=0.01)
    simulator = Simulator(history)
    context = simulator.get_mutable_context()
    port = history.GetInputPort("stack")
    port.FixValue(context, ("a", "b"))
    simulator.AdvanceTo(0.045)  # ticks at 0, 0.01, ..., 0.04: one entry, the stack did not change
    port.FixValue(context, ("b", "a"))
    simulator.AdvanceTo(0.075)  # seen at the tick of 0.05
    recorded = history.history(context)
    assert [stack for _, stack in recorded] == [("a", "b"), ("b", "a")]
    assert [t for t, _ in recorded] == pytest.approx([0.0, 0.05], abs=1e-12)
    assert [label for _, label in stack_changes(recorded)] == ["reordered"]
    port.FixValue(context, ("a", "a"))
    with pytest.raises(
        RuntimeError, match=r"'stack_history': input port 'stack': the stack \('a', 'a'\) lists"
    ):
        simulator.AdvanceTo(0.085)
