"""An identified MMG model against captive tests: forces at the tests' drift and rudder angles.

For each captive test (static drift, rudder angle, or both; yaw rate zero)
the model's total force is the hull terms at ``v' = -sin(beta)``, ``r' = 0``
plus the propeller and rudder modules at the test's speed, rudder angle and
propeller rate, on the model-scale vessel; it is made non-dimensional like
the captive table (:mod:`studies.data.captive`: over ``0.5 rho L^2 U^2``,
moment over ``0.5 rho L^3 U^2``) and set beside the measured ``X', Y', N'``.
The summary is the RMSE of each prime per test type, also as a fraction of
the measured range of that prime over the tests.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..data.captive import captive_motion
from ..models.abkowitz import ManoeuvringModel
from ..models.mmg import HULL_TERMS, MMGParameters, hull_forces, hull_primes, module_constants, module_forces
from ..plotting import pyplot

__all__ = ["captive_forces", "captive_comparison", "plot_captive"]


def captive_forces(model: ManoeuvringModel, values: dict, vessel, modules: MMGParameters,
                   tests: pd.DataFrame) -> np.ndarray:
    """Model primes ``(X', Y', N')`` (k, 3) at the tests' conditions (captive scaling).

    ``vessel`` at the scale of the tests; ``tests`` as read by
    :func:`studies.data.captive.read_captive`.
    """
    m = captive_motion(tests)
    speed = m["U"]
    names = set(model.names)
    hull = tuple(float(values.get(n, 0.0)) if n in names else 0.0 for n, *_ in HULL_TERMS)
    xh, yh, nh = hull_forces(*hull_primes(m["u"], m["v"], m["r"], m["delta"], m["n"], vessel, modules).T, hull)
    xm, ym, nm = module_forces(m["u"], m["v"], m["r"], m["delta"], m["n"], module_constants(vessel, modules))
    qd = 0.5 * vessel.rho * vessel.length * vessel.draught * speed ** 2
    q2 = 0.5 * vessel.rho * vessel.length ** 2 * speed ** 2
    return np.column_stack([(qd * xh + xm) / q2, (qd * yh + ym) / q2,
                            (qd * vessel.length * nh + nm) / (q2 * vessel.length)])


def captive_comparison(models: dict, vessel, tests: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Measured and predicted primes of every test, and a summary per model and test type.

    Parameters
    ----------
    models : dict
        ``{label: (model, values, modules)}``, e.g. the identified and the
        published coefficients.

    Returns
    -------
    (table, summary)
        ``table``: one row per test with ``beta_deg, delta_deg, test`` and
        ``X, Y, N`` measured and ``<label>_X`` ... predicted; ``summary``:
        ``model, test, quantity, rmse, rmse_pct_of_range`` (test ``all`` over
        every test).
    """
    table = pd.DataFrame({"test": tests["test"], "beta_deg": np.rad2deg(tests["beta"]),
                          "delta_deg": np.rad2deg(tests["delta"]), "speed": tests["speed"],
                          "n": tests["n"], "X": tests["X"], "Y": tests["Y"], "N": tests["N"]})
    rows = []
    for label, (model, values, modules) in models.items():
        pred = captive_forces(model, values, vessel, modules, tests)
        for j, q in enumerate("XYN"):
            table[f"{label}_{q}"] = pred[:, j]
        for kind in ["all"] + sorted(table["test"].unique()):
            sel = np.ones(len(table), bool) if kind == "all" else (table["test"] == kind).to_numpy()
            for j, q in enumerate("XYN"):
                meas = table[q].to_numpy(float)[sel]
                err = pred[sel, j] - meas
                span = float(np.ptp(table[q].to_numpy(float))) or 1.0
                rmse = float(np.sqrt(np.mean(err ** 2)))
                rows.append({"model": label, "test": kind, "quantity": q, "rmse": rmse,
                             "rmse_pct_of_range": 100.0 * rmse / span})
    return table, pd.DataFrame(rows)


def plot_captive(table: pd.DataFrame, labels, path, title: str) -> None:
    """Measured against predicted ``X', Y', N'`` of every test, one panel per prime."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.5))
    markers = {"drift angle": "o", "rudder angle": "s", "drift + rudder angle": "^"}
    colours = ["tab:blue", "tab:orange", "tab:green"]
    for ax, q in zip(axes, "XYN"):
        meas = table[q].to_numpy(float)
        for c, label in zip(colours, labels):
            for kind, m in markers.items():
                sel = (table["test"] == kind).to_numpy()
                if sel.any():
                    ax.scatter(meas[sel], table[f"{label}_{q}"].to_numpy(float)[sel], s=14, marker=m,
                               color=c, alpha=0.7, label=f"{label}, {kind}" if q == "X" else None)
        lo, hi = float(np.min(meas)), float(np.max(meas))
        ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
        ax.set_xlabel(f"measured {q}'")
        ax.set_ylabel(f"model {q}'")
        ax.set_title(f"{q}' (over 0.5 rho L^{2 if q != 'N' else 3} U^2)")
    axes[0].legend(fontsize=6)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
