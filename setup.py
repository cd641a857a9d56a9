"""Builds drake_sot's compiled core, ``drake_sot.kernels._compiled``: the hot numerics of the pure
modules in C++ (pybind11 over Eigen), each kernel beside its numpy version (the oracle, and the
fallback). Everything else about the package is in pyproject.toml.

Why pybind11 over Eigen, built by setuptools: both are header-only wheels on PyPI (build-time
requirements only: the installed package needs neither), so ``pip install .`` builds with the
machine's g++ and nothing from apt; Eigen gives the QR, SVD and triangular solves of the strict
hierarchy without BLAS, so a kernel's time does not depend on a BLAS thread count. setuptools
is already the backend: one ``optional`` extension, whose failed build leaves a package that runs on
the numpy kernels and says so in one line (``drake_sot.kernels``), where scikit-build-core would
fail the install.
"""

from __future__ import annotations

import pathlib
import sys

from pybind11.setup_helpers import ParallelCompile, Pybind11Extension, build_ext
from setuptools import setup

ROOT = pathlib.Path(__file__).resolve().parent


def _eigen_include() -> str:
    """Eigen's headers, from the cmeel-eigen wheel of the build environment."""
    for entry in map(pathlib.Path, sys.path):
        candidate = entry / "cmeel.prefix" / "include" / "eigen3"
        if (candidate / "Eigen" / "Core").is_file():
            return str(candidate)
    raise RuntimeError("Eigen's headers (the cmeel-eigen wheel) are not on sys.path: see pyproject.toml")


# The C++ files compile in parallel, one job per core (DRAKE_SOT_BUILD_JOBS=N to choose).
ParallelCompile("DRAKE_SOT_BUILD_JOBS").install()

KERNELS = ROOT / "drake_sot" / "kernels"
SOURCES = sorted(str(p.relative_to(ROOT)) for p in KERNELS.glob("*.cpp"))
sys.path.insert(0, str(KERNELS))  # the hash of the sources, as drake_sot.kernels checks it at import
from source_hash import source_hash  # noqa: E402

sys.path.pop(0)

setup(
    ext_modules=[
        Pybind11Extension(
            "drake_sot.kernels._compiled",
            SOURCES,
            include_dirs=[_eigen_include()],
            cxx_std=17,
            # No OpenMP, no BLAS behind Eigen: one thread whatever the process's BLAS does.
            define_macros=[
                ("EIGEN_DONT_PARALLELIZE", "1"),
                ("EIGEN_MPL2_ONLY", "1"),
                ("DRAKE_SOT_SOURCE_HASH", f'"{source_hash(KERNELS)}"'),
            ],
            extra_compile_args=["-O2", "-fvisibility=hidden"],
            optional=True,
        )
    ],
    cmdclass={"build_ext": build_ext},
)
