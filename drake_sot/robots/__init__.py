"""Robot descriptions (one frozen value per robot) and their loading into a MultibodyPlant.

``get_robot("talos")`` gives a :class:`RobotDescription`; the builders take ``robot=`` (a
name or a description) and load it with :func:`load_robot`. The embedded humanoid is the
robot "embedded"; TALOS and the Unitree G1 need the optional extra ``drake_sot[robots]``.
"""

from drake_sot.robots.catalog import EMBEDDED, ROBOTS, RobotDataMissing, get_robot
from drake_sot.robots.description import CollisionShape, Drive, FrameSpec, RobotDescription
from drake_sot.robots.loading import (
    add_robot_collision,
    load_robot,
    make_robot_control_model,
    weld_robot_base,
)

__all__ = [
    "EMBEDDED",
    "ROBOTS",
    "CollisionShape",
    "Drive",
    "FrameSpec",
    "RobotDataMissing",
    "RobotDescription",
    "add_robot_collision",
    "get_robot",
    "load_robot",
    "make_robot_control_model",
    "weld_robot_base",
]
