"""The figure of the ``gain_sweep`` study: the right hand of ``reach`` over its task's gain
(matplotlib, no pyplot)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure
from drake_sot.studies.description import Study


def write_figures(study: Study, rows: Mapping[str, Mapping[str, Any]], out: Path) -> dict[str, Path]:
    """``<name>.png``: from the table's ``rows`` (the runs done, ok), the settling time [s] and
    the right hand's error at the end [m] over λ [1/s] (log scale)."""
    done = sorted(
        (row["rh_gain"], row["rh_settle_time"], row["final_error/taskRH"])
        for row in rows.values()
        if row["status"] == "ok"
    )
    gain, settle, error = (
        (np.array(column, dtype=float) for column in zip(*done, strict=True)) if done else ([],) * 3
    )
    fig = Figure(figsize=(10, 4.2), dpi=110, layout="tight")
    left, right = fig.subplots(1, 2, sharex=True)
    left.plot(gain, settle, "o-")
    left.set_ylabel("settling time within 1 cm [s] (none: not settled)")
    right.semilogy(gain, error, "o-")
    right.set_ylabel("right-hand error at the end [m]")
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_xlabel("λ of taskRH [1/s]")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"{study.name}: reach's right hand over its gain")
    files = {"png": out / f"{study.name}.png"}
    write_figure(fig, files["png"])
    return files
