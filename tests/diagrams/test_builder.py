"""HumanoidSoTBuilder: wiring checks that do not need a long simulation."""

import numpy as np
import pytest

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.errors import UnknownNameError
from drake_sot.robots.description import LOGICAL_FRAMES


def test_relative_feet_task_holds_the_stance_while_the_robot_stands():
    """The paper's featureTwofeet: right sole relative to left sole, at the top of the stack."""
    b = HumanoidSoTBuilder()
    b.add_relative_task("taskTwofeet", "right_foot", "left_foot", gain=5.0)
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_com_task("taskCom", gain=2.0, desired=b.initial_com() + [0.0, 0.02, 0.0])
    b.add_posture_task("taskPosture")
    built = b.build(stack=["taskLF", "taskTwofeet", "taskCom", "taskPosture"])
    simulator = built.create_simulator()
    context = simulator.get_context()
    X0 = built.frame_pose(context, "left_foot").InvertAndCompose(built.frame_pose(context, "right_foot"))
    simulator.AdvanceTo(1.5)
    X1 = built.frame_pose(context, "left_foot").InvertAndCompose(built.frame_pose(context, "right_foot"))
    assert np.linalg.norm(X1.translation() - X0.translation()) < 0.002
    # The CoM moved 2 cm toward the left foot on the simulated plant.
    com = built.plant.CalcCenterOfMassPositionInWorld(built.plant.GetMyContextFromRoot(context))
    assert com[1] == pytest.approx(0.02, abs=0.004)


def test_duplicate_and_unknown_names_are_refused():
    b = HumanoidSoTBuilder()
    b.add_com_task("taskCom")
    with pytest.raises(ValueError, match="'taskCom' exists already"):
        b.add_com_task("taskCom")
    frames = ", ".join(sorted(LOGICAL_FRAMES))  # the embedded robot gives exactly the logical frames
    with pytest.raises(UnknownNameError, match=f"^unknown frame 'nose'; known: {frames}$") as caught:
        b.add_op_point_task("taskNose", "nose")
    assert caught.value.kind == "frame" and isinstance(caught.value, KeyError)
    with pytest.raises(
        UnknownNameError,
        match=r"^StackOfTasks 'sot': the stack \('taskX',\): unknown task 'taskX'; known: taskCom$",
    ):
        b.build(stack=["taskX"])
    built = b.build(stack=["taskCom"])
    with pytest.raises(
        UnknownNameError,
        match=f"^unknown frame 'left_hnd' \\(did you mean 'left_hand'\\?\\); known: {frames}$",
    ):
        built.frame_pose(built.diagram.CreateDefaultContext(), "left_hnd")


def test_tasks_on_one_frame_can_share_its_pose_feature():
    """feature_of: the position and orientation tasks of a hand read one FeaturePoint6d,
    each its own rows; refusals name the task, the frame or the argument."""
    from pydrake.math import RigidTransform

    from drake_sot.systems.features import FeaturePoint6d

    b = HumanoidSoTBuilder()
    b.add_op_point_task("taskRH", "right_hand", selection="111000")
    b.add_op_point_task("taskRHo", "right_hand", selection="000111", feature_of="taskRH")
    b.add_posture_task("taskPosture")
    with pytest.raises(
        ValueError,
        match="feature_of='taskPosture': no op-point task of that name; op-point tasks: "
        r"\['taskRH', 'taskRHo'\]",
    ):
        b.add_op_point_task("taskX", "right_hand", feature_of="taskPosture")
    with pytest.raises(
        ValueError, match="feature_of='taskRH': that task's feature is on frame 'right_hand', not 'left_hand'"
    ):
        b.add_op_point_task("taskX", "left_hand", feature_of="taskRH")
    with pytest.raises(
        ValueError, match="feature_of='taskRH': the desired pose is that of the shared feature"
    ):
        b.add_op_point_task("taskX", "right_hand", feature_of="taskRH", desired=RigidTransform())
    built = b.build(stack=["taskRH", "taskRHo", "taskPosture"])
    assert built.features["taskRH"] is built.features["taskRHo"]
    assert sum(isinstance(s, FeaturePoint6d) for s in built.diagram.GetSystems()) == 1
    context = built.diagram.CreateDefaultContext()
    X0 = b.initial_pose("right_hand")
    shift = np.array([0.03, -0.02, 0.05])
    built.features["taskRH"].set_desired(context, RigidTransform(X0.rotation(), X0.translation() + shift))
    rh = built.tasks["taskRH"].GetOutputPort("task").Eval(built.tasks["taskRH"].GetMyContextFromRoot(context))
    rho = (
        built.tasks["taskRHo"]
        .GetOutputPort("task")
        .Eval(built.tasks["taskRHo"].GetMyContextFromRoot(context))
    )
    np.testing.assert_allclose(rh.error, -shift, atol=1e-12)  # e = p - p*
    np.testing.assert_allclose(rho.error, np.zeros(3), atol=1e-12)  # same orientation
    assert rh.jacobian.shape == rho.jacobian.shape == (3, built.control_plant.num_velocities())


