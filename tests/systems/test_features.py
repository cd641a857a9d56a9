"""Every feature's Jacobian against finite differences on the configuration manifold.

q is moved along random velocities v with Drake's own q̇ = N(q) v map and a
normalised quaternion (central differences, so the retraction's second-order error
cancels); the feature's J v must equal d e / dε.
"""

import numpy as np
import pytest
from feature_bench import FeatureBench, random_configuration, retract
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.framework import DiagramBuilder

from drake_sot.systems.features import (
    FeatureCoM,
    FeatureGeneric,
    FeatureJointLimits,
    FeaturePoint6d,
    FeaturePoint6dRelative,
    FeaturePosture,
    FeatureVisualPoint,
)

EPS = 1e-6


def fd_check(bench, feature, plant, q, rng, n_dirs=6, tol=2e-6):
    signal = bench.signal(feature, q)
    for _ in range(n_dirs):
        v = rng.normal(size=plant.num_velocities())
        e_plus = bench.signal(feature, retract(plant, q, v, EPS)).error
        e_minus = bench.signal(feature, retract(plant, q, v, -EPS)).error
        fd = (e_plus - e_minus) / (2 * EPS)
        np.testing.assert_allclose(signal.jacobian @ v, fd, atol=tol * (1 + np.linalg.norm(fd)))
    return signal


def random_pose(rng):
    return RigidTransform(RollPitchYaw(rng.uniform(-1, 1, 3)), rng.normal(scale=0.5, size=3))


def test_point6d_jacobian(control_model):
    plant, info, q0 = control_model
    rng = np.random.default_rng(0)
    feature = FeaturePoint6d(name="rh", desired=random_pose(rng))
    bench = FeatureBench(plant, [feature], op_points=[("rh", info.frames["right_hand"])])
    bench.connect(bench.dyn.GetOutputPort("rh"), feature.GetInputPort("position"))
    bench.connect(bench.dyn.GetOutputPort("Jrh"), feature.GetInputPort("Jq"))
    bench.build()
    for _ in range(3):
        q = random_configuration(plant, q0, rng)
        signal = fd_check(bench, feature, plant, q, rng)
        # The error itself: position difference and rotation vector, computed here with Drake.
        context = plant.CreateDefaultContext()
        plant.SetPositions(context, q)
        X = plant.GetFrameByName(info.frames["right_hand"]).CalcPoseInWorld(context)
        X_des = feature.desired(bench.context)
        np.testing.assert_allclose(signal.error[:3], X.translation() - X_des.translation(), atol=1e-12)
        aa = (X.rotation() @ X_des.rotation().inverse()).ToAngleAxis()
        np.testing.assert_allclose(signal.error[3:], aa.angle() * aa.axis(), atol=1e-9)


def test_point6d_selection_keeps_rows(control_model):
    plant, info, q0 = control_model
    full = FeaturePoint6d(name="full")
    z_only = FeaturePoint6d(name="z", selection="001000")
    bench = FeatureBench(plant, [full, z_only], op_points=[("lh", info.frames["left_hand"])])
    for f in (full, z_only):
        bench.connect(bench.dyn.GetOutputPort("lh"), f.GetInputPort("position"))
        bench.connect(bench.dyn.GetOutputPort("Jlh"), f.GetInputPort("Jq"))
    bench.build()
    a, b = bench.signal(full, q0), bench.signal(z_only, q0)
    assert b.error.shape == (1,) and b.jacobian.shape == (1, plant.num_velocities())
    np.testing.assert_array_equal(b.error, a.error[2:3])
    np.testing.assert_array_equal(b.jacobian, a.jacobian[2:3])


