"""The figures of the ``alpha_sweep`` study: Liu, Lober, Padois 2016, fig. 11 (matplotlib, no pyplot)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure, write_npz
from drake_sot.studies.description import Study


def write_figures(study: Study, rows: Mapping[str, Mapping[str, Any]], out: Path) -> dict[str, Path]:
    """The grid of ``study`` (an ``alpha_sweep``) from its table's ``rows``: ``alpha_sweep.npz``
    (``alpha_lh_head``, ``alpha_head_lh`` the axes, ``head_error`` and ``lh_error`` [m] rows
    α_lh,head and columns α_head,lh, NaN where not done, ``done`` which were) and the heat maps
    ``alpha_sweep.png``."""
    axes = study.runs.axes  # type: ignore[union-attr]
    rows_axis, columns_axis = np.array(axes["alpha_lh_head"]), np.array(axes["alpha_head_lh"])
    head = np.full((len(rows_axis), len(columns_axis)), np.nan)
    lh = np.full_like(head, np.nan)
    for row in rows.values():
        if row["status"] == "ok":
            i = int(np.flatnonzero(rows_axis == row["alpha_lh_head"])[0])
            j = int(np.flatnonzero(columns_axis == row["alpha_head_lh"])[0])
            head[i, j], lh[i, j] = row["steady_error_head"], row["steady_error_lh"]
    files = {"npz": out / f"{study.name}.npz", "png": out / f"{study.name}.png"}
    arrays = {"alpha_lh_head": rows_axis, "alpha_head_lh": columns_axis, "head_error": head, "lh_error": lh}
    write_npz(arrays | {"done": np.isfinite(head) & np.isfinite(lh)}, files["npz"])
    plot_alpha_sweep(rows_axis, head, lh, files["png"])
    return files


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
