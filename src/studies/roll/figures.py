"""Figures of the roll-decay study (PNG files).

- :func:`plot_prediction`: measured and predicted roll with the prediction
  error (Chen et al. 2019, Figs 5(b) and 8);
- :func:`plot_decay_curves`: decrement per half-cycle against mean amplitude
  (:func:`studies.roll.decay.decay_curve`), with the curves of identified models;
- :func:`plot_simulation_vs_tests`: time series and decay curves of a
  simulated decay against measured ones
  (:func:`studies.roll.comparison.compare_simulation_with_tests`);
- :func:`plot_peak_envelope`: the peak amplitude of every half-cycle against
  time, measured (points) and predicted (lines), one panel per record.

Angles are drawn in degrees; every function writes one file and returns its path.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from studies.plotting import pyplot
from studies.roll.decay import find_extrema
from studies.roll.model import damping_ratio

__all__ = ["plot_prediction", "plot_decay_curves", "plot_simulation_vs_tests", "plot_peak_envelope"]


def _figure(nrows: int, ncols: int = 1, figsize=(8.0, 6.0)):
    """A new figure with a ``nrows`` x ``ncols`` grid of axes (always 2-D)."""
    fig = pyplot().figure(figsize=figsize, constrained_layout=True)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def _save(fig, path: str) -> str:
    """Write ``fig`` as a PNG to ``path`` and release it."""
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
    return str(path)


def plot_prediction(t, measured, predictions: Mapping[str, np.ndarray], path: str,
                    title: str | None = None) -> str:
    """Prediction and error figure like Chen et al. (2019), Figs 5(b) and 8.

    Parameters
    ----------
    t : array_like
        Time [s].
    measured : array_like
        Measured roll angle [rad].
    predictions : mapping label -> array
        Predicted roll angles [rad] at ``t``.
    path : str
        PNG file to write.
    title : str, optional
        Figure title.

    Returns
    -------
    str
        ``path``.
    """
    t = np.asarray(t, float)
    meas = np.degrees(np.asarray(measured, float))
    fig, ax = _figure(2, 1, (9.0, 6.5))
    ax[0, 0].plot(t, meas, color="k", lw=1.6, label="measured")
    for lab, p in predictions.items():
        ax[0, 0].plot(t, np.degrees(np.asarray(p, float)), lw=0.9, label=lab)
        ax[1, 0].plot(t, meas - np.degrees(np.asarray(p, float)), lw=0.8, label=lab)
    ax[0, 0].set_ylabel("roll angle [deg]")
    ax[0, 0].legend(loc="upper right", fontsize=8)
    ax[0, 0].set_title("(a) measured and predicted roll" if title is None else f"(a) {title}")
    ax[1, 0].axhline(0.0, color="k", lw=0.5)
    ax[1, 0].set_xlabel("t [s]")
    ax[1, 0].set_ylabel("error = measured - predicted [deg]")
    ax[1, 0].set_title("(b) prediction error (Chen et al. 2019, eq. 19)")
    ax[1, 0].legend(loc="upper right", fontsize=8)
    return _save(fig, path)


def plot_decay_curves(curves: Mapping[str, pd.DataFrame], path: str,
                      models: Mapping[str, Mapping[str, float]] | None = None,
                      title: str | None = None) -> str:
    """Decay curves (decrement against mean amplitude, both in degrees).

    Parameters
    ----------
    curves : mapping label -> DataFrame
        Outputs of :func:`studies.roll.decay.decay_curve`.
    path : str
        PNG file to write.
    models : mapping label -> params, optional
        Identified models whose decay curve ``pi zeta_eq(A) A`` is drawn.
    title : str, optional
        Figure title.

    Returns
    -------
    str
        ``path``.
    """
    fig, ax = _figure(1, 1, (7.5, 5.0))
    a = ax[0, 0]
    amax = 0.0
    for lab, c in curves.items():
        a.plot(np.degrees(c["amplitude"]), np.degrees(c["decrement"]), "o", ms=3, label=lab)
        if len(c):
            amax = max(amax, float(c["amplitude"].max()))
    if models:
        A = np.linspace(0.0, amax if amax > 0 else math.radians(10), 100)
        for lab, p in models.items():
            a.plot(np.degrees(A), np.degrees(math.pi * damping_ratio(p, A) * A), lw=1.2, label=lab)
    a.set_xlabel("mean amplitude of the half-cycle [deg]")
    a.set_ylabel("decrement per half-cycle [deg]")
    a.set_title(title or "roll decay curves")
    a.grid(alpha=0.3)
    a.legend(fontsize=8)
    return _save(fig, path)


def plot_simulation_vs_tests(simulation, tests: Sequence, details: dict, path: str,
                             scale_note: str = "model scale", labels: Sequence[str] | None = None) -> str:
    """Figure of the simulation-vs-test comparison: time series and decay curves.

    Parameters
    ----------
    simulation : DataFrame
        Prepared simulated decay.
    tests : sequence of DataFrame
        Prepared measured decays.
    details : dict
        Second output of :func:`studies.roll.comparison.compare_simulation_with_tests`.
    path : str
        PNG file to write.
    scale_note : str
        Scale at which both are shown.
    labels : sequence of str, optional
        Names of the measured records.

    Returns
    -------
    str
        ``path``.
    """
    labels = list(labels) if labels is not None else [f"test {i + 1}" for i in range(len(tests))]
    fig, ax = _figure(2, 1, (9.0, 8.0))
    a0 = ax[0, 0]
    for lab, r in zip(labels, tests):
        a0.plot(r["t"], np.degrees(r["phi"]), lw=0.7, label=f"model test {lab}")
    a0.plot(simulation["t"], np.degrees(simulation["phi"]), lw=0.7, color="k", label="potential flow (FNPF)")
    a0.set_xlabel(f"t after release [s] ({scale_note})")
    a0.set_ylabel("roll angle [deg]")
    a0.set_title("(a) free roll decay: model tests vs inviscid simulation")
    a0.legend(fontsize=8, loc="upper right")
    a1 = ax[1, 0]
    for lab, c in zip(labels, details["curves_measured"]):
        a1.plot(np.degrees(c["amplitude"]), np.degrees(c["decrement"]), "o", ms=3, label=f"model test {lab}")
    cs = details["curve_simulation"]
    a1.plot(np.degrees(cs["amplitude"]), np.degrees(cs["decrement"]), "s", ms=3, color="k",
            label="potential flow (FNPF)")
    amax = max(float(cs["amplitude"].max()), max(float(c["amplitude"].max()) for c in details["curves_measured"]))
    A = np.linspace(0.0, amax, 100)
    for lab, p, col in (("fit, model tests", details["fit_measured"], "C3"),
                        ("fit, FNPF", details["fit_simulation"], "k")):
        a1.plot(np.degrees(A), np.degrees(math.pi * damping_ratio(p, A) * A), color=col, lw=1.2, label=lab)
    ref = details["reference_amplitude"]
    a1.axvline(math.degrees(ref), color="grey", ls="--", lw=0.8, label="reference amplitude")
    a1.set_xlabel("mean amplitude of the half-cycle [deg]")
    a1.set_ylabel("decrement per half-cycle [deg]")
    a1.set_title(f"(b) decay curves ({scale_note})")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    return _save(fig, path)


def plot_peak_envelope(panels: Sequence[tuple[str, pd.DataFrame, Mapping[str, tuple]]], path: str,
                       title: str | None = None) -> str:
    """Peak envelopes: the amplitude of every half-cycle against time, log scale.

    Parameters
    ----------
    panels : sequence of (title, record, predictions)
        One panel each (at most six are drawn): the measured record (``t``
        [s], ``phi`` [rad]; ``attrs["t_from_release"]`` [s] shifts a record
        that starts after the release) as points, and ``predictions``
        mapping a label to ``(t, phi)`` on the same time base as lines.
    path : str
        PNG file to write.
    title : str, optional
        Figure title.

    Returns
    -------
    str
        ``path``.
    """
    panels = list(panels)[:6]
    ncols = 1 if len(panels) == 1 else 2
    nrows = max(1, math.ceil(len(panels) / ncols))
    fig, axes = _figure(nrows, ncols, (7.5 if ncols == 1 else 11.0, 3.2 * nrows))
    for ax, (name, rec, preds) in zip(axes.ravel(), panels):
        shift = float(rec.attrs.get("t_from_release", 0.0))
        ex = find_extrema(rec["t"].to_numpy(float), rec["phi"].to_numpy(float), 0.0)
        ax.semilogy(ex.t + shift, np.degrees(ex.amplitude), "ko", ms=3, label="measured")
        tmax = float(rec["t"].iloc[-1])
        for label, (t, phi) in preds.items():
            t = np.asarray(t, float)
            keep = t <= tmax + 1e-9
            pe = find_extrema(t[keep], np.asarray(phi, float)[keep], 0.0)
            style = ":" if label == "other simulator" else "-"
            ax.semilogy(pe.t + shift, np.degrees(pe.amplitude), style, lw=1.3, label=label)
        ax.yaxis.set_major_formatter(lambda v, _: f"{v:g}")
        ax.yaxis.set_minor_formatter(lambda v, _: f"{v:g}" if f"{v:g}"[0] in "1235" else "")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("time after the release [s]")
        ax.set_ylabel("peak roll [deg]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title)
    return _save(fig, path)
