"""What goes wrong with a robot's files: one line naming the file (no pydrake import here)."""

from __future__ import annotations

from drake_sot.errors import DrakeSotError


class RobotFileError(DrakeSotError, OSError):
    """A file of a robot (its model, SRDF, a mesh, the mesh cache) is truncated, corrupt or not
    what it should be; the message names the file and says what is wrong with it, on one line."""


class RobotFileMissing(RobotFileError, FileNotFoundError):
    """A file of a robot is missing (its data may be installed in part); the message names it."""
