"""``method=sindy``: the terms SINDy kept against the model, and its prediction beside LS's.

For a SINDy run this writes ``sindy.md`` (and ``sindy_terms.csv``): per
degree of freedom the model's terms SINDy dropped, the library's terms it
added, each with its inclusion probability over the ensemble's
block-bootstrap draws, the threshold and ridge weight the cross-validation
chose; then the validation records predicted by SINDy's model and by least
squares on the same regression (same records, state and acceleration
estimates and row weights), side by side. The LS model's validation is
logged as ``ls/<record>/...`` metrics, its files under ``ls/``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from ..identification.ls import LeastSquares
from ..identification.regression import build_problems
from ..models.terms import DOFS

__all__ = ["COMPARED", "sparse_terms_table", "ls_problems", "sindy_beside_ls"]

#: validation quantities set side by side (prediction minus measurement)
COMPARED = ("rmse_position", "advance_error_pct", "tactical_diameter_error_pct", "steady_speed_error_pct",
            "steady_yaw_rate_error_pct", "overshoot1_error_deg", "overshoot2_error_deg", "diverged")


def sparse_terms_table(model, result) -> pd.DataFrame:
    """One row per term of the model or selected beyond it: ``dof``, ``term``, ``in_model``,
    ``kept``, ``inclusion`` (NaN without an ensemble), ``value``."""
    rows = []
    for dof in DOFS:
        inclusion = {k.rsplit("/", 1)[1]: v for k, v in result.metrics.items()
                     if k.startswith(f"sindy/{dof}/inclusion/")}
        names = [t.name for t in model.terms_of(dof)]
        extra = [n for n in inclusion if n not in names and result.params.get(n, 0.0) != 0.0]
        for name in names + extra:
            value = float(result.params.get(name, 0.0))
            rows.append({"dof": dof, "term": name, "in_model": name in names, "kept": value != 0.0,
                         "inclusion": float(inclusion.get(name, np.nan)), "value": value})
    return pd.DataFrame(rows, columns=["dof", "term", "in_model", "kept", "inclusion", "value"])


def ls_problems(study, estimates):
    """The regression problems of ``study``'s model on given estimates (None: its own
    records' derivatives), as the run built them for SINDy."""
    from .measured import problems_from_estimates

    if estimates is not None:
        return problems_from_estimates(study.model, study.vessel, study.records, estimates,
                                       weights=study.cfg.identify.weights)
    return build_problems(study.model, study.vessel, study.records, study.cfg.data.derivative)


def sindy_beside_ls(study, base_model, result, fit_ls, metrics: dict, out_dir: Path, validate) -> dict:
    """Write ``sindy.md``/``sindy_terms.csv`` and validate LS beside SINDy; the ``ls/...`` metrics.

    ``study`` is the run's study with SINDy's model, ``base_model`` the
    model the run was given, ``fit_ls()`` the least-squares coefficients of
    the same regression, ``metrics`` SINDy's own, ``validate(study, params,
    out_dir)`` the run's validation.
    """
    out_dir = Path(out_dir)
    table = sparse_terms_table(base_model, result)
    table.to_csv(out_dir / "sindy_terms.csv", index=False)
    ls_metrics = {}
    if study.validation_records:
        plain = dataclasses.replace(study, model=base_model, method="ls")
        ls_params = fit_ls()
        ls_dir = out_dir / "ls"
        ls_dir.mkdir(exist_ok=True)
        found = validate(plain, {n: ls_params[n] for n in base_model.names}, ls_dir)
        ls_metrics = {f"ls/{k}": v for k, v in found.items()}
    lines = ["# SINDy: the terms kept and the prediction beside least squares", ""]
    for dof in DOFS:
        part = table[table["dof"] == dof]
        key = f"sindy/{dof}/"
        chosen = ", ".join(f"{name} {result.metrics[key + name]:g}" for name in ("threshold", "alpha")
                           if key + name in result.metrics)
        kept = int((part["kept"] & part["in_model"]).sum())
        added_n = int((part["kept"] & ~part["in_model"]).sum())
        lines += [f"## {dof}: {kept} of {int(part['in_model'].sum())} model terms kept"
                  f"{f', {added_n} added' if added_n else ''} ({chosen})", ""]
        dropped = part[part["in_model"] & ~part["kept"]]
        added = part[~part["in_model"] & part["kept"]]
        fmt = (lambda p: "–" if not np.isfinite(p) else f"{p:.2f}")
        lines.append("dropped: " + (", ".join(f"{r.term} ({fmt(r.inclusion)})" for r in dropped.itertuples())
                                    or "none"))
        lines.append("")
        lines.append("added: " + (", ".join(f"{r.term} ({fmt(r.inclusion)})" for r in added.itertuples())
                                  or "none"))
        lines.append("")
    lines.append("Inclusion probabilities in brackets (share of the block-bootstrap draws that keep the term).")
    lines.append("")
    if study.validation_records:
        lines += ["## Held-out prediction, SINDy beside least squares", "",
                  "Prediction minus measurement (`_pct` in %, `_deg` in deg, `rmse_position` in m); "
                  "least squares on the same regression rows.", "",
                  "| record | quantity | SINDy | LS |", "|---|---|---:|---:|"]
        for rec in study.validation_records:
            name = rec.attrs.get("name", "record")
            for quantity in COMPARED:
                a, b = metrics.get(f"{name}/{quantity}"), ls_metrics.get(f"ls/{name}/{quantity}")
                if a is None and b is None:
                    continue
                show = (lambda x: "–" if x is None or not np.isfinite(x) else f"{x:+.2f}")
                lines.append(f"| {name} | {quantity} | {show(a)} | {show(b)} |")
    (out_dir / "sindy.md").write_text("\n".join(lines) + "\n")
    return ls_metrics
