"""HumanoidSoTBuilder: wiring checks that do not need a long simulation."""

import numpy as np
import pytest

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder


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
    with pytest.raises(KeyError, match="unknown frame 'nose'; known: .*right_hand"):
        b.add_op_point_task("taskNose", "nose")
    with pytest.raises(KeyError, match="unknown task 'taskX'; known tasks: taskCom"):
        b.build(stack=["taskX"])
