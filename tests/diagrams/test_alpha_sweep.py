"""alpha_sweep: the corner cases of the priority grid, run by the study's worker processes."""

import signal

import numpy as np
import pytest

from drake_sot.diagrams import alpha_sweep
from drake_sot.diagrams.run import Interrupted


def test_corners_of_the_grid_in_parallel(tmp_path):
    seen = []
    files = alpha_sweep.run(
        tmp_path, grid=(0.0, 1.0), duration=3.0, workers=2, progress=lambda d, n, w: seen.append((d, n))
    )
    logs = np.load(files.files["npz"])
    head, lh = logs["head_error"], logs["lh_error"]  # rows α_lh,head, columns α_head,lh
    assert seen[-1] == (4, 4)
    # α_lh,head = 0, α_head,lh = 1: the left hand has strict priority over the head.
    assert lh[0, 1] < 0.5 * head[0, 1]
    # α_lh,head = 1, α_head,lh = 0: the head has strict priority over the left hand.
    assert head[1, 0] < 0.5 * lh[1, 0]
    assert files.files["png"].stat().st_size > 1000


def test_a_signal_cancels_the_rest_and_still_writes_what_was_done(tmp_path):
    """SIGTERM after the first point: the others are cancelled, both files are written with
    the finished point, and the interruption reaches the caller (the command exits 143)."""

    def progress(done, total, wall):
        if done == 1:
            signal.raise_signal(signal.SIGTERM)

    with pytest.raises(Interrupted) as stopped:
        alpha_sweep.run(tmp_path, grid=(0.0, 1.0), duration=0.5, workers=1, progress=progress)
    assert stopped.value.signum == signal.SIGTERM
    logs = np.load(tmp_path / "alpha_sweep.npz")
    assert logs["done"].sum() == 1  # one worker, stopped after its first point
    assert np.isfinite(logs["head_error"][logs["done"]]).all()
    assert np.isnan(logs["head_error"][~logs["done"]]).all()
    assert (tmp_path / "alpha_sweep.png").stat().st_size > 1000
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # the handlers are restored
