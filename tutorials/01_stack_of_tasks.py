# %% [markdown]
# # Tutorial 01 — the Stack of Tasks scripts, line by line, on Drake
#
# The Stack of Tasks paper (Mansard et al., section III-B) drives the controller with a
# small script language: `new` creates an *entity*, `plug` links an output *signal* to
# an input signal, `set` gives a signal a value, `sot.push` puts a task in the stack.
# drake_sot rebuilds the same graph of entities with Drake's systems framework:
#
# | SoT script                    | drake_sot on Drake                                              |
# |-------------------------------|-----------------------------------------------------------------|
# | entity (`new Class name`)     | a `LeafSystem` added to a `DiagramBuilder`                      |
# | `plug a.x b.y`                | `builder.Connect(a.GetOutputPort("x"), b.GetInputPort("y"))`    |
# | `set e.sig value`             | a constant source, a parameter, or `port.FixValue(context, v)`  |
# | `dyn.createOpPoint rleg 6`    | `dyn.add_operational_point("rleg", "r_sole")` (a frame name)    |
# | `sot.push taskCom`            | `sot.push(context, "taskCom")`, on a context, at run time       |
# | `pool.writegraph file`        | `write_graph(diagram, "file.svg")` (`drake_sot.diagrams`)        |
#
# Every line of the paper's examples is quoted in a comment right above its
# translation. Around them we build what the paper takes for granted: the simulated
# robot (a `MultibodyPlant` standing on the ground), the `dyn` entity, the
# `StackOfTasks` solver, the "device" that integrates its q̇ into a reference
# posture, and the PD actuators that track it. Run it with
# `python tutorials/01_stack_of_tasks.py`, or open it as a notebook (`# %%` cells).

# %%
import os
import time
from pathlib import Path

import numpy as np
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_sot.diagrams.artifacts import GraphvizMissing
from drake_sot.diagrams.signal_graph import signal_graph, write_graph
from drake_sot.gains import AdaptiveGain
from drake_sot.models import add_ground, half_sitting_configuration, load_humanoid, make_control_model
from drake_sot.systems.device import Device
from drake_sot.systems.features import FeatureGeneric, FeaturePoint6d, FeaturePoint6dRelative
from drake_sot.systems.feedforward import TorqueFeedforward
from drake_sot.systems.kinematics import RobotKinematics
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.task import Task

OUT = Path(os.environ.get("DRAKE_SOT_OUT", "out"))
wall_start = time.perf_counter()

# %% [markdown]
# ## The world: the simulated humanoid on the ground
#
# The paper's robot is HRP-2 inside OpenHRP, stepped every 5 ms. Here it is the
# embedded HRP-2-class humanoid in a `MultibodyPlant` (SAP contact solver, 1 ms step,
# point contact), with a `SceneGraph` for the ground contact. `load_humanoid` gives
# every joint a PD actuator: the plant's *desired state* input is where the Stack of
# Tasks' reference posture will go.

# %%
builder = DiagramBuilder()
plant, scene_graph = AddMultibodyPlant(
    MultibodyPlantConfig(time_step=1e-3, discrete_contact_approximation="sap", contact_model="point"), builder
)
info = load_humanoid(plant)
add_ground(plant)
plant.Finalize()

# %% [markdown]
# ## The dynamic-model entity `dyn`
#
# The controller keeps its own model of the robot (a separate, continuous
# `MultibodyPlant` without contact geometry), as the SoT's `dyn` entity does.
# `RobotKinematics` named `"dyn"` computes the CoM (`com`), its Jacobian (`Jcom`) and,
# for each operational point we create, a pose and its Jacobian — only when `q`
# changed, which is Drake's cache doing what the paper's time-stamped signals did.

# %%
control_plant, control_info = make_control_model()
q0 = half_sitting_configuration(control_plant, control_info)
dyn = builder.AddSystem(RobotKinematics(control_plant))
dyn.set_name("dyn")
print("dyn output ports:", [dyn.get_output_port(i).get_name() for i in range(dyn.num_output_ports())])

