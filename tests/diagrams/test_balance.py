"""The balance stabilizer's place in the diagrams: between the pattern generator and the CoM
task in ``walk`` and ``walk_then_interact`` unless switched off, from the command line too,
and on a standing stack; no physics."""

from __future__ import annotations

import numpy as np
import pytest

from drake_sot import cli
from drake_sot.diagrams import walk, walk_then_interact
from drake_sot.diagrams.balance import add_hip_strategy, add_stabilizer
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder


def _com_reference_source(built) -> str:
    """Name of the system whose output feeds the CoM feature's desired value."""
    feature = built.features["taskCom"]
    sdes = feature.GetInputPort("sdes").get_index()
    for (dst, dst_index), (src, _) in built.diagram.connection_map().items():
        if dst is feature and dst_index == sdes:
            return src.get_name()
    raise AssertionError("taskCom's sdes is not connected")


@pytest.mark.parametrize("scenario", [walk, walk_then_interact])
def test_the_stabilizer_feeds_the_com_task_by_default_and_can_be_switched_off(scenario):
    on = scenario.build().built
    assert _com_reference_source(on) == "stabilizer"
    assert {"stabilizer_offset", "stabilizer_saturated", "zmp_desired", "dcm"} <= set(on.loggers)
    off = scenario.build(stabilizer=False).built
    assert _com_reference_source(off) == "pg"
    assert not any(s.get_name() == "stabilizer" for s in off.diagram.GetSystems())
    # one ZMP estimator (the walk also logs it: the stabilizer reads the same one)
    assert sum(s.get_name() == "zmp_estimator" for s in on.diagram.GetSystems()) == 1


def test_standing_the_references_are_the_initial_com_at_rest():
    b = HumanoidSoTBuilder()
    b.add_com_task("taskCom", selection="110")
    stabilizer = add_stabilizer(b, "taskCom")
    built = b.build(stack=["taskCom"])
    context = stabilizer.GetMyContextFromRoot(built.create_simulator().get_context())
    np.testing.assert_array_equal(stabilizer.GetInputPort("com_ref").Eval(context), b.initial_com())
    np.testing.assert_array_equal(stabilizer.GetInputPort("com_vel_ref").Eval(context), np.zeros(3))
    np.testing.assert_array_equal(stabilizer.GetInputPort("zmp_ref").Eval(context), b.initial_com()[:2])


def test_the_hip_strategy_leans_the_pelvis_orientation_task_from_the_stabilizer():
    """Standing at rest: the DCM inside, the trunk task's reference is the initial pelvis
    orientation; the lean and the DCM's excess are logged."""
    b = HumanoidSoTBuilder()
    b.add_com_task("taskCom", selection="110")
    b.add_posture_task("taskPosture")
    hip = add_hip_strategy(b, add_stabilizer(b, "taskCom"))
    built = b.build(stack=["taskCom", "taskTrunk", "taskPosture"])
    assert {"hip_lean", "dcm_excess"} <= set(built.loggers)
    feature = built.features["taskTrunk"]
    simulator = built.create_simulator()
    simulator.AdvanceTo(0.05)
    context = feature.GetMyContextFromRoot(simulator.get_context())
    desired = feature.GetInputPort("position_des").Eval(context)
    np.testing.assert_allclose(
        desired.rotation().matrix(), b.initial_pose("pelvis").rotation().matrix(), atol=1e-12
    )
    np.testing.assert_array_equal(feature.GetInputPort("velocity_des").Eval(context), np.zeros(6))
    np.testing.assert_array_equal(
        hip.GetOutputPort("lean").Eval(hip.GetMyContextFromRoot(simulator.get_context())), np.zeros(3)
    )


def test_add_stabilizer_refuses_an_unknown_task_and_missing_references():
    b = HumanoidSoTBuilder()
    b.add_com_task("taskCom")
    with pytest.raises(ValueError, match="com_task = 'taskCoM': no such task; known: taskCom"):
        add_stabilizer(b, "taskCoM")
    with pytest.raises(ValueError, match="references: missing com_vel, zmp"):
        add_stabilizer(b, "taskCom", {"com": None})


def test_the_command_line_switches_it_off_only_where_there_is_one(monkeypatch, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "reach", "--no-stabilizer"])
    assert exit_.value.code == 2
    assert "reach takes no --no-stabilizer" in capsys.readouterr().err
    given = {}
    monkeypatch.setattr(
        cli, "_run_scenario", lambda scenario, args, parameters: given.update(parameters) or 0
    )
    assert cli.main(["run", "walk", "--no-stabilizer", "--no-record"]) == 0
    assert given == {"stabilizer": False}