def test_point6d_feedforward_is_minus_time_derivative(control_model):
    """With the reference moving at [v*; ω*], feedforward = -∂e/∂t (finite differences in time)."""
    plant, info, q0 = control_model
    rng = np.random.default_rng(1)
    feature = FeaturePoint6d(name="rh")
    bench = FeatureBench(plant, [feature], op_points=[("rh", info.frames["right_hand"])])
    bench.connect(bench.dyn.GetOutputPort("rh"), feature.GetInputPort("position"))
    bench.connect(bench.dyn.GetOutputPort("Jrh"), feature.GetInputPort("Jq"))
    bench.build()
    fctx = feature.GetMyMutableContextFromRoot(bench.context)
    X_des = random_pose(rng)
    twist = rng.normal(size=6)  # [v*; ω*]
    feature.GetInputPort("velocity_des").FixValue(fctx, twist)

    def error_at(t):
        from pydrake.math import RotationMatrix

        R = RotationMatrix(_rodrigues(twist[3:] * t)) @ X_des.rotation()
        feature.set_desired(bench.context, RigidTransform(R, X_des.translation() + twist[:3] * t))
        return bench.signal(feature, q0)

    h = 1e-6
    de_dt = (error_at(h).error - error_at(-h).error) / (2 * h)
    np.testing.assert_allclose(error_at(0.0).feedforward, -de_dt, atol=1e-6)


def _rodrigues(w):
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(w).as_matrix()


def test_point6d_relative_jacobian(control_model):
    plant, info, q0 = control_model
    rng = np.random.default_rng(2)
    feature = FeaturePoint6dRelative(name="twofeet", desired=random_pose(rng))
    bench = FeatureBench(
        plant, [feature], op_points=[("rleg", info.frames["right_foot"]), ("lleg", info.frames["left_foot"])]
    )
    # The paper's plugs: dyn.Jrleg -> Jq, dyn.Jlleg -> JqRef, dyn.rleg -> position, dyn.lleg -> positionRef
    bench.connect(bench.dyn.GetOutputPort("Jrleg"), feature.GetInputPort("Jq"))
    bench.connect(bench.dyn.GetOutputPort("Jlleg"), feature.GetInputPort("JqRef"))
    bench.connect(bench.dyn.GetOutputPort("rleg"), feature.GetInputPort("position"))
    bench.connect(bench.dyn.GetOutputPort("lleg"), feature.GetInputPort("positionRef"))
    bench.build()
    for _ in range(3):
        q = random_configuration(plant, q0, rng)
        signal = fd_check(bench, feature, plant, q, rng)
        # The relative pose is independent of the base pose: moving only the base changes nothing.
        v_base = np.zeros(plant.num_velocities())
        v_base[:6] = rng.normal(size=6)
        np.testing.assert_allclose(signal.jacobian @ v_base, 0.0, atol=1e-12)


def _visual_bench(plant, info, feature):
    bench = FeatureBench(plant, [feature], op_points=[("camera", info.frames["head_camera"])])
    bench.connect(bench.dyn.GetOutputPort("camera"), feature.GetInputPort("position"))
    bench.connect(bench.dyn.GetOutputPort("Jcamera"), feature.GetInputPort("Jq"))
    return bench.build()


def _camera_pose(plant, info, q):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    return plant.GetFrameByName(info.frames["head_camera"]).CalcPoseInWorld(context)


def test_visual_point_jacobian_and_image_coordinates(control_model):
    """J matches finite differences on the configuration; s = (X/Z, Y/Z) of the point in the
    camera frame, computed here with Drake's transforms."""
    plant, info, q0 = control_model
    rng = np.random.default_rng(6)
    feature = FeatureVisualPoint(name="gaze", desired=[0.05, -0.1])
    bench = _visual_bench(plant, info, feature)
    point = feature.GetInputPort("point")
    for _ in range(4):
        q = random_configuration(plant, q0, rng)
        # A point 0.5-2 m ahead of the camera, anywhere in a 90° field of view.
        p_C = np.array([*rng.uniform(-0.9, 0.9, 2), 1.0]) * rng.uniform(0.5, 2.0)
        p_W = _camera_pose(plant, info, q) @ p_C
        point.FixValue(feature.GetMyMutableContextFromRoot(bench.context), p_W)
        signal = fd_check(bench, feature, plant, q, rng)
        X, Y, Z = _camera_pose(plant, info, q).inverse() @ p_W
        np.testing.assert_allclose(signal.error, [X / Z - 0.05, Y / Z + 0.1], atol=1e-12)
        np.testing.assert_array_equal(signal.feedforward, 0.0)  # no velocity given: a still point


