"""Physical facts about the embedded humanoid.

Reference values come from HRP-2 (the names, order and half-sitting angles of the
brief, its leg dimensions) or from physics (weights, support polygons), and are
measured on the plant and its SceneGraph, never read back from the model's tables.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.geometry import Role
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    ExternallyAppliedSpatialForce,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from scipy.spatial import ConvexHull

from drake_sot.models import (
    HumanoidInfo,
    add_ground,
    half_sitting_configuration,
    load_humanoid,
    make_control_model,
)

ACTUATOR_ORDER = (
    "r_hip_yaw", "r_hip_roll", "r_hip_pitch", "r_knee", "r_ankle_pitch", "r_ankle_roll",
    "l_hip_yaw", "l_hip_roll", "l_hip_pitch", "l_knee", "l_ankle_pitch", "l_ankle_roll",
    "chest_yaw", "chest_pitch", "head_yaw", "head_pitch",
    "r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw", "r_elbow", "r_wrist_yaw", "r_wrist_pitch",
    "l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow", "l_wrist_yaw", "l_wrist_pitch",
    "r_gripper", "l_gripper",
)  # fmt: skip
HRP2_LEG = (0.0, 0.0, -0.453786, 0.872665, -0.418879, 0.0)
HALF_SITTING = dict(
    zip(ACTUATOR_ORDER, HRP2_LEG + HRP2_LEG + (0.0, 0.0) + (0.0, 0.0)
        + (0.261799, -0.174533, 0.0, -0.523599, 0.0, 0.0)
        + (0.261799, 0.174533, 0.0, -0.523599, 0.0, 0.0) + (0.1, 0.1), strict=False)
)  # fmt: skip
#: HRP-2 leg: thigh 0.30 m, shank 0.30 m, ankle 0.105 m above the sole.
HRP2_PELVIS_HEIGHT = 0.105 + 0.30 * math.cos(0.453786) + 0.30 * math.cos(0.872665 - 0.453786)
SIM_CONFIG = dict(time_step=1e-3, discrete_contact_approximation="sap", contact_model="point")


# --------------------------------------------------------------------------- helpers


def _joint_positions(plant: MultibodyPlant, q: np.ndarray) -> np.ndarray:
    """Actuated joint angles in actuator order, read joint by joint from q."""
    return np.array([q[plant.GetJointByName(name).position_start()] for name in ACTUATOR_ORDER])


def _geometries(plant, scene_graph, body_names, role):
    """(body, shape, X_BG) of the geometries with `role` on the named bodies."""
    inspector = scene_graph.model_inspector()
    found = []
    for name in body_names:
        body = plant.GetBodyByName(name)
        frame_id = plant.GetBodyFrameIdOrThrow(body.index())
        for geometry in inspector.GetGeometries(frame_id, role):
            found.append((body, inspector.GetShape(geometry), inspector.GetPoseInFrame(geometry)))
    return found


def _sole_contact_points(plant, scene_graph, context) -> np.ndarray:
    """World positions of the lowest points of the foot contact spheres."""
    points = []
    for body, sphere, X_BG in _geometries(plant, scene_graph, ("r_foot", "l_foot"), Role.kProximity):
        centre = body.EvalPoseInWorld(context) @ X_BG.translation()
        points.append(centre - [0.0, 0.0, sphere.radius()])
    return np.array(points)


def _outboard_mass(plant: MultibodyPlant, joint_name: str) -> float:
    """Mass of the bodies on the child side of a joint, found by walking the tree."""
    parent_of = {}
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        parent_of[joint.child_body().index()] = joint.parent_body().index()
    root = plant.GetJointByName(joint_name).child_body().index()
    mass = 0.0
    for index in plant.GetBodyIndices(plant.GetJointByName(joint_name).model_instance()):
        body = index
        while body != root and body in parent_of:
            body = parent_of[body]
        if body == root:
            mass += plant.get_body(index).default_mass()
    return mass


def _tilt(rotation) -> float:
    """Angle (rad) between a frame's z axis and the world's z axis."""
    return math.acos(np.clip(rotation.matrix()[2, 2], -1.0, 1.0))


# --------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def control():
    return make_control_model()


@pytest.fixture(scope="module")
def world():
    """A simulation diagram: the humanoid with PD servos, on the ground."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(**SIM_CONFIG), builder)
    info = load_humanoid(plant)
    add_ground(plant)
    plant.Finalize()
    return builder.Build(), plant, scene_graph, info


