"""Shared by the robot tests: skip (with the reason printed) when example-robot-data is absent."""

from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from drake_sot.robots import RobotDataMissing, RobotFileError, get_robot
from drake_sot.robots.description import RobotDescription
from drake_sot.robots.draft import draft_description


def robot_or_skip(name: str) -> RobotDescription:
    """The description of ``name``, or a skip saying how to install the models."""
    try:
        return get_robot(name)
    except RobotDataMissing as error:
        pytest.skip(str(error))


def assert_mutated_model_is_drafted_or_refused(
    source: Path, path: Path, element: int, attribute: str, value: str | None
) -> None:
    """Copy the model ``source`` to ``path`` with ``attribute`` of the ``element``-th element that
    has it deleted (``value`` None) or set to ``value``; its draft must be TOML or a RobotFileError
    of one line naming ``path``, never an error from deep inside."""
    tree = ET.parse(source)
    elements = [e for e in tree.iter() if attribute in e.attrib]
    target = elements[element % len(elements)]
    if value is None:
        del target.attrib[attribute]
    else:
        target.set(attribute, value)
    tree.write(path)
    try:
        drafted = draft_description(path)
    except RobotFileError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc), str(exc)
    else:
        tomllib.loads(drafted.text)  # it is TOML
