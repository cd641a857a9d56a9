"""The base of the package's systems: a Drake ``LeafSystem`` that tells pydrake once, not at
every physics step, that it has no witness functions.

After every unrestricted update (the discrete ``MultibodyPlant``'s step, every millisecond: with
sampled output ports it is one) Drake's ``Simulator`` asks each system for its witness functions
again. For a system written in Python, pydrake's trampoline first looks for a Python override of
``DoGetWitnessFunctions``; pybind11 remembers that a method is not overridden only when the
attribute it finds is a C++ function, and pydrake's ``LeafSystem`` has no attribute of that name,
so the lookup missed at every step: 2.3 µs per system and step, 80 µs a millisecond for the ~35
systems of ``walk_then_interact`` (``benchmarks/bench_loop.py --per-step``). Here the attribute
is the C++ ``GetWitnessFunctions``, which pybind11 takes for "not overridden" and remembers per
class: Drake's own default then runs (no witness function), as it did. A subclass that has
witness functions overrides ``DoGetWitnessFunctions`` in Python as pydrake documents.
"""

from __future__ import annotations

from pydrake.systems.framework import LeafSystem

__all__ = ["SotLeafSystem"]


class SotLeafSystem(LeafSystem):
    """A ``LeafSystem`` without witness functions whose per-step query costs no Python lookup."""

    #: A C++ function, so that pybind11 caches "not overridden in Python" (the module docstring).
    DoGetWitnessFunctions = LeafSystem.GetWitnessFunctions
