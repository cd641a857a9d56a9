"""Plots of a run (matplotlib, no display needed)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_task_errors(
    time: np.ndarray,
    errors: Mapping[str, np.ndarray],
    events: Sequence[tuple[float, str]],
    path: str | Path,
    *,
    title: str = "",
) -> None:
    """One curve ‖e_i‖(t) per task (gaps while a task is out of the stack), commands marked.

    Args:
        time: (T,) sample times [s].
        errors: task name → (T, m_i) error samples, NaN while the task is inactive.
        events: ``(time, label)`` of the commands (stack changes, new targets).
        path: the PNG to write.
    """
    fig, ax = plt.subplots(figsize=(10, 5), dpi=110)
    for name, e in errors.items():
        ax.semilogy(time, np.maximum(np.linalg.norm(e, axis=1), 1e-6), label=name)
    merged: dict[float, list[str]] = {}
    for t, label in events:  # commands at the same instant share one marker
        merged.setdefault(round(t, 6), []).append(label)
    for t, labels in merged.items():
        label = "; ".join(labels)
        ax.axvline(t, color="0.5", linestyle="--", linewidth=0.8)
        ax.text(t, 1.0, f" {label}", transform=ax.get_xaxis_transform(), rotation=90,
                va="top", ha="left", fontsize=8, color="0.3")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("task error norm ‖e‖ (m, rad)")
    ax.set_title(title or "task errors")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
