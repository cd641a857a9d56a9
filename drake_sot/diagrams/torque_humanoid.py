"""The generalized hierarchy (Liu, Lober, Padois 2016) around the torque-controlled
humanoid, in one Drake diagram.

:class:`TorqueHumanoidBuilder` adds tasks by name as the kinematic builder does
(:class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder`), and
:meth:`~TorqueHumanoidBuilder.build` closes the loop with a
``GeneralizedHierarchyController`` whose torques drive the plant's actuation input; the
features read the *measured* configuration.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import OutputPort
from pydrake.systems.primitives import Demultiplexer

from drake_sot.diagrams.tasks import HumanoidTaskBuilder
from drake_sot.diagrams.world import BuiltHumanoid
from drake_sot.models import sole_corner_points
from drake_sot.systems.generalized_controller import (
    SHORTFALL_THRESHOLD,
    VECTOR_OUTPUTS,
    ContactPoints,
    ForceTask,
    GeneralizedHierarchyController,
    MotionTask,
)
from drake_sot.systems.inequalities import InequalityTask
from drake_sot.systems.priority_schedule import PrioritySchedule
from drake_sot.systems.stack_history import StackHistory
from drake_sot.validation import positive


@dataclass
class HumanoidTorqueControl(BuiltHumanoid):
    """The generalized hierarchical controller around a torque-controlled humanoid.

    Its logs (``loggers``, and the run's npz) hold every vector output of the controller
    (:data:`~drake_sot.systems.generalized_controller.VECTOR_OUTPUTS`): ``status`` per tick
    (0 optimal, 1 short, 2 infeasible, 3 failed), ``shortfall`` (one column per goal task,
    in ``controller.task_names`` order, the order of ``error_slices()``) and ``saturation``
    (one column per actuated joint, in ``controller.actuated_joints`` order).
    ``stack_history`` records the controller's ``stack`` by name: the active goal tasks by
    priority, then ``short:<task>``, ``fallback:<why>`` and ``saturated:<joint>`` while they
    hold; the npz carries it as ``stack``/``stack_time`` and the run's plot marks each change.
    """

    controller: GeneralizedHierarchyController | None = None


class TorqueHumanoidBuilder(HumanoidTaskBuilder):
    """Adds tasks by name around the torque-controlled humanoid, then closes the
    generalized hierarchy with :meth:`build`.

    Args: see :class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder` (the actuators
    take torques).
    """

    POSITION_CONTROLLED = False

    def build(
        self,
        *,
        motion: Sequence[tuple[str, float, float]],
        priorities: OutputPort,
        force: Sequence[tuple[str, float, float]] = (),
        force_inputs: dict[str, tuple[OutputPort, OutputPort]] | None = None,
        weighted: bool = False,
        weights: dict[str, float] | None = None,
        mu: float = 0.8,
        min_normal_force: float = 0.0,
        effort_limits: Mapping[str, float] | None = None,
        shortfall_threshold: float = SHORTFALL_THRESHOLD,
        log_period: float | None = None,
    ) -> HumanoidTorqueControl:
        """Close the loop with a ``GeneralizedHierarchyController`` (Liu, Lober, Padois
        2016) on the torque-controlled robot; the features read the *measured* configuration.

        Tasks are named: the order of ``motion`` and ``force`` only fixes the layout of the
        logged vectors (``error_slices()`` says where each task lies); the priorities are
        matched by name.

        Args:
            motion: ``(task name, kp, kd)`` of each motion task (eq. 2).
            priorities: the priorities signal, abstract
                :class:`~drake_sot.transitions.Priorities` (e.g.
                ``PrioritySchedule.priorities``) over exactly the motion and force tasks;
                when it comes from a ``PrioritySchedule`` its names are checked here.
            force: ``(task name, kp, ki)`` of each force task (eq. 3).
            force_inputs: force task name → (desired, measured) wrench output ports, for
                the controller's ``<name>_desired`` and ``<name>_measured`` inputs.
            weighted: the weighted baseline (eq. 5-7) with ``weights`` instead.
            mu: friction coefficient of the sole-corner contact points (none on a fixed base).
            min_normal_force: [N] per sole corner (>= 0).
            effort_limits: joint name → torque bound [N·m] replacing the model's for those
                joints (> 0).
            shortfall_threshold: see the controller (> 0).

        Raises:
            ValueError: an unknown task or joint name (listing the known ones), priorities
                over other tasks, a bad value (named), a log name already taken, or
                contacts and bounds that cannot hold the robot at q0 (the controller's
                check, naming the bound).
        """
        b = self.builder
        unknown = [n for n, *_ in (*motion, *force) if n not in self.tasks]
        if unknown:
            raise ValueError(f"unknown task(s) {unknown}; known tasks: {', '.join(self.tasks)}")
        bounded = [n for n, *_ in (*motion, *force) if isinstance(self.tasks[n], InequalityTask)]
        if bounded:
            raise ValueError(
                f"inequality task(s) {bounded}: they belong to the kinematic StackOfTasks(solver='hqp'); "
                "the torque controller takes equality tasks"
            )
        stray = sorted(set(force_inputs or {}) - {n for n, *_ in force})
        if stray:
            raise ValueError(
                f"force_inputs for {stray}, which are not force tasks; force tasks: {[n for n, *_ in force]}"
            )
        joints = list(self.control_info.actuated_joints)
        limits = np.array([self.control_plant.GetJointActuatorByName(j).effort_limit() for j in joints])
        for joint, limit in (effort_limits or {}).items():
            if joint not in joints:
                raise ValueError(
                    f"effort_limits: unknown joint {joint!r}; actuated joints: {', '.join(joints)}"
                )
            limits[joints.index(joint)] = positive(f"effort_limits[{joint!r}]", limit, unit="N·m")
        contacts = (
            []
            if self.fixed_base
            else [
                ContactPoints(
                    self.control_info.frames[foot],
                    sole_corner_points(self.info.sole_size),
                    mu=mu,
                    min_normal_force=min_normal_force,
                )
                for foot in ("left_foot", "right_foot")
            ]
        )
        controller = GeneralizedHierarchyController(
            self.control_plant,
            joints,
            motion_tasks=[MotionTask(self.tasks[n], kp, kd) for n, kp, kd in motion],
            force_tasks=[ForceTask(self.tasks[n], kp, ki) for n, kp, ki in force],
            contacts=contacts,
            q_posture=self.q0,
            period=self.control_period,
            weighted=weighted,
            weights=weights,
            effort_limits=limits,
            shortfall_threshold=shortfall_threshold,
        )
        schedule = priorities.get_system()
        if isinstance(schedule, PrioritySchedule):  # the names are known now: check them now
            schedule_names = schedule.task_names
            if set(schedule_names) != set(controller.task_names):
                extra = [n for n in schedule_names if n not in controller.task_names]
                missing = [n for n in controller.task_names if n not in schedule_names]
                raise ValueError(
                    f"the priority schedule {schedule.get_name()!r} names unknown task(s) {extra} and "
                    f"has no priority for {missing}; known tasks: {', '.join(controller.task_names)}"
                )
        b.AddSystem(controller)
        for name in controller.task_names:
            b.Connect(self.tasks[name].GetOutputPort("task"), controller.GetInputPort(name))
        for name, (desired, measured) in (force_inputs or {}).items():
            b.Connect(desired, controller.GetInputPort(f"{name}_desired"))
            b.Connect(measured, controller.GetInputPort(f"{name}_measured"))
        state = self.plant.get_state_output_port(self.info.model_instance)
        b.Connect(state, controller.GetInputPort("state"))
        b.Connect(priorities, controller.GetInputPort("priorities"))
        b.Connect(
            controller.GetOutputPort("tau"), self.plant.get_actuation_input_port(self.info.model_instance)
        )
        nq, nv = self.control_plant.num_positions(), self.control_plant.num_velocities()
        split = b.AddSystem(Demultiplexer([nq, nv]))
        split.set_name("measured_q_v")
        b.Connect(state, split.get_input_port())
        for port in self._q_consumers:
            b.Connect(split.get_output_port(0), port)
        history = b.AddSystem(StackHistory(period=self.control_period, name="torque_stack_history"))
        b.Connect(controller.GetOutputPort("stack"), history.GetInputPort("stack"))
        diagram, loggers, visualizer = self._finish(
            {name: controller.GetOutputPort(name) for name in VECTOR_OUTPUTS},
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
            fall_monitor=self.fall_monitor,
            pushes=self.pushes,
            controller=controller,
            error_layout=controller.error_slices(),
            stack_history=history,
        )
