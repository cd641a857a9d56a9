"""Compose the simulated humanoid and the kinematic Stack of Tasks in one Drake diagram.

:class:`HumanoidSoTBuilder` is what every scenario starts from::

    sot = HumanoidSoTBuilder()
    sot.add_op_point_task("taskRH", "right_hand", gain=2.0)
    sot.add_com_task("taskCom", selection="110")
    built = sot.build(stack=["taskCom", "taskRH"])
    simulator = built.create_simulator()

It puts the humanoid in a ``MultibodyPlant`` (SAP, 1 ms, point contact) on a ground
plane with its ``SceneGraph`` and builds the controller's own copy of the robot model
with its ``RobotKinematics`` (the paper's ``dyn``). Tasks are added by name; on
:meth:`HumanoidSoTBuilder.build` every task is wired into one ``StackOfTasks`` and the
loop is closed: features → tasks → ``StackOfTasks`` → ``Integrator`` (q_ref) → the
plant's PD actuators, with a torque feed-forward (quasi-static, or the full inverse
dynamics of the reference), loggers and
(optionally) a recorded Meshcat replay.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer, MeshcatVisualizerParams, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import BodyIndex, JointIndex
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder, OutputPort
from pydrake.systems.primitives import Demultiplexer, LogVectorOutput, VectorLogSink

from drake_sot.features import SelectionLike
from drake_sot.gains import Gain
from drake_sot.models import (
    HumanoidInfo,
    add_ground,
    half_sitting_configuration,
    load_humanoid,
    make_control_model,
    sole_corner_points,
    weld_base,
)
from drake_sot.systems.admittance import AdmittanceController
from drake_sot.systems.features import (
    FeatureCoM,
    FeatureJointLimits,
    FeaturePoint6d,
    FeaturePoint6dRelative,
    FeaturePosture,
    _Feature,
)
from drake_sot.systems.feedforward import TorqueFeedforward
from drake_sot.systems.force_sensor import ForceSensor
from drake_sot.systems.generalized_controller import (
    ContactPoints,
    ForceTask,
    GeneralizedHierarchyController,
    MotionTask,
)
from drake_sot.systems.integrator import Integrator
from drake_sot.systems.kinematics import RobotKinematics
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.stack_history import StackHistory
from drake_sot.systems.task import Task


@dataclass
class BuiltHumanoid:
    """A built diagram and handles on the parts a scenario, a test or a user needs."""

    diagram: Diagram
    plant: MultibodyPlant
    info: HumanoidInfo
    control_plant: MultibodyPlant
    dyn: RobotKinematics
    tasks: dict[str, Task]
    features: dict[str, _Feature]
    loggers: dict[str, VectorLogSink]
    q0: np.ndarray
    meshcat: Meshcat | None
    visualizer: MeshcatVisualizer | None

    def create_simulator(self) -> Simulator:
        """A simulator whose plant starts in the reference configuration q0, at rest."""
        simulator = Simulator(self.diagram)
        context = simulator.get_mutable_context()
        plant_context = self.plant.GetMyMutableContextFromRoot(context)
        self.plant.SetPositions(plant_context, self.info.model_instance, self.q0)
        simulator.Initialize()
        return simulator

    def frame_pose(self, root_context, frame_key: str) -> RigidTransform:
        """Pose in world of a humanoid frame (logical name, e.g. ``"right_hand"``) in the
        *simulated* plant."""
        plant_context = self.plant.GetMyContextFromRoot(root_context)
        return self.plant.GetFrameByName(
            self.info.frames[frame_key], self.info.model_instance
        ).CalcPoseInWorld(plant_context)

    def error_slices(self) -> dict[str, slice]:
        """Where each task's error lies in the logged ``errors``."""
        raise NotImplementedError


@dataclass
class HumanoidSoT(BuiltHumanoid):
    """The kinematic SoT around a position-controlled humanoid."""

    sot: StackOfTasks | None = None
    device: Integrator | None = None
    stack_history: StackHistory | None = None

    def error_slices(self) -> dict[str, slice]:
        return self.sot.error_slices()