# %% [markdown]
# ## Features: the CoM (paper III-B.4)
#
# `FeatureGeneric` takes its value `s` and its Jacobian from two input signals, and
# outputs `e = s - s*` with its Jacobian.
#
# **Which CoM target?** The paper sets `s* = (0, -0, 0.64)`: 0.64 m was HRP-2's CoM
# height during that particular motion. On this model the CoM stands at ≈ 0.81 m in
# half-sitting; asking for 0.64 m would make the robot squat by some 17 cm, a motion
# that has nothing to do with the paper's example. So we keep the paper's value but
# give the feature the *selection* `"110"`: only x and y are controlled (the CoM's ground
# projection, what balance needs) and z is left free. The target (0, 0) is 1.3 cm behind the initial CoM,
# well inside the feet's support polygon (the soles are 23 cm long).
#
# **Where does `s*` come from?** In the paper `featureComDes` is another feature whose
# value is `set`, and `set featureCom.sdes featureComDes` points `featureCom` to it.
# Here the desired value is an input port `sdes`; we plug a `ConstantVectorSource`
# named `featureComDes` into it (a trajectory generator would be plugged the same
# way — the paper's `plug PGselec.scomref featureComDes.errorIN`). When `sdes` is left
# unconnected, the desired value is a *parameter* of the feature instead: the
# constructor's `desired=` is its default and `feature.set_desired(context, value)`
# changes it at run time. The foot features below use that second way.

# %%
COM_DES_PAPER = np.array([0.0, -0.0, 0.64])  # the paper's [3](0,-0,0.64); z is not selected below

# new FeatureGeneric featureCom
featureCom = builder.AddSystem(FeatureGeneric(3, selection="110", name="featureCom"))
# plug dyn.com featureCom.errorIN
builder.Connect(dyn.GetOutputPort("com"), featureCom.GetInputPort("errorIN"))
# plug dyn.Jcom featureCom.jacobianIN
builder.Connect(dyn.GetOutputPort("Jcom"), featureCom.GetInputPort("jacobianIN"))
# new FeatureGeneric featureComDes
# set featureComDes.errorIN [3](0,-0,0.64)
featureComDes = builder.AddSystem(ConstantVectorSource(COM_DES_PAPER))  # the value is the source's default;
featureComDes.set_name("featureComDes")  # it can be `set` again in a context at run time (see below)
# set featureCom.sdes featureComDes
builder.Connect(featureComDes.get_output_port(), featureCom.GetInputPort("sdes"))

# %% [markdown]
# ## Tasks (paper III-B.5)
#
# A `Task` concatenates the features added to it and outputs `e`, `J` and the desired
# error rate `ė* = -λ e`. The paper's snippet does not show the gain λ (the SoT's
# `taskCom.controlGain` signal); here it is a constructor argument, and
# `task.set_gain(context, λ)` changes it at run time. `taskCom.add(featureCom)` declares
# one input port per feature and returns it, for the `plug` of the feature's output.

# %%
# new Task taskCom
taskCom = builder.AddSystem(Task("taskCom", gain=3.0))
# taskCom.add featureCom
builder.Connect(featureCom.GetOutputPort("feature"), taskCom.add(featureCom))

# sot.push taskCom
#   -> a command on the running controller: sot.push(context, "taskCom"), in the simulation below.

# %% [markdown]
# The SoT's adaptive gain `λ(‖e‖) = a·exp(-b‖e‖) + c` is high near the goal (fast final
# convergence) and bounded far from it (no violent start). The original software sets it
# from three numbers: λ at zero error, λ far away, and its slope at zero.

# %%
adaptive = AdaptiveGain.from_limits(at_zero=4.0, at_infinity=1.0, slope_at_zero=6.0)
print("adaptive λ at ‖e‖ = 0, 0.1, 1 m:", [round(adaptive(e), 3) for e in (0.0, 0.1, 1.0)])
# Task("taskCom", gain=adaptive) would use it; taskCom keeps its constant gain here.

