"""The base of the package's systems: a Drake ``LeafSystem`` that, where pydrake lets it, tells
pybind11 once rather than at every physics step that it has no witness functions.

After every unrestricted update (the discrete ``MultibodyPlant``'s step, every millisecond: with
sampled output ports it is one) Drake's ``Simulator`` asks each system for its witness functions
again. For a system written in Python, pydrake's trampoline first looks for a Python override of
``DoGetWitnessFunctions``. The pybind11 of drake 1.51 (the newest wheel for Python 3.11) remembers
that a method is not overridden only when the attribute it finds is a C++ function, and pydrake's
``LeafSystem`` has no attribute of that name: the lookup missed at every step, 2.1 µs per system
and step, ~75 µs a millisecond for the ~35 systems of ``walk_then_interact``
(``benchmarks/bench_loop.py --per-step``). There the attribute is set to a C++ function, which
pybind11 takes for "not overridden" and remembers per class: Drake's own default then runs (no
witness function), as before, for 0.65 µs. The pybind11 of drake 1.58 calls whatever it finds
(and costs 0.6 µs a system and step without it, as the marker does on 1.51): a probe at
import, which cannot loop (the marker is a static function, so a call of it is refused with
TypeError), sets the marker only where it is taken. A subclass that has witness functions
overrides ``DoGetWitnessFunctions`` in Python, as pydrake documents, either way.
"""

from __future__ import annotations

from pydrake.systems.framework import LeafSystem

__all__ = ["MARKER_TAKEN", "SotLeafSystem"]

#: The C++ function set as ``DoGetWitnessFunctions``: static, so that a pybind11 that calls it
#: (as an override, with the context) gets a TypeError instead of a loop back into the trampoline.
_MARKER = staticmethod(LeafSystem.GetWitnessFunctions)


def _marker_taken() -> bool:
    """Whether this pydrake's pybind11 takes :data:`_MARKER` for "not overridden"."""

    class Probe(LeafSystem):
        DoGetWitnessFunctions = _MARKER

    probe = Probe()
    try:
        return probe.GetWitnessFunctions(probe.CreateDefaultContext()) == []
    except TypeError:  # called as an override
        return False


#: True where the marker is set (drake 1.51), False where pybind11 would call it (drake 1.58).
MARKER_TAKEN = _marker_taken()


class SotLeafSystem(LeafSystem):
    """A ``LeafSystem`` without witness functions whose per-step query costs no Python lookup."""

    if MARKER_TAKEN:
        DoGetWitnessFunctions = _MARKER