def test_visual_point_feedforward_is_minus_time_derivative(control_model):
    """With the point moving at ṗ, feedforward = -∂e/∂t (finite differences in time)."""
    plant, info, q0 = control_model
    rng = np.random.default_rng(7)
    feature = FeatureVisualPoint(name="gaze")
    bench = _visual_bench(plant, info, feature)
    fctx = feature.GetMyMutableContextFromRoot(bench.context)
    p_W = _camera_pose(plant, info, q0) @ np.array([0.2, -0.3, 1.2])
    velocity = rng.normal(size=3)
    feature.GetInputPort("point_velocity").FixValue(fctx, velocity)

    def signal_at(t):
        feature.GetInputPort("point").FixValue(fctx, p_W + velocity * t)
        return bench.signal(feature, q0)

    h = 1e-6
    de_dt = (signal_at(h).error - signal_at(-h).error) / (2 * h)
    np.testing.assert_allclose(signal_at(0.0).feedforward, -de_dt, atol=1e-7)


def test_visual_point_behind_the_camera_is_refused_naming_the_feature(control_model):
    plant, info, q0 = control_model
    feature = FeatureVisualPoint(name="gaze")
    bench = _visual_bench(plant, info, feature)
    behind = _camera_pose(plant, info, q0) @ np.array([0.1, 0.0, -0.5])
    feature.GetInputPort("point").FixValue(feature.GetMyMutableContextFromRoot(bench.context), behind)
    with pytest.raises(
        ValueError, match=r"'gaze' at t = 0.0000 s: depth Z = -0.5\d* m: the point must be in front"
    ):
        bench.signal(feature, q0)
    with pytest.raises(ValueError, match="'g': desired image point \\[nan  0.\\] must be 2 finite numbers"):
        FeatureVisualPoint(name="g", desired=[np.nan, 0.0])


def test_com_jacobian_and_generic_passthrough(control_model):
    plant, info, q0 = control_model
    rng = np.random.default_rng(3)
    com = FeatureCoM(name="com", desired=np.array([0.1, -0.2, 0.7]))
    generic = FeatureGeneric(3, name="generic", selection="110")
    bench = FeatureBench(plant, [com, generic])
    for f in (com, generic):
        bench.connect(bench.dyn.GetOutputPort("com"), f.GetInputPort(f._value_port))
        bench.connect(bench.dyn.GetOutputPort("Jcom"), f.GetInputPort(f._jacobian_port))
    bench.build()
    q = random_configuration(plant, q0, rng)
    signal = fd_check(bench, com, plant, q, rng)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    np.testing.assert_allclose(
        signal.error, plant.CalcCenterOfMassPositionInWorld(context) - [0.1, -0.2, 0.7], atol=1e-12
    )
    g = bench.signal(generic, q)
    np.testing.assert_allclose(g.error, signal.error[:2] + [0.1, -0.2], atol=1e-15)  # generic: s* = 0
    np.testing.assert_array_equal(g.jacobian, signal.jacobian[:2])


def test_posture_jacobian(control_model):
    plant, info, q0 = control_model
    rng = np.random.default_rng(4)
    joints = ["r_knee", "chest_yaw", "l_elbow"]
    feature = FeaturePosture(plant, joints, name="posture", desired=q0)
    bench = FeatureBench(plant, [feature], q_inputs=[feature]).build()
    q = random_configuration(plant, q0, rng)
    signal = fd_check(bench, feature, plant, q, rng)
    expected = [
        q[plant.GetJointByName(j).position_start()] - q0[plant.GetJointByName(j).position_start()]
        for j in joints
    ]
    np.testing.assert_allclose(signal.error, expected, atol=1e-15)


