"""The package's error vocabulary (pure: no Drake).

Every exception the package defines derives from :class:`DrakeSotError`, and keeps the built-in
base that says what kind of failure it is (ValueError for a bad value, OSError for a file,
RuntimeError for a missing tool...), so ``except DrakeSotError`` catches what the package
refuses and ``except ValueError`` still catches what it always did.

A name that is looked up and not found — a task, a frame, a robot, a script's entity, signal,
command or class, a sequencer state, a served or writable signal — raises
:class:`UnknownNameError`, whose message lists the names that are known, the close ones first.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import TypeVar

__all__ = ["DrakeSotError", "UnknownNameError", "prefixed", "unknown_name_message"]

_E = TypeVar("_E", bound=Exception)

#: How alike (difflib's ratio, in [0, 1]) a known name must be to the unknown one to be offered
#: first: above difflib's 0.6, under which ``taskXX`` would suggest every ``taskAB``.
_CLOSE = 0.75


class DrakeSotError(Exception):
    """The base of every exception the package defines (each also keeps its built-in base)."""


def unknown_name_message(kind: str, name: object, known: Iterable[str], *, where: str = "") -> str:
    """``[where: ]unknown KIND 'name'[ (did you mean 'a', 'b'?)]; known: a, b, c``.

    ``known`` is listed sorted (``(none)`` when empty); the names close to ``name`` (difflib's
    close matches, ignoring case, for a string ``name``) are offered first. The message of
    :class:`UnknownNameError`, also for the replies of a server that refuses a name without
    raising.
    """
    names = sorted(set(known))
    close = []
    if isinstance(name, str):  # compared without case; a shared prefix alone is not close
        lowered = {n.lower(): n for n in names}
        close = [lowered[n] for n in difflib.get_close_matches(name.lower(), lowered, n=3, cutoff=_CLOSE)]
    hint = f" (did you mean {', '.join(map(repr, close))}?)" if close else ""
    prefix = f"{where}: " if where else ""
    return f"{prefix}unknown {kind} {name!r}{hint}; known: {', '.join(names) or '(none)'}"


class UnknownNameError(DrakeSotError, KeyError, ValueError):
    """A name that is none of the known ones: the failed lookup of a key (a KeyError) and a bad
    argument (a ValueError), so the handlers written for either catch it.

    Attributes:
        kind: what the name names (``"task"``, ``"frame"``, ``"robot"``, ``"entity"``,
            ``"signal"``...).
        name: the name looked up.
        known: the known names, sorted.
        where: what looked the name up (the message's prefix), or "".

    The message is :func:`unknown_name_message`'s (``where``, when given, says what looked the
    name up).
    """

    def __init__(self, kind: str, name: object, known: Iterable[str], *, where: str = "") -> None:
        self.kind = kind
        self.name = name
        self.known = tuple(sorted(set(known)))
        self.where = where
        super().__init__(unknown_name_message(kind, name, self.known, where=where))

    def __str__(self) -> str:
        return BaseException.__str__(self)  # the message, not KeyError's quoted repr of it


def prefixed(error: _E, prefix: str) -> _E:
    """``error`` itself, its message now ``prefix: message`` (what a caller adds: where it
    happened), its class and attributes kept (an :class:`UnknownNameError`'s ``where`` gets the
    prefix too); returned to be raised again."""
    if isinstance(error, UnknownNameError):
        error.where = f"{prefix}: {error.where}" if error.where else prefix
    error.args = (f"{prefix}: {error}",)
    return error
