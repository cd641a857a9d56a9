"""The plot every scenario writes: task error norms over time, commands marked.

Drawn with matplotlib's object-oriented API (:class:`matplotlib.figure.Figure`, no pyplot):
importing this module selects no backend and opens no window, so a notebook keeps its own.
Scenario-specific plots live beside their scenario (``drake_sot/diagrams/*_plots.py``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

#: Beyond this many marked instants the marks are drawn without their labels (which would
#: cover the plot), and the title counts them.
MAX_MARK_LABELS = 40
#: Marks closer than this fraction of the plotted time span share one marker and one label (at
#: the first one's time): labels a few ticks apart would be drawn over each other.
MERGE_FRACTION = 0.01


def plot_task_errors(
    time: np.ndarray,
    errors: Mapping[str, np.ndarray],
    events: Sequence[tuple[float, str]],
    *,
    title: str = "",
) -> Figure:
    """One curve ‖e_i‖(t) per task (gaps while a task is out of the stack), commands marked.

    Args:
        time: (T,) sample times [s].
        errors: task name → (T, m_i) error samples, NaN while the task is inactive.
        events: ``(time, label)`` of the commands (stack changes, new targets); those closer
            than :data:`MERGE_FRACTION` of the time span share one marker; more than
            :data:`MAX_MARK_LABELS` markers are drawn without labels.
        title: the figure's title (default "task errors").

    Returns:
        The figure (``fig.savefig(path)`` writes it; a notebook shows it).
    """
    fig = Figure(figsize=(10, 5), dpi=110, layout="tight")
    ax = fig.subplots()
    for name, e in errors.items():
        ax.semilogy(time, np.maximum(np.linalg.norm(e, axis=1), 1e-6), label=name)
    span = float(time[-1] - time[0]) if len(time) else 0.0
    merged: dict[float, list[str]] = {}
    for t, label in sorted(events, key=lambda event: event[0]):
        last = next(reversed(merged), None)
        if last is not None and t - last <= MERGE_FRACTION * span + 1e-6:
            merged[last].append(label)
        else:
            merged[t] = [label]
    labelled = len(merged) <= MAX_MARK_LABELS
    for t, labels in merged.items():
        if labelled:
            mark_event(ax, t, "; ".join(labels), linestyle="--", rotation=90, fontsize=8)
        else:
            ax.axvline(t, color="0.5", linestyle="--", linewidth=0.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("task error norm ‖e‖ (m, rad)")
    unlabelled = "" if labelled else f" ({len(events)} commands marked, unlabelled: the .npz names them)"
    ax.set_title((title or "task errors") + unlabelled)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    return fig


def mark_event(
    ax: Axes, t: float, label: str, *, linestyle: str = ":", rotation: float = 0, fontsize: float = 7
) -> None:
    """A vertical line at ``t`` [s] on ``ax`` with ``label`` at its top, cut at the axes' edge (a
    label longer than the axes would push them out of the figure's layout)."""
    ax.axvline(t, color="0.5", linestyle=linestyle, linewidth=0.8)
    text = ax.text(
        t,
        1.0,
        f" {label}",
        transform=ax.get_xaxis_transform(),
        rotation=rotation,
        va="top",
        ha="left",
        fontsize=fontsize,
        color="0.3",
        clip_on=True,
    )
    text.set_in_layout(False)
