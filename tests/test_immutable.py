"""``Immutable``'s contract: what derives from it cannot be changed once made, so that its copy
(Drake's of abstract state, at every tick) may be itself."""

from __future__ import annotations

import copy
import dataclasses
import importlib
import pkgutil

import pytest

import drake_sot
from drake_sot.immutable import Immutable


def _subclasses() -> list[type]:
    for module in pkgutil.walk_packages(drake_sot.__path__, "drake_sot."):
        importlib.import_module(module.name)
    found, todo = [], list(Immutable.__subclasses__())
    while todo:
        cls = todo.pop()
        found.append(cls)
        todo.extend(cls.__subclasses__())
    return sorted(found, key=lambda cls: f"{cls.__module__}.{cls.__qualname__}")


SUBCLASSES = _subclasses()


def test_the_values_drake_copies_every_tick_are_immutable_ones():
    names = {cls.__qualname__ for cls in SUBCLASSES}
    assert {"Stack", "Link", "Status", "WalkPlanner", "_Records"} <= names, names


@pytest.mark.parametrize("cls", SUBCLASSES, ids=lambda cls: f"{cls.__module__}.{cls.__qualname__}")
def test_an_immutable_class_is_a_frozen_dataclass(cls):
    assert dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen, (
        f"{cls.__qualname__} derives from Immutable: its instances must not change (a frozen dataclass)"
    )


def test_a_copy_of_an_immutable_value_is_the_value():
    @dataclasses.dataclass(frozen=True)
    class Value(Immutable):
        records: tuple = ((1.0, ("a",)),)

    value = Value()
    assert copy.copy(value) is value and copy.deepcopy(value) is value
    with pytest.raises(dataclasses.FrozenInstanceError):
        value.records = ()