@pytest.fixture(scope="module")
def posed(world):
    """The world's plant context in half-sitting."""
    _, plant, scene_graph, info = world
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    return plant, scene_graph, info, context


def _start(world):
    """A simulator in half-sitting, servos holding half-sitting; returns (sim, plant context)."""
    diagram, plant, _, info = world
    simulator = Simulator(diagram)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    desired = np.concatenate([[HALF_SITTING[j] for j in ACTUATOR_ORDER], np.zeros(30)])
    plant.get_desired_state_input_port(info.model_instance).FixValue(context, desired)
    plant.get_applied_spatial_force_input_port().FixValue(context, [])
    simulator.Initialize()
    return simulator, context


@pytest.fixture(scope="module")
def standing(world):
    """Stand for 3 s; record what the physics tests check."""
    _, plant, _, info = world
    simulator, context = _start(world)
    q0 = plant.GetPositions(context)
    soles = [plant.GetFrameByName(info.frames[f]) for f in ("left_foot", "right_foot")]
    torso = plant.GetBodyByName("torso")
    sole_start = [s.CalcPoseInWorld(context).translation() for s in soles]
    record = dict(joint_error=0.0, pelvis_dz=0.0, slide=0.0, torso_tilt=0.0, sole_tilt=0.0)
    for t in np.arange(0.01, 3.0 + 1e-9, 0.01):
        simulator.AdvanceTo(t)
        q = plant.GetPositions(context)
        record["joint_error"] = max(record["joint_error"], np.abs(_joint_positions(plant, q - q0)).max())
        record["pelvis_dz"] = max(record["pelvis_dz"], abs(q[6] - q0[6]))
        for sole, start in zip(soles, sole_start, strict=False):
            X = sole.CalcPoseInWorld(context)
            record["slide"] = max(record["slide"], np.linalg.norm((X.translation() - start)[:2]))
            record["sole_tilt"] = max(record["sole_tilt"], _tilt(X.rotation()))
        record["torso_tilt"] = max(record["torso_tilt"], _tilt(torso.EvalPoseInWorld(context).rotation()))
    reactions = plant.get_reaction_forces_output_port().Eval(context)
    record["sensor_force_W"] = {}
    for sensor, joint_name in info.force_sensors.items():
        joint = plant.GetJointByName(joint_name)
        R_WJ = joint.frame_on_child().CalcPoseInWorld(context).rotation()
        record["sensor_force_W"][sensor] = R_WJ @ reactions[int(joint.index())].translational()
    return record


# --------------------------------------------------------------------------- structure


def test_actuators_are_the_30_hrp2_joints_in_order(control):
    plant, info = control
    assert isinstance(info, HumanoidInfo)
    assert info.actuated_joints == ACTUATOR_ORDER
    assert plant.num_actuators() == 30 == plant.num_actuated_dofs()
    assert plant.GetActuatorNames(info.model_instance, add_model_instance_prefix=False) == list(
        ACTUATOR_ORDER
    )
    for k, name in enumerate(ACTUATOR_ORDER):
        actuator = plant.GetJointActuatorByName(name)
        assert actuator.joint().name() == name and actuator.input_start() == k
        assert actuator.joint().type_name() == "revolute"


def test_state_layout_floating_base_first_then_joints(control):
    plant, info = control
    assert (plant.num_positions(), plant.num_velocities()) == (37, 36)
    base = plant.GetBodyByName(info.base_body)
    assert info.base_body == "pelvis" and base.is_floating_base_body()
    assert (base.floating_positions_start(), base.floating_velocities_start_in_v()) == (0, 0)
    # Drake numbers a tree depth first: the joints follow the actuator order except
    # the grippers, which come right after their own wrist (children of the hands).
    q_order = sorted(ACTUATOR_ORDER, key=lambda j: plant.GetJointByName(j).position_start())
    expected = list(ACTUATOR_ORDER[:22]) + ["r_gripper"] + list(ACTUATOR_ORDER[22:28]) + ["l_gripper"]
    assert q_order == expected
    for k, name in enumerate(q_order):
        joint = plant.GetJointByName(name)
        assert (joint.position_start(), joint.velocity_start()) == (7 + k, 6 + k)
    # The actuation matrix maps actuator k onto its own joint's velocity.
    B = plant.MakeActuationMatrix()
    for k, name in enumerate(ACTUATOR_ORDER):
        assert B[plant.GetJointByName(name).velocity_start(), k] == 1.0 and B[:, k].sum() == 1.0


