"""The figures of ``studies report``, one function per figure.

Each takes the tables the page shows and the PNG path to write; they are
module-level functions of plain arguments, so that the report's figures can
be drawn by worker processes (:class:`studies.plotting.Drawer`) while the
page is assembled. Only numpy, pandas and matplotlib are imported here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..plotting import pyplot, readable_ticks, thinned, thinned_track
from .tables import condition_label, method_label

__all__ = ["plot_fitness", "plot_mae", "plot_overlays"]


def plot_fitness(table: pd.DataFrame, key: str | None, manoeuvre: str, path: Path,
                  diverged: pd.DataFrame | None = None) -> None:
    """Fitness against the condition per method (log scale); a red cross at
    the bottom marks a cell with diverged runs (left out of the mean)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    labels = [condition_label(key, c) for c in table.index]
    x = np.arange(len(labels))
    for method in table.columns:
        ax.plot(x, table[method].to_numpy(float), marker="o", label=method_label(method))
    if diverged is not None and diverged.to_numpy().sum() > 0:
        marked = x[(diverged.reindex(table.index).fillna(0).to_numpy() > 0).any(axis=1)]
        ax.plot(marked, np.full(len(marked), 0.02), "rx", ms=10, transform=ax.get_xaxis_transform(),
                label="diverged run(s), left out")
    ax.set_xticks(x, labels)
    ax.set_yscale("log")
    readable_ticks(ax)
    ax.set_xlabel(key or "condition")
    ax.set_ylabel("fitness (eq. 3.43)")
    ax.set_title(f"System performance: {manoeuvre}")
    ax.legend(fontsize=8)
    # margins set once (a layout engine draws the figure twice)
    longest = max((len(str(label)) for label in labels), default=1)
    fig.subplots_adjust(left=0.15, right=0.97, top=0.9, bottom=min(0.4, 0.12 + 0.012 * max(0, longest - 8)))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_mae(table: pd.DataFrame, diverged: pd.DataFrame, key: str | None, path: Path) -> None:
    """Li et al. Fig. 10: grouped bars of the MAE over bounded predictions per
    condition and series; the number of diverged predictions above each bar
    in red, a red cross where every prediction diverged."""
    plt = pyplot()
    labels = [condition_label(key, c) for c in table.index]
    x = np.arange(len(labels))
    width = 0.8 / max(1, len(table.columns))
    fig, ax = plt.subplots(figsize=(max(6.5, 0.9 * len(labels) * max(1, len(table.columns)) / 2), 4.5))
    for k, series in enumerate(table.columns):
        pos = x - 0.4 + width * (k + 0.5)
        values = table[series].to_numpy(float)
        counts = diverged[series].to_numpy(float)
        ax.bar(pos, np.nan_to_num(values, nan=0.0), width, label=method_label(series))
        for p, v, n in zip(pos, values, counts):
            if not np.isfinite(v):
                ax.plot(p, 0.02, "rx", ms=9, transform=ax.get_xaxis_transform())
                ax.text(p, 0.06, f"all {n:g} div.", color="red", fontsize=7, ha="center", va="bottom",
                        rotation=90, transform=ax.get_xaxis_transform())
            elif n > 0:
                ax.annotate(f"{n:g} div.", (p, v), color="red", fontsize=7, ha="center", va="bottom",
                            rotation=90)
    ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("MAE of u, v over bounded predictions [m/s]")
    ax.set_title("Validation MAE of speeds (red: diverged predictions, counted)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_overlays(curves: dict, title: str, path: Path) -> None:
    """Trajectory and u, v, r of the reference and every method's prediction."""
    plt = pyplot()
    fig = plt.figure(figsize=(12, 6))
    grid = fig.add_gridspec(3, 2, left=0.07, right=0.98, bottom=0.09, top=0.91, wspace=0.2, hspace=0.3)
    ax_traj = fig.add_subplot(grid[:, 0])
    axes = [fig.add_subplot(grid[i, 1]) for i in range(3)]
    first = next(iter(curves.values()))
    ax_traj.plot(*thinned_track(first["reference_y0"], first["reference_x0"]), "k", lw=2, label="reference")
    for ax, col, unit in zip(axes, ("u", "v", "r"), ("m/s", "m/s", "deg/s")):
        k = 180 / np.pi if col == "r" else 1.0
        ax.plot(*thinned(first["t"], first[f"reference_{col}"] * k), "k", lw=2)
        ax.set_ylabel(f"{col} [{unit}]")
    for method, table in curves.items():
        ax_traj.plot(*thinned_track(table["predicted_y0"], table["predicted_x0"]), label=method_label(method))
        for ax, col in zip(axes, ("u", "v", "r")):
            k = 180 / np.pi if col == "r" else 1.0
            ax.plot(*thinned(table["t"], table[f"predicted_{col}"] * k))
    axes[-1].set_xlabel("t [s]")
    ax_traj.set_xlabel("y0 (east) [m]")
    ax_traj.set_ylabel("x0 (north) [m]")
    ax_traj.set_aspect("equal", adjustable="datalim")
    ax_traj.legend(fontsize=8)
    fig.suptitle(title)
    fig.savefig(path, dpi=85)
    plt.close(fig)
