"""drake_sot.blas: the thread count of the OpenBLAS libraries loaded in the process, read
back through each library's own getter."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import scipy.linalg

from drake_sot.blas import blas_threads, limit_blas_threads


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps: Linux only")
def test_limit_sets_every_loaded_openblas_and_returns_the_counts_before():
    np.ones((2, 2)) @ np.ones((2, 2))  # numpy's and scipy's OpenBLAS are loaded
    scipy.linalg.cholesky(np.eye(2))
    before = blas_threads()
    if not before:
        pytest.skip(f"no OpenBLAS among the loaded libraries (numpy {np.__version__} uses another BLAS)")
    try:
        assert limit_blas_threads(1) == before
        assert set(blas_threads().values()) == {1}
        limit_blas_threads(2)
        assert set(blas_threads().values()) <= {1, 2}  # a library built for one thread stays at 1
    finally:
        for path, count in before.items():
            limit_blas_threads(count)
            assert blas_threads()[path] == count


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2", None])
def test_a_thread_count_below_one_or_not_an_integer_is_refused(bad):
    with pytest.raises(ValueError, match=r"threads = .*must be an integer >= 1"):
        limit_blas_threads(bad)
