"""The generalized hierarchy (Liu, Lober, Padois 2016) around the torque-controlled
humanoid, in one Drake diagram.

:class:`TorqueHumanoidBuilder` adds tasks by name as the kinematic builder does
(:class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder`), and
:meth:`~TorqueHumanoidBuilder.build` closes the loop with a
``GeneralizedHierarchyController`` whose torques drive the plant's actuation input; the
features read the *measured* configuration.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pydrake.systems.framework import OutputPort
from pydrake.systems.primitives import Demultiplexer

from drake_sot.diagrams.tasks import HumanoidTaskBuilder
from drake_sot.diagrams.world import BuiltHumanoid
from drake_sot.models import sole_corner_points
from drake_sot.systems.generalized_controller import (
    ContactPoints,
    ForceTask,
    GeneralizedHierarchyController,
    MotionTask,
)


@dataclass
class HumanoidTorqueControl(BuiltHumanoid):
    """The generalized hierarchical controller around a torque-controlled humanoid."""

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
            error_layout=controller.error_slices(),
        )
