"""Tasks by name around the embedded humanoid: the part both closed loops share.

:class:`HumanoidTaskBuilder` puts the simulated world in a ``DiagramBuilder``
(:func:`~drake_sot.diagrams.world.add_humanoid_plant`), builds the controller's own copy
of the robot model with its ``RobotKinematics`` (the ``dyn`` entity of Mansard et al.
2009) and wires features and tasks by name. It does not close the loop: the kinematic
Stack of Tasks on a position-controlled robot
(:class:`~drake_sot.diagrams.humanoid.HumanoidSoTBuilder`) and the generalized
hierarchy on a torque-controlled one
(:class:`~drake_sot.diagrams.torque_humanoid.TorqueHumanoidBuilder`) do.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Rgba
from pydrake.math import RigidTransform
from pydrake.multibody.plant import ExternallyAppliedSpatialForceMultiplexer, MultibodyPlant
from pydrake.systems.framework import Diagram, DiagramBuilder, InputPort, OutputPort
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink

from drake_sot.diagrams.collision_log import distance_log, pair_log
from drake_sot.diagrams.pushes import ExternalPush, check_pushes
from drake_sot.diagrams.world import add_humanoid_plant
from drake_sot.errors import UnknownNameError
from drake_sot.features import SelectionLike, selection_indices
from drake_sot.gains import Gain
from drake_sot.models import HumanoidInfo, half_sitting_configuration
from drake_sot.robots import RobotDescription, get_robot, make_robot_control_model
from drake_sot.stack import task_name as checked_task_name
from drake_sot.systems.admittance import AdmittanceController
from drake_sot.systems.fall_monitor import FallCriteria, FallMonitor
from drake_sot.systems.features import (
    Feature,
    FeatureCoM,
    FeatureJointLimits,
    FeaturePoint6d,
    FeaturePoint6dRelative,
    FeaturePosture,
    FeatureVisualPoint,
)
from drake_sot.systems.force_sensor import ForceSensor, payload
from drake_sot.systems.generalized_controller import VECTOR_OUTPUTS
from drake_sot.systems.inequalities import (
    CoMInSupportPolygon,
    DistanceAbove,
    InequalityTask,
    JointPositionLimits,
    JointVelocityLimits,
    PointAbovePlane,
)
from drake_sot.systems.kinematics import FRAME_SUFFIX, RobotKinematics
from drake_sot.systems.partner import ConstantForce, Partner
from drake_sot.systems.replay_view import Arrow, ArrowGroup, FollowCamera, ForceArrows, PairLines, SoleForces
from drake_sot.systems.self_collision import Obstacle, SelfCollisionAvoidance, add_obstacles
from drake_sot.systems.task import Task
from drake_sot.validation import positive, vector

#: Names of the logs the builders write (the plant state, the kinematic SoT's reference
#: and errors, the torque controller's outputs, the fall monitor's flag, the pushes'
#: forces, the contact forces at the soles); :meth:`HumanoidTaskBuilder.log` refuses them.
RESERVED_LOGS = ("state", "q_ref", *VECTOR_OUTPUTS, "fallen", "push_forces", "sole_forces")
#: The colours of the force arrows of a replay (see :meth:`HumanoidTaskBuilder.draw_forces`).
SOLE_COLOUR = Rgba(0.1, 0.7, 0.2, 1.0)
WRIST_COLOUR = Rgba(0.65, 0.1, 0.85, 1.0)
PARTNER_COLOUR = Rgba(1.0, 0.55, 0.0, 1.0)
PUSH_COLOUR = Rgba(0.9, 0.1, 0.1, 1.0)
#: [N/m] the scales of the arrows: the soles carry the robot's weight (hundreds of N), a
#: wrist and a partner tens of N.
SOLE_SCALE = 1000.0
HAND_SCALE = 100.0
PUSH_SCALE = 500.0
#: [m] how far from a sole's outer edge its contact force is drawn.
SOLE_ARROW_GAP = 0.03
#: The fall criteria every floating-base builder monitors by default.
FALL_CRITERIA = FallCriteria()
#: The self-collision task of the kinematic scenarios (:meth:`HumanoidTaskBuilder.below_joint_limits`).
SELF_COLLISION_TASK = "taskSelfCollision"


def feature_name(task_name: str) -> str:
    """The name of the feature a builder makes for the task ``task_name``, as the SoT's scripts
    name them (Mansard et al. 2009): ``taskCom`` → ``featureCom``, ``taskRH`` → ``featureRH``; a
    task name not of the form ``task<Name>`` gets ``feature_<task name>``."""
    if task_name.startswith("task") and task_name[4:5].isupper():
        return "feature" + task_name[4:]
    return f"feature_{task_name}"


class HumanoidTaskBuilder:
    """Adds features and tasks by name around the embedded humanoid (the loop is closed
    by a subclass, which says how the simulated robot is actuated in
    :attr:`POSITION_CONTROLLED`).

    Args:
        control_period: period of the controller's tick [s] (5 ms as on HRP-2), finite > 0.
        time_step: physics step of the plant [s], finite > 0.
        meshcat: a Meshcat to draw in; None for no visualisation. Use
            :func:`~drake_sot.diagrams.world.loopback_meshcat` for a headless recorder
            bound to localhost. Besides the robot it shows the forces as arrows (see
            :meth:`draw_forces`), the pairs each self-collision task holds apart (see
            :meth:`add_self_collision_task`) and, on a floating base, its camera follows the
            pelvis (:class:`~drake_sot.systems.replay_view.FollowCamera`).
        fixed_base: weld the pelvis in the air (no ground), as the real iCub of Liu,
            Lober, Padois 2016.
        before_finalize: adds to the simulated world before it is finalized (see
            :func:`~drake_sot.diagrams.world.add_humanoid_plant`).
        pushes: :class:`~drake_sot.diagrams.pushes.ExternalPush` disturbances applied to the
            simulated robot (their forces are logged as ``push_forces``, 3 columns per
            pushed frame, in the order of first push).
        fall_criteria: on a floating base, a ``FallMonitor`` with these criteria is added
            (its ``fallen`` flag is logged; :func:`~drake_sot.diagrams.run.simulate` stops
            the run and reports the fall); None for none. Ignored on a fixed base.
        robot: the robot, a name of ``drake_sot.robots.ROBOTS`` ("embedded", "talos", "g1")
            or a :class:`~drake_sot.robots.RobotDescription`.
        q0: (nq,) the initial and reference configuration of the control model (the
            simulated robot starts there, at rest; the posture task's default goal); None:
            the robot's half-sitting configuration.
        obstacles: boxes fixed in the simulated world (a table; after ``before_finalize``),
            which :meth:`add_self_collision_task` also keeps the robot away from.

    Raises:
        ValueError: a period or step that is NaN, infinite or not > 0 (checked before
            Drake sees it: a Drake assertion ends the interpreter); a push on an unknown
            frame, or two overlapping pushes on one frame.
    """

    #: True: PD-controlled actuators that take a desired state (the kinematic SoT);
    #: False: torque-controlled actuators (the generalized hierarchy).
    POSITION_CONTROLLED: bool = True

    def __init__(
        self,
        *,
        control_period: float = 0.005,
        time_step: float = 1e-3,
        meshcat: Meshcat | None = None,
        fixed_base: bool = False,
        before_finalize: Callable[[MultibodyPlant, HumanoidInfo], None] | None = None,
        pushes: Sequence[ExternalPush] = (),
        fall_criteria: FallCriteria | None = FALL_CRITERIA,
        robot: str | RobotDescription = "embedded",
        q0: np.ndarray | None = None,
        obstacles: Sequence[Obstacle] = (),
    ) -> None:
        control_period = positive("control_period", control_period, unit="s")
        self.obstacles = tuple(obstacles)

        def add_to_world(plant: MultibodyPlant, info: HumanoidInfo) -> None:
            if before_finalize is not None:
                before_finalize(plant, info)
            add_obstacles(plant, self.obstacles)

        if fall_criteria is not None and not isinstance(fall_criteria, FallCriteria):
            raise ValueError(f"fall_criteria = {fall_criteria!r}: must be a FallCriteria or None")
        self.fixed_base = fixed_base
        self.robot = get_robot(robot)
        self.builder = DiagramBuilder()
        self.plant, self.scene_graph, self.info = add_humanoid_plant(
            self.builder,
            time_step=time_step,
            pd_gains=self.POSITION_CONTROLLED,
            fixed_base=fixed_base,
            before_finalize=add_to_world,
            robot=self.robot,
        )
        self.pushes = check_pushes(pushes, self.info.frames)
        self.fall_criteria = None if fixed_base else fall_criteria
        self.fall_monitor: FallMonitor | None = None  # added by _finish
        self._spatial_forces: list[OutputPort] = []
        self._drawn_forces: list[tuple[ArrowGroup, OutputPort]] = []
        self.control_plant, self.control_info = make_robot_control_model(self.robot, fixed_base=fixed_base)
        self.q0 = (
            half_sitting_configuration(self.control_plant, self.control_info)
            if q0 is None
            else vector("q0", q0, self.control_plant.num_positions()).copy()
        )
        self.control_period = control_period
        self.meshcat = meshcat
        self.dyn = self.builder.AddSystem(RobotKinematics(self.control_plant))
        self.dyn.set_name("dyn")
        self.tasks: dict[str, Task | InequalityTask] = {}
        self.features: dict[str, Feature] = {}
        self._pose_feature_frames: dict[FeaturePoint6d, str] = {}  # op-point feature -> its frame key
        self._q_consumers: list = [self.dyn.GetInputPort("q")]
        self._qdot_consumers: list = []  # inputs of the q̇ the solver committed (its output)
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
            raise UnknownNameError("frame", frame_key, self.control_info.frames)
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

    def _connect_frame(self, op: str, feature: Feature, suffix: str = "") -> None:
        """Feed a pose feature's ``frame<suffix>`` input with the operational point's pose and
        Jacobian in one value (one port evaluation a tick, not two)."""
        self.builder.Connect(
            self.dyn.GetOutputPort(op + FRAME_SUFFIX), feature.GetInputPort("frame" + suffix)
        )

    def add_task(self, task: Task) -> Task:
        """Add a task made elsewhere (its features added and plugged by the caller, e.g. the
        script interpreter's ``new Task``): it joins the diagram and, at ``build``, the solver.

        Raises ValueError when a task of that name exists already.
        """
        if task.get_name() in self.tasks:
            raise ValueError(f"a task named {task.get_name()!r} exists already")
        self.tasks[task.get_name()] = self.builder.AddSystem(task)
        return task

    def use_reference_q(self, port: InputPort) -> None:
        """Feed ``port`` (a configuration input, e.g. ``FeaturePosture.q``) with the reference
        configuration the loop integrates, as ``dyn.q`` is (connected at ``build``)."""
        self._q_consumers.append(port)

    def _add_task(
        self, task_name: str, feature: Feature, gain: Gain, selection: SelectionLike = None
    ) -> Task:
        """A task reading ``feature`` (added to the diagram unless it is there already, shared).

        The task is made and given its feature (its name, gain and selection checked) before
        the builder changes: a refused call leaves the builder as it was."""
        if task_name in self.tasks:
            raise ValueError(f"a task named {task_name!r} exists already")
        task = Task(task_name, gain=gain)
        port = task.add(feature, selection=selection)
        if feature not in self.features.values():
            self.builder.AddSystem(feature)
        self.add_task(task)
        self.builder.Connect(feature.GetOutputPort("feature"), port)
        self.features[task_name] = feature
        return task

    def _check_new_task(
        self,
        task_name: str,
        *,
        frames: Sequence[str] = (),
        selection: SelectionLike = None,
        dimension: int = 6,
    ) -> None:
        """Refuse, before the builder changes, what would stop a task from being added half-way:
        a bad or taken ``task_name``, a frame that is no operational point and no frame of the
        robot, a ``selection`` of the ``dimension`` components that is not one (ValueError, or
        UnknownNameError for a frame, naming them)."""
        checked_task_name(task_name)
        if task_name in self.tasks:
            raise ValueError(f"a task named {task_name!r} exists already")
        for key in frames:
            if key not in self.dyn.operational_points:
                self._frame(key)
        if selection is not None:
            selection_indices(selection, dimension, name=f"selection of task {task_name!r}")

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
        self._check_new_task(task_name, frames=(frame_key,), selection=selection)
        if feature_of is not None:
            return self._add_task(
                task_name, self._shared_pose_feature(feature_of, frame_key, desired), gain, selection
            )
        feature = FeaturePoint6d(
            name=feature_name(task_name),
            desired=self.initial_pose(frame_key) if desired is None else desired,
        )
        task = self._add_task(task_name, feature, gain, selection)
        self._connect_frame(self.op_point(frame_key), feature)
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
        self._check_new_task(task_name, frames=(frame_key, reference_key))
        if desired is None:
            desired = self.initial_pose(reference_key).InvertAndCompose(self.initial_pose(frame_key))
        feature = FeaturePoint6dRelative(selection=selection, name=feature_name(task_name), desired=desired)
        task = self._add_task(task_name, feature, gain)
        self._connect_frame(self.op_point(frame_key), feature)
        self._connect_frame(self.op_point(reference_key), feature, "Ref")
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
            name=feature_name(task_name),
            desired=self.initial_com() if desired is None else desired,
        )
        task = self._add_task(task_name, feature, gain)
        self.builder.Connect(self.dyn.GetOutputPort("com"), feature.GetInputPort("com"))
        self.builder.Connect(self.dyn.GetOutputPort("Jcom"), feature.GetInputPort("Jcom"))
        return task

    def add_visual_point_task(
        self,
        task_name: str,
        point: OutputPort,
        *,
        point_velocity: OutputPort | None = None,
        camera: str = "head_camera",
        gain: Gain = 1.0,
        desired: np.ndarray | None = None,
        selection: SelectionLike = None,
    ) -> Task:
        """A gaze task (``FeatureVisualPoint``): keep the world point ``point`` at the image
        point ``desired`` (the image centre ``(0, 0)`` by default) of the camera frame
        ``camera``.

        The humanoid's ``head_camera`` sits on the face of the head and looks along the
        head's +x (forward), x to the image's right and y down (``models.humanoid.HEAD_CAMERA``);
        ``camera`` may name another frame of the robot, whose z axis is then the optical axis.

        Args:
            task_name: the task.
            point: an output (3,) [m], the point's position in world (e.g.
                ``MovingPoint.position``).
            point_velocity: an output (3,) [m/s], its velocity, fed forward; None for a still point.
            camera: the camera frame's logical name.
            gain: λ [1/s]; desired: s* (2,) in normalised image coordinates; selection: of x, y.
        """
        self._check_new_task(task_name, frames=(camera,))
        feature = FeatureVisualPoint(selection=selection, name=feature_name(task_name), desired=desired)
        task = self._add_task(task_name, feature, gain)
        self._connect_frame(self.op_point(camera), feature)
        self.builder.Connect(point, feature.GetInputPort("point"))
        if point_velocity is not None:
            self.builder.Connect(point_velocity, feature.GetInputPort("point_velocity"))
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
            name=feature_name(task_name),
            desired=self.q0 if desired is None else desired,
        )
        task = self._add_task(task_name, feature, gain)
        self.use_reference_q(feature.GetInputPort("q"))
        return task

    def add_admittance_controller(
        self,
        name: str,
        side: str,
        *,
        mass: float | Sequence[float],
        damping: float | Sequence[float],
        stiffness: float | Sequence[float] = 0.0,
        max_velocity=(0.5, 1.0),
        weighted: bool = False,
    ) -> AdmittanceController:
        """An ``AdmittanceController`` named ``name`` on one hand, read by its wrist sensor
        (Mansard et al. 2009, IV-C): the sensor's wrench, the sensor frame's and the hand's
        poses (``dyn`` operational points ``<side>_wrist_sensor`` and ``<side>_hand``) are wired.

        Args:
            side: ``"right"`` or ``"left"``.
            mass, damping, stiffness: the virtual mass [kg, kg·m²], damping [N·s/m,
                N·m·s/rad] and stiffness of the admittance, per axis or one value.
            max_velocity: saturation (linear, angular).
            weighted: the A-weighted variant (Evrard et al. 2009, III-B): the translation's
                virtual mass is the hand's apparent inertia, from ``dyn.inertia`` and the hand's
                Jacobian (``mass`` then gives the rotation's only).
        Returns:
            the controller; its ``position_des`` and ``velocity_des`` are for a hand feature,
            its ``active`` and ``wrench_ref`` inputs are left for the caller to drive
            (active and zero when unconnected).
        """
        if side not in ("right", "left"):
            raise ValueError(f"side {side!r} must be 'right' or 'left'")
        sensor_joint = self.info.force_sensors[f"{side}_wrist"]
        joint = self.control_plant.GetJointByName(sensor_joint)
        hand_mass, hand_com = payload(self.control_plant, sensor_joint, self._probe_context)
        controller = AdmittanceController(  # its arguments checked before the builder changes
            mass=mass,
            damping=damping,
            stiffness=stiffness,
            hand_mass=hand_mass,
            hand_com=hand_com,
            period=self.control_period,
            max_velocity=max_velocity,
            weighted=weighted,
            name=name,
        )
        sensor = self.builder.AddSystem(ForceSensor(self.plant, sensor_joint))
        sensor.set_name(f"{side}_wrist_sensor")
        self.builder.Connect(
            self.plant.get_reaction_forces_output_port(), sensor.GetInputPort("reaction_forces")
        )
        sensor_op = self.op_point(f"{side}_wrist_sensor", joint.frame_on_child().name())
        admittance = self.builder.AddSystem(controller)
        hand = self.op_point(f"{side}_hand")
        if weighted:
            self.builder.Connect(self.dyn.GetOutputPort("inertia"), admittance.GetInputPort("inertia"))
            self.builder.Connect(self.dyn.GetOutputPort("J" + hand), admittance.GetInputPort("hand_jacobian"))
        self.builder.Connect(sensor.GetOutputPort("wrench"), admittance.GetInputPort("wrench"))
        self.builder.Connect(self.dyn.GetOutputPort(sensor_op), admittance.GetInputPort("sensor_pose"))
        self.builder.Connect(self.dyn.GetOutputPort(hand), admittance.GetInputPort("hand_pose"))
        body, point = self._body_point(f"{side}_hand")
        self.draw_forces(
            ArrowGroup(
                name,
                "wrist sensor: the external force on the hand",
                WRIST_COLOUR,
                HAND_SCALE,
                6,
                (Arrow(body, point, 3),),
            ),
            admittance.GetOutputPort("wrench_external"),
        )
        return admittance

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
        selection: SelectionLike = None,
        weighted: bool = False,
    ) -> AdmittanceController:
        """A force-based hand task (Mansard et al. 2009, IV-C): the hand's wrist sensor drives an
        ``AdmittanceController`` (:meth:`add_admittance_controller`, named
        ``admittance_<task_name>``) whose reference pose and velocity feed a 6D hand task.

        Args:
            task_name: the task (e.g. the paper's ``taskForce``).
            side, mass, damping, stiffness, max_velocity, weighted: as
                :meth:`add_admittance_controller`.
            gain: the hand task's gain [1/s].
            selection: the components of the hand task (as :meth:`add_op_point_task`; None: all 6).
        Returns:
            the controller, whose ``active``, ``wrench_ref`` inputs are left for the
            scenario to drive (active and zero when unconnected).
        """
        self._check_new_task(task_name, frames=(f"{side}_hand",) if side in ("right", "left") else (),
                             selection=selection)  # fmt: skip
        admittance = self.add_admittance_controller(
            f"admittance_{task_name}",
            side,
            mass=mass,
            damping=damping,
            stiffness=stiffness,
            max_velocity=max_velocity,
            weighted=weighted,
        )
        self.add_op_point_task(task_name, f"{side}_hand", gain=gain, selection=selection)
        feature = self.features[task_name]
        self.builder.Connect(admittance.GetOutputPort("position_des"), feature.GetInputPort("position_des"))
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
            name=feature_name(task_name),
        )
        task = self._add_task(task_name, feature, gain)
        self.use_reference_q(feature.GetInputPort("q"))
        return task

    # --- inequality tasks (StackOfTasks(solver="hqp")) ---------------------------------
    def _add_inequality(self, task: InequalityTask) -> InequalityTask:
        if task.get_name() in self.tasks:
            raise ValueError(f"a task named {task.get_name()!r} exists already")
        self.tasks[task.get_name()] = self.builder.AddSystem(task)
        return task

    def add_joint_position_limits_task(
        self,
        task_name: str,
        *,
        margin: float = 0.02,
        velocity_scale: float | None = None,
        joints: Sequence[str] | None = None,
    ) -> JointPositionLimits:
        """Joint position limits as velocity bounds over the control period, ``margin`` inside
        each limit (``JointPositionLimits``), on ``joints`` (every actuated joint by default);
        with ``velocity_scale``, the velocity limits (times it) in the same rows. The solver's
        q̇ output feeds its ``qdot`` input (the device's one-tick latency). An inequality
        task: the stack needs ``build(..., solver="hqp")``."""
        task = JointPositionLimits(
            self.control_plant,
            period=self.control_period,
            joints=list(joints) if joints is not None else list(self.control_info.actuated_joints),
            margin=margin,
            velocity_scale=velocity_scale,
            name=task_name,
        )
        self._add_inequality(task)
        self._q_consumers.append(task.GetInputPort("q"))
        self._qdot_consumers.append(task.GetInputPort("qdot"))
        return task

    def add_joint_velocity_limits_task(
        self, task_name: str, *, scale: float = 1.0, joints: Sequence[str] | None = None
    ) -> JointVelocityLimits:
        """The model's joint velocity limits, times ``scale`` (``JointVelocityLimits``), on
        ``joints`` (every actuated joint by default). An inequality task."""
        joints = list(joints) if joints is not None else list(self.control_info.actuated_joints)
        return self._add_inequality(
            JointVelocityLimits(self.control_plant, joints=joints, scale=scale, name=task_name)
        )

    def add_com_support_task(
        self,
        task_name: str,
        *,
        margin: float = 0.02,
        gain: float = 5.0,
        contacts: OutputPort | None = None,
        polygon: OutputPort | None = None,
        max_vertices: int = 8,
    ) -> CoMInSupportPolygon:
        """The CoM's ground projection ``margin`` inside the support polygon (``CoMInSupportPolygon``).

        The polygon is that of the feet in contact (the soles' frames from ``dyn``; both
        feet unless ``contacts``, a (2,) [left, right] output such as
        ``PatternGenerator.contacts``, says otherwise), or the output ``polygon`` (abstract
        (k, 2) vertices, counter-clockwise) when given. An inequality task.
        """
        if polygon is not None and contacts is not None:
            raise ValueError(f"{task_name!r}: contacts select feet; with a polygon output there are none")
        task = self._add_inequality(
            CoMInSupportPolygon(
                sole_size=None if polygon is not None else self.info.sole_size,
                margin=margin,
                gain=gain,
                max_vertices=max_vertices,
                name=task_name,
            )
        )
        b = self.builder
        b.Connect(self.dyn.GetOutputPort("com"), task.GetInputPort("com"))
        b.Connect(self.dyn.GetOutputPort("Jcom"), task.GetInputPort("Jcom"))
        if polygon is not None:
            b.Connect(polygon, task.GetInputPort("polygon"))
            return task
        for side in ("left", "right"):
            b.Connect(
                self.dyn.GetOutputPort(self.op_point(f"{side}_foot")), task.GetInputPort(f"{side}_sole")
            )
        if contacts is not None:
            b.Connect(contacts, task.GetInputPort("contacts"))
        return task

    def add_above_plane_task(
        self,
        task_name: str,
        frame_key: str,
        *,
        normal: Sequence[float] = (0.0, 0.0, 1.0),
        origin: Sequence[float] = (0.0, 0.0, 0.0),
        clearance: float = 0.0,
        offset: Sequence[float] = (0.0, 0.0, 0.0),
        gain: float = 5.0,
    ) -> PointAbovePlane:
        """A point (``offset`` in a humanoid frame) kept ``clearance`` above a plane
        (``PointAbovePlane``; e.g. a hand above a table). An inequality task."""
        self._check_new_task(task_name, frames=(frame_key,))
        task = self._add_inequality(
            PointAbovePlane(
                normal=normal, origin=origin, clearance=clearance, offset=offset, gain=gain, name=task_name
            )
        )
        self._wire_op_point(frame_key, task)
        return task

    def add_distance_task(
        self,
        task_name: str,
        frame_a: str,
        frame_b: str,
        *,
        minimum: float,
        offset_a: Sequence[float] = (0.0, 0.0, 0.0),
        offset_b: Sequence[float] = (0.0, 0.0, 0.0),
        gain: float = 5.0,
    ) -> DistanceAbove:
        """Two humanoid frames' points kept at least ``minimum`` apart (``DistanceAbove``; e.g. a
        hand and the torso, each inside a sphere). An inequality task."""
        self._check_new_task(task_name, frames=(frame_a, frame_b))
        task = self._add_inequality(
            DistanceAbove(minimum=minimum, offset_a=offset_a, offset_b=offset_b, gain=gain, name=task_name)
        )
        self._wire_op_point(frame_a, task, "_a")
        self._wire_op_point(frame_b, task, "_b")
        return task

    def add_self_collision_task(
        self,
        task_name: str,
        *,
        d_s: float = 0.01,
        d_i: float = 0.05,
        xi: float = 0.2,
        max_pairs: int = 16,
        leg_pairs: bool = True,
        recovery: float | None = None,
    ) -> SelfCollisionAvoidance:
        """Every pair of the robot's collision shapes that may collide kept ``d_s`` apart, with
        rows for the pairs closer than ``d_i`` (``SelfCollisionAvoidance``, on this builder's
        robot and base, and its ``obstacles``; without ``leg_pairs``, none between the two
        legs, which a footstep plan keeps apart; a pair inside ``d_s`` asked back at ``recovery``
        [1/s], by default 1 / the control period). Reads the reference q. An inequality task. Its
        rows' distances and pairs are logged (``collision/<task_name>/...``, see
        :mod:`~drake_sot.diagrams.collision_log`) and, with Meshcat, drawn
        (:class:`~drake_sot.systems.replay_view.PairLines`)."""
        task = self._add_inequality(
            SelfCollisionAvoidance(
                self.robot,
                fixed_base=self.fixed_base,
                d_s=d_s,
                d_i=d_i,
                xi=xi,
                max_pairs=max_pairs,
                name=task_name,
                obstacles=self.obstacles,
                leg_pairs=leg_pairs,
                recovery=1.0 / self.control_period if recovery is None else recovery,
            )
        )
        self.use_reference_q(task.GetInputPort("q"))
        self._log_self_collision(task)
        return task

    def _log_self_collision(self, task: SelfCollisionAvoidance) -> None:
        """Log the rows' distances and pairs of ``task`` (see
        :mod:`~drake_sot.diagrams.collision_log`); the replay draws its pairs (``_add_replay_view``)."""
        self.log(distance_log(task.get_name()), task.GetOutputPort("distances"))
        self.log(pair_log(task.get_name()), task.GetOutputPort("pair_indices"))

    def below_joint_limits(
        self, stack: Sequence[str], self_collision: bool = True, **parameters: float | bool
    ) -> tuple[str, ...]:
        """``stack`` with the self-collision task :data:`SELF_COLLISION_TASK` (added here by
        :meth:`add_self_collision_task` with ``parameters``: ``d_s``, ``d_i``, ``xi``,
        ``max_pairs``, ``leg_pairs``, ``recovery``, its defaults when not given) just below its first level,
        the joint limits, as every kinematic scenario has it; ``stack`` as it is when not
        ``self_collision``. The stack needs ``build(..., solver="hqp")``.

        Raises:
            ValueError: ``stack``'s first task is not a ``JointPositionLimits`` task of this
                builder (naming it); a task named :data:`SELF_COLLISION_TASK` exists already;
                what :meth:`add_self_collision_task` raises.
            TypeError: a parameter :meth:`add_self_collision_task` does not take.
        """
        stack = tuple(stack)
        if not self_collision:
            return stack
        if not stack or not isinstance(self.tasks.get(stack[0]), JointPositionLimits):
            raise ValueError(
                f"stack = {stack!r}: the self-collision task goes below the joint limits, its first "
                "level must be a task of add_joint_position_limits_task"
            )
        self.add_self_collision_task(SELF_COLLISION_TASK, **parameters)
        return (stack[0], SELF_COLLISION_TASK, *stack[1:])

    def _wire_op_point(self, frame_key: str, system, suffix: str = "") -> None:
        """The pose and Jacobian of the operational point on ``frame_key`` into ``system``'s
        ``position<suffix>`` and ``Jq<suffix>`` inputs."""
        op = self.op_point(frame_key)
        self.builder.Connect(self.dyn.GetOutputPort(op), system.GetInputPort("position" + suffix))
        self.builder.Connect(self.dyn.GetOutputPort("J" + op), system.GetInputPort("Jq" + suffix))

    def apply_spatial_forces(self, port: OutputPort) -> None:
        """Apply the forces of an abstract ``list[ExternallyAppliedSpatialForce]`` output (e.g.
        ``Partner.spatial_forces``) to the simulated plant, beside the pushes and any other
        such output (the plant has one input for them: the builder gathers them)."""
        self._spatial_forces.append(port)

    def draw_forces(self, group: ArrowGroup, port: OutputPort) -> None:
        """Draw the forces of the vector output ``port`` as ``group`` says (see
        :class:`~drake_sot.systems.replay_view.ForceArrows`) in the live view and the replay; no
        effect without Meshcat. The builder draws the contact forces at the soles, the pushes
        and the external forces the wrist sensors of the admittance controllers measure."""
        if self.meshcat is not None:
            self._drawn_forces.append((group, port))

    def _body_point(self, frame_key: str) -> tuple[str, tuple[float, float, float]]:
        """The body of the simulated plant a logical frame is on, and the frame's origin in it."""
        frame = self.plant.GetFrameByName(self.info.frames[frame_key], self.info.model_instance)
        return frame.body().name(), tuple(frame.GetFixedPoseInBodyFrame().translation())

    def log(self, name: str, port: OutputPort) -> None:
        """Log a vector output port at the control period; it appears as ``name`` in the run's logs."""
        if name in self._extra_logs or name in RESERVED_LOGS:
            raise ValueError(f"a log named {name!r} exists already")
        self._extra_logs[name] = port

    def _finish(
        self, logs: dict[str, OutputPort], log_period: float | None
    ) -> tuple[Diagram, dict[str, VectorLogSink], MeshcatVisualizer | None]:
        """The pushes, the fall monitor, the external forces; loggers (plant state, ``logs``, the
        extra ones), the visualizer, and the diagram."""
        b = self.builder
        logs = dict(logs)
        if self.pushes:
            logs["push_forces"] = self._add_pushes()
        if not self.fixed_base and self.meshcat is not None:  # drawn in the replay (a Python system
            logs["sole_forces"] = self._add_sole_forces()  # a tick: not paid where nothing draws it)
        if self.fall_criteria is not None:
            torso = self.plant.GetFrameByName(self.info.frames["torso"], self.info.model_instance).body()
            self.fall_monitor = b.AddSystem(
                FallMonitor(
                    self.plant,
                    pelvis=self.info.base_body,
                    trunk=torso.name(),
                    model_instance=self.info.model_instance,
                    criteria=self.fall_criteria,
                    period=self.control_period,
                )
            )
            self.fall_monitor.set_name("fall_monitor")
            b.Connect(self.plant.get_body_poses_output_port(), self.fall_monitor.GetInputPort("body_poses"))
            logs["fallen"] = self.fall_monitor.GetOutputPort("fallen")
        if len(self._spatial_forces) == 1:
            b.Connect(self._spatial_forces[0], self.plant.get_applied_spatial_force_input_port())
        elif self._spatial_forces:
            mux = b.AddSystem(ExternallyAppliedSpatialForceMultiplexer(len(self._spatial_forces)))
            mux.set_name("external_forces")
            for i, port in enumerate(self._spatial_forces):
                b.Connect(port, mux.get_input_port(i))
            b.Connect(mux.get_output_port(), self.plant.get_applied_spatial_force_input_port())
        log_period = (
            self.control_period if log_period is None else positive("log_period", log_period, unit="s")
        )
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
            self._add_replay_view()
        diagram = b.Build()
        diagram.set_name("drake_sot")
        return diagram, loggers, visualizer

    def _add_sole_forces(self) -> OutputPort:
        """A ``SoleForces`` on the two feet, drawn beside each sole (on its outer side, where the
        leg does not hide it); returns its ``forces`` (right, then left)."""
        sides = {"right": -1.0, "left": 1.0}  # the outer side, along the sole frame's y
        points = []
        for side, outward in sides.items():
            frame = self.plant.GetFrameByName(self.info.frames[f"{side}_foot"], self.info.model_instance)
            beside = [0.0, outward * (self.info.sole_size[1] / 2 + SOLE_ARROW_GAP), 0.0]
            points.append((frame.body().name(), tuple(frame.GetFixedPoseInBodyFrame() @ beside)))
        soles = self.builder.AddSystem(SoleForces(self.plant, [body for body, _ in points]))
        soles.set_name("sole_forces")
        self.builder.Connect(
            self.plant.get_contact_results_output_port(), soles.GetInputPort("contact_results")
        )
        arrows = tuple(Arrow(body, point, 3 * k) for k, (body, point) in enumerate(points))
        self.draw_forces(
            ArrowGroup("soles", "contact force on each sole (beside it)", SOLE_COLOUR, SOLE_SCALE, 6, arrows),
            soles.GetOutputPort("forces"),
        )
        return soles.GetOutputPort("forces")

    def _add_replay_view(self) -> None:
        """The force arrows of :meth:`draw_forces`, the pairs of the self-collision tasks and,
        on a floating base, a camera that follows the pelvis."""
        b, poses = self.builder, self.plant.get_body_poses_output_port()
        for task in self.tasks.values():
            if isinstance(task, SelfCollisionAvoidance):
                lines = b.AddSystem(
                    PairLines(self.meshcat, task.get_name(), task.dimension, task.d_s, task.d_i)
                )
                b.Connect(task.GetOutputPort("closest_pairs"), lines.GetInputPort("closest_pairs"))
        if self._drawn_forces:
            arrows = b.AddSystem(ForceArrows(self.meshcat, self.plant, [g for g, _ in self._drawn_forces]))
            b.Connect(poses, arrows.GetInputPort("body_poses"))
            for group, port in self._drawn_forces:
                b.Connect(port, arrows.GetInputPort(group.name))
        if not self.fixed_base:
            camera = b.AddSystem(FollowCamera(self.meshcat, self.plant, self.info.base_body))
            b.Connect(poses, camera.GetInputPort("body_poses"))

    def _add_pushes(self) -> OutputPort:
        """A ``Partner`` playing the pushes (one ``ConstantForce`` each, at its frame's origin);
        returns its ``forces`` output (3 columns per pushed frame, in the order of first push)."""
        script: dict[str, list[ConstantForce]] = {}  # the partner's script is per body
        points: dict[str, np.ndarray] = {}
        for push in self.pushes:
            frame = self.plant.GetFrameByName(self.info.frames[push.body], self.info.model_instance)
            body, point = frame.body().name(), frame.GetFixedPoseInBodyFrame().translation()
            if body in points and not np.array_equal(points[body], point):
                raise ValueError(f"push body = {push.body!r}: another pushed frame is on body {body!r}")
            points[body] = point
            script.setdefault(body, []).append(ConstantForce(push.time, push.end, push.force))
        partner = self.builder.AddSystem(
            Partner(self.plant, script, period=self.control_period, points=points)
        )
        partner.set_name("pushes")
        self.builder.Connect(self.plant.get_body_poses_output_port(), partner.GetInputPort("body_poses"))
        self.builder.Connect(
            self.plant.get_body_spatial_velocities_output_port(),
            partner.GetInputPort("body_spatial_velocities"),
        )
        self.apply_spatial_forces(partner.GetOutputPort("spatial_forces"))
        arrows = tuple(Arrow(body, tuple(points[body]), 3 * k) for k, body in enumerate(script))
        self.draw_forces(
            ArrowGroup("pushes", "push", PUSH_COLOUR, PUSH_SCALE, 3 * len(script), arrows),
            partner.GetOutputPort("forces"),
        )
        return partner.GetOutputPort("forces")