@dataclass
class HumanoidTorqueControl(BuiltHumanoid):
    """The generalized hierarchical controller around a torque-controlled humanoid."""

    controller: GeneralizedHierarchyController | None = None
    stack_history: None = None

    def error_slices(self) -> dict[str, slice]:
        out, start = {}, 0
        for name, task in self.tasks.items():
            if name in self.controller.task_names:
                out[name] = slice(start, start + task.dimension)
                start += task.dimension
        return out


def add_humanoid_plant(
    builder: DiagramBuilder,
    *,
    time_step: float = 1e-3,
    pd_gains: bool = True,
    fixed_base: bool = False,
    before_finalize: Callable[[MultibodyPlant, HumanoidInfo], None] | None = None,
) -> tuple[MultibodyPlant, SceneGraph, HumanoidInfo]:
    """The simulated world in a finalized ``MultibodyPlant`` (SAP, point contact,
    ``time_step`` [s]) and its ``SceneGraph``: the humanoid with PD-controlled actuators
    (or torque-controlled ones, ``pd_gains=False``) on the ground, or with its pelvis
    welded in the air (``fixed_base``, no ground). ``before_finalize`` may add to the
    world (a table, collision shapes on the hands) before the plant is finalized."""
    config = MultibodyPlantConfig(
        time_step=time_step, discrete_contact_approximation="sap", contact_model="point"
    )
    plant, scene_graph = AddMultibodyPlant(config, builder)
    info = load_humanoid(plant, pd_gains=pd_gains)
    if fixed_base:
        weld_base(plant, info)
    else:
        add_ground(plant)
    if before_finalize is not None:
        before_finalize(plant, info)
    plant.Finalize()
    return plant, scene_graph, info


