"""The discovery report: discovery.json, report.md and report.html with figures."""

from __future__ import annotations

import json
from html import escape
from pathlib import Path

import numpy as np
import pandas as pd

from ..plotting import pyplot, thinned, thinned_track
from ..markdown import markdown_table
from .causes.base import compact_parameters

__all__ = ["write_discovery", "write_report", "plot_predictions", "plot_ranking", "plot_evidence", "plot_residuals"]


def _clean(x):
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if np.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    return x


#: causes whose scores differ by less than this are not told apart by the data
#: (2 on the 2 ln Bayes-factor scale: "not worth more than a bare mention")
INDISTINGUISHABLE = 2.0


def indistinguishable(ranking: list, cause: str, margin: float = INDISTINGUISHABLE) -> list[str]:
    """The other causes (``none`` excepted) whose score lies within ``margin`` of
    the named cause's in ``ranking`` (``[{"cause", "score"}, ...]``): the data
    explain them as well, e.g. quadratic and cubic roll damping over a narrow
    range of amplitudes. Empty for ``none``."""
    scores = {r["cause"]: float(r["score"]) for r in ranking if r.get("score") is not None}
    if cause == "none" or cause not in scores:
        return []
    return [c for c, s in scores.items() if c not in (cause, "none") and abs(s - scores[cause]) < margin]


def write_discovery(path: Path, discovery: dict) -> None:
    Path(path).write_text(json.dumps(_clean(discovery), indent=1))


