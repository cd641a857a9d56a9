"""The balance stabilizer's place in the diagrams: between the pattern generator and the CoM
task in ``walk`` and ``walk_then_interact`` unless switched off, from the command line too,
and on a standing stack; no physics."""

from __future__ import annotations

import numpy as np
import pytest

from drake_sot.app import cli
from drake_sot.diagrams import telecooperation, walk, walk_then_interact
from drake_sot.diagrams.balance import add_hip_strategy, add_stabilizer, connect_hand_wrenches
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush


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
    with pytest.raises(
        ValueError, match=r"^com_task: unknown task 'taskCoM' \(did you mean 'taskCom'\?\); known: taskCom$"
    ):
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


def _source_of(built, system, port: str) -> tuple[str, str]:
    """(system name, output port name) feeding ``system``'s input ``port``."""
    index = system.GetInputPort(port).get_index()
    for (dst, dst_index), (src, src_index) in built.diagram.connection_map().items():
        if dst is system and dst_index == index:
            return src.get_name(), src.get_output_port(src_index).get_name()
    raise AssertionError(f"{system.get_name()}'s {port} is not connected")


def test_the_hands_admittance_wrenches_reach_the_stabilizer_left_then_right():
    """Standing with both hands' admittance tasks, the left hand pushed forward by 20 N: the
    stabilizer's ``hand_wrenches`` is the left hand's external wrench, then the right's, as the
    admittance controllers output them (the left one with about the push's force)."""
    b = HumanoidSoTBuilder(pushes=[ExternalPush(0.0, "left_hand", (20.0, 0.0, 0.0), 1.0)])
    b.add_com_task("taskCom", selection="110")
    stabilizer = add_stabilizer(b, "taskCom")
    hands = {
        side: b.add_admittance_task(f"hand_{side}", side, mass=4.0, damping=150.0)
        for side in ("left", "right")
    }
    connect_hand_wrenches(
        b, stabilizer, {side: a.GetOutputPort("wrench_external") for side, a in hands.items()}
    )
    built = b.build(stack=["taskCom", "hand_left", "hand_right"])
    simulator = built.create_simulator()
    simulator.AdvanceTo(0.02)
    root = simulator.get_context()
    received = stabilizer.GetInputPort("hand_wrenches").Eval(stabilizer.GetMyContextFromRoot(root))
    for side, part in (("left", slice(0, 6)), ("right", slice(6, 12))):
        sent = hands[side].GetOutputPort("wrench_external").Eval(hands[side].GetMyContextFromRoot(root))
        np.testing.assert_array_equal(received[part], sent)
    assert received[3] > 10.0 and abs(received[9]) < 5.0  # the push is on the left hand
    with pytest.raises(ValueError, match="wrenches: keys \\['left'\\], needs 'left' and 'right'"):
        connect_hand_wrenches(b, stabilizer, {"left": hands["left"].GetOutputPort("wrench_external")})


def test_in_telecooperation_the_stabilizer_has_the_hands_admittance_wrenches():
    built = telecooperation.build(leader="cooperator").built
    stabilizer = next(s for s in built.diagram.GetSystems() if s.get_name() == "stabilizer")
    mux_name, _ = _source_of(built, stabilizer, "hand_wrenches")
    mux = next(s for s in built.diagram.GetSystems() if s.get_name() == mux_name)
    assert [_source_of(built, mux, mux.get_input_port(i).get_name()) for i in range(2)] == [
        ("admittance_e_fl", "wrench_external"),
        ("admittance_e_fr", "wrench_external"),
    ]
