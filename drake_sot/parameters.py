"""Typed parameters of the runnable scenarios, studies and peers (pure: no Drake).

Each runnable declares what its builder takes besides the Meshcat as a tuple of
:class:`Parameter`: name, type, default, bounds or choices, unit and help. The declarations are
the one source of the ``drake-sot run`` and ``serve`` options (one option per distinct name,
``--NAME``, or ``--no-NAME`` for a bool on by default) and of the check of every value before a
builder sees it (:func:`check_parameters`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from drake_sot import validation
from drake_sot.errors import UnknownNameError

__all__ = ["Kind", "Parameter", "UndeclaredParameter", "check_parameters"]

Kind = Literal["float", "int", "bool", "choice"]


@dataclass(frozen=True)
class Parameter:
    """One keyword argument of a runnable's builder.

    Attributes:
        name: the keyword (a Python identifier); the option is ``--name`` with ``-`` for ``_``,
            or ``--no-name`` for a ``bool`` whose default is True.
        kind: ``"float"``, ``"int"``, ``"bool"`` or ``"choice"`` (one of ``choices``, a str).
        default: the builder's value when the parameter is not given.
        help: what it is, one phrase (the option's help adds the bounds and the default).
        minimum: the least value accepted (inclusive), None for none (numbers only).
        maximum: the largest value accepted, None for none (numbers only).
        maximum_excluded: ``maximum`` itself is refused (a probability in [0, 1)).
        choices: the accepted values of a ``choice``.
        paths: file suffixes (lower case, with the dot) a ``choice`` also accepts: a string
            ending with one of them is a path, accepted as it is (whoever opens the file says
            when it is missing or wrong); a robot's name or its description file.
        unit: the unit of a number, shown in messages and help (e.g. ``"s"``).

    Raises:
        ValueError: a declaration that contradicts itself (a default it would refuse, choices
            on a number, bounds on a choice or a bool, an unknown kind).
    """

    name: str
    kind: Kind
    default: float | int | bool | str
    help: str
    minimum: float | None = None
    maximum: float | None = None
    maximum_excluded: bool = False
    choices: tuple[str, ...] = ()
    unit: str = ""
    paths: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise ValueError(f"Parameter.name = {self.name!r}: must be a Python identifier")
        if self.kind not in ("float", "int", "bool", "choice"):
            raise ValueError(f"Parameter {self.name}: kind = {self.kind!r}: one of float, int, bool, choice")
        numeric = self.kind in ("float", "int")
        if not numeric and (self.minimum is not None or self.maximum is not None):
            raise ValueError(f"Parameter {self.name}: a {self.kind} has no minimum or maximum")
        if (self.kind == "choice") != bool(self.choices):
            raise ValueError(f"Parameter {self.name}: choices are for (and needed by) a choice only")
        if self.paths and self.kind != "choice":
            raise ValueError(f"Parameter {self.name}: paths are for a choice only")
        if self.kind == "int" and self.minimum is None:
            raise ValueError(f"Parameter {self.name}: an int needs a minimum")
        self.check(self.default)

    @property
    def option(self) -> str:
        """The command-line option: ``--name``, or ``--no-name`` for a bool on by default."""
        flag = self.name.replace("_", "-")
        return f"--no-{flag}" if self.kind == "bool" and self.default is True else f"--{flag}"

    def accepted(self) -> str:
        """What the parameter accepts, as a message or a help text ends: ``in [0, 0.3] s``,
        ``in [0, 1)``, ``>= 0 s``, ``an integer in [1, 8]``, ``one of: plain, weighted``,
        ``True or False``; ``one of: a, b, or a path ending with .toml``."""
        if self.kind == "choice":
            paths = f", or a path ending with {', '.join(self.paths)}" if self.paths else ""
            return f"one of: {', '.join(self.choices)}{paths}"
        if self.kind == "bool":
            return "True or False"
        unit = f" {self.unit}" if self.unit else ""
        low, high = self.minimum, self.maximum
        if low is not None and high is not None:
            text = f"in [{low:g}, {high:g}{')' if self.maximum_excluded else ']'}{unit}"
        elif low is not None:
            text = f">= {low:g}{unit}"
        elif high is not None:
            text = f"{'<' if self.maximum_excluded else '<='} {high:g}{unit}"
        else:
            text = "finite" if self.kind == "float" else ""
        return f"an integer {text}".rstrip() if self.kind == "int" else text

    def describe(self) -> str:
        """The help of the option: the phrase, what is accepted and the default."""
        if self.kind == "bool":
            return f"without {self.help} (on by default)" if self.default else self.help
        default = f"{self.default:g}" if self.kind == "float" else str(self.default)
        return f"{self.help}; {self.accepted()} (default {default}{f' {self.unit}' if self.unit else ''})"

    def is_path(self, value: Any) -> bool:
        """True when ``value`` is a string ending with one of ``paths`` (any case)."""
        return isinstance(value, str) and bool(self.paths) and value.lower().endswith(self.paths)

    def check(self, value: Any) -> float | int | bool | str:
        """``value`` checked and converted (a float, an int, a bool or one of the choices).

        Raises:
            ValueError: naming the parameter, the value and what is accepted: NaN, ±inf, an
                integer beyond float range, a value out of bounds, a non-integral int, a bool
                that is not one, a choice that is not one of ``choices`` (nor a path).
        """
        refused = f"{self.name} = {validation.shown(value)}{f' {self.unit}' if self.unit else ''}"
        if self.kind == "choice":
            if not (isinstance(value, str) and (value in self.choices or self.is_path(value))):
                raise ValueError(f"{refused}: must be {self.accepted()}")
            return value
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise ValueError(f"{self.name} = {validation.shown(value)}: must be True or False")
            return value
        if self.kind == "int":
            number: float | int = validation.positive_int(self.name, value, minimum=int(self.minimum or 0))
        else:
            try:
                number = validation.finite(self.name, value)
            except ValueError:  # NaN, ±inf, beyond float range, not a number: named with the bounds
                raise ValueError(f"{refused}: must be {self.accepted()}") from None
        low = -math.inf if self.minimum is None else self.minimum
        high = math.inf if self.maximum is None else self.maximum
        inside = low <= number < high if self.maximum_excluded else low <= number <= high
        if not inside:  # NaN never reaches here (finite), but fails the comparison too
            raise ValueError(f"{refused}: must be {self.accepted()}")
        return number


class UndeclaredParameter(UnknownNameError):
    """A value given for a parameter the runnable does not declare (the first such name)."""


def check_parameters(
    owner: str, declared: Sequence[Parameter], values: Mapping[str, Any] | None
) -> dict[str, Any]:
    """``values`` checked against ``declared`` (the parameters of the runnable named ``owner``).

    Raises:
        UndeclaredParameter: an undeclared name (the message lists the declared ones).
        ValueError: a value its declaration refuses (:meth:`Parameter.check`).
    """
    by_name = {p.name: p for p in declared}
    unknown = sorted(set(values or {}) - set(by_name))
    if unknown:
        raise UndeclaredParameter("parameter", unknown[0], by_name, where=f"scenario {owner!r}")
    return {name: by_name[name].check(value) for name, value in (values or {}).items()}
