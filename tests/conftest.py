"""pytest loads this file first in every worker (also under pytest-xdist), which puts tests/ on
sys.path, so that the shared helpers here (headless, landings) import from any test directory."""

import sys
from importlib.metadata import version
from pathlib import Path

#: The test files of the pure modules whose hot functions have a compiled kernel, besides the
#: ``test_kernels*.py`` files that check each kernel against its numpy version: with them, the
#: ``kernels`` marker, which ``make test`` runs again on the numpy kernels (DRAKE_SOT_KERNELS=numpy).
KERNEL_TESTS = {
    "test_hqp.py",
    "test_hierarchy.py",
    "test_inequalities.py",
    "test_generalized.py",
    "test_generalized_projector.py",
    "test_task_wrenches.py",
    "test_quasistatic.py",
    "test_six_vectors.py",
    "test_features.py",
    "test_preview.py",
    "test_stabilization.py",
    "test_so3.py",
    "test_support.py",
    "test_recovery.py",
    "test_bad_input_helpers.py",
}


def pytest_report_header(config) -> str:
    """The versions this run tests, first in its output (``make test`` runs the suite on several
    Pythons, each with the newest drake, numpy and scipy pip resolves there), and the kernels."""
    from drake_sot import kernels

    return (
        f"drake_sot on Python {sys.version.split()[0]}: drake {version('drake')}, numpy {version('numpy')}, "
        f"scipy {version('scipy')}, daqp {version('daqp')}; {kernels.BACKEND} kernels ({kernels.REASON})"
    )


def pytest_collection_modifyitems(config, items) -> None:
    """Every test of ``tests/diagrams`` (a scenario simulated in physics, seconds to minutes) carries
    the ``scenario`` marker, so that a run on another Python can leave them out but for the
    ``compat`` ones (``make test``: ``-m "compat or not (slow or scenario)"``). The tests of the compiled
    kernels and of the pure modules that call them carry the ``kernels`` marker (:data:`KERNEL_TESTS`).

    Then the files are ordered by their cost, the long ones first: the files with a ``slow`` test,
    then those with a ``scenario`` one, then the rest, each group in collection order and each file's
    tests in theirs. ``make test`` gives files to its two workers in this order (``--dist loadfile
    --no-loadscope-reorder``; xdist's own order, the files with more tests first, left the long
    simulations of two or three tests each to the end, one worker idle while the other ran them):
    the many short files come last and fill whichever worker is free first."""
    for item in items:
        if "diagrams" in item.path.parent.parts[-1:]:
            item.add_marker("scenario")
        if item.path.name.startswith("test_kernels") or item.path.name in KERNEL_TESTS:
            item.add_marker("kernels")
    rank: dict[Path, int] = {}
    for item in items:
        cost = 0 if item.get_closest_marker("slow") else 1 if item.get_closest_marker("scenario") else 2
        rank[item.path] = min(rank.get(item.path, 2), cost)
    items.sort(key=lambda item: rank[item.path])  # stable: the order within a group is kept


def pytest_configure(config) -> None:
    """The test run is a front-end: its controllers' small matrices run on one BLAS thread, as the
    command line's do (:mod:`drake_sot.blas` says why); the constructors leave the threads alone."""
    from drake_sot.blas import limit_blas_threads

    limit_blas_threads(1)
