"""The thread count of the BLAS libraries loaded in the process (pure: ctypes, no Drake).

OpenBLAS spreads a matrix product or factorisation over its threads. On the matrices of
a control tick (tens of rows) that gains nothing, and on a loaded machine the threads
wait for one another (``benchmarks/README.md``: the generalized controller's update
with OpenBLAS's default threads and with one). The controllers (``StackOfTasks``,
``GeneralizedHierarchyController``) leave the process's threads alone: the front-ends that
start a run (the command line, serving, the study workers, the benchmarks) call
:func:`limit_blas_threads`, and a notebook or a library user decides for itself. Setting
``OPENBLAS_NUM_THREADS=1`` in the environment before Python starts has the same effect for
the whole process; :func:`limit_blas_threads` acts on each OpenBLAS loaded, and this module
loads numpy's and scipy's (they ship one each) so that a front-end can call it first thing.

Linux only (the loaded libraries are read from ``/proc/self/maps``); elsewhere nothing
is changed and an empty mapping is returned.
"""

from __future__ import annotations

import ctypes
import pathlib

import scipy.linalg  # noqa: F401 (loads scipy's OpenBLAS, so that limit_blas_threads sees it)

from drake_sot.validation import positive_int

__all__ = ["blas_threads", "limit_blas_threads"]

#: (setter, getter) symbol names of OpenBLAS builds: plain, 64-bit integer interface, and the
#: prefixed builds that the numpy and scipy wheels bundle.
_SYMBOLS = (
    ("openblas_set_num_threads", "openblas_get_num_threads"),
    ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
    ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
    ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
)
_MAPS = pathlib.Path("/proc/self/maps")


def _openblas() -> dict[str, tuple[ctypes._CFuncPtr, ctypes._CFuncPtr]]:
    """Path → (set, get) of every OpenBLAS shared library mapped in this process."""
    if not _MAPS.exists():
        return {}
    paths = sorted(
        {
            line.split()[-1]
            for line in _MAPS.read_text().splitlines()
            if "openblas" in line.rsplit("/", 1)[-1].lower() and ".so" in line
        }
    )
    found = {}
    for path in paths:
        library = ctypes.CDLL(path)  # already loaded: the same handle
        for setter, getter in _SYMBOLS:
            if hasattr(library, setter) and hasattr(library, getter):
                get = getattr(library, getter)
                get.restype = ctypes.c_int
                found[path] = (getattr(library, setter), get)
                break
    return found


def blas_threads() -> dict[str, int]:
    """Path of each OpenBLAS loaded in the process → the number of threads it uses."""
    return {path: int(get()) for path, (_, get) in _openblas().items()}


def limit_blas_threads(threads: int = 1) -> dict[str, int]:
    """Make every OpenBLAS loaded in the process use ``threads`` threads (>= 1).

    Returns each library's path → the count it had before (call again with a count to
    restore it). Raises ValueError for ``threads`` < 1 or not an integer.
    """
    threads = positive_int("threads", threads)
    before = {}
    for path, (set_threads, get) in _openblas().items():
        before[path] = int(get())
        set_threads(ctypes.c_int(threads))
    return before