def test_inequality_tasks_by_name_need_the_hqp_solver():
    """Building an svd stack that holds inequality tasks is refused, naming them all."""
    b = HumanoidSoTBuilder()
    b.add_joint_velocity_limits_task("taskVL", scale=0.5)
    b.add_joint_position_limits_task("taskJL", margin=0.05)
    b.add_com_support_task("taskSupport", margin=0.01, gain=2.0)
    table = b.initial_pose("right_hand").translation()[2] - 0.1  # a table 10 cm under the hand
    b.add_above_plane_task("taskTable", "right_hand", origin=(0.0, 0.0, table), clearance=0.03, gain=4.0)
    b.add_distance_task("taskHands", "right_hand", "left_hand", minimum=0.1, gain=3.0)
    b.add_posture_task("taskPosture")
    names = ["taskVL", "taskJL", "taskSupport", "taskTable", "taskHands", "taskPosture"]
    with pytest.raises(ValueError, match=r"inequality tasks \['taskHands', .*'taskVL'\] need solver='hqp'"):
        b.build(stack=names)


def test_inequality_tasks_by_name_at_the_initial_posture():
    """Each builder method wires its inequality task to dyn (and the device): the bounds at the
    initial posture against the geometry measured here."""
    b = HumanoidSoTBuilder()
    b.add_joint_position_limits_task("taskJL", margin=0.05)
    b.add_com_support_task("taskSupport", margin=0.01, gain=2.0)
    hand = b.initial_pose("right_hand").translation()
    b.add_above_plane_task(
        "taskTable", "right_hand", origin=(0.0, 0.0, hand[2] - 0.1), clearance=0.03, gain=4.0
    )
    b.add_distance_task("taskHands", "right_hand", "left_hand", minimum=0.1, gain=3.0)
    b.add_posture_task("taskPosture")
    built = b.build(stack=["taskJL", "taskSupport", "taskTable", "taskHands", "taskPosture"], solver="hqp")
    context = built.diagram.CreateDefaultContext()

    def signal(name):
        task = built.tasks[name]
        return task.GetOutputPort("task").Eval(task.GetMyContextFromRoot(context))

    assert signal("taskTable").lower[0] == pytest.approx(4.0 * (0.03 - 0.1), abs=1e-12)
    distance = np.linalg.norm(hand - b.initial_pose("left_hand").translation())
    assert signal("taskHands").lower[0] == pytest.approx(3.0 * (0.1 - distance), abs=1e-12)
    support = signal("taskSupport")
    assert not support.error.any() and (support.lower[np.isfinite(support.lower)] < 0.0).all()  # CoM inside
    # Half-sitting is inside every joint's limits: the position bounds straddle zero.
    jl = signal("taskJL")
    assert (jl.lower < 0.0).all() and (jl.upper > 0.0).all()
    assert built.sot.solver == "hqp"
    # Standing still, the stack holds: q̇ stays zero (no limit, no support row is violated).
    simulator = built.create_simulator()
    simulator.AdvanceTo(0.05)
    np.testing.assert_allclose(
        built.sot.GetOutputPort("qdot").Eval(built.sot.GetMyContextFromRoot(simulator.get_context())),
        0.0,
        atol=1e-9,
    )


