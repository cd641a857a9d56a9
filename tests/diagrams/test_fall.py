"""Falls in physics: a fallen robot lies on the ground on its collision shapes; a 3000 N shove
knocks the standing robot down, the run says when and ``drake-sot run`` exits with 3; a
smaller push is survived (350 N on the torso thanks to the hip strategy, without which it
falls)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_sot.app import cli
from drake_sot.diagrams import scenario as scenario_module
from drake_sot.diagrams import walk_then_interact
from drake_sot.diagrams.balance import add_hip_strategy, add_stabilizer
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import simulate
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.diagrams.tasks import FALL_CRITERIA
from drake_sot.diagrams.torque_humanoid import TorqueHumanoidBuilder
from drake_sot.models import (
    add_body_collision,
    add_ground,
    half_sitting_configuration,
    load_humanoid,
    make_control_model,
)
from drake_sot.models.humanoid import LINKS
from drake_sot.recovery import LeanProfile
from drake_sot.systems.fall_monitor import FallCriteria
from drake_sot.systems.partner import ConstantForce, Partner

#: What "lying on the ground" allows: no part of the body deeper than this below z = 0 [m].
SINK = -0.02


def _lowest_points(q: np.ndarray) -> dict[str, float]:
    """Link name → the lowest z [m] of the link's own solid (its box, cylinder or sphere, as in
    the model's table: the body itself, not its collision shapes) in configuration ``q``."""
    plant, _ = make_control_model()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    lowest = {}
    for link in LINKS:
        X = plant.GetBodyByName(link.name).EvalPoseInWorld(context)
        R, centre = X.rotation().matrix(), X @ np.asarray(link.centre)
        kind, *dims = link.shape
        if kind == "box":  # the lowest corner: half sizes along the link axes, projected on z
            depth = sum(abs(R[2, i]) * dims[i] / 2 for i in range(3))
        elif kind == "cylinder":  # axis z: the lowest point of a rim, or of a flat face
            radius, length = dims
            depth = abs(R[2, 2]) * length / 2 + radius * math.sqrt(max(0.0, 1.0 - R[2, 2] ** 2))
        else:
            depth = dims[0]
        lowest[link.name] = centre[2] - depth
    return lowest


