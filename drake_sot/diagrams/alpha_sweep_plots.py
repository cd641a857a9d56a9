"""The plot of the ``alpha_sweep`` study: Liu, Lober, Padois 2016, fig. 11 (matplotlib, no pyplot)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure


def plot_alpha_sweep(grid: np.ndarray, head: np.ndarray, lh: np.ndarray, path: str | Path) -> None:
    """Write heat maps of the steady head and left-hand errors over the grid of priorities
    (Liu, Lober, Padois 2016, fig. 11).

    Args:
        grid: (n,) the α values of both axes. head, lh: (n, n) steady error norms [m], row i
            for α_lh,head = grid[i], column j for α_head,lh = grid[j]. path: the PNG to write.
    """
    fig = Figure(figsize=(11, 4.6), dpi=110, layout="tight")
    axes = fig.subplots(1, 2)
    for ax, values, title in (
        (axes[0], head, "head task error [cm]"),
        (axes[1], lh, "left-hand task error [cm]"),
    ):
        image = ax.imshow(
            100 * values,
            origin="lower",
            cmap="viridis",
            aspect="auto",
            extent=(grid[0] - 0.1, grid[-1] + 0.1, grid[0] - 0.1, grid[-1] + 0.1),
        )
        for i, a in enumerate(grid):
            for j, b in enumerate(grid):
                ax.text(b, a, f"{100 * values[i, j]:.1f}", ha="center", va="center", fontsize=7, color="w")
        ax.set_xlabel("α_head,lh")
        ax.set_ylabel("α_lh,head")
        ax.set_title(title)
        fig.colorbar(image, ax=ax)
    write_figure(fig, path)
