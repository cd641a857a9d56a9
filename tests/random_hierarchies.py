"""The large random hierarchies of ``tests/test_hqp.py`` (``large_problems``) and of
``benchmarks/bench_hqp.py``, drawn in one place so that the benchmark times the problems the
tests check. Pure numpy: the benchmark imports it with ``tests/`` on its path."""

from __future__ import annotations

import numpy as np

Level3 = tuple[np.ndarray, np.ndarray, np.ndarray]


def random_hierarchy(rng: np.random.Generator, degenerate: bool, n: int, count: int) -> list[Level3]:
    """``count`` levels ``(J, lower, upper)`` of 2-13 rows on ``n`` joints, drawn from ``rng``; a
    level is all equalities (probability 0.35) or mixes one-sided, two-sided and equality rows.
    ``degenerate``: rows repeated from a level above (the same row, its opposite or its double,
    with its bounds or others: parallel and contradictory rows), rank-deficient levels (a row the
    sum of two others), bounds through 0 (rows at their bound where q̇ starts, with zero
    multipliers)."""
    levels: list[Level3] = []
    for _ in range(count):
        m = int(rng.integers(2, 14))
        J = rng.normal(size=(m, n))
        lo, hi = np.empty(m), np.empty(m)
        equalities = rng.random() < 0.35
        for i in range(m):
            centre, width = rng.normal(), rng.uniform(0.0, 1.0)
            if degenerate and rng.random() < 0.4:
                centre, width = 0.0, float(rng.choice([0.0, 1.0]))
            kind = "equality" if equalities or rng.random() < 0.2 else rng.choice(["box", "above", "below"])
            lo[i], hi[i] = {
                "equality": (centre, centre),
                "box": (centre - width, centre + width),
                "above": (centre - width, np.inf),
                "below": (-np.inf, centre + width),
            }[kind]
            if degenerate and levels and rng.random() < 0.3:
                J_src, lo_src, hi_src = levels[rng.integers(len(levels))]
                k = rng.integers(J_src.shape[0])
                J[i] = J_src[k] * rng.choice([1.0, -1.0, 2.0])
                if rng.random() < 0.5:
                    lo[i], hi[i] = lo_src[k], hi_src[k]
        if degenerate and m >= 3 and rng.random() < 0.3:
            J[2] = J[0] + J[1]
        levels.append((J, lo, hi))
    return levels
