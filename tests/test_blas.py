"""drake_sot.blas: the thread count of the OpenBLAS libraries loaded in the process, read
back through each library's own getter."""

from __future__ import annotations

import os
import subprocess
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


def _openblas_at(threads: int) -> dict[str, int]:
    """Every loaded OpenBLAS set to ``threads``; the counts before. Skips (saying why) when
    no OpenBLAS is loaded or none takes ``threads`` (a build for one thread stays at 1)."""
    scipy.linalg.cholesky(np.eye(2))
    before = limit_blas_threads(threads)
    if not before:
        pytest.skip(f"no OpenBLAS among the loaded libraries (numpy {np.__version__} uses another BLAS)")
    if set(blas_threads().values()) != {threads}:
        limit_blas_threads(min(before.values()))
        pytest.skip(f"the loaded OpenBLAS builds do not take {threads} threads: {blas_threads()}")
    return before


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps: Linux only")
def test_making_a_stack_of_tasks_leaves_the_blas_threads_alone():
    """A constructor does not change process-wide state: a notebook's numpy keeps its threads."""
    from drake_sot.systems.sot import StackOfTasks

    before = _openblas_at(2)
    try:
        StackOfTasks(2, {"reach": 2, "posture": 1}, period=0.005, stack=("reach", "posture"))
        assert set(blas_threads().values()) == {2}
    finally:
        for path, count in before.items():
            limit_blas_threads(count)
            assert blas_threads()[path] == count


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps: Linux only")
def test_the_command_line_runs_on_one_blas_thread():
    """The front-end decides: ``drake-sot`` limits every loaded OpenBLAS to one thread when it
    starts (here ``list``, which builds no controller), whatever the environment asked for."""
    code = (
        "from drake_sot.blas import blas_threads, limit_blas_threads; limit_blas_threads(2); "
        "from drake_sot.app.cli import main; main(['list']); print(sorted(set(blas_threads().values())))"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env
    )
    assert result.returncode == 0, result.stderr
    counts = result.stdout.strip().splitlines()[-1]
    if counts == "[]":
        pytest.skip("no OpenBLAS among the loaded libraries: nothing to limit")
    assert counts == "[1]", result.stdout
