"""How far an identification on measured records can be trusted: ``identifiability.md``.

A hydrodynamicist signing off a prediction asks three things of the
regression behind it, and the page answers each with numbers:

1. **Are the coefficients separable on these records?** Per degree of
   freedom, the condition number of the regression matrix (columns scaled to
   unit norm; the records' rows only, without the prior's pseudo-rows) and
   each coefficient's variance inflation factor (VIF: 1 for a column
   orthogonal to the others; above 10 the records barely separate it).
2. **Does a coefficient depend on which record was used?** Every training
   record's rows are left out in turn and the hull regressed again on the
   others (the prior's pseudo-rows kept as weighted in the full fit):
   each coefficient's change [% of its value with every record] per record
   left out, and its largest.
3. **Do the held-out records go where training went?** The training
   records' envelope of drift angle, yaw rate ``r' = r L / U``, speed
   ``U / U0``, rudder angle and thrust loading
   (:mod:`studies.analysis.state_ranges`), and, for each held-out record,
   the states it takes beyond it, for what share of its samples: there the
   prediction is an extrapolation.

Metrics: ``identifiability/<dof>/condition_number``,
``identifiability/<dof>/max_vif``, ``identifiability/<coefficient>/vif``,
``identifiability/<coefficient>/loo_drift_max_pct``,
``<record>/outside_training_share`` and ``<record>/outside_training/<state>``
(the share of its samples beyond the envelope in that state).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..analysis.state_ranges import STATES, beyond, training_ranges
from ..identification.base import condition_number, variance_inflation
from ..identification.ls import LeastSquares
from ..markdown import format_number, markdown_table

__all__ = ["identifiability", "IDENTIFIABILITY_FILE", "VIF_HIGH"]

#: the states in a sentence
SHORT = {"drift_deg": "drift angle", "yaw_rate_prime": "yaw rate", "speed_ratio": "speed",
         "rudder_deg": "rudder angle", "thrust_loading": "thrust loading"}

IDENTIFIABILITY_FILE = "identifiability.md"
#: a VIF above this: the records barely separate the coefficient from the others
VIF_HIGH = 10.0


def _data_rows(problem) -> tuple[np.ndarray, np.ndarray]:
    n = int(getattr(problem, "n_data", problem.theta.shape[0]))
    return problem.theta[:n], problem.y[:n]


def _conditioning(problems: dict) -> tuple[pd.DataFrame, dict]:
    rows, metrics = [], {}
    for dof, problem in problems.items():
        theta, _ = _data_rows(problem)
        if theta.shape[1] == 0:
            continue
        cond = condition_number(theta)
        vif = variance_inflation(theta)
        metrics[f"identifiability/{dof}/condition_number"] = cond
        metrics[f"identifiability/{dof}/max_vif"] = float(np.max(vif))
        for name, value in zip(problem.names, vif):
            metrics[f"identifiability/{name}/vif"] = float(value)
            rows.append({"coefficient": name, "dof": dof, "vif": float(value),
                         "condition number of the dof": cond,
                         "separable": "barely" if value > VIF_HIGH else "yes"})
    return pd.DataFrame(rows).set_index("coefficient") if rows else pd.DataFrame(), metrics


def _without_record(problem, k: int):
    """``problem`` without the rows of record ``k`` (prior and captive rows kept)."""
    keep = np.asarray(problem.record) != k
    out = replace(problem, theta=problem.theta[keep], y=problem.y[keep], record=np.asarray(problem.record)[keep],
                  time=None if problem.time is None else np.asarray(problem.time)[keep], states=None)
    if hasattr(problem, "n_data"):
        out.n_data = int(np.sum(keep[:problem.n_data]))
    return out


def _leave_one_out(problems: dict, records: list, params: dict) -> tuple[pd.DataFrame, dict]:
    """Each coefficient's change [%] with each training record's rows left out of the
    regression (the prior's pseudo-rows, weighted as in the full fit, kept)."""
    if len(records) < 2 or any(p.record is None for p in problems.values()):
        return pd.DataFrame(), {}
    columns = {}
    free = {name for p in problems.values() for name in p.names}     # not the known ones
    for k, record in enumerate(records):
        refit = LeastSquares().fit({dof: _without_record(p, k) for dof, p in problems.items()}).params
        columns[str(record.attrs.get("name", f"record {k + 1}"))] = {
            name: 100.0 * (refit[name] - value) / abs(value) if value else np.nan
            for name, value in params.items() if name in refit and name in free}
    table = pd.DataFrame(columns)
    table.index.name = "coefficient"
    largest = table.abs().max(axis=1)
    table.insert(0, "largest change (absolute) %", largest)
    metrics = {f"identifiability/{name}/loo_drift_max_pct": float(v) for name, v in largest.items()
               if np.isfinite(v)}
    return table, metrics


def _states(train: list, held_out: list, vessel) -> tuple[pd.DataFrame, pd.DataFrame, dict, list]:
    ranges = training_ranges(train, vessel)
    envelope = pd.DataFrame([{"state": STATES[k][1], "unit": STATES[k][0], "training from": lo, "training to": hi}
                             for k, (lo, hi) in ranges.items()]).set_index("state") if ranges else pd.DataFrame()
    rows, metrics, warnings = [], {}, []
    for record in held_out:
        found = beyond(record, ranges, vessel)
        metrics[f"{found.record}/outside_training_share"] = found.share
        for name, info in found.states.items():
            metrics[f"{found.record}/outside_training/{name}"] = info["share"]
            rows.append({"record": found.record, "state": STATES[name][1], "unit": STATES[name][0],
                         "training from": info["training"][0], "training to": info["training"][1],
                         "held out from": info["record"][0], "held out to": info["record"][1],
                         "share of samples beyond": info["share"]})
        if found.states:
            warnings.append(f"{found.record} goes beyond the training records in "
                            f"{', '.join(SHORT[n] for n in found.states)}"
                            f" for {100 * found.share:.0f} % of its samples: its prediction there is an extrapolation")
    table = pd.DataFrame(rows).set_index("record") if rows else pd.DataFrame()
    return envelope, table, metrics, warnings


def identifiability(problems: dict, params: dict, train: list, held_out: list, vessel,
                    out_dir: Path, scale_note: str = "") -> dict:
    """Write ``identifiability.md`` beside the run's files; its metrics.

    Parameters
    ----------
    problems : dict
        ``{dof: RegressionProblem}`` of the identification (records' rows first,
        ``n_data`` of them, prior rows after; ``record``: each row's record).
    params : dict
        The identified coefficients (prime).
    train, held_out : list of DataFrame
        The training and validation records (data contract; SI, radians).
    vessel
        Length L [m], approach speed U0 [m/s] (and draught, rho for the thrust loading).
    """
    conditioning, metrics = _conditioning(problems)
    drift, drift_metrics = _leave_one_out(problems, train, params)
    metrics.update(drift_metrics)
    envelope, outside, state_metrics, warnings = _states(train, held_out, vessel)
    metrics.update(state_metrics)
    lines = ["# Identifiability: how far these coefficients can be trusted", ""]
    if scale_note:
        lines += [scale_note, ""]
    lines += ["Coefficients in the prime system; the regression's records' rows only (without the "
              "prior's pseudo-rows), columns scaled to unit norm.", ""]
    lines += [f"**Warning:** {w}." for w in warnings] + ([""] if warnings else [])
    known = {name: value for p in problems.values() for name, value in p.fixed.items()}
    if known:
        lines += ["Known in these regressions, so in neither table: "
                  + ", ".join(f"{name} = {format_number(value)}" for name, value in known.items())
                  + " (a family's tied rudder terms are regressed first, on the sway and yaw rows "
                  "together: `model.tie_rudder`).", ""]
    if not conditioning.empty:
        barely = [n for n, row in conditioning.iterrows() if row["vif"] > VIF_HIGH]
        lines += ["## Are the coefficients separable on these records?", "",
                  f"Variance inflation factor of each coefficient (above {VIF_HIGH:g}: the records barely "
                  "separate it from the others" + (f"; here {', '.join(barely)}" if barely else "") + ").", "",
                  markdown_table(conditioning, "coefficient"), ""]
    if not drift.empty:
        lines += ["## Does a coefficient depend on which record was used?", "",
                  "Each training record left out in turn, the hull regressed again on the others: the "
                  "change of each coefficient [% of its value with every record].", "",
                  markdown_table(drift, "coefficient"), ""]
    if not envelope.empty:
        lines += ["## Do the held-out records go where training went?", "",
                  "The training records' states (0.5 and 99.5 % quantiles over their samples; drift angle "
                  "beta = atan2(-v, u), r' = r L / U):", "", markdown_table(envelope, "state"), ""]
        lines += (["Held-out records beyond them (by more than 5 % of the range's width):", "",
                   markdown_table(outside, "record"), ""] if not outside.empty else
                  ["Every held-out record stays within them.", ""])
    (Path(out_dir) / IDENTIFIABILITY_FILE).write_text("\n".join(lines))
    return metrics
