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

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import OutputPort

from drake_sot.diagrams.tasks import HumanoidTaskBuilder
from drake_sot.diagrams.world import BuiltHumanoid
from drake_sot.systems.command_server import RemoteCommandServer
from drake_sot.systems.device import Device
from drake_sot.systems.feedforward import TorqueFeedforward
from drake_sot.systems.sot import StackOfTasks
from drake_sot.systems.stack_history import StackHistory


@dataclass
class HumanoidSoT(BuiltHumanoid):
    """The kinematic SoT around a position-controlled humanoid."""

    sot: StackOfTasks | None = None
    device: Device | None = None
    remote: RemoteCommandServer | None = None


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
                builder that declared writable signals has one whatever this says.
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
                commands_input=self._server is not None,
            )
        )
        remote = self._server
        if remote is not None:
            b.Connect(remote.GetOutputPort("commands"), sot.GetInputPort("commands"))
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
