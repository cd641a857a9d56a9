"""Robot descriptions (one frozen value per robot) and their loading into a MultibodyPlant.

``get_robot("talos")`` gives a :class:`RobotDescription`; the builders take ``robot=`` (a
name or a description) and load it with :func:`load_robot`. The embedded humanoid is the
robot "embedded"; TALOS and the Unitree G1 need the optional extra ``drake_sot[robots]``.

The descriptions (:mod:`~drake_sot.robots.catalog`, :mod:`~drake_sot.robots.description`,
:mod:`~drake_sot.robots.model_tree`) and the model fixes (:mod:`~drake_sot.robots.urdf`,
:mod:`~drake_sot.robots.sdf`, :mod:`~drake_sot.robots.mjcf`) import no pydrake, nor does this
package until one of the loading functions is asked for: the peer benchmark reads TALOS from
here without Drake.
"""

from typing import Any

from drake_sot.robots.catalog import ROBOTS, RobotDataMissing, get_robot
from drake_sot.robots.description import CollisionShape, Drive, FrameSpec, RobotDescription
from drake_sot.robots.errors import RobotFileError, RobotFileMissing

#: The names this package gives from :mod:`drake_sot.robots.loading` (pydrake), on first use.
_LOADING = ("add_robot_collision", "load_robot", "make_robot_control_model", "weld_robot_base")

__all__ = [
    "EMBEDDED",
    "ROBOTS",
    "CollisionShape",
    "Drive",
    "FrameSpec",
    "RobotDataMissing",
    "RobotDescription",
    "RobotFileError",
    "RobotFileMissing",
    "add_robot_collision",
    "get_robot",
    "load_robot",
    "make_robot_control_model",
    "weld_robot_base",
]


def __getattr__(name: str) -> Any:
    """The loading functions (importing pydrake) and ``EMBEDDED``, on first use."""
    if name in _LOADING:
        from drake_sot.robots import loading

        return getattr(loading, name)
    if name == "EMBEDDED":
        from drake_sot.robots import catalog

        return catalog.EMBEDDED
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
