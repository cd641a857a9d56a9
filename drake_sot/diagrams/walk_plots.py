"""The plot of the ``walk`` scenario: ZMP, CoM and support polygon (matplotlib, no pyplot)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure


def plot_walk(
    time: np.ndarray,
    zmp_ref: np.ndarray,
    zmp: np.ndarray,
    com_ref: np.ndarray,
    com: np.ndarray,
    polygons: Sequence[np.ndarray],
    footprints: Sequence[np.ndarray],
    path: str | Path,
) -> None:
    """Write a top view (footprints, ZMP reference, measured ZMP, CoM) and x(t), y(t) with the
    support polygon's extent shaded.

    Args:
        time: (T,) [s]. zmp_ref, zmp: (T, 2) [m]. com_ref, com: (T, ≥2) [m] (reference, measured).
        polygons: T support polygons (k, 2) of the soles in contact.
        footprints: planned sole rectangles (4, 2) to draw on the top view.
        path: the PNG to write.
    """
    fig = Figure(figsize=(13, 6), dpi=110, layout="tight")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.1, 1.4))
    top = fig.add_subplot(grid[:, 0])
    for corners in footprints:
        top.fill(*np.vstack((corners, corners[:1])).T, color="0.85", edgecolor="0.5", linewidth=0.8)
    top.plot(*zmp_ref.T, color="C0", label="ZMP reference")
    top.plot(*zmp.T, ".", color="C3", markersize=1.5, label="ZMP measured (ankle sensors)")
    top.plot(*com_ref[:, :2].T, color="C2", linestyle="--", label="CoM reference")
    top.plot(*com[:, :2].T, color="C1", label="CoM measured")
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title("top view: planned footprints in grey")
    top.legend(loc="upper center", bbox_to_anchor=(0.5, -0.18), ncol=2, fontsize=8)
    low = np.array([p.min(axis=0) for p in polygons])
    high = np.array([p.max(axis=0) for p in polygons])
    for axis, name in ((0, "x"), (1, "y")):
        ax = fig.add_subplot(grid[axis, 1])
        ax.fill_between(time, low[:, axis], high[:, axis], color="0.88", label="support polygon extent")
        ax.plot(time, zmp_ref[:, axis], color="C0", label="ZMP reference")
        ax.plot(time, zmp[:, axis], color="C3", linewidth=0.7, label="ZMP measured")
        ax.plot(time, com_ref[:, axis], color="C2", linestyle="--", label="CoM reference")
        ax.plot(time, com[:, axis], color="C1", label="CoM measured")
        ax.set_ylabel(f"{name} [m]")
        ax.grid(True, alpha=0.3)
        if axis == 0:
            ax.legend(loc="upper left", fontsize=7)
        else:
            ax.set_xlabel("time [s]")
    write_figure(fig, path)
