"""The predictive bands of an experiment's runs, pooled: are they calibrated?

Every ``method=bayes`` run with validation records logs, per record, the
share of the record that its 50/80/90/95 % predictive bands hold
(``<record>/band/coverage_joint_<level>`` for a manoeuvre: the joint band of
``x0`` and ``y0``; ``<record>/band/coverage_<level>`` for a roll decay:
``phi(t)``), the band's width and the verdict ``trusted``
(:mod:`studies.analysis.bands`). One record's coverage is close to all or
nothing, because a prediction's errors are correlated over the whole record;
calibration is judged over many records. This module gathers those numbers
from the store into one table, pools them per model and discrepancy setting
(the model taken as exact, or with ``method.discrepancy``), draws coverage
against the nominal level and says in words what the pooled coverage means.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..analysis.bands import LEVELS as NOMINAL
from ..analysis.bands import TRUSTED_COVERAGE as CALIBRATED
from ..plotting import pyplot

__all__ = ["LEVELS", "KINDS", "band_rows", "pooled_calibration", "plot_calibration", "calibration_sentences"]

#: nominal levels of the bands [%], as the metrics name them (``coverage_joint_90``, ...)
LEVELS = tuple(int(round(100 * level)) for level in NOMINAL)

#: the two kinds of band: the banded quantity, its unit and its metric names after ``<record>/band/``
#: (:mod:`studies.analysis.bands` for a manoeuvre, :mod:`studies.roll.bands` for a roll decay)
KINDS = (
    {"what": "track (x0, y0), joint band", "unit": "m", "coverage": "coverage_joint_{}",
     "width": "width_xy_m", "width_over_extent": "width_over_extent",
     "interval_score": "interval_score_xy_m", "crps": "crps_xy_m"},
    {"what": "roll angle phi(t)", "unit": "deg", "coverage": "coverage_{}",
     "width": "width_deg", "width_over_extent": "width_over_amplitude",
     "interval_score": "interval_score_deg", "crps": "crps_deg"},
)


def _records(metrics: dict) -> list[str]:
    return sorted({k.split("/band/")[0] for k in metrics if "/band/" in k})


def _kind(metrics: dict, record: str) -> dict | None:
    """The kind of band (:data:`KINDS`) a record's metrics describe; None without bands."""
    return next((kind for kind in KINDS
                 if f"{record}/band/" + kind["coverage"].format(90) in metrics), None)


def band_rows(items: list[dict]) -> pd.DataFrame:
    """One row per finished run and validation record with predictive bands.

    ``items`` are the report's run summaries (``run``, ``method``,
    ``condition``, ``metrics``, ``status``). Columns: run, condition,
    method, model, record, what (the banded quantity), unit (of the widths
    and scores: ``m`` of ``x0``/``y0``, ``deg`` of roll), discrepancy (bool),
    coverage_<level> for :data:`LEVELS` (shares 0-1), width (mean 90 %
    width), width_over_extent, covered_until_s, interval_score, crps,
    outside_training, trusted.
    """
    rows = []
    for item in items:
        if item["status"] != "FINISHED":
            continue
        m = item["metrics"]
        for record in _records(m):
            kind = _kind(m, record)
            if kind is None:
                continue

            def get(name, record=record):
                return float(m.get(f"{record}/band/{name}", np.nan))
            row = {"run": item["run"].name, "condition": item["condition"], "method": item["method"],
                   "model": str(item["run"].params.get("model.name", "")), "record": record,
                   "what": kind["what"], "unit": kind["unit"], "discrepancy": get("discrepancy") == 1.0}
            for level in LEVELS:
                row[f"coverage_{level}"] = get(kind["coverage"].format(level))
            for column in ("width", "width_over_extent", "interval_score", "crps"):
                row[column] = get(kind[column])
            row.update({"covered_until_s": get("covered_until_s"), "outside_training": get("outside_training"),
                        "trusted": get("trusted") == 1.0})
            rows.append(row)
    return pd.DataFrame(rows)


