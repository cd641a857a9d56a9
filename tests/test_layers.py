"""The layering rule of the house, read off the package's imports.

pure algorithms (``drake_sot/*.py``), transport (``drake_sot/remote``) and study descriptions
and their runner (``drake_sot/studies``) <- systems, robot
models and descriptions <- builders and scenarios (``drake_sot/diagrams``) <- front-ends
(``drake_sot/app``): no module imports one of a layer above its own (imports inside functions
count), the two bottom ones import no Drake, and the packages form no cycle.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "drake_sot"

#: Each package's layer, bottom first; ``drake_sot`` stands for the top-level (pure) modules.
LAYERS = {
    "drake_sot": 0,
    "drake_sot.kernels": 0,
    "drake_sot.remote": 0,
    "drake_sot.studies": 0,
    "drake_sot.models": 1,
    "drake_sot.robots": 1,
    "drake_sot.systems": 1,
    "drake_sot.diagrams": 2,
    "drake_sot.app": 3,
}


def _modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package's ``__init__`` by the package's)."""
    modules = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


MODULES = _modules()


def _package(module: str) -> str:
    """The package of ``module`` whose layer counts: a subpackage, or ``drake_sot`` for a top-level
    module."""
    parts = module.split(".")
    candidate = ".".join(parts[:2])
    return candidate if candidate in LAYERS else "drake_sot"


def _imports(module: str) -> set[str]:
    """The drake_sot modules (or packages) ``module`` imports, anywhere in its body; and "pydrake"
    when it imports Drake."""
    path = MODULES[module]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{module}: relative import (the house uses absolute ones)"
            base = node.module or ""
            names = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base for alias in node.names
            ]
        else:
            continue
        for name in names:
            if name.split(".")[0] == "pydrake":
                found.add("pydrake")
            elif name.split(".")[0] == "drake_sot":
                found.add(name)
    return found


def _violations() -> list[str]:
    upward = []
    for module in sorted(MODULES):
        layer = LAYERS[_package(module)]
        for imported in sorted(_imports(module) - {"pydrake"}):
            if imported == "drake_sot":  # the package's own __init__
                continue
            if LAYERS[_package(imported)] > layer:
                upward.append(
                    f"{module} (layer {layer}) imports {imported} (layer {LAYERS[_package(imported)]})"
                )
    return upward


def test_every_module_has_a_layer():
    unknown = sorted({_package(m) for m in MODULES} - set(LAYERS))
    assert not unknown
    assert {
        m.split(".")[1] for m in MODULES if m.count(".") >= 1 and (PACKAGE / m.split(".")[1]).is_dir()
    } <= {p.split(".")[1] for p in LAYERS if "." in p}, "a subpackage without a layer in LAYERS"


def test_no_module_imports_one_of_a_layer_above_it():
    assert _violations() == []


def test_the_check_sees_an_upward_import(tmp_path, monkeypatch):
    """The walker is not blind: a pure module importing a scenario is reported."""
    fake = tmp_path / "fake_pure.py"
    fake.write_text("def f():\n    from drake_sot.diagrams import walk\n    import pydrake.systems\n")
    monkeypatch.setitem(MODULES, "drake_sot.fake_pure", fake)
    assert _imports("drake_sot.fake_pure") == {"drake_sot.diagrams.walk", "pydrake"}
    assert any(
        v.startswith("drake_sot.fake_pure (layer 0) imports drake_sot.diagrams.walk") for v in _violations()
    )


@pytest.mark.parametrize("module", sorted(m for m in MODULES if LAYERS[_package(m)] == 0))
def test_pure_and_transport_modules_import_no_drake(module):
    assert "pydrake" not in _imports(module)


def test_importing_every_pure_and_transport_module_loads_no_drake():
    pure = sorted(m for m in MODULES if LAYERS[_package(m)] == 0)
    code = (
        f"import importlib, sys\nfor m in {pure!r}:\n    importlib.import_module(m)\n"
        "sys.exit('pydrake' in sys.modules)"
    )
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_the_packages_form_no_cycle():
    edges: dict[str, set[str]] = {p: set() for p in LAYERS}
    for module in MODULES:
        for imported in _imports(module) - {"pydrake", "drake_sot"}:
            a, b = _package(module), _package(imported)
            if a != b:
                edges[a].add(b)

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        return any(n == goal or (n not in seen and reaches(n, goal, seen | {n})) for n in edges[start])

    cycles = sorted(p for p in edges if reaches(p, p, set()))
    assert cycles == [], {p: sorted(edges[p]) for p in cycles}
