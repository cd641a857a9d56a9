"""The compiled preview servo (Kajita et al. 2003) against its numpy version, to 1e-12: one tick
anywhere in a reference (its end held past the end included) and whole plans."""

import numpy as np
import pytest
from kernel_paths import compiled_kernels

from drake_sot.preview import PreviewController


def _close(a: np.ndarray, b: np.ndarray) -> None:
    assert a.shape == b.shape
    assert np.abs(a - b).max() <= 1e-12 * (1.0 + np.abs(b).max())


CONTROLLERS = [PreviewController(), PreviewController(dt=0.01, z_c=0.6, horizon=0.05)]


@pytest.mark.parametrize("seed", range(12))
def test_one_tick_anywhere_in_the_reference_matches_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(seed)
    c = CONTROLLERS[seed % 2]
    K = int(rng.integers(1, 3 * c.N))
    reference = rng.normal(size=(K, 2))
    x, s = rng.normal(size=(3, 2)), rng.normal(size=2)
    for k in sorted({0, K - 1, K, K + c.N, *rng.integers(0, K + c.N, size=5).tolist()}):
        got = core.preview_step_at(c._tick, x, s, reference, k)
        expected = c.step_numpy(x, s, c.window(reference, k))
        for a, b in zip(got, expected, strict=True):
            _close(a, b)


@pytest.mark.parametrize("seed", range(6))
def test_a_plan_matches_numpy(seed):
    core = compiled_kernels()
    rng = np.random.default_rng(100 + seed)
    c = CONTROLLERS[seed % 2]
    reference = np.cumsum(rng.normal(scale=0.01, size=(int(rng.integers(1, 800)), 2)), axis=0)
    x, s = rng.normal(scale=0.1, size=(3, 2)), rng.normal(size=2)
    rows, zmp = core.preview_plan(c._tick, reference, x, s)
    states, expected_zmp = c.run_numpy(reference, x, s)
    _close(rows.reshape(-1, 3, 2), states)
    _close(zmp, expected_zmp)


def test_a_bad_tick_matrix_is_refused_by_value_not_by_a_crash():
    core = compiled_kernels()
    with pytest.raises(ValueError, match="tick matrix"):
        core.preview_step_at(np.zeros((4, 8)), np.zeros((3, 2)), np.zeros(2), np.zeros((3, 2)), 0)
    with pytest.raises(ValueError, match="at least one sample"):
        core.preview_plan(np.zeros((5, 8)), np.zeros((0, 2)), np.zeros((3, 2)), np.zeros(2))