# %% [markdown]
# ## Operational points and the relative feature of the two feet (paper III-B.7)
#
# `createOpPoint rleg 6` named an operational point after the rank of the joint that
# carries it (HRP-2's 6th and 12th joints are the ankles). `add_operational_point`
# names a frame of the model instead — here the sole frames, from
# `control_info.frames`. Each creates two output ports on `dyn`: the pose `rleg` and the
# Jacobian `Jrleg`. (The paper's `dyn2` is a second dynamic entity of its setup; one
# `dyn` is enough here.)
#
# `featureTwofeet` holds the right foot in the frame of the left foot. Its desired
# value is a parameter: the relative pose of the soles in half-sitting. Alone it would
# let both feet fly away together, so a `FeaturePoint6d` on the left foot holds that one
# in the world; with the relative feature it pins both feet to the ground.

# %%
right_sole, left_sole = (
    control_info.frames["right_foot"],
    control_info.frames["left_foot"],
)  # "r_sole", "l_sole"
# dyn2.createOpPoint rleg 6
dyn.add_operational_point("rleg", right_sole)
# dyn2.createOpPoint lleg 12
dyn.add_operational_point("lleg", left_sole)
print("dyn output ports:", [dyn.get_output_port(i).get_name() for i in range(dyn.num_output_ports())])

probe = control_plant.CreateDefaultContext()
control_plant.SetPositions(probe, q0)
X_W_lleg0 = control_plant.GetFrameByName(left_sole).CalcPoseInWorld(probe)
X_W_rleg0 = control_plant.GetFrameByName(right_sole).CalcPoseInWorld(probe)
X_lleg_rleg0 = X_W_lleg0.inverse() @ X_W_rleg0  # right sole in the left sole's frame: 19 cm to its right

# new FeaturePoint6dRelative featureTwofeet
featureTwofeet = builder.AddSystem(FeaturePoint6dRelative(name="featureTwofeet", desired=X_lleg_rleg0))
# plug dyn.Jrleg featureTwofeet.Jq
builder.Connect(dyn.GetOutputPort("Jrleg"), featureTwofeet.GetInputPort("Jq"))
# plug dyn.Jlleg featureTwofeet.JqRef
builder.Connect(dyn.GetOutputPort("Jlleg"), featureTwofeet.GetInputPort("JqRef"))
# plug dyn.rleg featureTwofeet.position
builder.Connect(dyn.GetOutputPort("rleg"), featureTwofeet.GetInputPort("position"))
# plug dyn.lleg featureTwofeet.positionRef
builder.Connect(dyn.GetOutputPort("lleg"), featureTwofeet.GetInputPort("positionRef"))

# Not in the paper's snippet: the tasks around the feet features.
taskTwofeet = builder.AddSystem(Task("taskTwofeet", gain=5.0))
builder.Connect(featureTwofeet.GetOutputPort("feature"), taskTwofeet.add(featureTwofeet))
featureLeftFoot = builder.AddSystem(FeaturePoint6d(name="featureLeftFoot", desired=X_W_lleg0))
builder.Connect(dyn.GetOutputPort("lleg"), featureLeftFoot.GetInputPort("position"))
builder.Connect(dyn.GetOutputPort("Jlleg"), featureLeftFoot.GetInputPort("Jq"))
taskLeftFoot = builder.AddSystem(Task("taskLeftFoot", gain=5.0))
builder.Connect(featureLeftFoot.GetOutputPort("feature"), taskLeftFoot.add(featureLeftFoot))

# %% [markdown]
# ## The solver, the device, and the loop around the robot
#
# * `StackOfTasks` (the paper's `sot`, eq. 8): one input port per task it may ever
#   use. Which of them act, and in which order, is the *stack*, held in the context —
#   data, not wiring. It ticks every 5 ms, as on HRP-2.
# * `Device` (the SoT "device"): integrates q̇ into the reference configuration q,
#   starting in half-sitting. Its `q` feeds `dyn` (the open-loop scheme of a
#   position-controlled robot) and its `state_des` feeds the plant's PD actuators.
# * `TorqueFeedforward`: the static joint torques of the reference posture on both
#   feet, added to the PD torques so the joints do not sag under the robot's weight.