def test_a_robot_dropped_on_its_back_lies_on_the_ground():
    """Without servos (limp), 10 cm above the ground, lying on its back: after 1.5 s it rests on
    its shapes (only the soles collided before: it sank through the floor)."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=1e-3, discrete_contact_approximation="sap", contact_model="point"),
        builder,
    )
    info = load_humanoid(plant, pd_gains=False)
    add_body_collision(plant, scene_graph, info)
    add_ground(plant)
    plant.Finalize()
    simulator = Simulator(builder.Build())
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    pelvis = plant.GetBodyByName("pelvis")
    # Pitched back by 90°: the pelvis's back face (0.10 m behind its origin) 10 cm above the ground.
    plant.SetFreeBodyPose(
        context, pelvis, RigidTransform(RollPitchYaw(0.0, -math.pi / 2, 0.0), [0.0, 0.0, 0.2])
    )
    plant.get_actuation_input_port().FixValue(context, np.zeros(plant.num_actuated_dofs()))
    simulator.AdvanceTo(1.5)
    lowest = _lowest_points(plant.GetPositions(context))
    assert min(lowest.values()) > SINK, min(lowest.items(), key=lambda kv: kv[1])
    assert min(lowest.values()) < 0.01  # on the ground, not held above it
    assert pelvis.EvalPoseInWorld(context).translation()[2] < 0.15
    assert np.abs(plant.GetVelocities(context)[3:6]).max() < 0.05  # at rest


def _standing(**kwargs):
    b = HumanoidSoTBuilder(**kwargs)
    b.add_com_task("taskCom")
    return b.build(stack=["taskCom"])


def test_floating_base_builders_monitor_falls_unless_asked_not_to():
    built = _standing()
    assert built.fall_monitor is not None and built.fall_monitor.criteria == FALL_CRITERIA
    assert "fallen" in built.loggers
    assert _standing(fall_criteria=None).fall_monitor is None
    strict = FallCriteria(min_pelvis_height=0.6, max_tilt=0.2, stop_after=0.0)
    assert _standing(fall_criteria=strict).fall_monitor.criteria == strict
    fixed = TorqueHumanoidBuilder(fixed_base=True)  # welded in the air: it cannot fall
    assert fixed.fall_criteria is None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"fall_criteria": 0.4}, "fall_criteria = 0.4: must be a FallCriteria or None"),
        ({"pushes": [ExternalPush(1.0, "elbow", (0, 1, 0), 0.1)]}, "push body: unknown frame 'elbow'"),
        ({"pushes": [(1.0, "pelvis", (0, 1, 0), 0.1)]}, "is not an ExternalPush"),
    ],
)
def test_builders_refuse_bad_pushes_and_criteria(kwargs, message):
    with pytest.raises(ValueError, match=message):
        HumanoidSoTBuilder(**kwargs)


def test_pushes_and_other_external_forces_reach_the_plant_together():
    """A push on the right hand's tool point and a partner's force on the pelvis, both at once."""
    b = HumanoidSoTBuilder(pushes=[ExternalPush(0.0, "right_hand", (10.0, 0.0, 0.0), 1.0)])
    partner = b.builder.AddSystem(Partner(b.plant, {"pelvis": [ConstantForce(0.0, 1.0, (0.0, -20.0, 0.0))]}))
    b.builder.Connect(b.plant.get_body_poses_output_port(), partner.GetInputPort("body_poses"))
    b.builder.Connect(
        b.plant.get_body_spatial_velocities_output_port(), partner.GetInputPort("body_spatial_velocities")
    )
    b.apply_spatial_forces(partner.GetOutputPort("spatial_forces"))
    b.add_com_task("taskCom")
    built = b.build(stack=["taskCom"])
    simulator = built.create_simulator()
    simulator.AdvanceTo(0.01)
    plant = built.plant
    applied = plant.get_applied_spatial_force_input_port().Eval(
        plant.GetMyContextFromRoot(simulator.get_context())
    )
    got = {plant.get_body(f.body_index).name(): (f.p_BoBq_B, f.F_Bq_W.translational()) for f in applied}
    tool = plant.GetFrameByName(built.info.frames["right_hand"]).GetFixedPoseInBodyFrame().translation()
    assert set(got) == {"r_hand", "pelvis"}
    np.testing.assert_array_equal(got["r_hand"][0], tool)
    np.testing.assert_array_equal(got["r_hand"][1], [10.0, 0.0, 0.0])
    np.testing.assert_array_equal(got["pelvis"][1], [0.0, -20.0, 0.0])


def test_a_run_that_stops_before_the_partner_takes_the_hands_writes_every_plot(tmp_path):
    """walk_then_interact cut short (as by a fall or Ctrl-C) before its interaction at 7 s."""
    output = run_scenario(walk_then_interact.SCENARIO, tmp_path, duration=1.0, record=False)
    assert output.result.completed
    for name in ("svg", "npz", "png", "hands"):
        assert output.files[name].stat().st_size > 1000, name


@pytest.mark.slow
def test_a_3000_N_shove_knocks_the_robot_down_and_the_command_exits_3(tmp_path, monkeypatch, capsys):
    marks = []

    def plot(time, errors, events, **kwargs):
        marks.extend(events)
        return real_plot(time, errors, events, **kwargs)

    real_plot = scenario_module.plot_task_errors
    monkeypatch.setattr(scenario_module, "plot_task_errors", plot)
    push_at = 0.5
    code = cli.main(
        [
            "run",
            "reach",
            "--duration",
            "6",
            "--no-record",
            "--out",
            str(tmp_path),
            "--push",
            "0.5,pelvis,0,3000,0,0.1",
        ]
    )
    err = capsys.readouterr().err
    assert code == 3, err
    assert "the robot fell at t = " in err
    for ext in ("svg", "png", "npz"):
        assert (tmp_path / f"reach.{ext}").stat().st_size > 1000, ext
    logs = np.load(tmp_path / "reach.npz")  # no pickle
    record = logs["pushes"]
    assert record.shape == (1,) and record[0]["body"] == "pelvis" and record[0]["time"] == push_at
    np.testing.assert_array_equal(record[0]["force"], [0.0, 3000.0, 0.0])
    assert record[0]["duration"] == 0.1
    fall_time, height, tilt = logs["fall"]

    # The fall, found again from the logged configurations: the first sample whose pelvis is
    # below the height or whose torso leans past the angle (each log sample may lead or lag
    # the monitor's tick by a physics step: one control period of slack).
    plant, _ = make_control_model()
    context = plant.CreateDefaultContext()
    first = None
    for t, q in zip(logs["time"], logs["q"], strict=True):
        plant.SetPositions(context, q)
        z = plant.GetBodyByName("pelvis").EvalPoseInWorld(context).translation()[2]
        lean = math.acos(plant.GetBodyByName("torso").EvalPoseInWorld(context).rotation().matrix()[2, 2])
        if z < FALL_CRITERIA.min_pelvis_height or lean > FALL_CRITERIA.max_tilt:
            first = t
            break
    assert first is not None and abs(first - fall_time) <= 0.005 + 1e-9
    assert push_at < fall_time < push_at + 1.5
    assert height < FALL_CRITERIA.min_pelvis_height or tilt > FALL_CRITERIA.max_tilt
    assert (
        f"fell at t = {fall_time:.3f} s (pelvis z = {height:.3f} m, tilt = {math.degrees(tilt):.1f}°)" in err
    )

    # The run went on for stop_after so the robot came down, then stopped before its 6 s.
    assert logs["time"][-1] == pytest.approx(fall_time + FALL_CRITERIA.stop_after, abs=0.006)
    assert logs["fallen"][-1, 0] == 1.0 and logs["fallen"][0, 0] == 0.0
    lowest = _lowest_points(logs["q"][-1])
    assert min(lowest.values()) > SINK, min(lowest.items(), key=lambda kv: kv[1])
    assert logs["q"][-1, 6] < FALL_CRITERIA.min_pelvis_height  # the pelvis is down too

    # The task-error plot marks the push and the fall.
    labels = [label for _, label in marks]
    assert "push pelvis 3000 N (0, 3000, 0) for 0.1 s" in labels
    assert any(label.startswith(f"fell at t = {fall_time:.3f} s") for label in labels)


def _standing_pushed(body: str, force: float, *, hip: bool):
    """The README stack standing, the balance stabilizer on its CoM task and (``hip``) the hip
    strategy's trunk task below it, pushed 0.1 s laterally (+y for a positive ``force``) at
    t = 0.5 s for 4 s; the run, the builder's result, the simulator and the push."""
    push = ExternalPush(0.5, body, (0.0, force, 0.0), 0.1)
    b = HumanoidSoTBuilder(pushes=[push])
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    b.add_posture_task("taskPosture")
    stabilizer = add_stabilizer(b, "taskCom")
    stack = ["taskLF", "taskRF", "taskCom", "taskPosture"]
    if hip:
        add_hip_strategy(b, stabilizer, "taskTrunk")
        stack.insert(3, "taskTrunk")
    built = b.build(stack=stack)
    simulator = built.create_simulator()
    return simulate(simulator, 4.0, check=False), built, simulator, push


