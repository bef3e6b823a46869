"""Reading a paper's runs back from the store, shared by the reproduction pages."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["latest_coefficients"]


def latest_coefficients(runs: list, scratch: Path, column: str, methods=("ls", "svm"),
                        keep=lambda run: True) -> dict:
    """``{(method, coefficient): value}`` from ``coefficients.csv`` (its ``column``: ``value`` or
    ``deviation_pct``) of the latest finished run of each of ``methods`` that ``keep`` accepts;
    empty when there is none."""
    latest = {}
    for run in runs or []:
        method = run.params.get("method.name")
        if run.status == "FINISHED" and method in methods and keep(run) and \
                (method not in latest or run.start_time > latest[method].start_time):
            latest[method] = run
    found = {}
    for method, run in latest.items():
        local = run.artifact("coefficients.csv", Path(scratch) / run.run_id)
        if local is not None:
            for row in pd.read_csv(local).to_dict("records"):
                found[(method, row["name"])] = float(row[column])
    return found
