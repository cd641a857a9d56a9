"""AdmittanceController at unit level (inputs fixed on a context) and ForceSensor on a small plant.

Sensor readings are built here from the statics of the hand (moments about the
sensor origin, a different derivation from the controller's, which takes moments
about the hand frame), and expected motions from the closed form of the
mass-damper: v(t) = f/B (1 - e^{-Bt/M}), x(t) = x0 + f/B t - M f/B² (1 - e^{-Bt/M}).
"""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, SpatialInertia, WeldJoint
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.models.humanoid import LINKS
from drake_sot.systems.admittance import AdmittanceController
from drake_sot.systems.force_sensor import ForceSensor, payload

G = np.array([0.0, 0.0, -9.81])
DT = 0.005
HAND_MASS = 0.5
HAND_COM = np.array([0.01, -0.02, -0.06])  # in the sensor frame
M_LIN, B_LIN = 2.0, 100.0
M_ROT, B_ROT = 0.05, 2.0


def axis_angle(R: np.ndarray) -> np.ndarray:
    """Rotation vector of R through Drake's own angle-axis (an independent log)."""
    aa = RotationMatrix(R).ToAngleAxis()
    return aa.angle() * aa.axis()


def reading(X_WS, p_H, f_ext=(0.0, 0.0, 0.0), tau_ext=(0.0, 0.0, 0.0), mass=HAND_MASS, com=HAND_COM):
    """What the sensor reads when the world applies (f_ext, tau_ext about p_H) on the hand at rest.

    Wrist on hand = -(external + weight), moments taken about the sensor origin p_S.
    """
    R, p_S = X_WS.rotation().matrix(), X_WS.translation()
    f_ext, tau_ext = np.asarray(f_ext, dtype=float), np.asarray(tau_ext, dtype=float)
    weight = mass * G
    p_com = p_S + R @ com
    f_wrist = -(f_ext + weight)
    tau_wrist = -(tau_ext + np.cross(p_H - p_S, f_ext) + np.cross(p_com - p_S, weight))
    return np.concatenate((R.T @ tau_wrist, R.T @ f_wrist))


class Bench:
    """One controller and its own context, with the inputs fixed."""

    def __init__(self, rng=None, **kwargs):
        rng = rng or np.random.default_rng(0)
        args = {
            "mass": (M_LIN, M_ROT),
            "damping": (B_LIN, B_ROT),
            "hand_mass": HAND_MASS,
            "hand_com": HAND_COM,
            "period": DT,
        }
        args.update(kwargs)
        self.c = AdmittanceController(**args)
        self.context = self.c.CreateDefaultContext()
        # A random sensor orientation; the hand frame 7 cm below the sensor, turned a little.
        self.X_WS = RigidTransform(RollPitchYaw(rng.uniform(-np.pi, np.pi, 3)), rng.normal(scale=0.3, size=3))
        self.X_WH = self.X_WS @ RigidTransform(RollPitchYaw(0.1, -0.2, 0.3), [0.0, 0.0, -0.07])
        self.fix("sensor_pose", self.X_WS)
        self.fix("hand_pose", self.X_WH)
        self.push()

    def fix(self, port, value):
        self.c.GetInputPort(port).FixValue(self.context, value)

    def push(self, f_ext=(0.0, 0.0, 0.0), tau_ext=(0.0, 0.0, 0.0)):
        """Fix the reading of an external wrench (f, τ about the hand origin) on the hand."""
        self.fix("wrench", reading(self.X_WS, self.X_WH.translation(), f_ext, tau_ext))

    def step(self, n=1):
        for _ in range(n):
            self.context.SetDiscreteState(self.c.EvalUniquePeriodicDiscreteUpdate(self.context))

    def out(self, port):
        return self.c.GetOutputPort(port).Eval(self.context)

    @property
    def pose(self) -> RigidTransform:
        return RigidTransform(self.out("position_des"))  # a copy: the port's value changes at the next tick

    @property
    def velocity(self) -> np.ndarray:
        return self.out("velocity_des").copy()


