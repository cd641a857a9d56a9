"""The survival map of the ``push_recovery`` study: the largest pelvis push the walk survives
over push time (gait phase) x direction, with and without the stabilizer (matplotlib, no pyplot)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure, write_npz
from drake_sot.studies.description import Study


def survival_map(study: Study, rows: Mapping[str, Mapping[str, Any]]) -> dict[str, np.ndarray]:
    """From the table's ``rows`` of ``study`` (a bisection of ``push_force`` over ``stabilizer``
    x ``push_time`` x ``push_direction``): ``push_time`` (n,) [s], ``push_direction`` (m,) [deg],
    ``stabilizer`` (k,) and ``largest_survived`` (k, n, m) [N], per cell the largest force
    survived among the runs done (the bisection's ``low`` when none was)."""
    cells = study.runs.cells.axes  # type: ignore[union-attr]
    stabilizer = np.array(cells["stabilizer"], dtype=bool)
    times, directions = np.array(cells["push_time"]), np.array(cells["push_direction"])
    largest = np.full((len(stabilizer), len(times), len(directions)), float(study.runs.low))  # type: ignore[union-attr]
    for row in rows.values():
        if row["status"] == "ok" and row["survived"] is True:
            k = int(np.flatnonzero(stabilizer == row["stabilizer"])[0])
            i = int(np.flatnonzero(times == row["push_time"])[0])
            j = int(np.flatnonzero(directions == row["push_direction"])[0])
            largest[k, i, j] = max(largest[k, i, j], row["push_force"])
    return {
        "push_time": times,
        "push_direction": directions,
        "stabilizer": stabilizer,
        "largest_survived": largest,
    }


def write_figures(study: Study, rows: Mapping[str, Mapping[str, Any]], out: Path) -> dict[str, Path]:
    """``<name>.npz`` (the :func:`survival_map`) and ``<name>.png``: one heat map of the largest
    push survived [N] per stabilizer setting, push time on the rows, direction on the columns."""
    survival = survival_map(study, rows)
    files = {"npz": out / f"{study.name}.npz", "png": out / f"{study.name}.png"}
    write_npz(survival, files["npz"])
    largest = survival["largest_survived"]
    fig = Figure(figsize=(5.5 * len(survival["stabilizer"]), 4.6), dpi=110, layout="tight")
    axes = np.atleast_1d(fig.subplots(1, len(survival["stabilizer"])))
    for ax, on, values in zip(axes, survival["stabilizer"], largest, strict=True):
        image = ax.imshow(
            values, origin="lower", cmap="viridis", aspect="auto", vmin=0.0, vmax=study.runs.high
        )  # type: ignore[union-attr]
        for i in range(values.shape[0]):
            for j in range(values.shape[1]):
                ax.text(j, i, f"{values[i, j]:.0f}", ha="center", va="center", fontsize=8, color="w")
        ax.set_xticks(range(len(survival["push_direction"])), [f"{d:g}°" for d in survival["push_direction"]])
        ax.set_yticks(range(len(survival["push_time"])), [f"{t:g}" for t in survival["push_time"]])
        ax.set_xlabel("push direction (0° forward, 90° left)")
        ax.set_ylabel("push time [s]")
        ax.set_title(f"largest pelvis push survived [N], stabilizer {'on' if on else 'off'}")
        fig.colorbar(image, ax=ax)
    write_figure(fig, files["png"])
    return files
