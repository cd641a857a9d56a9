"""Plots of a run (matplotlib, no display needed)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


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
        ax.text(
            t,
            1.0,
            f" {label}",
            transform=ax.get_xaxis_transform(),
            rotation=90,
            va="top",
            ha="left",
            fontsize=8,
            color="0.3",
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("task error norm ‖e‖ (m, rad)")
    ax.set_title(title or "task errors")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


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
    """Top view (footprints, ZMP reference, measured ZMP, CoM) and x(t), y(t) with the
    support polygon's extent shaded.

    Args:
        time: (T,) [s]. zmp_ref, zmp: (T, 2) [m]. com_ref, com: (T, ≥2) [m] (reference, measured).
        polygons: T support polygons (k, 2) of the soles in contact.
        footprints: planned sole rectangles (4, 2) to draw on the top view.
        path: the PNG to write.
    """
    fig = plt.figure(figsize=(13, 6), dpi=110)
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
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_interaction(
    time: np.ndarray,
    measured: Mapping[str, np.ndarray],
    applied: Mapping[str, np.ndarray],
    displacement: Mapping[str, np.ndarray],
    events: Sequence[tuple[float, str]],
    path: str | Path,
) -> None:
    """Per hand: forces (measured at the wrist sensor, applied by the partner) and the
    hand's displacement, x/y/z over time.

    Args:
        time: (T,) [s]. measured, applied, displacement: hand name → (T, 3) [N, N, m].
        events: ``(time, label)`` to mark. path: the PNG to write.
    """
    hands = list(measured)
    fig, axes = plt.subplots(2, len(hands), figsize=(6 * len(hands), 7), dpi=110, sharex=True, squeeze=False)
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
                ax.axvline(t, color="0.5", linestyle=":", linewidth=0.8)
                ax.text(
                    t, 1.0, f" {label}", transform=ax.get_xaxis_transform(), fontsize=7, va="top", color="0.3"
                )
        force_ax.legend(loc="lower left", fontsize=7, ncol=2)
        disp_ax.legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_priority_switch(
    time: np.ndarray, alphas: Mapping[str, np.ndarray], errors: Mapping[str, np.ndarray], path: str | Path
) -> None:
    """Priority parameters (top) and task error norms (bottom) over time (paper 004 fig. 10)."""
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6), dpi=110, sharex=True)
    for name, values in alphas.items():
        top.plot(time, values, label=name)
    top.set_ylabel("α")
    top.set_ylim(-0.05, 1.05)
    top.legend(loc="center right", fontsize=8)
    for name, values in errors.items():
        bottom.plot(time, 100 * values, label=name)
    bottom.set_ylabel("task error ‖e‖ [cm]")
    bottom.set_xlabel("time [s]")
    bottom.legend(loc="upper right", fontsize=8)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_alpha_sweep(grid: np.ndarray, head: np.ndarray, lh: np.ndarray, path: str | Path) -> None:
    """Heat maps of the steady head and left-hand errors over (α_lh,head rows, α_head,lh columns)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), dpi=110)
    for ax, values, title in (
        (axes[0], head, "head task error [cm]"),
        (axes[1], lh, "left-hand task error [cm]"),
    ):
        image = ax.imshow(
            100 * values,
            origin="lower",
            cmap="viridis",
            aspect="auto",
            extent=(grid[0] - 0.1, grid[-1] + 0.1, grid[0] - 0.1, grid[-1] + 0.1),
        )
        for i, a in enumerate(grid):
            for j, b in enumerate(grid):
                ax.text(b, a, f"{100 * values[i, j]:.1f}", ha="center", va="center", fontsize=7, color="w")
        ax.set_xlabel("α_head,lh")
        ax.set_ylabel("α_lh,head")
        ax.set_title(title)
        fig.colorbar(image, ax=ax)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


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
    """Paper 004 figures 4-7 in one page: α (top), desired and measured hand force, CoM and
    hand position errors, and the squared sum of joint torques τᵀτ."""
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), dpi=110, sharex=True)
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
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
