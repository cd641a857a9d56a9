"""The plot of the ``priority_switching`` scenario: Liu, Lober, Padois 2016, fig. 10 (no pyplot)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure


def plot_priority_switch(
    time: np.ndarray, alphas: Mapping[str, np.ndarray], errors: Mapping[str, np.ndarray], path: str | Path
) -> None:
    """Write the priority parameters (top) and the task error norms (bottom) over time
    (Liu, Lober, Padois 2016, fig. 10).

    Args:
        time: (T,) [s]. alphas: name → (T,) priority parameter α ∈ [0, 1].
        errors: task name → (T,) error norm [m]. path: the PNG to write.
    """
    fig = Figure(figsize=(9, 6), dpi=110, layout="tight")
    top, bottom = fig.subplots(2, 1, sharex=True)
    for name, values in alphas.items():
        top.plot(time, values, label=name)
    top.set_ylabel("α")
    top.set_ylim(-0.05, 1.05)
    top.legend(loc="center right", fontsize=8)
    for name, values in errors.items():
        bottom.plot(time, 100 * values, label=name)
    bottom.set_ylabel("task error ‖e‖ [cm]")
    bottom.set_xlabel("time [s]")
    bottom.legend(loc="upper right", fontsize=8)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    write_figure(fig, path)