# %%
tasks = [taskLeftFoot, taskTwofeet, taskCom]
sot = builder.AddSystem(StackOfTasks(control_plant.num_velocities(), tasks, period=0.005, name="sot"))
for task in tasks:
    builder.Connect(task.GetOutputPort("task"), sot.GetInputPort(task.get_name()))

device = builder.AddSystem(Device(control_plant, control_info.actuated_joints, q0, period=0.005))
builder.Connect(sot.GetOutputPort("qdot"), device.GetInputPort("qdot"))
builder.Connect(device.GetOutputPort("q"), dyn.GetInputPort("q"))
builder.Connect(device.GetOutputPort("state_des"), plant.get_desired_state_input_port(info.model_instance))

gravity = builder.AddSystem(
    TorqueFeedforward(control_plant, control_info.actuated_joints, [left_sole, right_sole])
)
gravity.set_name("gravity_feedforward")
builder.Connect(device.GetOutputPort("q"), gravity.GetInputPort("q"))
builder.Connect(gravity.GetOutputPort("tau"), plant.get_actuation_input_port(info.model_instance))

diagram = builder.Build()
diagram.set_name("tutorial_01")

# %% [markdown]
# ## `pool.writegraph`: the graph of entities
#
# The paper's Fig. 1 is the dot graph written by `pool.writegraph`: the entities and the
# signals plugged between them. `write_graph` draws the same from the diagram: each system
# under its name, with the ports that carry a signal, grouped by family, left to right
# (`everything=True` adds the plumbing: the scene graph, the constant sources).
# `diagram.GetGraphvizString()` is Drake's own picture, every port of every system.

# %%
# pool.writegraph tutorial_01.svg
graph = signal_graph(diagram)
print("graphviz source, first lines:")
for line in graph.splitlines()[:8]:
    print("   ", line)
OUT.mkdir(parents=True, exist_ok=True)
try:
    write_graph(diagram, OUT / "tutorial_01.svg")
    print(f"diagram written: {OUT / 'tutorial_01.svg'}")
except GraphvizMissing as missing:
    print(missing)

# %% [markdown]
# ## Running the controller, and commanding the stack
#
# The simulated robot starts at rest in half-sitting, its PD actuators holding the
# device's reference. The stack starts empty: q̇ = 0, the reference does not move.
# Between `AdvanceTo` calls we act on the running system's context exactly as the
# paper's shell acts on the running SoT:
#
# 1. `push` the two feet tasks (they hold the feet where they are);
# 2. `sot.push taskCom`: the CoM moves 1.3 cm back to (0, 0);
# 3. `up taskCom` / `down taskCom`: priorities change; both orders are feasible here, so
#    the motion barely changes — what a priority decides is who yields in a conflict;
# 4. `rm taskCom`: the CoM is no longer controlled (nothing moves it, so it stays);
#    we `set featureComDes.errorIN` to a CoM 3 cm toward the left foot, which has no
#    effect until `push taskCom` puts the task back in the stack.

# %%
simulator = Simulator(diagram)
context = simulator.get_mutable_context()
plant_context = plant.GetMyMutableContextFromRoot(context)
plant.SetPositions(plant_context, info.model_instance, q0)
simulator.Initialize()


def show(command: str) -> None:
    com_xy = plant.CalcCenterOfMassPositionInWorld(plant_context, [info.model_instance])[:2]
    print(
        f"t = {context.get_time():.2f} s  {command:<20} -> stack = {sot.list(context)}"
        f"   (measured CoM xy: {com_xy[0]:+.4f}, {com_xy[1]:+.4f} m)"
    )


show("(initial)")
# (not in the paper's snippet: sot.push taskLeftFoot; sot.push taskTwofeet)
sot.push(context, "taskLeftFoot")
show("push taskLeftFoot")
sot.push(context, "taskTwofeet")
show("push taskTwofeet")
simulator.AdvanceTo(0.4)

