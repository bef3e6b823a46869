"""Leave-one-record-out cross-validation of an MMG identification (``model.cross_validate``).

Each training record is held out in turn: the model is identified from the
others with the run's own settings (method, prior, interaction factors,
weights) and the held-out record is replayed with its measured rudder and
propeller rate from its first state, as a validation record is
(:func:`studies.workflows.manoeuvring._validate_records`). Nothing of the
held-out record enters its own prediction, so the table says how the
identification does on a record it has not seen, for every record; with
records of two facilities (HSVA's zig-zags and MARIN's runs, Froude scaled
to one scale) it is the cross-facility check.

Outputs: ``cross_validation.csv`` (record, quantity, value), a Markdown
table ``cross_validation.md`` (one row per held-out record: whole-record
position RMSE, turning-circle advance and tactical diameter, speed and yaw
rate in the steady turn, zig-zag overshoots, prediction minus measurement),
the plots and tables of each fold under ``cross_validation/<record>/`` and
the metrics ``cv/<record>/<quantity>`` with ``cv/median_abs/<quantity>``
over the records that have it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from . import manoeuvring as _manoeuvring
from .band_calibration import held_out_bands

__all__ = ["CV_QUANTITIES", "cross_validate", "cv_table_markdown"]

#: characteristics reported per held-out record (prediction minus measurement); a zig-zag's
#: overshoots both replayed with its measured rudder and run again by the model as the test
#: was run (``closed_loop/``: the rudder reversed when the model's heading reaches the
#: record's execute heading)
CV_QUANTITIES = ("rmse_position", "advance_error_pct", "tactical_diameter_error_pct",
                 "steady_speed_error_pct", "steady_yaw_rate_error_pct", "overshoot1_error_deg",
                 "overshoot2_error_deg", "closed_loop/overshoot1_error_deg",
                 "closed_loop/overshoot2_error_deg")
_HEADINGS = {"rmse_position": "RMSE position [m]", "advance_error_pct": "advance [%]",
             "tactical_diameter_error_pct": "tactical diameter [%]",
             "steady_speed_error_pct": "speed in turn [%]", "steady_yaw_rate_error_pct": "yaw rate in turn [%]",
             "overshoot1_error_deg": "1st overshoot [deg]", "overshoot2_error_deg": "2nd overshoot [deg]",
             "closed_loop/overshoot1_error_deg": "1st overshoot, run as the test [deg]",
             "closed_loop/overshoot2_error_deg": "2nd overshoot, run as the test [deg]"}


def _fold(run, i: int, identify, out_dir: Path, band_draws: int, seed: int):
    """Record ``i`` of ``run`` held out: ``(name, validation metrics, band rows, PITs)``."""
    records = list(run.records)
    held = records[i]
    name = str(held.attrs.get("name", f"record_{i}"))
    fold = dataclasses.replace(run, records=records[:i] + records[i + 1:], validation_records=[held])
    fold.modules = run.modules
    result, modules, _ = identify(fold)
    fold.modules = modules
    params = {n: result.params[n] for n in run.model.names}
    fold_dir = out_dir / "cross_validation" / name
    fold_dir.mkdir(parents=True, exist_ok=True)
    found = _manoeuvring._validate_records(fold, params, fold_dir)
    if band_draws > 0 and getattr(result, "samples", None):
        rmse = found.get(f"{name}/rmse_position", float("nan"))
        found_rows, pit = held_out_bands(fold, result, held, rmse, band_draws, seed,
                                         steer=run.cfg.validate.band_replay == "steered")
        return name, found, found_rows, pit
    return name, found, [], {}


def cross_validate(run, identify, out_dir: Path, band_draws: int = 0, seed: int = 0,
                   jobs: int = 1) -> tuple[pd.DataFrame, dict, tuple | None]:
    """Hold each training record of ``run`` out in turn; ``(table, metrics, bands)``.

    Parameters
    ----------
    run : MMGRun
        The prepared run; its training records are the folds.
    identify : callable
        ``identify(run) -> (result, modules, metrics)``, the run's own
        identification (:func:`studies.workflows.mmg.identify_mmg`).
    out_dir : Path
        The run's output folder; each fold writes under
        ``cross_validation/<record>/``.
    band_draws : int
        With posterior samples (``method=bayes``) and ``band_draws > 0``,
        each held-out record's predictive band and its coefficient-only
        baseline are judged on it
        (:func:`studies.workflows.band_calibration.held_out_bands`; zig-zags
        run by their rule with the run's ``validate.band_replay=steered``).
    seed : int
        Seed of the posterior draws and the discrepancy's realisations.
    jobs : int
        Folds identified at once (joblib processes); the results do not
        depend on it.

    Returns
    -------
    table : pandas.DataFrame
        Columns ``record``, ``quantity``, ``value`` (the quantities of
        :data:`CV_QUANTITIES` each record has: a zig-zag has no advance).
    metrics : dict
        ``cv/<record>/<quantity>``, ``cv/median_abs/<quantity>`` and
        ``cv/folds``.
    bands : tuple or None
        ``(table, pit)``: one row per record and band, and per band the
        list of the records' PIT arrays; None without posterior samples.
    """
    rows, metrics = [], {}
    band_rows, pits = [], {}
    records = list(run.records)
    n_jobs = max(1, min(int(jobs), len(records)))
    folds = Parallel(n_jobs=n_jobs)(delayed(_fold)(run, i, identify, Path(out_dir), band_draws, seed)
                                    for i in range(len(records))) if n_jobs > 1 else \
        [_fold(run, i, identify, Path(out_dir), band_draws, seed) for i in range(len(records))]
    for name, found, found_rows, pit in folds:
        band_rows += found_rows
        for band, values in pit.items():
            pits.setdefault(band, []).append(values)
        for quantity in CV_QUANTITIES:
            value = found.get(f"{name}/{quantity}")
            if value is None or not np.isfinite(value):
                continue
            rows.append({"record": name, "quantity": quantity, "value": float(value)})
            metrics[f"cv/{name}/{quantity}"] = float(value)
    table = pd.DataFrame(rows, columns=["record", "quantity", "value"])
    for quantity in CV_QUANTITIES:
        values = table.loc[table["quantity"] == quantity, "value"].to_numpy(float)
        if len(values):
            metrics[f"cv/median_abs/{quantity}"] = float(np.median(np.abs(values)))
    metrics["cv/folds"] = float(len(records))
    bands = (pd.DataFrame(band_rows), pits) if band_rows else None
    return table, metrics, bands


def cv_table_markdown(table: pd.DataFrame, title: str, scale: str) -> str:
    """One row per held-out record, one column per quantity ("–": not that kind of manoeuvre)."""
    lines = [f"# {title}", "",
             f"Each record predicted by the model identified from all the others (leave one record "
             f"out); prediction minus measurement, {scale}.", "",
             "| held-out record | " + " | ".join(_HEADINGS[q] for q in CV_QUANTITIES) + " |",
             "|---|" + "---:|" * len(CV_QUANTITIES)]
    for record, part in table.groupby("record", sort=False):
        values = dict(zip(part["quantity"], part["value"]))
        cells = [f"{values[q]:+.1f}" if q in values else "–" for q in CV_QUANTITIES]
        lines.append(f"| {record} | " + " | ".join(cells) + " |")
    medians = []
    for q in CV_QUANTITIES:
        values = table.loc[table["quantity"] == q, "value"].to_numpy(float)
        medians.append(f"{np.median(np.abs(values)):.1f}" if len(values) else "–")
    lines.append("| median of abs | " + " | ".join(medians) + " |")
    return "\n".join(lines) + "\n"
