"""The plot of the ``walk_then_interact`` scenario: hand forces and displacements (matplotlib, no pyplot)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure
from drake_sot.plots import mark_event


def plot_interaction(
    time: np.ndarray,
    measured: Mapping[str, np.ndarray],
    applied: Mapping[str, np.ndarray],
    displacement: Mapping[str, np.ndarray],
    events: Sequence[tuple[float, str]],
    path: str | Path,
) -> None:
    """Write, per hand, the forces (measured at the wrist sensor, applied by the partner) and
    the hand's displacement, x/y/z over time.

    Args:
        time: (T,) [s]. measured, applied, displacement: hand name → (T, 3) [N, N, m].
        events: ``(time, label)`` to mark. path: the PNG to write.
    """
    hands = list(measured)
    fig = Figure(figsize=(6 * len(hands), 7), dpi=110, layout="tight")
    axes = fig.subplots(2, len(hands), sharex=True, squeeze=False)
    for j, hand in enumerate(hands):
        force_ax, disp_ax = axes[0, j], axes[1, j]
        for i, axis in enumerate("xyz"):
            force_ax.plot(
                time,
                applied[hand][:, i],
                color=f"C{i}",
                linestyle="--",
                linewidth=0.9,
                label=f"partner f{axis}",
            )
            force_ax.plot(
                time, measured[hand][:, i], color=f"C{i}", linewidth=1.2, label=f"wrist sensor f{axis}"
            )
            disp_ax.plot(time, 100 * displacement[hand][:, i], color=f"C{i}", label=f"Δ{axis}")
        force_ax.set_title(f"{hand} hand")
        force_ax.set_ylabel("force [N]")
        disp_ax.set_ylabel("hand displacement [cm]")
        disp_ax.set_xlabel("time [s]")
        for ax in (force_ax, disp_ax):
            ax.grid(True, alpha=0.3)
            for t, label in events:
                mark_event(ax, t, label)
        force_ax.legend(loc="lower left", fontsize=7, ncol=2)
        disp_ax.legend(loc="lower left", fontsize=7)
    write_figure(fig, path)