@pytest.mark.slow
@pytest.mark.parametrize(("body", "force"), [("pelvis", 450.0), ("torso", 350.0), ("torso", -350.0)])
def test_the_standing_robot_survives_a_lateral_push(body, force):
    """The README stack standing, with the balance stabilizer and the hip strategy; a 0.1 s
    lateral push at t = 0.5 s: 450 N on the pelvis, 350 N on the torso either way.
    The torso push takes the DCM out of the support polygon: the trunk leans towards it and
    comes back upright (the next test: without the lean, the robot falls)."""
    result, built, simulator, push = _standing_pushed(body, force, hip=True)
    assert result.completed and result.fell is None, result.fell
    context = simulator.get_context()
    time = built.loggers["state"].FindLog(context).sample_times()
    q = built.loggers["state"].FindLog(context).data()[: built.plant.num_positions()].T
    forces = built.loggers["push_forces"].FindLog(context).data().T
    # A sample at t shows the force held before the tick at t (Drake publishes before updating).
    pushing = (time > push.time + 1e-9) & (time < push.end + 1e-9)
    np.testing.assert_array_equal(forces[pushing], np.tile(push.force, (pushing.sum(), 1)))
    np.testing.assert_array_equal(forces[~pushing], 0.0)
    assert q[:, 6].min() > 0.6  # the pelvis stayed up
    # The push took: the pelvis swayed the push's way, then came back over the feet (which may
    # have slid: measured from their midpoint), within 2 cm: after 450 N the robot still rocks
    # from foot to foot 3 s later, with or without the stabilizer.
    plant, _ = make_control_model()
    plant_context = plant.CreateDefaultContext()
    sway, soles = [], []
    for qk in q:
        plant.SetPositions(plant_context, qk)
        feet = [plant.GetFrameByName(built.info.frames[f"{side}_foot"]) for side in ("left", "right")]
        soles.append([f.CalcPoseInWorld(plant_context).translation()[1] for f in feet])
        sway.append(qk[5] - np.mean(soles[-1]))
    # The soles ended within 2 cm sideways of where they started (a sole lifts and rolls on
    # its edge while the robot rocks): the robot recovered on its feet, not by skating.
    np.testing.assert_allclose(soles[-1], soles[0], atol=0.02)
    sway = (np.array(sway) - sway[0]) * np.sign(force)
    assert sway.max() > 0.03 and abs(sway[-1]) < 0.02, (sway.max(), sway[-1])
    if body == "torso":  # the trunk leaned the push's way, then stood up again
        lean = built.loggers["hip_lean"].FindLog(context).data().T
        assert lean[:, 0].max() == pytest.approx(LeanProfile().angle)
        assert np.sign(lean[lean[:, 0] > 0, 2]).tolist() == [np.sign(force)] * int((lean[:, 0] > 0).sum())
        assert lean[-1, 0] == 0.0


@pytest.mark.slow
def test_without_the_hip_strategy_the_standing_robot_falls_at_350_N_on_the_torso():
    """The same push, stabilizer alone: the DCM leaves the support polygon (0.16 m from the
    feet's middle), which no ZMP brings back; the robot tips over the left sole's edge."""
    result, built, simulator, push = _standing_pushed("torso", 350.0, hip=False)
    assert result.fell is not None, "survived without the hip strategy"
    assert push.end < result.fell.time < push.end + 2.0
    context = simulator.get_context()
    excess = built.loggers["dcm_excess"].FindLog(context).data().T
    assert excess[:, 1].max() > 0.1  # it left by the left (+y) edge
