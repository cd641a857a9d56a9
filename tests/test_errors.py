"""The package's error vocabulary: one base for every exception it defines, one error for an
unknown name, whose message lists the known names sorted, the close ones first."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

from drake_sot.errors import DrakeSotError, UnknownNameError, prefixed, unknown_name_message
from drake_sot.robots import ROBOTS, get_robot

PACKAGE = Path(__file__).resolve().parents[1] / "drake_sot"

#: Exceptions that are not errors: a run stopped by SIGINT or SIGTERM is a KeyboardInterrupt
#: (``except Exception`` must not catch it), so it cannot derive from DrakeSotError.
NOT_ERRORS = {"drake_sot.diagrams.run.Interrupted"}


def _exception_classes() -> dict[str, type]:
    """Every class the package's sources define that is an exception, by dotted name (found by
    reading the sources, then imported)."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        module_name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        classes = [n.name for n in ast.parse(path.read_text()).body if isinstance(n, ast.ClassDef)]
        if not classes:
            continue
        module = importlib.import_module(module_name)
        for name in classes:
            cls = getattr(module, name)
            if isinstance(cls, type) and issubclass(cls, BaseException):
                found[f"{module_name}.{name}"] = cls
    return found


def test_every_exception_of_the_package_is_a_drake_sot_error_with_its_builtin_base():
    classes = _exception_classes()
    assert {"drake_sot.stack.StackError", "drake_sot.remote.protocol.ProtocolError"} <= set(classes)
    assert len(classes) >= 15, sorted(classes)
    outside = sorted(name for name, cls in classes.items() if not issubclass(cls, DrakeSotError))
    assert outside == sorted(NOT_ERRORS)
    for name, cls in classes.items():
        builtin = [b for b in cls.__mro__ if b.__module__ == "builtins" and b not in (object, BaseException)]
        assert builtin and builtin[0] is not Exception or cls is DrakeSotError, (
            f"{name} keeps no built-in base more precise than Exception: {cls.__mro__}"
        )


def test_the_message_lists_the_known_names_sorted_and_the_close_ones_first():
    assert (
        unknown_name_message("frame", "elbow", ("torso", "head"))
        == "unknown frame 'elbow'; known: head, torso"
    )
    assert unknown_name_message("task", "x", ()) == "unknown task 'x'; known: (none)"
    assert (
        unknown_name_message("frame", "Right_Hnd", ("torso", "right_hand", "left_hand"), where="push")
        == "push: unknown frame 'Right_Hnd' (did you mean 'right_hand'?); known: left_hand, right_hand, torso"
    )
    # A shared prefix alone is not close: taskXX suggests none of the taskAB.
    assert "did you mean" not in unknown_name_message("task", "taskXX", ("taskRH", "taskLH", "taskCom"))


def test_an_unknown_name_is_a_key_error_and_a_value_error_and_keeps_a_prefix():
    error = UnknownNameError("signal", "nope", ["b", "a"], where="'dyn' (Dynamic)")
    assert isinstance(error, KeyError) and isinstance(error, ValueError) and isinstance(error, DrakeSotError)
    assert (error.kind, error.name, error.known) == ("signal", "nope", ("a", "b"))
    assert str(error) == "'dyn' (Dynamic): unknown signal 'nope'; known: a, b"  # not KeyError's repr
    same = prefixed(error, "line 3")
    assert same is error and error.where == "line 3: 'dyn' (Dynamic)"
    assert str(error) == unknown_name_message("signal", "nope", "ab", where=error.where)


def test_an_unknown_robot_lists_the_catalogue():
    with pytest.raises(UnknownNameError) as caught:
        get_robot("talo")
    assert (caught.value.kind, caught.value.name, caught.value.known) == (
        "robot",
        "talo",
        tuple(sorted(ROBOTS)),
    )
    assert str(caught.value).startswith("unknown robot 'talo' (did you mean 'talos'?); known: ")
    with pytest.raises(ValueError, match="unknown robot 'nao'"):  # what callers catch still catches it
        get_robot("nao")
