"""The simulated world of every scenario: the humanoid in a ``MultibodyPlant`` on the
ground (or welded in the air), its ``SceneGraph``, a headless Meshcat recorder, and
:class:`BuiltHumanoid`, what a builder returns.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pydrake.geometry import Meshcat, MeshcatParams, MeshcatVisualizer, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import VectorLogSink

from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.errors import UnknownNameError
from drake_sot.models import HumanoidInfo, add_ground
from drake_sot.robots import RobotDescription, add_robot_collision, load_robot, weld_robot_base
from drake_sot.systems.fall_monitor import FallMonitor
from drake_sot.systems.features import Feature
from drake_sot.systems.kinematics import RobotKinematics
from drake_sot.systems.stack_history import StackHistory
from drake_sot.systems.task import Task
from drake_sot.validation import positive


@dataclass
class BuiltHumanoid:
    """A built diagram and handles on the parts a scenario, a test or a user needs.

    ``error_layout`` says where each task's error lies in the logged ``errors`` (task
    name → slice), as the controller that produced them declares it; ``stack_history``
    records the controller's ``stack`` output by name (the kinematic SoT's stack; the
    torque controller's active tasks and what is short, saturated or in fallback).
    ``fall_monitor`` is the diagram's ``FallMonitor`` (None on a fixed base or when the
    builder was asked for none); ``pushes`` the disturbances the diagram applies.
    """

    diagram: Diagram
    plant: MultibodyPlant
    info: HumanoidInfo
    control_plant: MultibodyPlant
    dyn: RobotKinematics
    tasks: dict[str, Task]
    features: dict[str, Feature]
    loggers: dict[str, VectorLogSink]
    q0: np.ndarray
    meshcat: Meshcat | None
    visualizer: MeshcatVisualizer | None
    error_layout: dict[str, slice] = field(default_factory=dict)
    stack_history: StackHistory | None = None
    fall_monitor: FallMonitor | None = None
    pushes: tuple[ExternalPush, ...] = ()

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
        *simulated* plant.

        Raises:
            UnknownNameError: ``frame_key`` is not a frame of the robot (lists its frames).
        """
        if frame_key not in self.info.frames:
            raise UnknownNameError("frame", frame_key, self.info.frames)
        plant_context = self.plant.GetMyContextFromRoot(root_context)
        return self.plant.GetFrameByName(
            self.info.frames[frame_key], self.info.model_instance
        ).CalcPoseInWorld(plant_context)

    def error_slices(self) -> dict[str, slice]:
        """Where each task's error lies in the logged ``errors`` (a copy of ``error_layout``)."""
        return dict(self.error_layout)


def add_humanoid_plant(
    builder: DiagramBuilder,
    *,
    time_step: float = 1e-3,
    pd_gains: bool = True,
    fixed_base: bool = False,
    body_collision: bool = True,
    before_finalize: Callable[[MultibodyPlant, HumanoidInfo], None] | None = None,
    robot: str | RobotDescription = "embedded",
) -> tuple[MultibodyPlant, SceneGraph, HumanoidInfo]:
    """The simulated world in a finalized ``MultibodyPlant`` (SAP, point contact,
    ``time_step`` [s]) and its ``SceneGraph``: the humanoid ``robot`` (a name of
    ``drake_sot.robots.ROBOTS`` or a description) with PD-controlled actuators
    (or torque-controlled ones, ``pd_gains=False``) on the ground, or with its pelvis
    welded in the air (``fixed_base``, no ground). With ``body_collision`` the whole body
    collides (:func:`~drake_sot.robots.add_robot_collision`), else only the soles.
    ``before_finalize`` may add to the world (a table, collision shapes on the hands)
    before the plant is finalized.

    Raises ValueError when ``time_step`` is not finite and > 0 (checked here: Drake
    would end the interpreter on it).
    """
    time_step = positive("time_step", time_step, unit="s")
    config = MultibodyPlantConfig(
        time_step=time_step, discrete_contact_approximation="sap", contact_model="point"
    )
    plant, scene_graph = AddMultibodyPlant(config, builder)
    info = load_robot(plant, robot, pd_gains=pd_gains)
    if body_collision:
        add_robot_collision(plant, scene_graph, info, robot)
    if fixed_base:
        weld_robot_base(plant, info, robot)
    else:
        add_ground(plant)
    if before_finalize is not None:
        before_finalize(plant, info)
    plant.Finalize()
    return plant, scene_graph, info


def loopback_meshcat() -> Meshcat:
    """A Meshcat server bound to localhost on a free port (headless recording; nothing listens outside)."""
    return Meshcat(MeshcatParams(host="localhost", port=0))
