"""Shared by the robot tests: skip (with the reason printed) when example-robot-data is absent."""

from __future__ import annotations

import pytest

from drake_sot.robots import RobotDataMissing, get_robot
from drake_sot.robots.description import RobotDescription


def robot_or_skip(name: str) -> RobotDescription:
    """The description of ``name``, or a skip saying how to install the models."""
    try:
        return get_robot(name)
    except RobotDataMissing as error:
        pytest.skip(str(error))