def test_joint_limits_rows_activate_past_the_margin(control_model):
    plant, info, q0 = control_model
    margin = 0.05
    feature = FeatureJointLimits(plant, ["r_knee", "l_knee"], margin=margin, name="jl")
    bench = FeatureBench(plant, [feature], q_inputs=[feature]).build()
    inside = bench.signal(feature, q0)
    np.testing.assert_array_equal(inside.error, 0.0)
    np.testing.assert_array_equal(inside.jacobian, 0.0)
    q = q0.copy()
    knee = plant.GetJointByName("r_knee")
    low = knee.position_lower_limits()[0]
    q[knee.position_start()] = low + 0.01  # inside the margin
    s = bench.signal(feature, q)
    assert s.error[0] == pytest.approx(0.01 - margin)
    assert s.jacobian[0, knee.velocity_start()] == 1.0 and np.count_nonzero(s.jacobian) == 1
    rng = np.random.default_rng(5)
    fd_check(bench, feature, plant, q, rng)


def test_bad_inputs_are_refused_with_names(control_model):
    plant, info, q0 = control_model
    with pytest.raises(ValueError, match="selection of 'f'"):
        FeaturePoint6d(name="f", selection="11100")
    with pytest.raises(ValueError, match="selects no component"):
        FeatureCoM(name="c", selection="000")
    with pytest.raises(ValueError, match="unknown joints \\['no_such_joint'\\]"):
        FeaturePosture(plant, ["no_such_joint"])
    with pytest.raises(ValueError, match="desired value"):
        FeatureGeneric(2, name="g", desired=[np.nan, 0.0])
    # A desired value set while the port is connected would be ignored: refused instead.
    from pydrake.systems.primitives import ConstantVectorSource

    builder = DiagramBuilder()
    feature = builder.AddSystem(FeatureGeneric(3, name="featureCom"))
    source = builder.AddSystem(ConstantVectorSource(np.array([0.0, 0.0, 0.64])))
    builder.Connect(source.get_output_port(), feature.GetInputPort("sdes"))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    with pytest.raises(ValueError, match="comes from input port 'sdes'"):
        feature.set_desired(context, np.zeros(3))
    np.testing.assert_array_equal(feature.desired(context), [0.0, 0.0, 0.64])