def test_half_sitting_angles_and_limits_are_hrp2(control):
    plant, info = control
    assert dict(info.half_sitting) == pytest.approx(HALF_SITTING)
    for name in ACTUATOR_ORDER:
        joint = plant.GetJointByName(name)
        lo, hi = joint.position_lower_limits()[0], joint.position_upper_limits()[0]
        assert lo < HALF_SITTING[name] < hi
        assert 0.0 < joint.velocity_upper_limits()[0] < 10.0
        assert joint.velocity_lower_limits()[0] == -joint.velocity_upper_limits()[0]
        assert 0.0 < plant.GetJointActuatorByName(name).effort_limit() <= 300.0
    knee = plant.GetJointByName("r_knee")
    assert knee.position_lower_limits()[0] == pytest.approx(0.0, abs=0.01)
    assert knee.position_upper_limits()[0] == pytest.approx(2.6, abs=0.05)
    hip = plant.GetJointByName("l_hip_pitch")
    assert (hip.position_lower_limits()[0], hip.position_upper_limits()[0]) == pytest.approx(
        (-2.2, 0.7), abs=0.05
    )


def test_the_head_camera_looks_forward_from_the_face_with_image_x_right_and_y_down(control):
    """In half-sitting (head straight), the optical axis z_C is the world's +x, image x (right of
    the robot) the world's -y, image y (down) the world's -z; the camera sits on the front face of
    the head box (0.16 m deep, centred 1 cm ahead of the head frame)."""
    plant, info = control
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    X_WC = plant.GetFrameByName(info.frames["head_camera"]).CalcPoseInWorld(context)
    X_WH = plant.GetFrameByName(info.frames["head"]).CalcPoseInWorld(context)
    R = X_WC.rotation().matrix()
    np.testing.assert_allclose(R[:, 2], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(R[:, 0], [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(R[:, 1], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(
        X_WC.translation() - X_WH.translation(), [0.01 + 0.16 / 2, 0, 0.05], atol=1e-12
    )
    assert plant.GetFrameByName("head_camera").body().name() == "head"


def test_bodies_frames_and_force_sensors_exist(control):
    plant, info = control
    for body in ("pelvis", "torso", "head", "r_foot", "l_foot", "r_hand", "l_hand"):
        assert plant.HasBodyNamed(body, info.model_instance)
    assert dict(info.frames) == {
        "pelvis": "pelvis", "waist": "pelvis", "torso": "torso", "head": "head", "head_camera": "head_camera",
        "left_foot": "l_sole", "right_foot": "r_sole",
        "left_ankle": "l_ankle_roll_link", "right_ankle": "r_ankle_roll_link",
        "left_wrist": "l_wrist_pitch_link", "right_wrist": "r_wrist_pitch_link",
        "left_hand": "l_hand_tool", "right_hand": "r_hand_tool",
    }  # fmt: skip
    for frame in info.frames.values():
        assert plant.HasFrameNamed(frame, info.model_instance)
    sensors = {"left_ankle": ("l_ankle_ft", "l_foot"), "right_ankle": ("r_ankle_ft", "r_foot"),
               "left_wrist": ("l_wrist_ft", "l_hand"), "right_wrist": ("r_wrist_ft", "r_hand")}  # fmt: skip
    assert dict(info.force_sensors) == {k: v[0] for k, v in sensors.items()}
    for joint_name, child in sensors.values():
        joint = plant.GetJointByName(joint_name)
        assert joint.type_name() == "weld" and joint.child_body().name() == child


def test_mass_is_hrp2_class(control):
    plant, info = control
    mass = sum(plant.get_body(b).default_mass() for b in plant.GetBodyIndices(info.model_instance))
    assert 56.0 <= mass <= 60.0
    assert info.mass == pytest.approx(mass)


def test_control_model_is_continuous_without_geometry_or_servos(control):
    plant, info = control
    assert plant.is_finalized() and plant.time_step() == 0.0
    assert not plant.geometry_source_is_registered()
    assert not any(plant.get_joint_actuator(a).has_controller() for a in plant.GetJointActuatorIndices())


def test_pd_gains_only_when_asked():
    with_gains, without = MultibodyPlant(1e-3), MultibodyPlant(1e-3)
    load_humanoid(with_gains)
    load_humanoid(without, pd_gains=False)
    for plant in (with_gains, without):
        plant.Finalize()
    for a in with_gains.GetJointActuatorIndices():
        gains = with_gains.get_joint_actuator(a).get_controller_gains()
        assert gains.p > 0.0 and gains.d > 0.0
    assert not any(without.get_joint_actuator(a).has_controller() for a in without.GetJointActuatorIndices())


def test_misuse_is_refused():
    plant = MultibodyPlant(0.0)
    with pytest.raises(RuntimeError, match="SceneGraph"):
        add_ground(plant)
    plant.Finalize()
    with pytest.raises(RuntimeError, match="finalized"):
        load_humanoid(plant)


# --------------------------------------------------------------------------- half-sitting


def test_half_sitting_soles_flat_on_the_ground(posed):
    plant, _, info, context = posed
    for foot in ("left_foot", "right_foot"):
        X = plant.GetFrameByName(info.frames[foot]).CalcPoseInWorld(context)
        assert X.translation()[2] == pytest.approx(0.0, abs=1e-9)
        assert np.allclose(X.rotation().matrix(), np.eye(3), atol=1e-9)
    X_pelvis = plant.GetBodyByName("pelvis").EvalPoseInWorld(context)
    assert X_pelvis.translation() == pytest.approx([0.0, 0.0, HRP2_PELVIS_HEIGHT], abs=1e-6)
    assert np.allclose(X_pelvis.rotation().matrix(), np.eye(3))
    # The default state is half-sitting too, and it respects the joint limits.
    q = plant.GetPositions(context)
    assert plant.GetDefaultPositions() == pytest.approx(q)
    assert np.all(q >= plant.GetPositionLowerLimits()) and np.all(q <= plant.GetPositionUpperLimits())


def test_half_sitting_is_a_knees_bent_stance_with_arms_forward_and_out(posed):
    plant, _, _, context = posed

    def p(body):
        return plant.GetBodyByName(body).EvalPoseInWorld(context).translation()

    for s in ("r", "l"):
        hip, knee, ankle = p(f"{s}_thigh"), p(f"{s}_shank"), p(f"{s}_ankle_pitch_link")
        assert knee[0] > hip[0] + 0.1 and knee[0] > ankle[0] + 0.1  # knees bent forward
        shoulder, elbow, wrist = p(f"{s}_shoulder_roll_link"), p(f"{s}_forearm"), p(f"{s}_wrist_yaw_link")
        tool = plant.GetFrameByName(f"{s}_hand_tool").CalcPoseInWorld(context).translation()
        assert wrist[0] > elbow[0] and tool[0] > shoulder[0]  # forearm and hand forward
        assert abs(tool[1]) > abs(elbow[1]) > abs(shoulder[1])  # arm opened away from the body
        assert shoulder[2] == pytest.approx(1.2, abs=0.05) and tool[2] < elbow[2] < shoulder[2]


def test_half_sitting_com_height_and_support(posed):
    plant, scene_graph, info, context = posed
    com = plant.CalcCenterOfMassPositionInWorld(context, [info.model_instance])
    assert 0.78 <= com[2] <= 0.84
    contacts = _sole_contact_points(plant, scene_graph, context)
    hull = ConvexHull(contacts[:, :2])
    distance_inside = -(hull.equations[:, :2] @ com[:2] + hull.equations[:, 2]).max()
    assert distance_inside > 0.05  # well inside the double-support polygon


def test_feet_touch_the_ground_at_eight_sole_corners(posed):
    plant, scene_graph, _, context = posed
    inspector = scene_graph.model_inspector()
    colliding = {inspector.GetFrameId(g) for g in inspector.GetAllGeometryIds(Role.kProximity)}
    foot_frames = {plant.GetBodyFrameIdOrThrow(plant.GetBodyByName(f).index()) for f in ("r_foot", "l_foot")}
    assert colliding == foot_frames | {inspector.world_frame_id()}  # feet and ground only
    points = _sole_contact_points(plant, scene_graph, context)
    assert len(points) == 8 and np.allclose(points[:, 2], 0.0, atol=1e-9)
    for side in (points[points[:, 1] > 0], points[points[:, 1] < 0]):
        extent = side.max(axis=0) - side.min(axis=0)
        assert extent[:2] == pytest.approx([0.23, 0.13], abs=0.02)  # HRP-2 sole size


def test_head_top_is_about_1_5_m(posed):
    plant, scene_graph, _, context = posed
    top = -np.inf
    for body, box, X_BG in _geometries(plant, scene_graph, ("head",), Role.kIllustration):
        X_WG = body.EvalPoseInWorld(context) @ X_BG
        half = np.array([box.width(), box.depth(), box.height()]) / 2
        corners = [X_WG @ (half * [sx, sy, sz]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
        top = max(top, max(c[2] for c in corners))
    assert top == pytest.approx(1.5, abs=0.08)


# --------------------------------------------------------------------------- physics


@pytest.mark.slow
def test_stands_still_on_its_servos(standing):
    assert standing["pelvis_dz"] < 0.01
    assert standing["joint_error"] < 0.03
    assert standing["slide"] < 0.001
    assert standing["sole_tilt"] < 0.01
    assert standing["torso_tilt"] < math.radians(2.0)


@pytest.mark.slow
def test_force_sensors_weigh_what_hangs_on_them(world, standing):
    _, plant, _, info = world
    g = -plant.gravity_field().gravity_vector()[2]
    robot_mass = sum(plant.get_body(b).default_mass() for b in plant.GetBodyIndices(info.model_instance))
    feet = _outboard_mass(plant, "l_ankle_ft") + _outboard_mass(plant, "r_ankle_ft")
    forces = standing["sensor_force_W"]
    # On the foot from the ankle: everything above the sensors pushes down.
    vertical = forces["left_ankle"][2] + forces["right_ankle"][2]
    assert vertical == pytest.approx(-(robot_mass - feet) * g, rel=0.03)
    # On the hand from the wrist: the wrist holds up the hand and its finger.
    for wrist, sensor in (("left_wrist", "l_wrist_ft"), ("right_wrist", "r_wrist_ft")):
        assert forces[wrist][2] == pytest.approx(_outboard_mass(plant, sensor) * g, rel=0.03)


@pytest.mark.slow
def test_withstands_a_100_N_side_push(world):
    _, plant, _, info = world
    simulator, context = _start(world)
    torso = plant.GetBodyByName("torso")
    push = ExternallyAppliedSpatialForce()
    push.body_index = torso.index()
    push.p_BoBq_B = [0.0, 0.0, 0.15]
    push.F_Bq_W = SpatialForce(tau=[0.0, 0.0, 0.0], f=[0.0, 100.0, 0.0])
    simulator.AdvanceTo(0.5)
    z0 = plant.GetPositions(context)[6]
    plant.get_applied_spatial_force_input_port().FixValue(context, [push])
    simulator.AdvanceTo(0.6)
    plant.get_applied_spatial_force_input_port().FixValue(context, [])
    worst_tilt = 0.0
    for t in np.arange(0.65, 2.5 + 1e-9, 0.05):
        simulator.AdvanceTo(t)
        worst_tilt = max(worst_tilt, _tilt(torso.EvalPoseInWorld(context).rotation()))
    assert worst_tilt < math.radians(10.0)
    assert plant.GetPositions(context)[6] == pytest.approx(z0, abs=0.01)
    for foot in ("left_foot", "right_foot"):
        X = plant.GetFrameByName(info.frames[foot]).CalcPoseInWorld(context)
        assert abs(X.translation()[2]) < 0.002 and _tilt(X.rotation()) < 0.01