# sot.push taskCom
sot.push(context, "taskCom")
show("push taskCom")
simulator.AdvanceTo(1.0)

sot.up(context, "taskCom")
show("up taskCom")
simulator.AdvanceTo(1.2)

sot.down(context, "taskCom")
show("down taskCom")
simulator.AdvanceTo(1.4)

sot.rm(context, "taskCom")
show("rm taskCom")
# set featureComDes.errorIN [3](0,0.03,0.64)   -- the paper's `set`, at run time
COM_DES = np.array([0.0, 0.03, 0.64])
featureComDes.get_mutable_source_value(featureComDes.GetMyMutableContextFromRoot(context)).SetFromVector(
    COM_DES
)
simulator.AdvanceTo(1.5)

sot.push(context, "taskCom")
show("push taskCom")
simulator.AdvanceTo(2.5)
print("final stack (highest priority first):", " > ".join(sot.list(context)))

# %% [markdown]
# ## What happened to the robot
#
# Measured on the *simulated* plant (physics, contact, PD actuators), not on the
# controller's reference: the pelvis height (≈ 0.65 m in half-sitting — the robot is
# still standing), the CoM's ground projection against the last target, and how far
# the feet moved. `featureTwofeet`'s own error is the controller's view of the feet
# (on the reference posture).

# %%
pelvis = plant.GetBodyByName(info.base_body, info.model_instance)
pelvis_height = plant.EvalBodyPoseInWorld(plant_context, pelvis).translation()[2]
com = plant.CalcCenterOfMassPositionInWorld(plant_context, [info.model_instance])
com_xy_error = np.linalg.norm(com[:2] - COM_DES[:2])
twofeet_error = featureTwofeet.GetOutputPort("error").Eval(featureTwofeet.GetMyContextFromRoot(context))
X_W_lleg = plant.GetFrameByName(left_sole, info.model_instance).CalcPoseInWorld(plant_context)
X_W_rleg = plant.GetFrameByName(right_sole, info.model_instance).CalcPoseInWorld(plant_context)
feet_gap_error = np.linalg.norm((X_W_lleg.inverse() @ X_W_rleg).translation() - X_lleg_rleg0.translation())
left_foot_drift = np.linalg.norm(X_W_lleg.translation() - X_W_lleg0.translation())

print(f"pelvis height: {pelvis_height:.3f} m")
print(
    f"CoM: ({com[0]:+.4f}, {com[1]:+.4f}, {com[2]:.4f}) m, target xy ({COM_DES[0]:+.4f}, {COM_DES[1]:+.4f})"
)
print(f"CoM xy error: {com_xy_error:.4f} m")
print(f"featureTwofeet error norm: {np.linalg.norm(twofeet_error):.2e}")
print(f"measured feet relative position error: {feet_gap_error:.4f} m")
print(f"measured left foot drift: {left_foot_drift:.4f} m")
print(
    "featureTwofeet s* (a parameter, see set_desired):",
    np.round(featureTwofeet.desired(context).translation(), 4),
)
print(f"wall time (manual diagram, 2.5 s simulated): {time.perf_counter() - wall_start:.1f} s")

# %% [markdown]
# ## The same diagram from the paper's script
#
# drake_sot also reads the script language itself. `examples/paper_III_B.sot` holds the
# paper's III-B lines as printed, plus the lines the paper leaves out (the selection of
# the CoM's x and y, the gains, the left-foot task), build-time lines first:
# a Drake diagram is fixed once built, so the first run-time line (`sot.push`) builds it
# through `HumanoidSoTBuilder`, and from then on only run-time commands act.
# `drake-sot script examples/paper_III_B.sot` runs it and writes the usual artefacts; here
# a `ScriptSession` plays it line by line. Side by side, the paper's lines and this
# tutorial's Python:

# %%
from drake_sot.diagrams.script_session import ScriptSession, load_script  # noqa: E402
from drake_sot.script import Plug  # noqa: E402

