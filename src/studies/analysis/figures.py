"""Run figures: trajectory and velocity overlays, coefficient deviations.

Every function returns nothing and writes one PNG; matplotlib uses the
non-interactive Agg backend (:func:`studies.plotting.pyplot`) so it works on
machines without a screen.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..plotting import pyplot, thinned, thinned_track

__all__ = ["plot_overlay", "plot_deviations"]


def plot_overlay(records: dict, path: str | Path, title: str) -> None:
    """Trajectory (y0 east vs x0 north) and u, v, r, psi, delta time series.

    ``records`` maps a label ("reference", "identified", ...) to a record.
    """
    plt = pyplot()
    fig = plt.figure(figsize=(12, 7))
    grid = fig.add_gridspec(3, 3, left=0.07, right=0.98, bottom=0.08, top=0.92, wspace=0.3, hspace=0.3)
    ax_traj = fig.add_subplot(grid[:, 0])
    axes = [fig.add_subplot(grid[i // 2, 1 + i % 2]) for i in range(5)]
    specs = [("u", "u [m/s]", 1.0), ("v", "v [m/s]", 1.0), ("r", "r [deg/s]", 180 / np.pi),
             ("psi", "psi [deg]", 180 / np.pi), ("delta", "delta [deg]", 180 / np.pi)]
    for label, rec in records.items():
        ax_traj.plot(*thinned_track(rec["y0"], rec["x0"]), label=label)
        for ax, (col, name, k) in zip(axes, specs):
            ax.plot(*thinned(rec["t"], rec[col] * k), label=label)
            ax.set_ylabel(name)
    ax_traj.set_xlabel("y0 (east) [m]")
    ax_traj.set_ylabel("x0 (north) [m]")
    ax_traj.set_aspect("equal", adjustable="datalim")
    ax_traj.legend(loc="best", fontsize=8)
    for ax in axes[-2:]:
        ax.set_xlabel("t [s]")
    fig.suptitle(title)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_deviations(table: pd.DataFrame, path: str | Path, title: str) -> None:
    """Bar chart of ``deviation_pct`` per coefficient (symlog axis)."""
    plt = pyplot()
    data = table.dropna(subset=["deviation_pct"])
    # the margin below the axes fits the longest rotated name (8 pt labels, about 0.6 em a
    # character), set once instead of measured by a layout engine (a second draw)
    longest = max((len(str(name)) for name in data["name"]), default=1)
    fig, ax = plt.subplots(figsize=(12, 4))
    fig.subplots_adjust(left=0.07, right=0.99, top=0.9, bottom=min(0.6, 0.08 + longest * 8 * 0.6 / 72 / 4))
    ax.bar(data["name"], data["deviation_pct"], color="tab:blue")
    ax.set_yscale("symlog", linthresh=1.0)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("deviation [%]")
    ax.set_title(title)
    ax.tick_params(axis="x", rotation=90, labelsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)
