"""The plot of the ``table_pounding`` scenario: Liu, Lober, Padois 2016, figs. 4-7 (matplotlib, no pyplot)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure


def plot_table_pounding(
    time: np.ndarray,
    alphas: Mapping[str, np.ndarray],
    force_target: float,
    force: np.ndarray,
    errors: Mapping[str, np.ndarray],
    tau_squared: np.ndarray,
    transition: float,
    path: str | Path,
) -> None:
    """Write Liu, Lober, Padois 2016, figures 4-7 in one page: α (top), desired and measured
    hand force, CoM and hand position errors, and the squared sum of joint torques τᵀτ.

    Args:
        time: (T,) [s]. alphas: name → (T,) priority parameter. force_target: desired force [N].
        force: (T,) measured force [N]. errors: task name → (T,) error norm [m].
        tau_squared: (T,) τᵀτ [N²·m²]. transition: the rearrangement period [s], in the title.
        path: the PNG to write.
    """
    fig = Figure(figsize=(10, 10), dpi=110, layout="tight")
    axes = fig.subplots(4, 1, sharex=True)
    for name, values in alphas.items():
        axes[0].plot(time, values, label=name)
    axes[0].set_ylabel("α")
    axes[0].set_title(f"priority rearrangement period {transition:g} s")
    axes[1].plot(time, force, label="measured (spring displacement)")
    axes[1].axhline(force_target, color="k", linestyle="--", linewidth=0.8, label="desired")
    axes[1].set_ylabel("hand force on the table [N]")
    for name, values in errors.items():
        axes[2].plot(time, 100 * values, label=name)
    axes[2].set_ylabel("task error [cm]")
    axes[3].plot(time, tau_squared)
    axes[3].set_ylabel("τᵀτ [N²·m²]")
    axes[3].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=7)
    write_figure(fig, path)
