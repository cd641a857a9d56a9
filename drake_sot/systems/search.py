"""Finding the systems of a kind in a diagram, through its nested diagrams."""

from __future__ import annotations

from typing import TypeVar

from pydrake.systems.framework import Diagram, System

T = TypeVar("T")


def systems_of_type(system: System, kind: type[T]) -> list[T]:
    """The systems of ``kind`` in ``system`` (itself, or inside it through nested diagrams), in
    the diagrams' order."""
    if isinstance(system, kind):
        return [system]
    if isinstance(system, Diagram):
        return [found for sub in system.GetSystems() for found in systems_of_type(sub, kind)]
    return []
