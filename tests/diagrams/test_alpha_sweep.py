"""alpha_sweep: the corner cases of the priority grid, run by the study's worker processes."""

import numpy as np

from drake_sot.diagrams import alpha_sweep


def test_corners_of_the_grid_in_parallel(tmp_path):
    seen = []
    files = alpha_sweep.run(
        tmp_path, grid=(0.0, 1.0), duration=3.0, workers=2, progress=lambda d, n, w: seen.append((d, n))
    )
    logs = np.load(files["npz"])
    head, lh = logs["head_error"], logs["lh_error"]  # rows α_lh,head, columns α_head,lh
    assert seen[-1] == (4, 4)
    # α_lh,head = 0, α_head,lh = 1: the left hand has strict priority over the head.
    assert lh[0, 1] < 0.5 * head[0, 1]
    # α_lh,head = 1, α_head,lh = 0: the head has strict priority over the left hand.
    assert head[1, 0] < 0.5 * lh[1, 0]
    assert files["png"].stat().st_size > 1000