def pooled_calibration(rows: pd.DataFrame) -> pd.DataFrame:
    """Mean coverage per nominal level over the records, per banded quantity,
    model and discrepancy setting; with the number of records, how many of them
    have a 90 % coverage within :data:`CALIBRATED`, and the mean 90 % width."""
    out = []
    for (what, model, disc), group in rows.groupby(["what", "model", "discrepancy"], sort=True):
        row = {"what": what, "unit": group["unit"].iloc[0], "model": model, "discrepancy": disc,
               "records": len(group)}
        for level in LEVELS:
            row[f"coverage_{level}"] = float(group[f"coverage_{level}"].mean())
        c90 = group["coverage_90"]
        row["records_within"] = int(((c90 >= CALIBRATED[0]) & (c90 <= CALIBRATED[1])).sum())
        row["width"] = float(group["width"].mean())
        row["width_over_extent"] = float(group["width_over_extent"].mean())
        row["trusted"] = int(group["trusted"].sum())
        out.append(row)
    return pd.DataFrame(out)


def _setting(disc: bool, model: str = "") -> str:
    name = f"model={model}" if model else "the model"
    return f"{name} with its discrepancy" if disc else f"{name} taken as exact"


def plot_calibration(rows: pd.DataFrame, pooled: pd.DataFrame, path: Path) -> None:
    """Coverage against nominal level: each record a thin line, the pooled
    mean of each setting a thick one, the diagonal a calibrated band."""
    plt = pyplot()
    kinds = list(pooled["what"].unique())
    fig, axes = plt.subplots(1, len(kinds), figsize=(max(6.5, 5.5 * len(kinds)), 5.0), squeeze=False)
    nominal = np.array(LEVELS) / 100.0
    settings = sorted({(p["model"], p["discrepancy"]) for _, p in pooled.iterrows()})
    colours = {k: f"C{i}" for i, k in enumerate(settings)}
    for ax, what in zip(axes[0], kinds):
        ax.plot([0, 1], [0, 1], color="0.5", lw=1, ls="--", label="calibrated")
        ax.axhspan(*CALIBRATED, xmin=0.88, xmax=0.92, color="0.85")
        for _, r in rows[rows["what"] == what].iterrows():
            ax.plot(nominal, [r[f"coverage_{lv}"] for lv in LEVELS],
                    color=colours[(r["model"], r["discrepancy"])], lw=0.8, alpha=0.35)
        for _, p in pooled[pooled["what"] == what].iterrows():
            ax.plot(nominal, [p[f"coverage_{lv}"] for lv in LEVELS],
                    color=colours[(p["model"], p["discrepancy"])], lw=2.5, marker="o",
                    label=f"{_setting(p['discrepancy'], p['model'])} (mean of {p['records']})")
        ax.set_xlim(0.4, 1.0)
        ax.set_ylim(0.0, 1.02)
        ax.set_xlabel("nominal level of the band")
        ax.set_ylabel("share of the record inside the band")
        ax.set_title(what)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    fig.suptitle("Calibration of the predictive bands (thin lines: one validation record each)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def calibration_sentences(pooled: pd.DataFrame) -> list[str]:
    """One sentence per banded quantity and setting: can the bands be trusted here?"""
    out = []
    for _, p in pooled.iterrows():
        c90 = p["coverage_90"]
        if c90 < CALIBRATED[0]:
            verdict = ("overconfident: the measurement leaves the 90 % band more often than one time in "
                       "ten, so the band understates the prediction's error on this data")
        elif c90 > CALIBRATED[1]:
            verdict = ("conservative: the measurement almost never leaves the 90 % band, which is wider "
                       "than the errors on this data need")
        else:
            verdict = "calibrated at the 90 % level on these records"
        if p["width_over_extent"] >= 1.0:
            verdict += "; but wider than the manoeuvre itself, so of no use for prediction"
        records = f"{p['records']} validation record" + ("s" if p["records"] != 1 else "")
        out.append(f"{p['what']}, {_setting(p['discrepancy'], p['model'])}: over {records} the "
                   f"90 % band holds the measurement {100 * c90:.0f} % of the time on average "
                   f"({p['records_within']} of {p['records']} records within "
                   f"{100 * CALIBRATED[0]:.0f}-{100 * CALIBRATED[1]:.0f} %, {p['trusted']} trusted by their "
                   f"own verdict), mean width {p['width']:.3g} {p['unit']} ({100 * p['width_over_extent']:.0f} % of "
                   f"the manoeuvre): {verdict}.")
    return out
