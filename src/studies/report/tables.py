"""Comparison tables built from stored runs (thesis Tables 4.6-4.14 layout)."""

from __future__ import annotations

import re

from collections import defaultdict

import numpy as np
import pandas as pd

from ..markdown import markdown_table

__all__ = ["condition_label", "deviation_table", "fitness_table", "winners", "markdown_table",
           "divergence_table", "speed_mae_cells", "mae_table", "mae_display", "condition_number_table"]

METHOD_ORDER = ["ls", "ls_ga", "svm", "svm_ga", "bayes", "sindy"]
METHOD_LABEL = {"ls": "LS", "ls_ga": "LS+GA", "svm": "SVM", "svm_ga": "SVM+GA",
                "bayes": "Bayes", "sindy": "SINDy"}


def method_label(method: str) -> str:
    return METHOD_LABEL.get(method, method)


def condition_label(key: str | None, value: str) -> str:
    """Readable column-group label of a condition value (``12 m/s``, ``-5 %``)."""
    if key is None:
        return str(value)
    if "," in key:
        keys = [k.strip() for k in key.split(",")]
        parts = str(value).split(" | ")
        return ", ".join(condition_label(k, v) if k != keys[0] else str(v) for k, v in zip(keys, parts))
    try:
        x = float(value)
    except (TypeError, ValueError):
        return f"{key}={value}"
    if key == "wind.speed":
        return f"{x:g} m/s"
    if key.endswith("direction"):
        return f"{x:g} deg"
    if key in ("noise.wind_speed_error", "noise.measurement"):
        return f"{100 * x:+g} %"
    return f"{key}={x:g}"


def _method_sort(methods) -> list[str]:
    known = [m for m in METHOD_ORDER if m in methods]
    return known + sorted(m for m in methods if m not in METHOD_ORDER)


