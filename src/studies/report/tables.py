"""Comparison tables built from stored runs (thesis Tables 4.6-4.14 layout)."""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["condition_label", "deviation_table", "fitness_table", "winners", "markdown_table"]

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


def _condition_sort(values) -> list[str]:
    try:
        return sorted(values, key=float)
    except (TypeError, ValueError):
        return sorted(values, key=str)


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


def winners(tables: dict) -> pd.DataFrame:
    """Best method (lowest fitness) per manoeuvre and condition (thesis Table 5.1 style)."""
    out = {}
    for man, table in tables.items():
        if table.empty:
            continue
        best = table.min(axis=1)
        tied = table.le(best * (1 + 1e-9), axis=0)
        out[man] = tied.apply(lambda row: " = ".join(method_label(m) for m in row.index[row]), axis=1)
    return pd.DataFrame(out)


def _fmt(x) -> str:
    if isinstance(x, (float, np.floating)):
        if not np.isfinite(x):
            return "-"
        if x == 0 or 1e-3 <= abs(x) < 1e5:
            return f"{x:.4g}"
        return f"{x:.3e}"
    return str(x)


def markdown_table(table: pd.DataFrame, index_name: str = "") -> str:
    """A pipe table; MultiIndex columns are joined with a line break-free ' / '."""
    if table.empty:
        return "_(no data)_\n"
    cols = [" / ".join(str(c) for c in col) if isinstance(col, tuple) else str(col)
            for col in table.columns]
    lines = ["| " + " | ".join([index_name or ""] + cols) + " |",
             "|" + "---|" * (len(cols) + 1)]
    for idx, row in table.iterrows():
        lines.append("| " + " | ".join([str(idx)] + [_fmt(v) for v in row.tolist()]) + " |")
    return "\n".join(lines) + "\n"
