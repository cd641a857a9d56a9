"""``FallMonitor`` on a one-body plant: a free fall and a spin whose threshold crossings are
known in closed form; the run stops ``stop_after`` later and ``simulate`` reports the fall."""

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.diagrams.run import simulate
from drake_sot.systems.fall_monitor import Fall, FallCriteria, FallMonitor

PERIOD = 0.005
G = 9.81


def _one_body(criteria: FallCriteria, *, gravity: bool, z0: float, omega_x: float = 0.0):
    """A free box (the "pelvis", also the trunk) at height ``z0``, spinning about x at ``omega_x``."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(time_step=1e-3))
    body = plant.AddRigidBody("pelvis", SpatialInertia.SolidBoxWithMass(10.0, 0.2, 0.2, 0.2))
    if not gravity:
        plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    plant.Finalize()
    monitor = builder.AddSystem(
        FallMonitor(
            plant,
            pelvis="pelvis",
            trunk="pelvis",
            model_instance=body.model_instance(),
            criteria=criteria,
            period=PERIOD,
        )
    )
    builder.Connect(plant.get_body_poses_output_port(), monitor.GetInputPort("body_poses"))
    simulator = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetFreeBodyPose(context, body, RigidTransform([0.0, 0.0, z0]))
    plant.SetFreeBodySpatialVelocity(context, body, SpatialVelocity([omega_x, 0.0, 0.0], [0.0, 0.0, 0.0]))
    simulator.Initialize()
    return simulator, monitor


def test_a_free_fall_is_caught_when_the_pelvis_passes_the_height():
    z0, h = 1.0, 0.6
    criteria = FallCriteria(min_pelvis_height=h, max_tilt=math.pi, stop_after=0.2)
    simulator, monitor = _one_body(criteria, gravity=True, z0=z0)
    result = simulate(simulator, 3.0, check=False)
    crossing = math.sqrt(2 * (z0 - h) / G)  # z0 - g t² / 2 = h
    fall = result.fell
    assert fall is not None and not result.completed and result.failure is None
    # Caught at a tick within one period of the crossing (the plant's pose may lead the
    # context time by a physics step), less than one tick's drop (g t T) below the height.
    assert abs(fall.time - crossing) <= PERIOD
    assert h - G * crossing * PERIOD < fall.pelvis_height < h
    assert fall.tilt == pytest.approx(0.0, abs=1e-9)
    # The run went on for stop_after, then stopped.
    assert result.end_time == pytest.approx(fall.time + 0.2, abs=1e-9)


def test_a_spin_is_caught_when_the_trunk_passes_the_tilt():
    omega, max_tilt = 2.0, 1.0
    criteria = FallCriteria(min_pelvis_height=0.1, max_tilt=max_tilt, stop_after=0.0)
    simulator, monitor = _one_body(criteria, gravity=False, z0=1.0, omega_x=omega)
    result = simulate(simulator, 3.0, check=False)
    fall = result.fell
    crossing = max_tilt / omega  # tilt = ω t for a spin about a horizontal axis
    assert fall is not None
    assert abs(fall.time - crossing) <= PERIOD
    assert max_tilt < fall.tilt < max_tilt + omega * PERIOD
    assert fall.pelvis_height == pytest.approx(1.0, abs=1e-9)
    assert result.end_time == pytest.approx(fall.time, abs=1e-9)  # stop_after = 0: at the detection
    assert str(fall) == (
        f"fell at t = {fall.time:.3f} s (pelvis z = 1.000 m, tilt = {math.degrees(fall.tilt):.1f}°)"
    )


def test_outputs_before_and_after_the_fall():
    criteria = FallCriteria(min_pelvis_height=0.6, max_tilt=math.pi, stop_after=1.0)
    simulator, monitor = _one_body(criteria, gravity=True, z0=1.0)
    context = monitor.GetMyContextFromRoot(simulator.get_context())
    simulator.AdvanceTo(0.1)
    assert monitor.GetOutputPort("fallen").Eval(context)[0] == 0.0
    assert np.isnan(monitor.GetOutputPort("fall").Eval(context)).all()
    assert monitor.fall(context) is None
    simulator.AdvanceTo(0.5)
    fall = monitor.fall(context)
    assert monitor.GetOutputPort("fallen").Eval(context)[0] == 1.0
    np.testing.assert_array_equal(
        monitor.GetOutputPort("fall").Eval(context), [fall.time, fall.pelvis_height, fall.tilt]
    )


def test_a_robot_that_stays_up_completes():
    criteria = FallCriteria(min_pelvis_height=0.6, max_tilt=0.5)
    simulator, _ = _one_body(criteria, gravity=False, z0=1.0)
    result = simulate(simulator, 0.5)
    assert result.completed and result.fell is None and result.end_time == pytest.approx(0.5)


def test_fall_description():
    assert (
        str(Fall(1.2345, 0.3, math.radians(61.0))) == "fell at t = 1.234 s (pelvis z = 0.300 m, tilt = 61.0°)"
    )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"min_pelvis_height": math.nan}, "min_pelvis_height = nan m: must be finite and > 0"),
        ({"min_pelvis_height": -0.1}, "min_pelvis_height = -0.1 m: must be finite and > 0"),
        ({"max_tilt": math.nan}, r"max_tilt = nan rad: must be in \[0, 3.14159\]"),
        ({"max_tilt": 4.0}, r"max_tilt = 4.0 rad: must be in \[0, 3.14159\]"),
        ({"max_tilt": 0.0}, "max_tilt = 0.0 rad: must be > 0"),
        ({"stop_after": -1.0}, "stop_after = -1.0 s: must be finite and >= 0"),
        ({"stop_after": math.inf}, "stop_after = inf s: must be finite and >= 0"),
    ],
)
def test_criteria_refuse_bad_values(kwargs, message):
    with pytest.raises(ValueError, match=message):
        FallCriteria(**kwargs)