_LEADING_NUMBER = re.compile(r"^\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


def condition_order(value) -> tuple:
    """Sort key of a condition or its label: by value where its parts start
    with a number (``4 m/s`` before ``12 m/s``, ``-10 %`` before ``+5 %``),
    by text otherwise; parts of a multi-key label (``a, b``) in turn."""
    key = []
    for part in str(value).split(", "):
        number = _LEADING_NUMBER.match(part)
        key.append((0, float(number.group(0)), part) if number else (1, 0.0, part))
    return tuple(key)


def _condition_sort(values) -> list[str]:
    return sorted(values, key=condition_order)


def deviation_table(entries: list[dict], column: str = "deviation_pct") -> pd.DataFrame:
    """Rows = coefficients, columns = (condition, method).

    ``entries`` holds dicts with ``condition``, ``method`` and ``table``
    (a coefficients.csv DataFrame).
    """
    frames = {}
    order = []
    for e in entries:
        t = e["table"].set_index("name")[column]
        frames[(e["condition"], e["method"])] = t
        for name in t.index:
            if name not in order:
                order.append(name)
    if not frames:
        return pd.DataFrame()
    conditions = _condition_sort({c for c, _ in frames})
    methods = _method_sort({m for _, m in frames})
    cols = [(c, m) for c in conditions for m in methods if (c, m) in frames]
    table = pd.DataFrame({col: frames[col] for col in cols}).reindex(order)
    table.columns = pd.MultiIndex.from_tuples(cols, names=["condition", "method"])
    return table


def fitness_table(runs: list[dict], manoeuvre: str) -> pd.DataFrame:
    """Rows = conditions, columns = methods, values = ``<manoeuvre>/fitness``."""
    rows = {}
    for r in runs:
        value = r["metrics"].get(f"{manoeuvre}/fitness")
        if value is not None:
            rows.setdefault(r["condition"], {})[r["method"]] = value
    if not rows:
        return pd.DataFrame()
    table = pd.DataFrame(rows).T
    table = table.reindex(index=_condition_sort(table.index), columns=_method_sort(table.columns))
    return table


def divergence_table(table: pd.DataFrame, diverged: dict) -> pd.DataFrame:
    """Counts ``{(condition, method): n}`` laid out like ``table`` (0 where none)."""
    out = pd.DataFrame(0.0, index=table.index, columns=table.columns)
    for (condition, method), n in diverged.items():
        if condition in out.index and method in out.columns:
            out.loc[condition, method] = float(n)
    return out


def speed_mae_cells(items: list[dict]) -> dict:
    """``validation/mae_speed`` of the runs gathered per (condition, method).

    ``items`` hold ``condition``, ``method`` and ``metrics``. Per cell:
    ``sum`` of the MAE [m/s] over bounded validation predictions (a run's
    mean weighted by its bounded count), ``bounded``, ``diverged`` and
    ``validated`` prediction counts over all its runs. A run logged before
    ``validation/validated`` existed counts as one prediction when none
    diverged, else as its diverged ones (its mean held the penalty).
    """
    cells = defaultdict(lambda: {"sum": 0.0, "bounded": 0.0, "diverged": 0.0, "validated": 0.0})
    for item in items:
        m = item["metrics"]
        if "validation/mae_speed" not in m and "validation/validated" not in m:
            continue
        diverged = float(m.get("validation/diverged", 0.0))
        validated = m.get("validation/validated")
        bounded = (float(validated) - diverged) if validated is not None else float(diverged == 0)
        cell = cells[(item["condition"], item["method"])]
        cell["diverged"] += diverged
        cell["validated"] += float(validated) if validated is not None else max(1.0, diverged)
        if bounded > 0 and "validation/mae_speed" in m:
            cell["sum"] += bounded * float(m["validation/mae_speed"])
            cell["bounded"] += bounded
    return dict(cells)


def mae_table(cells: dict) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Rows = conditions, columns = methods: the MAE over bounded predictions
    [m/s] (NaN where all diverged), the diverged and the validated counts."""
    conditions = _condition_sort({c for c, _ in cells})
    methods = _method_sort({m for _, m in cells})
    mae = pd.DataFrame(np.nan, index=conditions, columns=methods)
    diverged = pd.DataFrame(0.0, index=conditions, columns=methods)
    validated = pd.DataFrame(0.0, index=conditions, columns=methods)
    for (c, m), cell in cells.items():
        if cell["bounded"] > 0:
            mae.loc[c, m] = cell["sum"] / cell["bounded"]
        diverged.loc[c, m] = cell["diverged"]
        validated.loc[c, m] = cell["validated"]
    return mae, diverged, validated


def condition_number_table(items: list[dict]) -> pd.DataFrame:
    """Rows = conditions, columns = (method, DOF): the median over runs of
    ``regression/<dof>/condition_number`` (collinear, weakly excited
    regressors give large numbers and drifting coefficients)."""
    values = defaultdict(list)
    for item in items:
        for dof in ("X", "Y", "N"):
            v = item["metrics"].get(f"regression/{dof}/condition_number")
            if v is not None:
                values[(item["condition"], item["method"], dof)].append(float(v))
    if not values:
        return pd.DataFrame()
    conditions = _condition_sort({c for c, _, _ in values})
    methods = _method_sort({m for _, m, _ in values})
    cols = [(m, d) for m in methods for d in ("X", "Y", "N") if any((c, m, d) in values for c in conditions)]
    table = pd.DataFrame({(method_label(m), d): [float(np.median(values[(c, m, d)])) if (c, m, d) in values
                                                 else np.nan for c in conditions] for m, d in cols},
                         index=conditions)
    table.columns = pd.MultiIndex.from_tuples([(method_label(m), d) for m, d in cols])
    return table


def mae_display(mae: pd.DataFrame, diverged: pd.DataFrame, validated: pd.DataFrame) -> pd.DataFrame:
    """Per method two columns: the MAE over bounded predictions [m/s] and
    ``diverged / validated`` predictions."""
    columns, data = [], {}
    for m in mae.columns:
        columns += [(method_label(m), "MAE [m/s]"), (method_label(m), "diverged")]
        data[columns[-2]] = mae[m]
        data[columns[-1]] = [f"{d:g} / {v:g}" for d, v in zip(diverged[m], validated[m])]
    out = pd.DataFrame(data, index=mae.index)
    out.columns = pd.MultiIndex.from_tuples(columns)
    return out


def winners(tables: dict) -> pd.DataFrame:
    """Best method (lowest fitness) per manoeuvre and condition (thesis Table 5.1 style)."""
    out = {}
    for man, table in tables.items():
        if table.empty:
            continue
        best = table.min(axis=1)
        tied = table.le(best * (1 + 1e-9), axis=0)
        out[man] = tied.apply(lambda row: " = ".join(method_label(m) for m in row.index[row]) or "none bounded",
                              axis=1)
    return pd.DataFrame(out)