def plot_predictions(record, predictions: dict, title: str, path: Path) -> None:
    """Track and u, v, r of the measurement against each model's prediction."""
    plt = pyplot()
    fig = plt.figure(figsize=(12, 6))
    grid = fig.add_gridspec(3, 2, left=0.07, right=0.98, bottom=0.09, top=0.91, wspace=0.2, hspace=0.3)
    ax = fig.add_subplot(grid[:, 0])
    axes = [fig.add_subplot(grid[i, 1]) for i in range(3)]
    ax.plot(*thinned_track(record["y0"], record["x0"]), "k", lw=2, label="measured")
    for label, pred in predictions.items():
        ax.plot(*thinned_track(pred["y0"], pred["x0"]), label=label)
    for a, (c, unit, k) in zip(axes, (("u", "m/s", 1), ("v", "m/s", 1), ("r", "deg/s", 180 / np.pi))):
        a.plot(*thinned(record["t"], record[c] * k), "k", lw=1.5)
        for pred in predictions.values():
            a.plot(*thinned(pred["t"], pred[c] * k))
        a.set_ylabel(f"{c} [{unit}]")
    axes[-1].set_xlabel("t [s]")
    ax.set_xlabel("y0 (east) [m]")
    ax.set_ylabel("x0 (north) [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.savefig(path, dpi=85)
    plt.close(fig)


def plot_ranking(ranking: list, path: Path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ranking = [r for r in ranking if r.get("score") is not None]   # scored on the baseline's residual
    names = [r["cause"] for r in ranking]
    scores = [r["score"] for r in ranking]
    ax.barh(names[::-1], scores[::-1], color=["tab:green" if i == 0 else "tab:grey"
                                              for i in range(len(names))][::-1])
    ax.set_xlabel("score above the best (BIC, lower is better)")
    ax.set_xscale("symlog", linthresh=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_evidence(evidence: dict, threshold: float, second_threshold: float, named: str, path: Path,
                  measure: str = "held-out gain over its standard error (blocks left out in turn)") -> None:
    """Each cause's (and each second cause's) margin (``measure``: what it
    is), against the threshold that names it; the named verdict in green."""
    plt = pyplot()
    items = sorted(evidence.items(), key=lambda kv: ("+" in kv[0], -kv[1]))
    fig, ax = plt.subplots(figsize=(7, 0.9 + 0.3 * len(items)))
    names = [k for k, _ in items]
    values = [v for _, v in items]
    ax.barh(names[::-1], values[::-1], color=["tab:green" if k == named else "tab:grey" for k in names][::-1])
    ax.axvline(threshold, color="tab:red", lw=1.0, label=f"threshold {threshold:.2f}")
    if np.isfinite(second_threshold):
        ax.axvline(second_threshold, color="tab:red", lw=1.0, ls="--",
                   label=f"second cause {second_threshold:.2f}")
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xlabel(measure if len(measure) < 70 else measure[:measure.index(" (")] if " (" in measure else measure)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_residuals(problems: dict, residuals: list, path: Path) -> None:
    """Baseline regression residual against heading and rudder, per DOF."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(12, 6))
    for k, dof in enumerate(("X", "Y", "N")):
        s = problems[dof].states
        step = max(1, len(residuals[k]) // 3000)
        axes[0, k].plot(np.rad2deg(np.angle(np.exp(1j * s["psi"])))[::step], residuals[k][::step], ".", ms=2)
        axes[0, k].set_xlabel("heading [deg]")
        axes[0, k].set_title(f"{dof} residual (prime)")
        axes[1, k].plot(np.rad2deg(s["delta"])[::step], residuals[k][::step], ".", ms=2)
        axes[1, k].set_xlabel("rudder [deg]")
    fig.tight_layout()
    fig.savefig(path, dpi=85)
    plt.close(fig)


def _md_table(df: pd.DataFrame) -> str:
    """A report section's table: its index (or, unnamed, its first column) first."""
    if df is None or df.empty:
        return markdown_table(pd.DataFrame())
    table = df if df.index.name else df.set_index(df.columns[0])
    return markdown_table(table, str(table.index.name))


def _explained(d: dict) -> list[str]:
    """Verdict lines: does the named model explain the held-out records, and
    where the baseline departs most from them."""
    lines = []
    named = d["extended"] if d["cause"] != "none" else d["baseline"]
    unit = (d.get("units") or "m").split()[0]
    if named.get("training_rmse") is not None:
        who = "extended model" if d["cause"] != "none" else "identified model"
        v, t = named.get("validation_rmse_windowed", named["validation_rmse"]), named["training_rmse"]
        ratio = f" ({v / t:.1f} times as much)" if t > 0 else ""
        lines.append(f"\nThe {who} predicts the records it was fitted to with {t:.4g} {unit} and the held-out "
                     f"ones with {v:.4g} {unit}{ratio}: "
                     + ("it explains them." if d.get("explains_validation", True) else
                        "it does not explain them."))
    if d.get("peak_decay"):
        name, rows = next(iter(d["peak_decay"].items()))
        last = [c for c in rows["measured"] if c.startswith("peak_after")][-1]
        lines.append(f"\nPeak roll angle of {name} after {last.split('_')[2]} cycles: "
                     + ", ".join(f"{label} {row[last]:.3g}" for label, row in rows.items()) + " deg.")
    units = {"u": "m/s", "v": "m/s", "r": "deg/s"}
    for model in dict.fromkeys(row.get("model", "baseline") for row in d.get("departures") or []):
        if model == "baseline" and d["cause"] == "none" and d.get("explains_validation", True):
            continue            # nothing to show: the baseline explains the held-out records
        run = "whole replay" if model == "baseline" else "its run"
        lines.append(f"\nWhere the {model} departs most from the held-out records ({run}, means over "
                     "the phase):\n")
        for row in (r for r in d["departures"] if r.get("model", "baseline") == model):
            lines.append(f"- {row['record']}, {row['phase']} ({row['share_%']:.0f} % of the record): "
                         f"{row['state']} {row['predicted_mean']:.3g} predicted against "
                         f"{row['measured_mean']:.3g} {units[row['state']]} measured, "
                         f"RMSE {row['rmse']:.3g} {units[row['state']]}")
    return lines


def _shown(value) -> str:
    """A parameter's value to 4 significant digits, ranges (lists) included."""
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_shown(v) for v in value) + "]"
    return str(value)


def _parameter_lines(params: dict, units, uncertainty, depth: int = 0) -> list[str]:
    """One line per estimated value (a pair's causes and a missing term's
    terms nested), with its 90 % interval and its unit: ``units`` and
    ``uncertainty`` are shaped as ``params``, a unit given above nested
    values applying to each (a missing term's terms)."""
    lines = []
    for name, value in params.items():
        unit = units.get(name) if isinstance(units, dict) else units
        interval = uncertainty.get(name) if isinstance(uncertainty, dict) else None
        if isinstance(value, dict):
            lines += _parameter_lines(value, unit if unit is not None else {}, interval or {}, depth + 1)
            continue
        if value is None:
            continue
        iv = f" [{interval[0]:.4g}, {interval[1]:.4g}]" if isinstance(interval, (list, tuple)) else ""
        shown = _shown(value)
        text = f" ({unit})" if isinstance(unit, str) and unit else ""
        lines.append(f"- `{name}` = {shown}{iv}{text}")
    return lines


def _scale_line(d: dict) -> str:
    """The scale the records were studied at, and the units of the page's numbers."""
    scale, ratio = d.get("scale"), d.get("scale_ratio")
    if scale == "model" and ratio:
        where = f"model scale (1:{ratio:g})"
    elif scale in ("model", "full"):
        where = f"{scale} scale" + (" (Froude scaled where a record was at another)" if scale == "full" else "")
    else:
        where = "a scale the records do not state (no particulars beside them)"
    if str(d.get("units", "")).startswith("deg (roll"):
        return (f"Records studied at {where}; roll angles in deg, time in s, omega0 in rad/s, b1 in 1/s, "
                "b2 dimensionless, unless a table says otherwise.")
    return (f"Records studied at {where}; SI units (m, m/s, s, N, N m) unless a table says otherwise, "
            "angles in the text in deg, coefficients in the prime system.")


def write_report(out_dir: Path, discovery: dict, explanation: str, sections: list, figures: list) -> None:
    """report.md and report.html: verdict first, then evidence."""
    out_dir = Path(out_dir)
    d = discovery
    members = d.get("class") or []
    title = (f"# Discovery: one of **{'**, **'.join(members)}** (the records cannot tell them apart; "
             f"**{d['cause']}** the most probable)" if len(members) > 1 and d["cause"] != "outside_training_states"
             else f"# Discovery: **{d['cause']}**")
    verdict = [title, "", _scale_line(d), "", explanation, ""]
    if d.get("parameters"):
        verdict.append("Estimated parameters (90 % interval; unit and convention):")
        verdict.append("")
        verdict += _parameter_lines(d["parameters"], d.get("parameter_units") or {}, d.get("uncertainty") or {})
        if d.get("fixed_parameters"):
            verdict.append("- used as published, not fitted: "
                           + ", ".join(f"`{k}` = {v:.4g}" for k, v in d["fixed_parameters"].items()))
        verdict.append("")
    b, e = d["baseline"]["validation_rmse"], d["extended"]["validation_rmse"]
    interval = d.get("gain_interval_pct")
    shown = f" (90 % interval {interval[0]:.1f} to {interval[1]:.1f} %)" if interval else ""
    windowed = d.get("gain_windowed_pct")
    verdict.append(f"Prediction error on the held-out records: baseline {b:.4g}, extended {e:.4g} "
                   f"{d.get('units', '')} -> gain {d['gain_pct']:.1f} %{shown}"
                   + (f"; over prediction windows of the dynamics, {windowed:.1f} %." if windowed is not None else "."))
    worse = (d.get("held_out") or {}).get("worse")
    if worse and d["cause"] != "none":
        verdict.append(f"\nThe extension predicts the held-out records worse than the baseline on: {'; '.join(worse)}.")
    verdict += _explained(d)
    if d.get("indistinguishable_from"):
        others = ", ".join(f"**{c}**" for c in d["indistinguishable_from"])
        verdict.append(f"\nThe training data do not tell it apart from {others} (scores within "
                       f"{INDISTINGUISHABLE:g}): the choice between them is not established by these records.")
    members = d.get("class") or []
    if len(members) > 1:
        verdict.append(f"\n{_class_sentence(d)}")
    if d.get("confidence") is not None and np.isfinite(d["confidence"]):
        what = (f"the class {', '.join(f'**{m}**' for m in members)}" if len(members) > 1 and
                d["cause"] != "outside_training_states" else f"**{d['cause']}**")
        verdict.append(f"\nConfidence in {what}: {d['confidence']:.2f} "
                       f"({d.get('confidence_basis', 'posterior probability from the scores')}).")
    if d.get("detection_limits"):
        verdict.append(f"\n{detection_sentence(d)}")
    if d["cause"] == "outside_training_states" and d.get("next_manoeuvre"):
        verdict.append(f"\nWhat would cover those states: {d['next_manoeuvre']}.")
    elif d.get("next_manoeuvre") and d.get("undecided"):
        rivals = ", ".join(f"**{c}**" for c in d.get("undecided", [])[1:])
        verdict.append(f"\nThese records cannot decide between **{d['cause']}** and {rivals}: "
                       f"{d['next_manoeuvre']} would.")
    if d.get("splits"):
        rows = d["splits"]
        if d["cause"] != "none":
            better = sum(1 for r in rows if r["extended_validation_rmse"] < r["baseline_validation_rmse"])
            verdict.append(f"\nHolding out each of the {len(rows)} records in turn (the baseline and "
                           f"**{d['cause']}** identified on the others): the named model predicts it better in "
                           f"{better} of {len(rows)}"
                           + ("." if better == len(rows) else
                              ", so its gain depends on which manoeuvre is held out."))
        unexplained = [row["held_out"] for row in rows if not row.get("explains_validation", True)]
        if unexplained:
            verdict.append(f"The {'named' if d['cause'] != 'none' else 'identified'} model does not explain "
                           f"{len(unexplained)} of the {len(rows)} held-out records ({', '.join(unexplained)}): "
                           "its error there is many times that on the records it was fitted to.")
    if d.get("notes"):
        verdict += ["", "Notes:"] + [f"- {note}" for note in d["notes"]]
    md = "\n".join(verdict) + "\n"
    for title, table in sections:
        md += f"\n## {title}\n\n" + (_md_table(table) if isinstance(table, pd.DataFrame) else str(table) + "\n")
    if figures:
        md += "\n## Figures\n\n" + "\n\n".join(f"![{f}]({f})" for f in figures) + "\n"
    (out_dir / "report.md").write_text(md)
    html = ["<!doctype html><html><head><meta charset='utf-8'><title>discovery</title>",
            "<style>body{font-family:sans-serif;margin:2em;max-width:1300px}table{border-collapse:collapse;"
            "font-size:.85em}td,th{border:1px solid #ccc;padding:2px 6px}img{max-width:100%}</style></head><body>"]
    html.append(f"<h1>Discovery: {escape(d['cause'])}</h1><p>{escape(explanation)}</p>")
    html.append("<pre>" + escape("\n".join(verdict[4:])) + "</pre>")
    for title, table in sections:
        html.append(f"<h2>{escape(title)}</h2>")
        if isinstance(table, pd.DataFrame):
            html.append(table.to_html(float_format=lambda x: f"{x:.4g}", na_rep="-"))
        else:
            html.append(f"<p>{escape(str(table))}</p>")
    for f in figures:
        html.append(f"<p><img src='{escape(f)}' alt='{escape(f)}'></p>")
    html.append("</body></html>")
    (out_dir / "report.html").write_text("\n".join(html))


def _class_sentence(d: dict) -> str:
    """The class of look-alikes: its members with their parameters, and why they are one class."""
    members = d["class"]
    params = d.get("class_parameters") or {}
    listed = "; ".join(f"**{m}** ({compact_parameters(params[m])})" if params.get(m) else f"**{m}**"
                       for m in members)
    evidence = (d.get("class_evidence") or {})
    named = "what the inference named on the training records" if d["cause"] == "outside_training_states" else \
        "the verdict"
    return (f"These records cannot tell apart {listed}: {named} is a class of look-alikes, each fitted as given "
            f"(the records' evidence for the first over each other is below {evidence.get('threshold', float('nan')):.2f}, "
            f"{evidence.get('measure', '')}); class probability {d.get('class_probability', float('nan')):.2f}.")


def detection_sentence(d: dict) -> str:
    """The smallest effect of each cause these records would show, in the causes' units."""
    limits = d.get("detection_limits") or {}
    shown = "; ".join(f"{cid} {compact_parameters(p)}" for cid, p in limits.items() if p)
    hidden = [cid for cid, p in limits.items() if not p]
    return ("Smallest effect of each cause these records would show (its fit on these records scaled, in the "
            f"direction fitted, to where its evidence reaches the naming threshold; each cause's units): {shown}"
            + (f"; not estimable for {', '.join(hidden)} (its fit explains nothing)" if hidden else "") + ".")