def x_closed(M, B, f, t):
    return f / B * t - M * f / B**2 * (1 - np.exp(-B * t / M))


def v_closed(M, B, f, t):
    return f / B * (1 - np.exp(-B * t / M))


def test_the_hand_weight_alone_is_compensated():
    for seed in range(5):
        bench = Bench(np.random.default_rng(seed))
        bench.step(100)
        np.testing.assert_allclose(bench.out("wrench_external"), 0.0, atol=1e-12)
        np.testing.assert_allclose(bench.pose.GetAsMatrix4(), bench.X_WH.GetAsMatrix4(), atol=1e-12)
        np.testing.assert_allclose(bench.velocity, 0.0, atol=1e-12)
        assert bench.out("fault")[0] == 0 and bench.out("saturated")[0] == 0


def test_a_constant_force_moves_the_reference_along_it_at_f_over_b():
    rng = np.random.default_rng(1)
    bench = Bench(rng)
    f = 20.0 * rng.normal(size=3)
    f *= 20.0 / np.linalg.norm(f)  # 20 N, a random direction
    bench.push(f_ext=f)
    steps = 200  # 1 s, twenty time constants M/B
    bench.step(steps)
    T = steps * DT
    np.testing.assert_allclose(bench.out("wrench_external"), np.concatenate((np.zeros(3), f)), atol=1e-10)
    p0 = bench.X_WH.translation()
    np.testing.assert_allclose(
        bench.pose.translation() - p0, x_closed(M_LIN, B_LIN, f, T), rtol=1e-6, atol=1e-12
    )
    np.testing.assert_allclose(bench.velocity[:3], v_closed(M_LIN, B_LIN, f, T), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(bench.velocity[:3], f / B_LIN, rtol=1e-6)
    # The force acts at the hand origin: no torque, the orientation stays.
    np.testing.assert_allclose(bench.velocity[3:], 0.0, atol=1e-12)
    np.testing.assert_allclose(bench.pose.rotation().matrix(), bench.X_WH.rotation().matrix(), atol=1e-12)
    assert bench.out("saturated")[0] == 0


def test_a_constant_torque_turns_the_reference_about_it():
    rng = np.random.default_rng(2)
    bench = Bench(rng)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    tau = 0.8 * axis  # steady ω = 0.4 rad/s, under the 1 rad/s limit
    # A couple: two opposite forces at points off the hand origin (zero net force).
    bench.push(tau_ext=tau)
    steps = 150
    bench.step(steps)
    T = steps * DT
    np.testing.assert_allclose(bench.out("wrench_external"), np.concatenate((tau, np.zeros(3))), atol=1e-10)
    np.testing.assert_allclose(bench.velocity[3:], v_closed(M_ROT, B_ROT, tau, T), rtol=1e-6)
    R_rel = bench.pose.rotation().matrix() @ bench.X_WH.rotation().matrix().T
    np.testing.assert_allclose(axis_angle(R_rel), x_closed(M_ROT, B_ROT, tau, T), rtol=1e-6)
    np.testing.assert_allclose(bench.pose.translation(), bench.X_WH.translation(), atol=1e-12)


def test_an_off_centre_push_gives_the_torque_of_its_lever_arm():
    bench = Bench(np.random.default_rng(3))
    f = np.array([0.0, 5.0, 0.0])
    p_app = bench.X_WH.translation() + np.array([0.1, 0.0, 0.0])
    bench.push(f_ext=f, tau_ext=np.cross(p_app - bench.X_WH.translation(), f))
    bench.step()
    np.testing.assert_allclose(bench.out("wrench_external"), [0, 0, 0.5, 0, 5.0, 0], atol=1e-10)


def test_the_reference_wrench_adds_to_the_measured_one():
    rng = np.random.default_rng(4)
    f_meas, f_ref = np.array([6.0, -3.0, 2.0]), np.array([-1.0, 8.0, 4.0])
    tau_ref = np.array([0.1, 0.0, -0.2])
    steps = 60
    T = steps * DT
    benches = {}
    for key in ("split", "ref only"):
        bench = Bench(np.random.default_rng(5))
        bench.push(f_ext=f_meas if key == "split" else np.zeros(3))
        bench.fix("wrench_ref", np.concatenate((tau_ref, f_ref)))
        bench.step(steps)
        benches[key] = bench
    split = benches["split"]
    p0 = split.X_WH.translation()
    np.testing.assert_allclose(
        split.pose.translation() - p0, x_closed(M_LIN, B_LIN, f_meas + f_ref, T), rtol=1e-6
    )
    np.testing.assert_allclose(split.velocity[3:], v_closed(M_ROT, B_ROT, tau_ref, T), rtol=1e-6)
    # wrench_external reports the measured part only.
    np.testing.assert_allclose(split.out("wrench_external")[3:], f_meas, atol=1e-10)
    ref_only = benches["ref only"]
    np.testing.assert_allclose(ref_only.pose.translation() - p0, x_closed(M_LIN, B_LIN, f_ref, T), rtol=1e-6)
    del rng


def test_velocity_saturation_is_reported():
    bench = Bench(np.random.default_rng(6))
    f = np.array([300.0, -400.0, 0.0])  # f/B = 5 m/s, ten times the 0.5 m/s limit
    bench.push(f_ext=f)
    bench.step(3)
    assert bench.out("saturated")[0] == 1
    for _ in range(20):
        p = bench.pose.translation()
        bench.step()
        np.testing.assert_allclose(np.linalg.norm(bench.velocity[:3]), 0.5, rtol=1e-12)
        np.testing.assert_allclose(bench.velocity[:3] / 0.5, f / 500.0, atol=1e-12)  # along the force
        assert np.linalg.norm(bench.pose.translation() - p) <= 0.5 * DT * (1 + 1e-12)
        assert bench.out("saturated")[0] == 1
    np.testing.assert_allclose(bench.velocity[3:], 0.0, atol=1e-12)
    # Angular: a large torque saturates |ω| at 1 rad/s.
    bench = Bench(np.random.default_rng(7))
    bench.push(tau_ext=np.array([0.0, 0.0, 10.0]))
    bench.step(40)
    np.testing.assert_allclose(bench.velocity[3:], [0.0, 0.0, 1.0], atol=1e-12)
    assert bench.out("saturated")[0] == 1
    # Per-axis limits (6 values): the vector is scaled by the tightest axis, keeping its direction.
    bench = Bench(np.random.default_rng(8), max_velocity=(0.1, 0.2, 0.3, 1.0, 1.0, 1.0))
    bench.push(f_ext=np.array([100.0, 100.0, 0.0]))
    bench.step(40)
    np.testing.assert_allclose(bench.velocity[:3], [0.1, 0.1, 0.0], atol=1e-12)
    # Below the limit: not saturated.
    bench = Bench(np.random.default_rng(9))
    bench.push(f_ext=np.array([10.0, 0.0, 0.0]))
    bench.step(40)
    assert bench.out("saturated")[0] == 0


def test_faulty_readings_never_reach_the_reference():
    bench = Bench(np.random.default_rng(10))
    f = np.array([0.0, 10.0, 0.0])
    bench.push(f_ext=f)
    bench.step(20)
    held = bench.pose
    assert np.linalg.norm(bench.velocity) > 0.05
    good = bench.out("wrench_external").copy()
    for bad, code in (
        (np.array([0.0, 0.0, 0.0, np.nan, 0.0, 0.0]), 1),
        (np.array([0, 0, 0, 0, 0, np.inf]), 1),
        (np.concatenate((np.zeros(3), [0.0, 1500.0, 0.0])), 2),
        # A 1e9 N·m torque reading (a broken sensor) is a fault too: it would rotate the reference.
        (np.array([0.0, 1e9, 0.0, 0.0, 0.0, 0.0]), 3),
    ):
        bench.fix("wrench", bad)
        for _ in range(10):
            bench.step()
            np.testing.assert_array_equal(bench.pose.GetAsMatrix4(), held.GetAsMatrix4())
            np.testing.assert_array_equal(bench.velocity, 0.0)
            assert bench.out("fault")[0] == code
    # A non-finite reference wrench is a fault too.
    bench.push(f_ext=f)
    bench.fix("wrench_ref", np.array([0, 0, 0, np.nan, 0, 0]))
    bench.step(3)
    assert bench.out("fault")[0] == 1
    np.testing.assert_array_equal(bench.pose.GetAsMatrix4(), held.GetAsMatrix4())
    # Valid again: resumes from the held pose, at rest.
    bench.fix("wrench_ref", np.zeros(6))
    bench.step()
    assert bench.out("fault")[0] == 0
    np.testing.assert_allclose(bench.out("wrench_external"), good, atol=1e-10)
    np.testing.assert_allclose(bench.velocity[:3], v_closed(M_LIN, B_LIN, f, DT), rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(
        bench.pose.translation() - held.translation(), x_closed(M_LIN, B_LIN, f, DT), rtol=1e-9, atol=1e-15
    )


def test_inactive_follows_the_hand_and_activation_starts_from_it():
    rng = np.random.default_rng(11)
    bench = Bench(rng)
    f = np.array([-12.0, 0.0, 6.0])
    bench.push(f_ext=f)
    bench.fix("active", [0.0])
    for _ in range(5):
        X = RigidTransform(RollPitchYaw(rng.uniform(-1, 1, 3)), rng.normal(size=3))
        bench.fix("hand_pose", X)
        bench.step()
        np.testing.assert_allclose(bench.pose.GetAsMatrix4(), X.GetAsMatrix4(), atol=1e-12)
        np.testing.assert_array_equal(bench.velocity, 0.0)
    # Back to the sensor's hand pose (so the reading is consistent), then activate.
    X_start = RigidTransform(bench.X_WH.rotation(), bench.X_WH.translation() + [0.0, 0.0, 0.01])
    bench.X_WH = X_start
    bench.fix("hand_pose", X_start)
    bench.push(f_ext=f)
    bench.step()
    np.testing.assert_allclose(bench.pose.GetAsMatrix4(), X_start.GetAsMatrix4(), atol=1e-12)
    bench.fix("active", [1.0])
    steps = 30
    bench.step(steps)
    T = steps * DT
    np.testing.assert_allclose(
        bench.pose.translation() - X_start.translation(), x_closed(M_LIN, B_LIN, f, T), rtol=1e-6, atol=1e-12
    )
    np.testing.assert_allclose(bench.velocity[:3], v_closed(M_LIN, B_LIN, f, T), rtol=1e-6, atol=1e-12)


def test_the_spring_pulls_back_to_the_pose_at_activation():
    bench = Bench(np.random.default_rng(12), stiffness=(400.0, 4.0), damping=(60.0, 1.0))
    f, tau = np.array([8.0, -4.0, 2.0]), np.array([0.0, 0.2, 0.0])
    bench.push(f_ext=f, tau_ext=tau)
    bench.step(600)  # 3 s: settled
    np.testing.assert_allclose(bench.pose.translation(), bench.X_WH.translation() + f / 400.0, rtol=1e-6)
    R_rel = bench.pose.rotation().matrix() @ bench.X_WH.rotation().matrix().T
    np.testing.assert_allclose(axis_angle(R_rel), tau / 4.0, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(bench.velocity, 0.0, atol=1e-7)


def test_initialization_and_no_direct_feedthrough():
    c = AdmittanceController(mass=1.0, damping=10.0, hand_mass=0.0, hand_com=np.zeros(3))
    assert not c.HasAnyDirectFeedthrough()
    simulator = Simulator(c)
    context = simulator.get_mutable_context()
    X = RigidTransform(RollPitchYaw(0.3, 0.2, -0.1), [0.4, -0.2, 0.9])
    c.GetInputPort("hand_pose").FixValue(context, X)
    c.GetInputPort("sensor_pose").FixValue(context, X)
    c.GetInputPort("wrench").FixValue(context, np.zeros(6))
    simulator.Initialize()
    np.testing.assert_allclose(
        c.GetOutputPort("position_des").Eval(context).GetAsMatrix4(), X.GetAsMatrix4(), atol=1e-12
    )
    simulator.AdvanceTo(0.1)
    np.testing.assert_allclose(
        c.GetOutputPort("position_des").Eval(context).GetAsMatrix4(), X.GetAsMatrix4(), atol=1e-12
    )


def test_bad_arguments_and_inputs_are_named():
    ok = {"mass": 1.0, "damping": 10.0, "hand_mass": 0.5, "hand_com": np.zeros(3)}
    for bad, match in (
        ({"mass": 0.0}, "mass = .*: every value must be finite and > 0"),
        ({"mass": np.nan}, "mass = .*: every value must be finite and > 0"),
        ({"damping": (1.0, -1.0)}, "damping = .*: every value must be finite and >= 0; entry 3"),
        (
            {"mass": (1.0, 2.0, 3.0)},
            r"mass must be a scalar, a pair \(3 \+ 3 axes\) or 6 values, got 3 values",
        ),
        ({"hand_mass": -1.0}, "hand_mass"),
        ({"hand_com": [0.0, 0.0]}, "hand_com"),
        ({"max_velocity": (1.0, 2.0, 3.0)}, "max_velocity"),
        ({"max_velocity": (0.0, 1.0)}, "max_velocity = .* must be finite and > 0 \\(or \\+inf\\)"),
        ({"max_velocity": (np.nan, 1.0)}, "max_velocity"),
        ({"max_torque": np.nan}, "max_torque = nan"),
        ({"max_torque": -1.0}, "max_torque = -1.0"),
        ({"hand_mass": np.nan}, "hand_mass = nan"),
        ({"max_force": np.nan}, "max_force"),
        ({"period": 0.0}, "period"),
    ):
        with pytest.raises(ValueError, match=match):
            AdmittanceController(**{**ok, **bad})
    bench = Bench()
    bench.fix("hand_pose", RigidTransform([np.nan, 0.0, 0.0]))
    with pytest.raises(RuntimeError, match="input 'hand_pose' is not finite"):
        bench.step()


# --- ForceSensor on a small plant -------------------------------------------------------------


def two_body_plant(time_step=1e-3):
    """Body 'arm' welded to the world, body 'hand' welded below it through the sensor 'ft'.

    Frames are turned and offset so that no axis or lever arm is trivial.
    """
    plant = MultibodyPlant(time_step)
    arm = plant.AddRigidBody("arm", SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1))
    hand_inertia = SpatialInertia.SolidBoxWithMass(HAND_MASS, 0.08, 0.06, 0.1).Shift(
        -np.array([0.03, -0.01, -0.05])
    )
    hand = plant.AddRigidBody(
        "hand", hand_inertia
    )  # centre of mass at (0.03, -0.01, -0.05) in the hand frame
    plant.WeldFrames(
        plant.world_frame(), arm.body_frame(), RigidTransform(RollPitchYaw(0.3, -0.2, 0.5), [0, 0, 1])
    )
    parent = plant.AddFrame(
        FixedOffsetFrame(
            "ft_parent", arm.body_frame(), RigidTransform(RollPitchYaw(0.1, 0.4, -0.3), [0.05, 0, -0.1])
        )
    )
    child = plant.AddFrame(
        FixedOffsetFrame(
            "ft_child", hand.body_frame(), RigidTransform(RollPitchYaw(-0.5, 0.2, 0.1), [0.0, 0.03, 0.04])
        )
    )
    plant.AddJoint(WeldJoint("ft", parent, child, RigidTransform()))
    plant.Finalize()
    return plant, hand, child


def push(body, p_BoBq_B, f_W):
    """An external force f_W [N] (world axes) on ``body`` at the point p_BoBq_B of its frame."""
    force = ExternallyAppliedSpatialForce()
    force.body_index = body.index()
    force.p_BoBq_B = p_BoBq_B
    force.F_Bq_W = SpatialForce(np.zeros(3), f_W)
    return force


def test_force_sensor_reads_what_the_parent_applies_on_the_child():
    plant, hand, child = two_body_plant()
    builder = DiagramBuilder()
    builder.AddSystem(plant)
    sensor = builder.AddSystem(ForceSensor(plant, "ft"))
    builder.Connect(plant.get_reaction_forces_output_port(), sensor.GetInputPort("reaction_forces"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    pc = plant.GetMyMutableContextFromRoot(root)
    sc = sensor.GetMyContextFromRoot(root)
    # A discrete plant samples its reaction forces at each step: zeros before the first one.
    np.testing.assert_array_equal(sensor.GetOutputPort("wrench").Eval(sc), 0.0)
    # The hand's weight, computed from its body and frames (not from the sensor's payload()).
    X_WJ = child.CalcPoseInWorld(pc)
    X_WB = hand.body_frame().CalcPoseInWorld(pc)
    p_com = X_WB @ np.array([0.03, -0.01, -0.05])
    R = X_WJ.rotation().matrix()
    hand_at_rest = reading(X_WJ, X_WJ.translation(), com=X_WJ.inverse() @ p_com)
    simulator.AdvanceTo(0.003)
    np.testing.assert_allclose(sensor.GetOutputPort("wrench").Eval(sc), hand_at_rest, atol=1e-9)
    # The wrist holds the hand up: the force on the hand points up in world.
    np.testing.assert_allclose(
        R @ sensor.GetOutputPort("wrench").Eval(sc)[3:], [0, 0, HAND_MASS * 9.81], atol=1e-9
    )
    # Push the hand at a point off its origin: the reading changes by what the wrist resists.
    f_push, p_push_B = np.array([3.0, -2.0, 5.0]), np.array([0.02, 0.04, -0.09])
    plant.get_applied_spatial_force_input_port().FixValue(pc, [push(hand, p_push_B, f_push)])
    simulator.AdvanceTo(0.006)
    p_push = X_WB @ p_push_B
    expected = reading(
        X_WJ,
        X_WJ.translation(),
        f_ext=f_push,
        tau_ext=np.cross(p_push - X_WJ.translation(), f_push),
        com=X_WJ.inverse() @ p_com,
    )
    np.testing.assert_allclose(sensor.GetOutputPort("wrench").Eval(sc), expected, atol=1e-9)
    # payload(): the hand's mass and centre of mass in the sensor frame.
    mass, com = sensor.payload(pc)
    assert mass == pytest.approx(HAND_MASS, rel=1e-14)
    np.testing.assert_allclose(com, X_WJ.inverse() @ p_com, atol=1e-14)
    assert sensor.frame.name() == "ft_child"


def test_sensor_and_admittance_recover_the_push_on_a_plant():
    """End to end: the controller's compensated wrench is the push applied to the hand."""
    plant, hand, child = two_body_plant()
    builder = DiagramBuilder()
    builder.AddSystem(plant)
    sensor = builder.AddSystem(ForceSensor(plant, "ft"))
    mass, com = sensor.payload()
    admittance = builder.AddSystem(AdmittanceController(mass=2.0, damping=50.0, hand_mass=mass, hand_com=com))
    builder.Connect(plant.get_reaction_forces_output_port(), sensor.GetInputPort("reaction_forces"))
    builder.Connect(sensor.GetOutputPort("wrench"), admittance.GetInputPort("wrench"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    pc = plant.GetMyMutableContextFromRoot(root)
    ac = admittance.GetMyMutableContextFromRoot(root)
    X_WB = hand.body_frame().CalcPoseInWorld(pc)
    X_WH = X_WB @ RigidTransform([0.0, 0.0, -0.08])  # a "tool" frame on the hand
    admittance.GetInputPort("sensor_pose").FixValue(ac, child.CalcPoseInWorld(pc))
    admittance.GetInputPort("hand_pose").FixValue(ac, X_WH)
    f_push, p_push_B = np.array([-4.0, 1.0, 2.0]), np.array([0.05, 0.0, -0.02])
    plant.get_applied_spatial_force_input_port().FixValue(pc, [push(hand, p_push_B, f_push)])
    simulator.AdvanceTo(0.0201)  # the tick at 20 ms reads the sample of the step that ended at 20 ms
    tau_push = np.cross(X_WB @ p_push_B - X_WH.translation(), f_push)
    np.testing.assert_allclose(
        admittance.GetOutputPort("wrench_external").Eval(ac), np.concatenate((tau_push, f_push)), atol=1e-9
    )


def test_force_sensor_payload_of_the_humanoid_wrist_includes_the_gripper(control_model):
    plant, info, _ = control_model
    sensor = ForceSensor(plant, info.force_sensors["right_wrist"])
    mass, com = sensor.payload()
    names = ("r_hand", "r_finger")  # the gripper finger hangs from the hand, below the sensor too
    assert mass == pytest.approx(sum(link.mass for link in LINKS if link.name in names), rel=1e-14)
    # Centre of mass: the mass-weighted mean of the two bodies' centres, in the sensor frame.
    context = plant.CreateDefaultContext()
    bodies = [plant.GetBodyByName(n) for n in names]
    p_W = sum(b.default_mass() * (b.EvalPoseInWorld(context) @ b.default_com()) for b in bodies) / mass
    np.testing.assert_allclose(com, sensor.frame.CalcPoseInWorld(context).inverse() @ p_W, atol=1e-14)
    assert com[2] < 0.0  # the hand hangs below the wrist sensor
    # The module function works on any plant holding the joint, with any configuration.
    np.testing.assert_allclose(payload(plant, info.force_sensors["right_wrist"], context)[1], com, atol=1e-15)
    with pytest.raises(TypeError, match="not a WeldJoint"):
        ForceSensor(plant, "r_knee")
    with pytest.raises(ValueError, match="no joint 'nope'.*r_wrist_ft"):
        ForceSensor(plant, "nope")


def test_humanoid_wrist_sensor_reads_the_hand_weight_and_a_push():
    """The embedded humanoid standing (posture + CoM tasks): the right wrist sensor holds the
    hand (and its finger) up, and the controller's compensation recovers a push on the hand."""
    from drake_sot.diagrams.humanoid import HumanoidSoTBuilder

    sot = HumanoidSoTBuilder()
    sot.add_com_task("com")
    sot.add_posture_task("posture")
    joint = sot.info.force_sensors["right_wrist"]
    sensor = sot.builder.AddSystem(ForceSensor(sot.plant, joint))
    sot.builder.Connect(sot.plant.get_reaction_forces_output_port(), sensor.GetInputPort("reaction_forces"))
    built = sot.build(stack=["com", "posture"])
    simulator = built.create_simulator()
    root = simulator.get_mutable_context()
    pc = built.plant.GetMyMutableContextFromRoot(root)
    sc = sensor.GetMyContextFromRoot(root)
    simulator.AdvanceTo(0.3)
    mass, com = sensor.payload(pc)
    X_WS = sensor.frame.CalcPoseInWorld(pc)
    w = sensor.GetOutputPort("wrench").Eval(sc)
    # hand_mass · g upward on the hand, within what the hand's small residual motion costs.
    np.testing.assert_allclose(X_WS.rotation().matrix() @ w[3:], [0.0, 0.0, mass * 9.81], atol=5e-3)
    controller = AdmittanceController(mass=1.0, damping=10.0, hand_mass=mass, hand_com=com)
    hand = built.plant.GetFrameByName(built.info.frames["right_hand"])
    np.testing.assert_allclose(
        controller.external_wrench(w, X_WS, hand.CalcPoseInWorld(pc).translation()), 0.0, atol=5e-3
    )
    # Push the hand 8 N forward and up at its tool point; once the arm has yielded and the sway
    # has died out (the sensor also carries m·a of the hand: 0.15 N still at 1 s), the
    # compensated wrench is the push.
    hand_body = built.plant.GetBodyByName("r_hand")
    p_tool_B = hand.GetFixedPoseInBodyFrame().translation()
    f_push = np.array([6.0, 0.0, 5.3])
    built.plant.get_applied_spatial_force_input_port().FixValue(pc, [push(hand_body, p_tool_B, f_push)])
    simulator.AdvanceTo(2.2)
    w = sensor.GetOutputPort("wrench").Eval(sc)
    X_WS = sensor.frame.CalcPoseInWorld(pc)
    w_ext = controller.external_wrench(w, X_WS, hand.CalcPoseInWorld(pc).translation())
    np.testing.assert_allclose(w_ext, np.concatenate((np.zeros(3), f_push)), atol=2e-2)


def test_weighted_the_reference_moves_as_a_body_of_the_hands_apparent_inertia():
    """Evrard et al. 2009, eq. 5-7: with ``weighted=True`` the translation's virtual mass is
    Λ = (J_v A⁻¹ J_vᵀ)⁻¹; under a constant force the reference follows ``Λ r̈ + b ṙ = f``,
    whose closed form is summed here over the eigenvectors u_i (eigenvalues λ_i) of Λ:
    ṙ(t) = Σ u_i u_iᵀ f / b (1 − e^{−b t/λ_i}), coupled axes (the velocity leaves f's direction)."""
    rng = np.random.default_rng(3)
    n = 8
    X = rng.normal(size=(n, n))
    A = X @ X.T + n * np.eye(n)
    J = rng.normal(size=(6, n))
    Lam = np.linalg.inv(J[3:] @ np.linalg.inv(A) @ J[3:].T)
    plain = Bench(rng)
    bench = Bench(rng, weighted=True)
    bench.fix("inertia", A)
    bench.fix("hand_jacobian", J)
    f = np.array([12.0, -5.0, 3.0])
    for b in (bench, plain):
        b.push(f_ext=f)
        b.step(6)
    T = 6 * DT
    lam, U = np.linalg.eigh(Lam)
    modes = U.T @ f / B_LIN
    v = U @ (modes * (1 - np.exp(-B_LIN * T / lam)))
    x = U @ (modes * (T - lam / B_LIN * (1 - np.exp(-B_LIN * T / lam))))
    np.testing.assert_allclose(bench.velocity[:3], v, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(bench.pose.translation() - bench.X_WH.translation(), x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(bench.out("virtual_mass").reshape(3, 3), Lam, rtol=1e-9)
    # The plain admittance along f at M_LIN (its virtual_mass: diag(M_LIN)); the two differ.
    np.testing.assert_allclose(plain.velocity[:3], v_closed(M_LIN, B_LIN, f, T), rtol=1e-9)
    np.testing.assert_array_equal(plain.out("virtual_mass").reshape(3, 3), M_LIN * np.eye(3))
    assert np.linalg.norm(bench.velocity[:3] - plain.velocity[:3]) > 0.1 * np.linalg.norm(v)
    # The rotation keeps its own diagonal mass.
    np.testing.assert_allclose(bench.velocity[3:], 0.0, atol=1e-12)


def test_weighted_needs_its_inputs_and_a_full_rank_jacobian():
    bench = Bench(weighted=True)
    bench.push(f_ext=(1.0, 0.0, 0.0))
    with pytest.raises(RuntimeError, match="needs input 'inertia'"):
        bench.step()
    bench.fix("inertia", np.eye(4))
    bench.fix("hand_jacobian", np.zeros((3, 4)))
    with pytest.raises(RuntimeError, match=r"'hand_jacobian' has shape \(3, 4\)"):
        bench.step()
    bench.fix("hand_jacobian", np.zeros((6, 4)))
    with pytest.raises(ValueError, match="full row rank"):
        bench.step()
    assert not Bench().c.HasInputPort("inertia")  # the plain variant has no such inputs
