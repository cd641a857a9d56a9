"""Scenario ``look_and_reach``: the head keeps a moving object centred in its camera image
while the right hand reaches for it.

An object (a ball, drawn in the replay) moves on a slow Lissajous curve in front of the
robot, within reach of the right hand. A gaze task (``FeatureVisualPoint``, the fourth
feature family of Mansard et al. 2009) keeps its image at the centre of the head camera,
above the hand; the object's velocity is fed forward. Stack (highest priority first, solved
by ``solve_hqp``): joint position and velocity limits (an inequality: velocity bounds over
the control period that stop each joint 0.02 rad inside its limits, clipped to its velocity
limits), self-collision avoidance (``taskSelfCollision``, unless ``self_collision`` is off),
left foot 6D, right foot 6D, CoM xy, gaze (2 rows), posture. Script:

- t = 0 s: the object is below and to the right of the line of sight: the head (and the
  chest) turn to it;
- t = 1 s: ``push taskRH`` then ``up taskRH`` (above the posture) with a 0.5 s transition:
  the right hand (position only) reaches for the object and follows it, q̇ staying
  continuous (:class:`~drake_sot.systems.sot.StackOfTasks`).

Image coordinates are normalised: x = X/Z, y = Y/Z of the object in the camera frame
(focal length 1); |x|, |y| <= 0.05 is within 5 % of the image centre.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.look_and_reach_plots import plot_look_and_reach
from drake_sot.diagrams.pushes import ExternalPush
from drake_sot.diagrams.run import TimedCommand
from drake_sot.diagrams.scenario import SELF_COLLISION, Scenario, ScenarioHandles, ScenarioSetup
from drake_sot.diagrams.world import BuiltHumanoid
from drake_sot.gains import AdaptiveGain
from drake_sot.systems.marker import MeshcatMarker
from drake_sot.systems.moving_point import MovingPoint

STACK = ("taskJL", "taskLF", "taskRF", "taskCom", "taskGaze", "taskPosture")
REACH_AT = 1.0  # [s] the right-hand task is pushed
TRANSITION = 0.5  # [s] of the push
#: After this time [s] the gaze has converged: the object stays within 5 % of the image centre.
CONVERGED_AFTER = 1.0


#: Adaptive gains (λ = a·exp(-b‖e‖) + c): stiff near the goal, gentle far from it, so that the
#: first glance (an image error near 1) and the reach (0.7 m) do not jerk the robot.
GAZE_GAIN = AdaptiveGain.from_limits(at_zero=6.0, at_infinity=2.0, slope_at_zero=12.0)
REACH_GAIN = AdaptiveGain.from_limits(at_zero=4.0, at_infinity=1.0, slope_at_zero=12.0)


@dataclass(frozen=True)
class Lissajous:
    """``p(t) = centre + amplitude ⊙ sin(2π frequency t + phase)`` per axis (world frame) and its
    velocity; the object's path.

    Attributes:
        centre: (3,) [m]; amplitude: (3,) [m]; frequency: (3,) [Hz]; phase: (3,) [rad].
    """

    centre: tuple[float, float, float]
    amplitude: tuple[float, float, float]
    frequency: tuple[float, float, float]
    phase: tuple[float, float, float]

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        omega = 2 * np.pi * np.asarray(self.frequency)
        angle = omega * t + np.asarray(self.phase)
        amplitude = np.asarray(self.amplitude)
        return np.asarray(self.centre) + amplitude * np.sin(angle), amplitude * omega * np.cos(angle)


#: In front of the right shoulder, 0.3 m below the camera: a figure of eight of 16 x 12 cm in the
#: y-z plane, breathing 5 cm along x, one period every 6 s (at most 0.2 m/s).
OBJECT_PATH = Lissajous(
    centre=(0.40, -0.18, 1.12),
    amplitude=(0.05, 0.08, 0.06),
    frequency=(1 / 6, 1 / 6, 1 / 3),
    phase=(np.pi / 2, 0.0, 0.0),
)


def build(
    meshcat: Meshcat | None = None,
    pushes: Sequence[ExternalPush] = (),
    command_server: bool = False,
    self_collision: bool = True,
) -> ScenarioSetup:
    """Build the ``look_and_reach`` diagram and its script, with ``pushes`` on the robot, with
    or without the self-collision task; ``command_server``: see
    :func:`~drake_sot.diagrams.scenario.build_scenario`."""
    b = HumanoidSoTBuilder(meshcat=meshcat, pushes=pushes)
    target = b.builder.AddSystem(
        MovingPoint(OBJECT_PATH, orientation=b.initial_pose("right_hand").rotation(), name="object")
    )
    b.add_joint_position_limits_task("taskJL", velocity_scale=1.0)
    b.add_op_point_task("taskLF", "left_foot", gain=5.0)
    b.add_op_point_task("taskRF", "right_foot", gain=5.0)
    b.add_com_task("taskCom", selection="110", gain=3.0)
    b.add_visual_point_task(
        "taskGaze",
        target.GetOutputPort("position"),
        point_velocity=target.GetOutputPort("velocity"),
        gain=GAZE_GAIN,
    )
    b.add_op_point_task("taskRH", "right_hand", selection="111000", gain=REACH_GAIN)
    hand = b.features["taskRH"]
    b.builder.Connect(target.GetOutputPort("pose"), hand.GetInputPort("position_des"))
    b.builder.Connect(target.GetOutputPort("spatial_velocity"), hand.GetInputPort("velocity_des"))
    b.add_posture_task("taskPosture", gain=1.0)
    if meshcat is not None:  # the object in the replay
        marker = b.builder.AddSystem(MeshcatMarker(meshcat, "/drake_sot/object", radius=0.03))
        b.builder.Connect(target.GetOutputPort("position"), marker.GetInputPort("position"))
    stack = b.below_joint_limits(STACK, self_collision)
    built = b.build(stack=stack, solver="hqp", command_server=command_server)
    sot = built.sot

    def reach(context) -> None:
        sot.push(context, "taskRH", transition=TRANSITION)
        sot.up(context, "taskRH", transition=TRANSITION)

    return ScenarioSetup(
        built=built,
        commands=[TimedCommand(REACH_AT, f"push taskRH, up taskRH ({TRANSITION} s)", reach)],
        duration=8.0,
        extras=ScenarioHandles(object=target),
    )


def image_points(built: BuiltHumanoid, arrays: dict[str, np.ndarray], path: Lissajous) -> np.ndarray:
    """(T, 2) normalised image coordinates (X/Z, Y/Z) of the object in the head camera of the
    *simulated* plant, at the logged samples."""
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    camera = plant.GetFrameByName(info.frames["head_camera"], info.model_instance)
    out = np.empty((len(arrays["time"]), 2))
    for k, t in enumerate(arrays["time"]):
        plant.SetPositions(context, info.model_instance, arrays["q"][k])
        X, Y, Z = camera.CalcPoseInWorld(context).inverse() @ path(t)[0]
        out[k] = X / Z, Y / Z
    return out


def hand_distances(built: BuiltHumanoid, arrays: dict[str, np.ndarray], path: Lissajous) -> np.ndarray:
    """(T,) distance [m] from the right hand of the *simulated* plant to the object."""
    plant, info = built.plant, built.info
    context = plant.CreateDefaultContext()
    hand = plant.GetFrameByName(info.frames["right_hand"], info.model_instance)
    out = np.empty(len(arrays["time"]))
    for k, t in enumerate(arrays["time"]):
        plant.SetPositions(context, info.model_instance, arrays["q"][k])
        out[k] = np.linalg.norm(hand.CalcPoseInWorld(context).translation() - path(t)[0])
    return out


def write_plots(setup: ScenarioSetup, arrays: dict[str, np.ndarray], out_dir: Path) -> dict[str, Path]:
    """The object in the camera image and the hand's distance to it, over time."""
    path = Path(out_dir) / "look_and_reach_image.png"
    plot_look_and_reach(
        arrays["time"],
        image_points(setup.built, arrays, OBJECT_PATH),
        hand_distances(setup.built, arrays, OBJECT_PATH),
        converged_after=CONVERGED_AFTER,
        reach_at=REACH_AT,
        path=path,
    )
    return {"look_and_reach_image": path}


SCENARIO = Scenario(
    name="look_and_reach",
    description="the head keeps a moving object centred in its camera image; the right hand reaches for it",
    build=build,
    extra_plots=write_plots,
    parameters=(SELF_COLLISION,),
    servable=True,
)
