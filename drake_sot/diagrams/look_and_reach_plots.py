"""The plot of the ``look_and_reach`` scenario: the object in the camera image, and the hand's
distance to it (matplotlib, no pyplot)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from drake_sot.diagrams.artifacts import write_figure
from drake_sot.plots import mark_event

#: Half-width of the image-centre box drawn and checked (5 % in normalised image coordinates).
CENTRE_BOX = 0.05


def plot_look_and_reach(
    time: np.ndarray,
    image: np.ndarray,
    hand_distance: np.ndarray,
    *,
    converged_after: float,
    reach_at: float,
    path: str | Path,
) -> None:
    """Write the image-plane track of the object (the 5 % box around the centre drawn), x(t)
    and y(t), and the right hand's distance to the object.

    Args:
        time: (T,) [s]. image: (T, 2) normalised image coordinates (X/Z, Y/Z).
        hand_distance: (T,) [m].
        converged_after: the time [s] after which the gaze is expected in the box.
        reach_at: when the reaching task was pushed [s].
        path: the PNG to write.
    """
    fig = Figure(figsize=(13, 6), dpi=110, layout="tight")
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.5))
    plane = fig.add_subplot(grid[:, 0])
    early, late = time < converged_after, time >= converged_after
    box = CENTRE_BOX * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]])
    plane.fill(*box.T, color="0.9", edgecolor="0.5", label="5 % of the image centre")
    plane.plot(*image[early].T, color="C1", linewidth=0.8, label=f"t < {converged_after:g} s (converging)")
    plane.plot(*image[late].T, color="C0", linewidth=0.8, label=f"t ≥ {converged_after:g} s")
    plane.invert_yaxis()  # image y points down
    plane.set_aspect("equal")
    plane.set_xlabel("x = X/Z (image right)")
    plane.set_ylabel("y = Y/Z (image down)")
    plane.set_title("the object in the head camera")
    plane.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), fontsize=8)
    coords = fig.add_subplot(grid[0, 1])
    coords.axhspan(-CENTRE_BOX, CENTRE_BOX, color="0.9")
    coords.plot(time, image[:, 0], label="x")
    coords.plot(time, image[:, 1], label="y")
    lim = max(3 * CENTRE_BOX, float(np.abs(image[late]).max(initial=0.0)) * 1.2)
    coords.set_ylim(-lim, lim)
    coords.set_ylabel("image coordinate")
    coords.legend(loc="upper right", fontsize=8)
    coords.grid(True, alpha=0.3)
    distance = fig.add_subplot(grid[1, 1], sharex=coords)
    distance.plot(time, 100 * hand_distance, color="C2")
    distance.set_ylabel("right hand to object [cm]")
    distance.set_xlabel("time [s]")
    distance.grid(True, alpha=0.3)
    for ax in (coords, distance):
        ax.axvspan(time[0], converged_after, color="0.95")
        mark_event(ax, reach_at, "push taskRH", fontsize=7)
    coords.text(time[0], -0.9 * lim, " converging", fontsize=7, color="0.3")
    write_figure(fig, path)