def test_the_torque_builder_refuses_inequality_tasks():
    from drake_sot.diagrams.torque_humanoid import TorqueHumanoidBuilder

    b = TorqueHumanoidBuilder(fixed_base=True)
    b.add_joint_velocity_limits_task("taskVL")
    b.add_posture_task("taskPosture")
    with pytest.raises(ValueError, match=r"inequality task\(s\) \['taskVL'\]: they belong to the kinematic"):
        b.build(motion=[("taskVL", 10, 1), ("taskPosture", 16, 8)], priorities=None)  # refused before


def test_a_given_initial_configuration_is_where_the_robot_starts_and_a_bad_one_is_refused():
    """The simulated robot and the reference start at the given q0: the right hand sits where
    the control model puts it in that configuration (computed on a fresh model)."""
    from drake_sot.models import half_sitting_configuration, make_control_model

    plant, info = make_control_model()
    q0 = half_sitting_configuration(plant, info)
    q0[plant.GetJointByName("r_elbow").position_start()] = -1.3
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q0)
    hand = plant.GetFrameByName(info.frames["right_hand"]).CalcPoseInWorld(context).translation()

    b = HumanoidSoTBuilder(q0=q0)
    np.testing.assert_allclose(b.initial_pose("right_hand").translation(), hand, atol=1e-12)
    b.add_posture_task("taskPosture")
    built = b.build(stack=["taskPosture"])
    simulator = built.create_simulator()
    np.testing.assert_allclose(
        built.frame_pose(simulator.get_context(), "right_hand").translation(), hand, atol=1e-9
    )
    with pytest.raises(ValueError, match="q0"):
        HumanoidSoTBuilder(q0=np.zeros(3))


@pytest.mark.parametrize(
    ("task", "feature"),
    [
        ("taskCom", "featureCom"),  # the paper's script: new FeatureCoM featureCom; taskCom.add featureCom
        ("taskTwofeet", "featureTwofeet"),
        ("taskRH", "featureRH"),
        ("taskcom", "feature_taskcom"),  # not task<Name>: the task's whole name, prefixed
        ("task", "feature_task"),
        ("posture", "feature_posture"),
    ],
)
def test_features_are_named_as_the_sot_scripts_name_them(task, feature):
    """A builder's feature of ``taskX`` is ``featureX`` (Mansard et al. 2009), in the diagram too."""
    builder = HumanoidSoTBuilder()
    builder.add_com_task(task)
    assert builder.features[task].get_name() == feature


def test_the_builders_damping_reaches_the_stack():
    """``build(damping=)``: a posture task alone (its Jacobian selects the actuated joints, σ = 1)
    damped by μ gives the undamped first-tick q̇ divided by 1 + μ² (damped least squares,
    σ / (σ² + μ²)), for one μ and for μ by task name; the floating base does not move."""
    mu = 0.5

    def first_qdot(**damping) -> np.ndarray:
        b = HumanoidSoTBuilder()
        b.add_posture_task("taskPosture", desired=b.q0 + np.where(np.arange(len(b.q0)) >= 7, 0.1, 0.0))
        built = b.build(stack=["taskPosture"], solver="hqp", **damping)
        simulator = built.create_simulator()
        simulator.AdvanceTo(0.001)  # the event at t = 0
        return built.sot.GetOutputPort("qdot").Eval(built.sot.GetMyContextFromRoot(simulator.get_context()))

    exact = first_qdot()
    assert np.abs(exact[6:]).min() > 0.05 and np.allclose(exact[:6], 0.0, atol=1e-12)
    np.testing.assert_allclose(first_qdot(damping=mu), exact / (1.0 + mu**2), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(
        first_qdot(damping={"taskPosture": mu}), exact / (1.0 + mu**2), rtol=1e-9, atol=1e-12
    )