class HumanoidSoTBuilder:
    """Adds tasks by name around the embedded humanoid, then builds the closed loop.

    Args:
        control_period: period of the SoT tick [s] (5 ms as on HRP-2).
        time_step: physics step of the plant [s].
        meshcat: a Meshcat to draw in; None for no visualisation. Use
            :func:`loopback_meshcat` for a headless recorder bound to localhost.
        actuation: ``"pd"``: position-controlled robot, closed with :meth:`build` (the
            kinematic SoT); ``"torque"``: torque-controlled robot, closed with
            :meth:`build_generalized` (paper 004). The tasks are added the same way.
        fixed_base: weld the pelvis in the air (no ground), as the paper's real iCub.
        before_finalize: adds to the simulated world before it is finalized (see
            :func:`add_humanoid_plant`).
    """

    def __init__(
        self,
        *,
        control_period: float = 0.005,
        time_step: float = 1e-3,
        meshcat: Meshcat | None = None,
        actuation: str = "pd",
        fixed_base: bool = False,
        before_finalize: Callable[[MultibodyPlant, HumanoidInfo], None] | None = None,
    ) -> None:
        if actuation not in ("pd", "torque"):
            raise ValueError(
                f"actuation {actuation!r} must be 'pd' (kinematic SoT) or 'torque' (generalized hierarchy)"
            )
        self.actuation = actuation
        self.fixed_base = fixed_base
        self.builder = DiagramBuilder()
        self.plant, self.scene_graph, self.info = add_humanoid_plant(
            self.builder,
            time_step=time_step,
            pd_gains=actuation == "pd",
            fixed_base=fixed_base,
            before_finalize=before_finalize,
        )
        self.control_plant, self.control_info = make_control_model(fixed_base=fixed_base)
        self.q0 = half_sitting_configuration(self.control_plant, self.control_info)
        self.control_period = control_period
        self.meshcat = meshcat
        self.dyn = self.builder.AddSystem(RobotKinematics(self.control_plant))
        self.dyn.set_name("dyn")
        self.tasks: dict[str, Task] = {}
        self.features: dict[str, _Feature] = {}
        self._pose_feature_frames: dict[FeaturePoint6d, str] = {}  # op-point feature -> its frame key
        self._q_consumers: list = [self.dyn.GetInputPort("q")]
        self._extra_logs: dict[str, OutputPort] = {}
        self._probe_context = self.control_plant.CreateDefaultContext()
        self.control_plant.SetPositions(self._probe_context, self.q0)

    # --- reference values at the initial configuration -----------------------------
    def initial_pose(self, frame_key: str) -> RigidTransform:
        """Pose in world of a humanoid frame (logical name) in the initial configuration q0."""
        return self._frame(frame_key).CalcPoseInWorld(self._probe_context)

    def initial_com(self) -> np.ndarray:
        """CoM position (3,) [m] in the initial configuration q0."""
        return self.control_plant.CalcCenterOfMassPositionInWorld(self._probe_context)

    def _frame(self, frame_key: str):
        if frame_key not in self.control_info.frames:
            raise KeyError(f"unknown frame {frame_key!r}; known: {', '.join(self.control_info.frames)}")
        return self.control_plant.GetFrameByName(self.control_info.frames[frame_key])

    # --- tasks -----------------------------------------------------------------------
    def op_point(self, frame_key: str, frame_name: str | None = None) -> str:
        """Create (once) an operational point on ``dyn``; returns its name.

        ``frame_key`` is a humanoid frame's logical name (``"right_hand"``), or any new
        name when ``frame_name`` gives the model's frame.
        """
        if frame_key not in self.dyn.operational_points:
            if frame_name is None:
                self._frame(frame_key)
                frame_name = self.control_info.frames[frame_key]
            self.dyn.add_operational_point(frame_key, frame_name)
        return frame_key

    def _add_task(
        self, task_name: str, feature: _Feature, gain: Gain, selection: SelectionLike = None
    ) -> Task:
        """A task reading ``feature`` (added to the diagram unless it is there already, shared)."""
        if task_name in self.tasks:
            raise ValueError(f"a task named {task_name!r} exists already")
        if feature not in self.features.values():
            self.builder.AddSystem(feature)
        task = self.builder.AddSystem(Task(task_name, gain=gain))
        self.builder.Connect(feature.GetOutputPort("feature"), task.add(feature, selection=selection))
        self.tasks[task_name] = task
        self.features[task_name] = feature
        return task

    def add_op_point_task(
        self,
        task_name: str,
        frame_key: str,
        *,
        selection: SelectionLike = None,
        gain: Gain = 1.0,
        desired: RigidTransform | None = None,
        feature_of: str | None = None,
    ) -> Task:
        """A 6D task (``FeaturePoint6d``) on a humanoid frame; holds its initial pose unless ``desired``.

        The feature is 6D and ``selection`` is applied by the task, so that tasks on one
        frame can share it: ``feature_of`` names an earlier op-point task on the same
        frame whose feature (and hence desired pose, ``features[feature_of]``) this task
        reads — e.g. a hand's position, orientation and force tasks at different
        priorities, one pose error computed per tick. ``desired`` must then be None.
        """
        op = self.op_point(frame_key)
        if feature_of is not None:
            return self._add_task(
                task_name, self._shared_pose_feature(feature_of, frame_key, desired), gain, selection
            )
        feature = FeaturePoint6d(
            name=f"feature_{task_name}",
            desired=self.initial_pose(frame_key) if desired is None else desired,
        )
        task = self._add_task(task_name, feature, gain, selection)
        self.builder.Connect(self.dyn.GetOutputPort(op), feature.GetInputPort("position"))
        self.builder.Connect(self.dyn.GetOutputPort("J" + op), feature.GetInputPort("Jq"))
        self._pose_feature_frames[feature] = frame_key
        return task

    def _shared_pose_feature(
        self, task_name: str, frame_key: str, desired: RigidTransform | None
    ) -> FeaturePoint6d:
        feature = self.features.get(task_name)
        frame = self._pose_feature_frames.get(feature)
        if frame is None:
            raise ValueError(
                f"feature_of={task_name!r}: no op-point task of that name; "
                f"op-point tasks: "
                f"{sorted(t for t, f in self.features.items() if f in self._pose_feature_frames)}"
            )
        if frame != frame_key:
            raise ValueError(
                f"feature_of={task_name!r}: that task's feature is on frame {frame!r}, not {frame_key!r}"
            )
        if desired is not None:
            raise ValueError(
                f"feature_of={task_name!r}: the desired pose is that of the shared feature; "
                "set it on features[feature_of], not with desired="
            )
        return feature

    def add_relative_task(
        self,
        task_name: str,
        frame_key: str,
        reference_key: str,
        *,
        selection: SelectionLike = None,
        gain: Gain = 1.0,
        desired: RigidTransform | None = None,
    ) -> Task:
        """A relative 6D task (``FeaturePoint6dRelative``): the pose of ``frame_key`` in
        ``reference_key`` (e.g. the paper's ``featureTwofeet``); holds the initial relative pose
        unless ``desired``."""
        op, ref = self.op_point(frame_key), self.op_point(reference_key)
        if desired is None:
            desired = self.initial_pose(reference_key).InvertAndCompose(self.initial_pose(frame_key))
        feature = FeaturePoint6dRelative(selection=selection, name=f"feature_{task_name}", desired=desired)
        task = self._add_task(task_name, feature, gain)
        self.builder.Connect(self.dyn.GetOutputPort(op), feature.GetInputPort("position"))
        self.builder.Connect(self.dyn.GetOutputPort("J" + op), feature.GetInputPort("Jq"))
        self.builder.Connect(self.dyn.GetOutputPort(ref), feature.GetInputPort("positionRef"))
        self.builder.Connect(self.dyn.GetOutputPort("J" + ref), feature.GetInputPort("JqRef"))
        return task

    def add_com_task(
        self,
        task_name: str,
        *,
        selection: SelectionLike = "110",
        gain: Gain = 1.0,
        desired: np.ndarray | None = None,
    ) -> Task:
        """A CoM task (``FeatureCoM``, xy by default); holds the initial CoM unless ``desired``."""
        feature = FeatureCoM(
            selection=selection,
            name=f"feature_{task_name}",
            desired=self.initial_com() if desired is None else desired,
        )
        task = self._add_task(task_name, feature, gain)
        self.builder.Connect(self.dyn.GetOutputPort("com"), feature.GetInputPort("com"))
        self.builder.Connect(self.dyn.GetOutputPort("Jcom"), feature.GetInputPort("Jcom"))
        return task

    def add_posture_task(
        self,
        task_name: str,
        joints: Sequence[str] | None = None,
        *,
        gain: Gain = 1.0,
        desired: np.ndarray | None = None,
    ) -> Task:
        """A posture task (``FeaturePosture``) on ``joints`` (all actuated joints by default) toward q0."""
        feature = FeaturePosture(
            self.control_plant,
            list(joints) if joints is not None else list(self.control_info.actuated_joints),
            name=f"feature_{task_name}",
            desired=self.q0 if desired is None else desired,
        )
        task = self._add_task(task_name, feature, gain)
        self._q_consumers.append(feature.GetInputPort("q"))
        return task

    def add_admittance_task(
        self,
        task_name: str,
        side: str,
        *,
        mass: float | Sequence[float],
        damping: float | Sequence[float],
        stiffness: float | Sequence[float] = 0.0,
        gain: Gain = 5.0,
        max_velocity=(0.5, 1.0),
    ) -> AdmittanceController:
        """A force-based hand task (paper 000 IV-C): the hand's wrist sensor drives an
        ``AdmittanceController`` whose reference pose and velocity feed a 6D hand task.

        Args:
            task_name: the task (e.g. the paper's ``taskForce``).
            side: ``"right"`` or ``"left"``.
            mass, damping, stiffness: the virtual mass [kg, kg·m²], damping [N·s/m,
                N·m·s/rad] and stiffness of the admittance, per axis or one value.
            gain: the hand task's gain [1/s]; max_velocity: saturation (linear, angular).
        Returns:
            the controller, whose ``active``, ``wrench_ref`` inputs are left for the
            scenario to drive (active and zero when unconnected).
        """
        if side not in ("right", "left"):
            raise ValueError(f"side {side!r} must be 'right' or 'left'")
        sensor_joint = self.info.force_sensors[f"{side}_wrist"]
        sensor = self.builder.AddSystem(ForceSensor(self.plant, sensor_joint))
        sensor.set_name(f"{side}_wrist_sensor")
        self.builder.Connect(
            self.plant.get_reaction_forces_output_port(), sensor.GetInputPort("reaction_forces")
        )
        joint = self.control_plant.GetJointByName(sensor_joint)
        sensor_op = self.op_point(f"{side}_wrist_sensor", joint.frame_on_child().name())
        hand_mass, hand_com = _mass_below(self.control_plant, self._probe_context, joint)
        admittance = self.builder.AddSystem(
            AdmittanceController(
                mass=mass,
                damping=damping,
                stiffness=stiffness,
                hand_mass=hand_mass,
                hand_com=hand_com,
                period=self.control_period,
                max_velocity=max_velocity,
                name=f"admittance_{task_name}",
            )
        )
        hand = self.op_point(f"{side}_hand")
        self.builder.Connect(sensor.GetOutputPort("wrench"), admittance.GetInputPort("wrench"))
        self.builder.Connect(self.dyn.GetOutputPort(sensor_op), admittance.GetInputPort("sensor_pose"))
        self.builder.Connect(self.dyn.GetOutputPort(hand), admittance.GetInputPort("hand_pose"))
        self.add_op_point_task(task_name, f"{side}_hand", gain=gain)
        feature = self.features[task_name]
        self.builder.Connect(admittance.GetOutputPort("pose_des"), feature.GetInputPort("position_des"))
        self.builder.Connect(admittance.GetOutputPort("velocity_des"), feature.GetInputPort("velocity_des"))
        return admittance

    def add_joint_limits_task(
        self, task_name: str, *, margin: float = 0.02, gain: Gain = 5.0, joints: Sequence[str] | None = None
    ) -> Task:
        """A joint-limit task (``FeatureJointLimits``) on ``joints`` (every actuated joint by
        default); put it at the top of the stack."""
        feature = FeatureJointLimits(
            self.control_plant,
            list(joints) if joints is not None else list(self.control_info.actuated_joints),
            margin=margin,
            name=f"feature_{task_name}",
        )
        task = self._add_task(task_name, feature, gain)
        self._q_consumers.append(feature.GetInputPort("q"))
        return task

    def log(self, name: str, port: OutputPort) -> None:
        """Log a vector output port at the control period; it appears as ``name`` in the run's logs."""
        if name in self._extra_logs or name in (
            "state",
            "q_ref",
            "errors",
            "wrenches",
            "tau",
            "status",
            "contact_forces",
        ):
            raise ValueError(f"a log named {name!r} exists already")
        self._extra_logs[name] = port

    # --- closing the loop ------------------------------------------------------------
    def build(
        self,
        stack: Sequence[str],
        *,
        log_period: float | None = None,
        load: OutputPort | None = None,
        dynamic_feedforward: bool = False,
        stack_source: OutputPort | None = None,
    ) -> HumanoidSoT:
        """Wire every task into a ``StackOfTasks`` holding ``stack`` and close the loop.

        Args:
            stack: the initial stack, highest priority first.
            log_period: period of the loggers [s] (default: the control period).
            load: a (2,) [left, right] load share of the feet for the torque feed-forward
                (e.g. ``PatternGenerator.load``); equal shares when None.
            dynamic_feedforward: feed forward the inverse dynamics of the reference motion
                (velocity and acceleration of the device) rather than the static torques
                of its posture; for dynamic motions such as walking.
            stack_source: an abstract ``tuple[str, ...]`` output that drives the stack
                (e.g. ``TaskSequencer.stack``); then ``stack`` is only the stack's name list
                for validation and the context commands are refused.
        """
        if self.actuation != "pd":
            raise ValueError(
                "build() closes the kinematic SoT on a position-controlled robot; use build_generalized()"
            )
        b = self.builder
        period = self.control_period
        sot = b.AddSystem(
            StackOfTasks(
                self.control_plant.num_velocities(), list(self.tasks.values()), period=period, stack=stack
            )
        )
        for task_name, task in self.tasks.items():
            b.Connect(task.GetOutputPort("task"), sot.GetInputPort(task_name))
        if stack_source is not None:
            b.Connect(stack_source, sot.GetInputPort("stack"))
        device = b.AddSystem(
            Integrator(self.control_plant, self.control_info.actuated_joints, self.q0, period=period)
        )
        b.Connect(sot.GetOutputPort("qdot"), device.GetInputPort("qdot"))
        for port in self._q_consumers:
            b.Connect(device.GetOutputPort("q"), port)
        b.Connect(
            device.GetOutputPort("state_des"),
            self.plant.get_desired_state_input_port(self.info.model_instance),
        )
        feet = [self.control_info.frames["left_foot"], self.control_info.frames["right_foot"]]
        feedforward = b.AddSystem(
            TorqueFeedforward(self.control_plant, self.control_info.actuated_joints, feet)
        )
        feedforward.set_name("torque_feedforward")
        inputs = ("q", "v", "vdot") if dynamic_feedforward else ("q",)
        for name in inputs:
            b.Connect(device.GetOutputPort(name), feedforward.GetInputPort(name))
        if load is not None:
            b.Connect(load, feedforward.GetInputPort("load"))
        b.Connect(
            feedforward.GetOutputPort("tau"), self.plant.get_actuation_input_port(self.info.model_instance)
        )

        history = b.AddSystem(StackHistory(period=period))
        b.Connect(sot.GetOutputPort("stack"), history.GetInputPort("stack"))

        diagram, loggers, visualizer = self._finish(
            {"q_ref": device.GetOutputPort("q"), "errors": sot.GetOutputPort("errors")}, log_period
        )
        return HumanoidSoT(
            diagram=diagram,
            plant=self.plant,
            info=self.info,
            control_plant=self.control_plant,
            dyn=self.dyn,
            sot=sot,
            device=device,
            tasks=dict(self.tasks),
            features=dict(self.features),
            loggers=loggers,
            stack_history=history,
            q0=self.q0,
            meshcat=self.meshcat,
            visualizer=visualizer,
        )

    def build_generalized(
        self,
        *,
        motion: Sequence[tuple[str, float, float]],
        alpha: OutputPort,
        force: Sequence[tuple[str, float, float]] = (),
        force_inputs: dict[str, tuple[OutputPort, OutputPort]] | None = None,
        weighted: bool = False,
        weights: dict[str, float] | None = None,
        mu: float = 0.8,
        log_period: float | None = None,
    ) -> HumanoidTorqueControl:
        """Close the loop with a ``GeneralizedHierarchyController`` (paper 004) on the
        torque-controlled robot; the features read the *measured* configuration.

        Args:
            motion: ``(task name, kp, kd)`` of each motion task (eq. 2).
            alpha: the priority matrix signal (e.g. ``PrioritySchedule.alpha``), over the
                motion tasks then the force tasks, in the order given here.
            force: ``(task name, kp, ki)`` of each force task (eq. 3).
            force_inputs: force task name → (desired, measured) wrench output ports, for
                the controller's ``<name>_desired`` and ``<name>_measured`` inputs.
            weighted: the weighted baseline (eq. 5-7) with ``weights`` instead.
            mu: friction coefficient of the sole-corner contact points (none on a fixed base).
        """
        if self.actuation != "torque":
            raise ValueError("build_generalized() needs HumanoidSoTBuilder(actuation='torque')")
        b = self.builder
        contacts = (
            []
            if self.fixed_base
            else [
                ContactPoints(self.control_info.frames[foot], sole_corner_points(), mu=mu)
                for foot in ("left_foot", "right_foot")
            ]
        )
        controller = b.AddSystem(
            GeneralizedHierarchyController(
                self.control_plant,
                self.control_info.actuated_joints,
                motion_tasks=[MotionTask(self.tasks[n], kp, kd) for n, kp, kd in motion],
                force_tasks=[ForceTask(self.tasks[n], kp, ki) for n, kp, ki in force],
                contacts=contacts,
                q_posture=self.q0,
                period=self.control_period,
                weighted=weighted,
                weights=weights,
            )
        )
        for name in controller.task_names:
            b.Connect(self.tasks[name].GetOutputPort("task"), controller.GetInputPort(name))
        for name, (desired, measured) in (force_inputs or {}).items():
            b.Connect(desired, controller.GetInputPort(f"{name}_desired"))
            b.Connect(measured, controller.GetInputPort(f"{name}_measured"))
        state = self.plant.get_state_output_port(self.info.model_instance)
        b.Connect(state, controller.GetInputPort("state"))
        b.Connect(alpha, controller.GetInputPort("alpha"))
        b.Connect(
            controller.GetOutputPort("tau"), self.plant.get_actuation_input_port(self.info.model_instance)
        )
        nq, nv = self.control_plant.num_positions(), self.control_plant.num_velocities()
        split = b.AddSystem(Demultiplexer([nq, nv]))
        split.set_name("measured_q_v")
        b.Connect(state, split.get_input_port())
        for port in self._q_consumers:
            b.Connect(split.get_output_port(0), port)
        diagram, loggers, visualizer = self._finish(
            {
                name: controller.GetOutputPort(name)
                for name in ("errors", "wrenches", "tau", "status", "contact_forces")
            },
            log_period,
        )
        return HumanoidTorqueControl(
            diagram=diagram,
            plant=self.plant,
            info=self.info,
            control_plant=self.control_plant,
            dyn=self.dyn,
            tasks=dict(self.tasks),
            features=dict(self.features),
            loggers=loggers,
            q0=self.q0,
            meshcat=self.meshcat,
            visualizer=visualizer,
            controller=controller,
        )

    def _finish(self, logs: dict[str, OutputPort], log_period: float | None):
        """Loggers (plant state, ``logs``, the extra ones), the visualizer, and the diagram."""
        b = self.builder
        log_period = log_period or self.control_period
        ports = {
            "state": self.plant.get_state_output_port(self.info.model_instance),
            **logs,
            **self._extra_logs,
        }
        loggers = {name: LogVectorOutput(port, b, log_period) for name, port in ports.items()}
        for name, logger in loggers.items():
            logger.set_name(f"log_{name}")
        visualizer = None
        if self.meshcat is not None:
            visualizer = MeshcatVisualizer.AddToBuilder(
                b, self.scene_graph, self.meshcat, MeshcatVisualizerParams(publish_period=1 / 30)
            )
        diagram = b.Build()
        diagram.set_name("drake_sot")
        return diagram, loggers, visualizer


def _mass_below(plant: MultibodyPlant, context, joint) -> tuple[float, np.ndarray]:
    """Mass [kg] and centre of mass (in the joint's child frame) of every body outboard of ``joint``."""
    parent = {}
    for i in range(plant.num_joints()):
        j = plant.get_joint(JointIndex(i))
        parent[j.child_body().index()] = j.parent_body().index()
    root = joint.child_body().index()

    def below(b) -> bool:
        while b != root and b in parent:
            b = parent[b]
        return b == root

    bodies = [plant.get_body(BodyIndex(i)) for i in range(plant.num_bodies()) if below(BodyIndex(i))]
    mass = sum(body.default_mass() for body in bodies)
    p_WCm = (
        sum(
            body.default_mass()
            * body.EvalPoseInWorld(context).multiply(body.default_spatial_inertia().get_com())
            for body in bodies
        )
        / mass
    )
    return mass, joint.frame_on_child().CalcPoseInWorld(context).inverse().multiply(p_WCm)


def loopback_meshcat() -> Meshcat:
    """A Meshcat server bound to localhost on a free port (headless recording; nothing listens outside)."""
    return Meshcat(MeshcatParams(host="localhost", port=0))
