"""The plots of the ``telecooperation`` scenario (matplotlib, no pyplot): the Fig.-7-like
body and hand positions of operator and teleoperator, force transparency, steps and delay."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure


def pelvis_positions(q: np.ndarray) -> np.ndarray:
    """(T, 3) the floating base's position from the logged ``q`` ``[quaternion (4); xyz (3); ...]``."""
    return q[:, 4:7]


def landings(time: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Times [s] where a single-support phase ends (a foot lands): phase leaves 1 or 2 for 0."""
    p = phase.reshape(-1)
    ends = np.flatnonzero((p[:-1] != 0) & (p[1:] == 0)) + 1
    return time[ends]


def plot_telecooperation(arrays: dict[str, np.ndarray], leader: str, delay: float, path: str | Path) -> None:
    """Write four panels over time: (1) like Evrard et al. 2009, Fig. 7, the x of the body
    (dashed) and of the right hand (solid) of the operator (black) and of the teleoperator
    (grey); (2) the same in y; (3) force transparency, the operator's force on the right handle
    against the external force measured at the robot's right wrist (x, z); (4) the step
    decision's error norm with its landings and the delay of each direction."""
    t = arrays["time"]
    body = pelvis_positions(arrays["q"])
    figure = Figure(figsize=(10, 11))
    axes = figure.subplots(4, 1, sharex=True)
    for i, axis_name in enumerate(("x", "y")):
        ax = axes[i]
        ax.plot(t, arrays["operator_body"][:, i], "k--", label="operator body")
        ax.plot(t, arrays["operator_hands"][:, i], "k-", label="operator right hand")
        ax.plot(t, body[:, i], "--", color="0.6", label="teleoperator body (pelvis)")
        ax.plot(t, arrays["robot_hands"][:, i], "-", color="0.6", label="teleoperator right hand")
        ax.set_ylabel(f"{axis_name} [m]")
        ax.legend(loc="upper left", fontsize=7)
    axes[0].set_title(f"telecooperation, {leader} leads, {1000 * delay:.0f} ms one way")
    ax = axes[2]
    for axis_name, style in (("x", "-"), ("z", ":")):
        k = 0 if axis_name == "x" else 2
        ax.plot(t, arrays["operator_forces"][:, k], "k" + style, label=f"operator on handle, {axis_name}")
        ax.plot(
            t,
            arrays["wrench/e_fr"][:, 3 + k],
            style,
            color="0.6",
            label=f"measured at robot wrist, {axis_name}",
        )
    ax.set_ylabel("right hand force [N]")
    ax.legend(loc="upper left", fontsize=7)
    ax = axes[3]
    ax.plot(t, np.linalg.norm(arrays["step_error"], axis=1), "k-", label="hand error in the waist frame")
    for k, landing in enumerate(landings(t, arrays["phase"])):
        ax.axvline(landing, color="0.8", lw=0.8, label="landings" if k == 0 else None)
    ax.plot(t, arrays["delay_forward"][:, 0], "b:", label="age of master data at the slave [s]")
    ax.plot(t, arrays["delay_backward"][:, 0], "r:", label="age of slave data at the master [s]")
    ax.set_ylabel("[m] / [s]")
    ax.set_xlabel("time [s]")
    ax.set_ylim(0.0, max(0.5, float(np.nanmax(np.linalg.norm(arrays["step_error"], axis=1))) * 1.1))
    ax.legend(loc="upper left", fontsize=7)
    write_figure(figure, path)
