"""Calibration of the predictive bands over many measured records, each held out in turn.

With ``method=bayes`` and ``model.cross_validate`` every training record is
held out in turn (:mod:`studies.workflows.cross_validation`): the model and
its discrepancy are identified from the others, and the held-out record is
replayed by posterior draws, twice:

- **the band**: coefficient draws and the model discrepancy
  (``method.discrepancy``), as a run's validation band;
- **the coefficient-only baseline**: the same coefficient draws without the
  discrepancy (the model taken as exact).

Per record and band (:func:`studies.analysis.bands.band_statistics`): the
share of the record inside the joint band of ``x0`` and ``y0`` at 50/80/90/95 %,
the probability integral transforms of the measurement (``pit_x0``,
``pit_y0``, ``joint_level``), the CRPS and the 90 % interval score [m], the
median 90 % half-width [m] (half the mean of the ``x0`` and ``y0`` widths)
against the point prediction's position RMSE [m] on the record (the replay
with the posterior medians: ``<record>/rmse_position`` of its validation).

Pooled (:func:`pooled`): every record counts once. Coverage at each level
is the mean of the records' coverages; the miscalibration is the mean of
``|coverage - nominal|`` over the four levels; the CRPS gain is
``1 - mean CRPS / mean CRPS of the baseline``; the width ratio is the
median over the records of half-width / RMSE. A calibrated band holds
about 90 % of the time at 90 % pooled over many records, while a single
record is nearly all or nothing (its errors are correlated over the whole
record).

Outputs: ``calibration.csv`` (one row per record and band), ``calibration.md``
(the table, the pooled figures and what they mean), ``pit.png`` (PIT
histograms of both bands) and ``calibration_pooled.png`` (coverage against
the nominal level, both bands); metrics ``calibration/<band>/...`` and
``calibration/<record>/coverage_90``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..analysis.bands import LEVELS, band_statistics, point_replay, predictive_draws
from ..analysis.metrics import position_rmse
from ..identification.discrepancy import Discrepancy
from ..plotting import pyplot
from . import measured as _measured

__all__ = ["BANDS", "TARGETS", "held_out_bands", "pooled", "calibration_markdown", "plot_pit",
           "plot_pooled", "write_band_calibration"]

#: the nominal levels as the columns name them: (level, percent), e.g. (0.9, 90) -> ``coverage_90``
PERCENT = tuple((lv, int(round(100 * lv))) for lv in LEVELS)

#: the two bands compared on every held-out record
BANDS = ("band", "coefficients_only")
_LABELS = {"band": "coefficients and discrepancy", "coefficients_only": "coefficients only (baseline)"}

#: what a calibrated default should reach, pooled over the records (issue of the calibration page):
#: 90 % coverage within (low, high); mean |coverage - nominal| at most; no record's 90 % coverage
#: below; median half-width / RMSE at most; CRPS gain over the coefficient-only band at least
TARGETS = {"coverage_90": (0.85, 0.95), "miscalibration": 0.05, "record_min_90": 0.5,
           "width_over_rmse": 1.5, "crps_gain": 0.20}


def held_out_bands(run, result, record: pd.DataFrame, rmse: float, n_draws: int,
                   seed: int = 0, steer: bool = False) -> tuple[list[dict], dict]:
    """Both bands of one held-out record; ``(rows, pit)``.

    ``run`` is the fold (its model, vessel and propeller/rudder modules),
    ``result`` its identification with posterior samples, ``rmse`` the
    position RMSE [m] of the replay with the point estimate (its validation's
    ``<record>/rmse_position``, nan when it diverged). With ``steer``
    (``validate.band_replay=steered``) a zig-zag's replays are run by its
    rule (:func:`~studies.analysis.bands.predictive_draws`), both bands and
    the point prediction whose RMSE the width is judged against (``steered``
    in the rows). ``rows`` holds one dict per band
    (:data:`BANDS`) with the record's name, ``coverage_<level>``, ``crps_m``,
    ``interval_score_m``, ``half_width_m``, ``rmse_m``, ``width_over_rmse``,
    ``diverged``; ``pit`` maps each band to its ``pit_x0``, ``pit_y0``,
    ``joint_level`` arrays.
    """
    name = str(record.attrs.get("name", "record"))
    vectors = _measured.posterior_vectors(run.model, result, n_draws, seed)
    discrepancy = Discrepancy.from_sample(result.samples.get("discrepancy"))
    modules = getattr(run, "modules", None)
    steered = False
    if steer:
        centre = np.array([result.params.get(n, 0.0) for n in run.model.names], float)
        track, steered = point_replay(run.model, centre, run.vessel, record, modules, steer)
        if steered:
            rmse = position_rmse(track, record)
    rows, pit = [], {}
    for band in BANDS:
        with_discrepancy = discrepancy if band == "band" else None
        states, diverged = predictive_draws(run.model, vectors, run.vessel, record, with_discrepancy, seed,
                                            modules=modules, steer=steer)
        stats = band_statistics(states, diverged, record, noise=True, seed=seed)
        half = 0.25 * ((stats["x0"][-1] - stats["x0"][0]) + (stats["y0"][-1] - stats["y0"][0]))
        row = {"record": name, "band": band, "discrepancy": with_discrepancy is not None,
               **{f"coverage_{pc}": stats[f"coverage_joint_{pc}"] for _, pc in PERCENT},
               "crps_m": stats["crps_xy_m"], "interval_score_m": stats["interval_score_xy_m"],
               "half_width_m": float(np.nanmedian(half)), "rmse_m": rmse,
               "diverged": stats["diverged"], "samples": len(record), "steered": steered}
        row["width_over_rmse"] = row["half_width_m"] / max(rmse, 1e-9)
        rows.append(row)
        pit[band] = {k: stats[k] for k in ("pit_x0", "pit_y0", "joint_level")}
    return rows, pit


def pooled(table: pd.DataFrame) -> dict:
    """Pooled figures per band: ``{band: {coverage_<level>, miscalibration, record_min_90,
    records_below_half, width_over_rmse, crps_m, interval_score_m, crps_gain}}`` (every
    record counts once; ``crps_gain`` is against the coefficient-only band)."""
    out = {}
    for band, part in table.groupby("band", sort=False):
        figures = {f"coverage_{pc}": float(part[f"coverage_{pc}"].mean()) for _, pc in PERCENT}
        figures["miscalibration"] = float(np.mean([abs(figures[f"coverage_{pc}"] - lv) for lv, pc in PERCENT]))
        figures["record_min_90"] = float(part["coverage_90"].min())
        figures["records_below_half"] = float(np.sum(part["coverage_90"] < 0.5))
        figures["width_over_rmse"] = float(part["width_over_rmse"].median())
        figures["crps_m"] = float(part["crps_m"].mean())
        figures["interval_score_m"] = float(part["interval_score_m"].mean())
        figures["records"] = float(len(part))
        out[band] = figures
    if "band" in out and "coefficients_only" in out:
        out["band"]["crps_gain"] = 1.0 - out["band"]["crps_m"] / max(out["coefficients_only"]["crps_m"], 1e-12)
    return out


def verdicts(figures: dict) -> list[tuple[str, str, bool]]:
    """``(what, measured, met)`` of the band against :data:`TARGETS`."""
    band = figures["band"]
    low, high = TARGETS["coverage_90"]
    out = [("pooled 90 % coverage within 0.85-0.95", f"{band['coverage_90']:.2f}",
            low <= band["coverage_90"] <= high),
           ("mean |coverage - nominal| over 50/80/90/95 % <= 0.05", f"{band['miscalibration']:.3f}",
            band["miscalibration"] <= TARGETS["miscalibration"]),
           ("no record's 90 % coverage below 0.5", f"lowest {band['record_min_90']:.2f}",
            band["record_min_90"] >= TARGETS["record_min_90"]),
           ("median 90 % half-width <= 1.5 x the point prediction's RMSE", f"{band['width_over_rmse']:.2f} x",
            band["width_over_rmse"] <= TARGETS["width_over_rmse"])]
    if "crps_gain" in band:
        out.append(("CRPS at least 20 % below the coefficient-only band", f"{100 * band['crps_gain']:.0f} % below",
                    band["crps_gain"] >= TARGETS["crps_gain"]))
    return out


def calibration_markdown(table: pd.DataFrame, figures: dict, setting: str, scale: str) -> str:
    """``calibration.md``: per record, pooled, and the verdict against :data:`TARGETS`."""
    levels = [pc for _, pc in PERCENT]
    lines = ["# Calibration of the predictive bands, each record held out in turn", "",
             f"Each record is predicted by the model and discrepancy identified from all the others ({setting}); "
             f"the joint band of x0 and y0 is judged on it at 50/80/90/95 %, {scale}. "
             "The baseline is the same coefficient draws without the discrepancy. "
             "Every record counts once in the pooled figures.", "",
             "| held-out record | " + " | ".join(f"{lv} %" for lv in levels)
             + " | baseline 90 % | CRPS [m] | baseline CRPS [m] | 90 % half-width [m] | RMSE [m] | width / RMSE |",
             "|---|" + "---:|" * (len(levels) + 6)]
    for record, part in table.groupby("record", sort=False):
        band = part[part["band"] == "band"].iloc[0]
        base = part[part["band"] == "coefficients_only"].iloc[0]
        lines.append(f"| {record} | " + " | ".join(f"{band[f'coverage_{lv}']:.2f}" for lv in levels)
                     + f" | {base['coverage_90']:.2f} | {band['crps_m']:.1f} | {base['crps_m']:.1f} | "
                     f"{band['half_width_m']:.1f} | {band['rmse_m']:.1f} | {band['width_over_rmse']:.2f} |")
    lines += ["", "## Pooled", "",
              "| band | " + " | ".join(f"{lv} %" for lv in levels)
              + " | mean abs miscalibration | lowest record at 90 % | median width / RMSE | CRPS [m] | interval score [m] |",
              "|---|" + "---:|" * (len(levels) + 5)]
    for band in BANDS:
        if band not in figures:
            continue
        f = figures[band]
        lines.append(f"| {_LABELS[band]} | " + " | ".join(f"{f[f'coverage_{lv}']:.2f}" for lv in levels)
                     + f" | {f['miscalibration']:.3f} | {f['record_min_90']:.2f} | {f['width_over_rmse']:.2f} | "
                     f"{f['crps_m']:.1f} | {f['interval_score_m']:.1f} |")
    lines += ["", "## Against the targets", ""]
    for what, value, met in verdicts(figures):
        lines.append(f"- {what}: {value}: {'met' if met else 'NOT met'}")
    band = figures["band"]
    if band["coverage_90"] < TARGETS["coverage_90"][0]:
        meaning = ("overconfident: the measured track leaves the 90 % band more often than one time in ten; "
                   "read the band as narrower than the real uncertainty")
    elif band["coverage_90"] > TARGETS["coverage_90"][1]:
        meaning = "wider than needed at 90 %: the band overstates the uncertainty"
    else:
        meaning = "calibrated at 90 % pooled over the records"
    lines += ["", f"Pooled over {int(band['records'])} records the band is {meaning}. "
              "PIT histograms (`pit.png`): flat for a calibrated band, U-shaped for an overconfident one, "
              "a hump for one wider than needed, a slope for a bias."]
    return "\n".join(lines) + "\n"


def plot_pit(pit: dict, path: Path, bins: int = 10) -> None:
    """Histograms of the PIT of ``x0``/``y0`` and of the joint level, one row per band."""
    plt = pyplot()
    bands = [b for b in BANDS if b in pit]
    fig, axes = plt.subplots(len(bands), 2, figsize=(9, 3.2 * len(bands)), squeeze=False)
    for row, band in zip(axes, bands):
        for ax, (keys, title) in zip(row, ((("pit_x0", "pit_y0"), "PIT of x0 and y0"),
                                             (("joint_level",), "level of the joint band that holds it"))):
            values = np.concatenate([np.concatenate([np.asarray(p[k]) for k in keys]) for p in pit[band]])
            ax.hist(values, bins=bins, range=(0, 1), density=True, color="tab:blue", alpha=0.7)
            ax.axhline(1.0, color="0.3", ls="--", lw=1)
            ax.set_title(f"{_LABELS[band]}: {title}", fontsize=9)
            ax.set_xlim(0, 1)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_pooled(table: pd.DataFrame, figures: dict, path: Path) -> None:
    """Pooled coverage against the nominal level, both bands, each record faint behind."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 5.0))
    ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
    levels = list(LEVELS)
    for band, color in zip(BANDS, ("tab:blue", "tab:orange")):
        if band not in figures:
            continue
        for _, row in table[table["band"] == band].iterrows():
            ax.plot(levels, [row[f"coverage_{pc}"] for _, pc in PERCENT], color=color,
                    alpha=0.15, lw=1)
        ax.plot(levels, [figures[band][f"coverage_{pc}"] for _, pc in PERCENT], "o-",
                color=color, label=f"{_LABELS[band]}, pooled")
    ax.set_xlim(0.4, 1.0)
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel("nominal level of the joint band")
    ax.set_ylabel("share of the held-out record inside")
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_band_calibration(bands: tuple, out_dir: Path, setting: str, scale: str) -> dict:
    """Write ``calibration.csv``, ``calibration.md``, ``pit.png`` and
    ``calibration_pooled.png`` from :func:`held_out_bands`' rows and PITs
    gathered over the folds; the metrics ``calibration/<band>/<figure>`` and
    ``calibration/<record>/coverage_90``."""
    table, pit = bands
    out_dir = Path(out_dir)
    table.to_csv(out_dir / "calibration.csv", index=False)
    figures = pooled(table)
    (out_dir / "calibration.md").write_text(calibration_markdown(table, figures, setting, scale))
    plot_pit(pit, out_dir / "pit.png")
    plot_pooled(table, figures, out_dir / "calibration_pooled.png")
    metrics = {f"calibration/{band}/{key}": float(value) for band, found in figures.items()
               for key, value in found.items()}
    for _, row in table[table["band"] == "band"].iterrows():
        metrics[f"calibration/{row['record']}/coverage_90"] = float(row["coverage_90"])
    return metrics