def test_pose_features_read_the_frame_input_as_the_two_paper_signals(control_model):
    """A pose feature fed ``dyn.<op>_frame`` on its ``frame`` input (one value: pose and Jacobian)
    gives the signal it gives fed ``dyn.<op>`` and ``dyn.J<op>`` on ``position`` and ``Jq``; its
    Jacobian also matches finite differences on its own."""
    plant, info, q0 = control_model
    rng = np.random.default_rng(8)
    desired = random_pose(rng)
    pairs = {
        "6d": (FeaturePoint6d(name="a", desired=desired), FeaturePoint6d(name="b", desired=desired)),
        "relative": (
            FeaturePoint6dRelative(name="c", desired=desired),
            FeaturePoint6dRelative(name="d", desired=desired),
        ),
        "visual": (FeatureVisualPoint(name="e"), FeatureVisualPoint(name="f")),
    }
    bench = FeatureBench(
        plant,
        [f for pair in pairs.values() for f in pair],
        op_points=[("rh", info.frames["right_hand"]), ("lh", info.frames["left_hand"])],
    )
    dyn = bench.dyn
    for one_value, two_signals in pairs.values():
        bench.connect(dyn.GetOutputPort("rh_frame"), one_value.GetInputPort("frame"))
        bench.connect(dyn.GetOutputPort("rh"), two_signals.GetInputPort("position"))
        bench.connect(dyn.GetOutputPort("Jrh"), two_signals.GetInputPort("Jq"))
    relative_one, relative_two = pairs["relative"]
    bench.connect(dyn.GetOutputPort("lh_frame"), relative_one.GetInputPort("frameRef"))
    bench.connect(dyn.GetOutputPort("lh"), relative_two.GetInputPort("positionRef"))
    bench.connect(dyn.GetOutputPort("Jlh"), relative_two.GetInputPort("JqRef"))
    bench.build()
    hand = plant.GetFrameByName(info.frames["right_hand"])
    for _ in range(3):
        q = random_configuration(plant, q0, rng)
        for feature in pairs["visual"]:  # a point 1 m along the hand frame's z axis (its optical axis)
            point = hand.CalcPoseInWorld(_positioned(plant, q)) @ np.array([0.1, -0.2, 1.0])
            feature.GetInputPort("point").FixValue(feature.GetMyMutableContextFromRoot(bench.context), point)
        for one_value, two_signals in pairs.values():
            a, b = bench.signal(one_value, q), bench.signal(two_signals, q)
            np.testing.assert_array_equal(a.error, b.error)
            np.testing.assert_array_equal(a.jacobian, b.jacobian)
            np.testing.assert_array_equal(a.feedforward, b.feedforward)
        fd_check(bench, pairs["6d"][0], plant, q, rng, n_dirs=3)


def test_a_pose_feature_fed_both_ways_is_refused_naming_it(control_model):
    plant, info, q0 = control_model
    feature = FeaturePoint6d(name="both")
    bench = FeatureBench(plant, [feature], op_points=[("rh", info.frames["right_hand"])])
    bench.connect(bench.dyn.GetOutputPort("rh_frame"), feature.GetInputPort("frame"))
    bench.connect(bench.dyn.GetOutputPort("rh"), feature.GetInputPort("position"))
    bench.build()
    with pytest.raises(RuntimeError, match=r"'both': inputs 'frame' and 'position'/'Jq' both have a value"):
        bench.signal(feature, q0)


def test_a_new_desired_value_reaches_the_cached_form_at_once(control_model):
    """The desired value is prepared in a cache entry: setting the parameter, or fixing the
    input port, must change the very next evaluation (no stale cache)."""
    plant, info, q0 = control_model
    feature = FeaturePoint6d(name="rh")
    bench = FeatureBench(plant, [feature], op_points=[("rh", info.frames["right_hand"])])
    bench.connect(bench.dyn.GetOutputPort("rh_frame"), feature.GetInputPort("frame"))
    bench.build()
    X = plant.GetFrameByName(info.frames["right_hand"]).CalcPoseInWorld(_positioned(plant, q0))
    feature.set_desired(bench.context, X)
    np.testing.assert_allclose(bench.signal(feature, q0).error, 0.0, atol=1e-12)
    shifted = RigidTransform(X.rotation(), X.translation() + [0.1, -0.2, 0.3])
    feature.set_desired(bench.context, shifted)
    np.testing.assert_allclose(bench.signal(feature, q0).error[:3], [-0.1, 0.2, -0.3], atol=1e-12)
    moved = RigidTransform(X.rotation(), X.translation() + [0.0, 0.0, -0.5])
    feature.GetInputPort("position_des").FixValue(feature.GetMyMutableContextFromRoot(bench.context), moved)
    np.testing.assert_allclose(bench.signal(feature, q0).error[:3], [0.0, 0.0, 0.5], atol=1e-12)
    posture = FeaturePosture(plant, name="posture")
    bench = FeatureBench(plant, [posture], q_inputs=[posture]).build()
    target = q0.copy()
    target[7:] += 0.1
    posture.set_desired(bench.context, target)
    np.testing.assert_allclose(bench.signal(posture, q0).error, -0.1, atol=1e-12)


def _positioned(plant, q):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    return context