SIDE_BY_SIDE = [
    (
        "new FeatureGeneric featureCom",
        'builder.AddSystem(FeatureGeneric(3, selection="110", name="featureCom"))',
    ),
    (
        "plug dyn.com featureCom.errorIN",
        'builder.Connect(dyn.GetOutputPort("com"), featureCom.GetInputPort("errorIN"))',
    ),
    ("set featureComDes.errorIN [3](0,-0,0.64)", "builder.AddSystem(ConstantVectorSource(COM_DES_PAPER))"),
    (
        "set featureCom.sdes featureComDes",
        'builder.Connect(featureComDes.get_output_port(), featureCom.GetInputPort("sdes"))',
    ),
    (
        "taskCom.add featureCom",
        'builder.Connect(featureCom.GetOutputPort("feature"), taskCom.add(featureCom))',
    ),
    ("dyn2.createOpPoint rleg 6", 'dyn.add_operational_point("rleg", right_sole)'),
    (
        "plug dyn.Jrleg featureTwofeet.Jq",
        'builder.Connect(dyn.GetOutputPort("Jrleg"), featureTwofeet.GetInputPort("Jq"))',
    ),
    ("sot.push taskCom", 'sot.push(context, "taskCom")'),
]
for line, python in SIDE_BY_SIDE:
    print(f"{line:42s} | {python}")

SCRIPT = Path("examples/paper_III_B.sot")  # run the tutorial from the repository root
session = ScriptSession()
for statement in load_script(SCRIPT).statements:
    session.execute(statement)  # its `run SECONDS` lines advance the session's own simulator


def named_connections(d) -> set[tuple[str, str, str, str]]:
    """(source system, output, target system, input) of every connection of a diagram."""
    return {
        (src.get_name(), src.get_output_port(o).get_name(), dst.get_name(), dst.get_input_port(i).get_name())
        for (dst, i), (src, o) in d.connection_map().items()
    }


plugs = [s.command for s in load_script(SCRIPT).statements if isinstance(s.command, Plug)]
by_hand = named_connections(diagram)
same = [p for p in plugs if ("dyn", p.source.name, p.target.entity, p.target.name) in by_hand]
print(f"script plugs that are connections of the hand-wired diagram: {len(same)} of {len(plugs)}")

# set, at run time, as in the hand-wired run above; then the script's own `run`
session.execute("set featureComDes.errorIN [3](0,0.03,0.64)")
session.execute("run 1.5")
script_context = session.simulator.get_context()
script_plant = session.built.plant
script_com = script_plant.CalcCenterOfMassPositionInWorld(
    script_plant.GetMyContextFromRoot(script_context), [session.built.info.model_instance]
)
print(f"script stack at t = {script_context.get_time():.1f} s: {session.execute('sot.list')}")
print(f"script CoM xy error: {np.linalg.norm(script_com[:2] - COM_DES[:2]):.4f}")

# %% [markdown]
# ## The same, in six lines
#
# `HumanoidSoTBuilder` does all of the above wiring: plant, ground, `dyn`, the
# features and tasks by name, the solver, the device and the gravity feed-forward
# (its `add_com_task` uses `FeatureCoM`, xy by default, holding the initial CoM).

# %%
from drake_sot.diagrams.humanoid import HumanoidSoTBuilder  # noqa: E402

b = HumanoidSoTBuilder()
b.add_op_point_task("taskLF", "left_foot", gain=5.0)
b.add_op_point_task("taskRF", "right_foot", gain=5.0)
b.add_com_task("taskCom", selection="110", gain=3.0, desired=COM_DES_PAPER)
built = b.build(stack=["taskLF", "taskRF", "taskCom"])
sim = built.create_simulator()
sim.AdvanceTo(0.5)
print(
    f"HumanoidSoTBuilder at t = {sim.get_context().get_time():.1f} s: stack =",
    built.sot.list(sim.get_mutable_context()),
)
print(f"total wall time: {time.perf_counter() - wall_start:.1f} s")
