"""The kinematic Stack of Tasks around the position-controlled humanoid, in one Drake diagram.

:class:`HumanoidSoTBuilder` is what the kinematic scenarios start from::

    sot = HumanoidSoTBuilder()
    sot.add_op_point_task("taskRH", "right_hand", gain=2.0)
    sot.add_com_task("taskCom", selection="110")
    built = sot.build(stack=["taskCom", "taskRH"])
    simulator = built.create_simulator()

Tasks are added by name (:class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder`); on
:meth:`HumanoidSoTBuilder.build` every task is wired into one ``StackOfTasks`` and the
loop is closed: features → tasks → ``StackOfTasks`` → ``Device`` (q_ref) → the
plant's PD actuators, with a torque feed-forward (quasi-static, or the full inverse
dynamics of the reference), loggers and (optionally) a recorded Meshcat replay.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context, OutputPort

from drake_sot.diagrams.tasks import HumanoidTaskBuilder
from drake_sot.diagrams.world import BuiltHumanoid
from drake_sot.systems.command_server import RemoteCommandServer
from drake_sot.systems.device import Device
from drake_sot.systems.features import FeaturePoint6d
from drake_sot.systems.feedforward import TorqueFeedforward
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.stack_history import StackHistory

#: The logical frames of the feet: a served 6D task on one holds the foot in stance (its target's
#: reach, :meth:`HumanoidSoTBuilder._serve_desired_poses`).
STANCE_FRAMES = ("left_foot", "right_foot")


@dataclass
class HumanoidSoT(BuiltHumanoid):
    """The kinematic SoT around a position-controlled humanoid."""

    sot: StackOfTasks | None = None
    device: Device | None = None
    remote: RemoteCommandServer | None = None

    def set_desired(self, context: Context, task: str, value: RigidTransform | np.ndarray) -> None:
        """Set the desired value s* of ``task``'s feature (the root context): in the command
        server's state when the server holds it (a served 6D task, see :meth:`HumanoidSoTBuilder.build`),
        else the feature's parameter.

        Raises:
            KeyError: an unknown task.
            TypeError, ValueError: a value the feature refuses (named), or one fed by another
                system's output.
        """
        if self.remote is not None and self.remote.holds_desired_pose(task):
            self.remote.set_desired_pose(context, task, value)
        else:
            self.features[task].set_desired(context, value)


class HumanoidSoTBuilder(HumanoidTaskBuilder):
    """Adds tasks by name around the position-controlled humanoid, then closes the
    kinematic Stack of Tasks (Mansard et al. 2009) with :meth:`build`.

    Args: see :class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder` (position-
    controlled actuators).
    """

    POSITION_CONTROLLED = True
    _server: RemoteCommandServer | None = None

    def command_server(self) -> RemoteCommandServer:
        """The diagram's remote command server, added on first use (see
        :class:`~drake_sot.systems.command_server.RemoteCommandServer`)."""
        if self._server is None:
            self._server = self.builder.AddSystem(RemoteCommandServer(self.control_period))
        return self._server

    def declare_writable(
        self, name: str, size: int, units: str, initial: np.ndarray | None = None, *, bound: float
    ) -> OutputPort:
        """A signal remote clients may write, ``remote.<name>`` of ``size`` [``units``], each entry
        within ``±bound``: the output port to wire into what it drives (see
        :meth:`~drake_sot.systems.command_server.RemoteCommandServer.declare_writable`)."""
        return self.command_server().declare_writable(name, size, units, initial, bound=bound)

    def _serve_desired_poses(self, remote: RemoteCommandServer) -> None:
        """Wire the desired pose of each ``FeaturePoint6d`` task that no other system feeds from
        ``remote``'s state, starting at the feature's own (a feature shared by tasks: under the
        first task's name). A foot's (a task on the frame ``left_foot`` or ``right_foot``) holds
        it in stance: a client's target for it stays within one stride of the robot
        (``robot.step_limits.max_stride``, 0.35 m for the embedded humanoid) of where it stood,
        since a foot the robot stands on, sent farther (lifted 1.5 m), throws the robot down."""
        for task_name, feature in self.features.items():
            if not isinstance(feature, FeaturePoint6d):
                continue
            port = feature.GetInputPort("position_des")
            if self.builder.IsConnectedOrExported(port):
                continue
            initial = feature.desired(feature.CreateDefaultContext())
            foot = self._pose_feature_frames.get(feature) in STANCE_FRAMES
            reach = self.robot.step_limits.max_stride if foot else None
            self.builder.Connect(remote.declare_desired_pose(task_name, initial, reach=reach), port)

    def build(
        self,
        stack: Sequence[str],
        *,
        log_period: float | None = None,
        load: OutputPort | None = None,
        dynamic_feedforward: bool = False,
        stack_source: OutputPort | None = None,
        solver: str = "svd",
        wire_solver: Callable[[StackOfTasks], None] | None = None,
        command_server: bool = False,
        damping: float | Mapping[str, float] = 0.0,
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
            stack_source: an abstract ``tuple[str, ...]`` (or ``Stack``) output that drives the
                stack (e.g. ``TaskSequencer.stack``, or ``smooth_stack`` for blended changes);
                then ``stack`` is only the stack's name list for validation and the context
                commands are refused.
            solver: the ``StackOfTasks`` solver, ``"svd"`` (equality tasks) or ``"hqp"``
                (also the inequality tasks, e.g. :meth:`add_joint_position_limits_task`).
            wire_solver: called with the ``StackOfTasks`` before the diagram is built, to
                connect its outputs (``qdot``, ``errors``, ``stack``) to other systems.
            command_server: add a :class:`~drake_sot.systems.command_server.RemoteCommandServer`
                driving the solver's stack commands (``built.remote``), to serve the diagram; a
                builder that declared writable signals has one whatever this says. The server then
                holds the desired pose of each ``FeaturePoint6d`` task whose ``position_des`` no
                other system feeds (clients write its position, ``TASK.position_des``, a foot's
                within a stride of where it stood; set it with :meth:`HumanoidSoT.set_desired`).
            damping: the ``StackOfTasks``' damped least squares (its ``damping``: one μ for every
                task, or, with ``solver="hqp"``, μ by task name); 0, exact.
        """
        b = self.builder
        period = self.control_period
        if command_server:
            self.command_server()
        sot = b.AddSystem(
            StackOfTasks(
                self.control_plant.num_velocities(),
                list(self.tasks.values()),
                period=period,
                stack=stack,
                solver=solver,
                damping=damping,
                commands_input=self._server is not None,
            )
        )
        remote = self._server
        if remote is not None:
            b.Connect(remote.GetOutputPort("commands"), sot.GetInputPort("commands"))
            self._serve_desired_poses(remote)
        for task_name, task in self.tasks.items():
            b.Connect(task.GetOutputPort("task"), sot.GetInputPort(task_name))
        if stack_source is not None:
            b.Connect(stack_source, sot.GetInputPort("stack"))
        device = b.AddSystem(
            Device(self.control_plant, self.control_info.actuated_joints, self.q0, period=period)
        )
        b.Connect(sot.GetOutputPort("qdot"), device.GetInputPort("qdot"))
        for port in self._qdot_consumers:
            b.Connect(sot.GetOutputPort("qdot"), port)
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

        if wire_solver is not None:
            wire_solver(sot)
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
            remote=remote,
            tasks=dict(self.tasks),
            features=dict(self.features),
            loggers=loggers,
            stack_history=history,
            error_layout=sot.error_slices(),
            q0=self.q0,
            meshcat=self.meshcat,
            visualizer=visualizer,
            fall_monitor=self.fall_monitor,
            pushes=self.pushes,
        )
