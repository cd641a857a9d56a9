"""The figure of the ``delay_sweep`` study: the tele-cooperation's hand tracking and force
transparency over the link's one-way delay, one curve per jitter and loss (matplotlib, no
pyplot)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure
from drake_sot.studies.description import Study

#: The panels: metric, its label, the factor from the table's unit to the plot's.
PANELS = (
    ("tracking_error_rms", "hand tracking error, RMS [cm]", 100.0),
    ("tracking_error_max", "hand tracking error, largest [cm]", 100.0),
    ("force_error_rms", "operator's force − robot hand's, RMS [N]", 1.0),
    ("force_ratio", "operator's force / robot hand's (RMS)", 1.0),
)


def curves(rows: Mapping[str, Mapping[str, Any]]) -> dict[tuple[float, float], dict[str, np.ndarray]]:
    """From the table's ``rows`` (the runs done, ok), per ``(jitter [s], loss)`` the arrays
    ``delay`` [s] (increasing), ``survived`` and each metric of :data:`PANELS` at those delays."""
    grouped: dict[tuple[float, float], list[Mapping[str, Any]]] = {}
    for row in rows.values():
        if row["status"] == "ok":
            grouped.setdefault((row["jitter"], row["loss"]), []).append(row)
    found = {}
    for key, group in sorted(grouped.items()):
        group = sorted(group, key=lambda row: row["delay"])
        columns = ("delay", "survived", *(metric for metric, _, _ in PANELS))
        found[key] = {name: np.array([row[name] for row in group], dtype=float) for name in columns}
    return found


def write_figures(study: Study, rows: Mapping[str, Mapping[str, Any]], out: Path) -> dict[str, Path]:
    """``<name>.png``: the metrics of :data:`PANELS` over the one-way delay [ms], one curve per
    jitter and loss; a run in which the robot fell is marked with a cross."""
    fig = Figure(figsize=(11, 8), dpi=110, layout="tight")
    axes = fig.subplots(2, 2, sharex=True).ravel()
    for (jitter, loss), curve in curves(rows).items():
        delay = 1000.0 * curve["delay"]
        fell = curve["survived"] < 0.5
        label = f"jitter ±{1000 * jitter:g} ms, loss {100 * loss:g} %"
        for ax, (metric, _, factor) in zip(axes, PANELS, strict=True):
            (line,) = ax.plot(delay, factor * curve[metric], "o-", label=label)
            ax.plot(delay[fell], factor * curve[metric][fell], "x", color=line.get_color(), markersize=10)
    for ax, (_, ylabel, _) in zip(axes, PANELS, strict=True):
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    for ax in axes[2:]:
        ax.set_xlabel("one-way delay [ms]")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{study.name}: tele-cooperation standing (x: the robot fell)")
    files = {"png": out / f"{study.name}.png"}
    write_figure(fig, files["png"])
    return files
