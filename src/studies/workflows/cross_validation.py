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

from . import manoeuvring as _manoeuvring

__all__ = ["CV_QUANTITIES", "cross_validate", "cv_table_markdown"]

#: characteristics reported per held-out record (prediction minus measurement)
CV_QUANTITIES = ("rmse_position", "advance_error_pct", "tactical_diameter_error_pct",
                 "steady_speed_error_pct", "steady_yaw_rate_error_pct", "overshoot1_error_deg",
                 "overshoot2_error_deg")
_HEADINGS = {"rmse_position": "RMSE position [m]", "advance_error_pct": "advance [%]",
             "tactical_diameter_error_pct": "tactical diameter [%]",
             "steady_speed_error_pct": "speed in turn [%]", "steady_yaw_rate_error_pct": "yaw rate in turn [%]",
             "overshoot1_error_deg": "1st overshoot [deg]", "overshoot2_error_deg": "2nd overshoot [deg]"}


def cross_validate(run, identify, out_dir: Path) -> tuple[pd.DataFrame, dict]:
    """Hold each training record of ``run`` out in turn; ``(table, metrics)``.

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

    Returns
    -------
    table : pandas.DataFrame
        Columns ``record``, ``quantity``, ``value`` (the quantities of
        :data:`CV_QUANTITIES` each record has: a zig-zag has no advance).
    metrics : dict
        ``cv/<record>/<quantity>``, ``cv/median_abs/<quantity>`` and
        ``cv/folds``.
    """
    rows, metrics = [], {}
    records = list(run.records)
    for i, held in enumerate(records):
        name = str(held.attrs.get("name", f"record_{i}"))
        others = records[:i] + records[i + 1:]
        fold = dataclasses.replace(run, records=others, validation_records=[held])
        fold.modules = run.modules
        result, modules, _ = identify(fold)
        fold.modules = modules
        params = {n: result.params[n] for n in run.model.names}
        fold_dir = Path(out_dir) / "cross_validation" / name
        fold_dir.mkdir(parents=True, exist_ok=True)
        found = _manoeuvring._validate_records(fold, params, fold_dir)
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
    return table, metrics


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
