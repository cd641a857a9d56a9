"""The two paths of each compiled kernel, for the tests that check them against each other: the
compiled module (``drake_sot.kernels.compiled``), or a skip that says why it is missing."""

from __future__ import annotations

import pytest

from drake_sot import kernels


def compiled_kernels():
    """The compiled module; the test is skipped, saying why, where the package runs on numpy."""
    if kernels.compiled is None:
        pytest.skip(f"the compiled kernels are not in use here: {kernels.REASON}")
    return kernels.compiled
