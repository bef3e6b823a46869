"""Zhu (2021) reproduced: Tables 4.6-4.14 and the GA beside the thesis' presets.

Reads the runs of the three thesis presets (``thesis_wind_speed``,
``thesis_noise``, ``thesis_direction``), under whichever set-ups the store
holds: the project's (``wind.convention=downwind``, the GA's fitness on the
recorded rudder replayed, RK4 records) and the thesis' own
(``conventions=zhu2021``: its eq. 3.17 as coded, the GA's fitness on the
zig-zag steered again, its records as MSS ``zigzag.m`` makes them, Euler
steps and the rudder to starboard first, differenced forward as its eq.
3.9), and any other combination of those settings (the thesis' set-up on
RK4 records shows what the GA does when the records and its simulator are
the same). For each set-up and method, GA variants included, it compares
the deviations with Tables 4.6-4.14 (:mod:`studies.papers`,
``zhu2021_deviations.csv``): sign agreement, magnitude ratio, the trends
the thesis describes, what the GA did and why, the validation fitness, and
a sentence per disagreement with its cause.

The causes are judged from measurable properties, not assumed: a
coefficient whose least-squares deviation moves, between the four 1000 s
quarters of the condition's own 4000 s zig-zag (simulated here as the
set-up makes it), by at least half the difference between the thesis and
the project is ill-determined: the record does not pin it down, and how the
wind-error force is shared among collinear terms depends on details of the
record the thesis does not publish; a deviation below
:data:`NEGLIGIBLE_PCT` in either has no meaningful sign, and when the
difference is within twice that allowance it is reported as such; an SVM
deviation is the two SVMs' difference when the thesis' SVM leaves its own
LS where the project's does not, or when the two least-squares solutions
agree (the records agree; the thesis' LinearSVR and the project's
cross-validated SVR do not); anything else is reported as not explained. The GA columns
differ by the GA's random search (one run per cell).
"""

from __future__ import annotations

import shutil
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np
import pandas as pd

from ...papers import published
from ...workflows.reproduction.zhu2021 import spread_by_condition
from ..tables import markdown_table, method_label
from .runs import latest_coefficients

__all__ = ["EXPERIMENTS", "COMMANDS", "sections", "substitutions", "conventions", "GROUPS"]

#: the presets' MLflow experiments -> (swept key, the thesis' tables, what the thesis varies)
GROUPS = {
    "thesis_wind_speed": ("wind.speed", ("4.6", "4.7", "4.8"), "wind speed (-5 % error, from 45 deg)"),
    "thesis_noise": ("noise.wind_speed_error", ("4.9", "4.10", "4.11"),
                     "wind-speed error (12 m/s from 45 deg)"),
    "thesis_direction": ("wind.direction", ("4.12", "4.13", "4.14"), "wind direction (12 m/s, -5 % error)"),
}
EXPERIMENTS = tuple(GROUPS) + ("thesis_calm",)
COMMANDS = [f"studies run experiment={e}" for e in EXPERIMENTS] + \
    [f"studies run experiment={e} conventions=project" for e in GROUPS]
METHODS = ("ls", "ls_ga", "svm", "svm_ga")
#: the thesis' GA stop: eq. 3.43 at or below it ends the GA before its first generation
STOP_FITNESS = 1e-5
#: |deviation| [%] below which its sign is not compared
NEGLIGIBLE_PCT = 2.0
#: magnitude ratio outside [1/RATIO_OFF, RATIO_OFF] is a disagreement
RATIO_OFF = 3.0

#: a run's set-up: ``"<wind.convention>, <objective.simulation>, <data.scheme>, <data.derivative>,
#: <manoeuvre.first_sign>, <manoeuvre.execute>"``
THESIS_SETUP = "zhu2021, closed_loop, euler, forward, -1, 9.5"
#: the thesis' set-up on records stepped by RK4 (the records and the GA's simulator the same)
THESIS_RK4_SETUP = "zhu2021, closed_loop, rk4, central, -1, 9.5"
PROJECT_SETUP = "downwind, replay, rk4, auto, 1, 0"
SETUP_LABEL = {THESIS_SETUP: "thesis set-up", THESIS_RK4_SETUP: "thesis set-up on RK4 records",
               PROJECT_SETUP: "project set-up"}


def _param(run, key: str, default: str) -> str:
    value = run.params.get(key)
    return default if value in (None, "", "null", "None") else str(value)


def _setup_of(run) -> str:
    return ", ".join((_param(run, "wind.convention", "downwind"), _param(run, "objective.simulation", "replay"),
                      _param(run, "data.scheme", "rk4"), _param(run, "data.derivative", "auto"),
                      f"{int(float(_param(run, 'manoeuvre.first_sign', '1')))}",
                      f"{float(_param(run, 'manoeuvre.execute', '0')):g}"))


def _setup_label(setup: str) -> str:
    wind, objective, scheme, derivative, first, execute = setup.split(", ")
    side = "starboard" if first == "-1" else "port"
    return SETUP_LABEL.get(setup, f"wind {wind}, objective {objective}, {scheme} records, {derivative} "
                                  f"derivatives, {side} first, rudder laid at {execute} s")


def _series(run) -> str:
    """The column a run fills: its method, with a GA mutation probability
    other than the thesis' 1 named (``ls_ga (mutation 0.1)``)."""
    method = run.params.get("method.name") or run.tags.get("method", "?")
    mutation = run.params.get("method.mutation_probability")
    if method.endswith("_ga") and mutation not in (None, "", "1", "1.0"):
        return f"{method} (mutation {float(mutation):g})"
    return method


def _collect(runs: dict, scratch: Path) -> pd.DataFrame:
    """One row per (experiment, set-up, condition, series, coefficient) of the
    latest finished run: its deviation and its GA and validation metrics."""
    rows = []
    for experiment, (key, _, _) in GROUPS.items():
        latest = {}
        for run in runs.get(experiment) or []:
            if run.status != "FINISHED" or key not in run.params:
                continue
            setup = _setup_of(run)
            cell = (setup, float(run.params[key]), _series(run))
            if cell not in latest or run.start_time > latest[cell].start_time:
                latest[cell] = run
        for (setup, value, series), run in latest.items():
            local = run.artifact("coefficients.csv", scratch / run.run_id)
            if local is None:
                continue
            table = pd.read_csv(local)
            m = run.metrics
            for r in table.itertuples():
                rows.append({"experiment": experiment, "setup": setup, "value": value, "series": series,
                             "coefficient": r.name, "deviation_pct": r.deviation_pct,
                             "value_identified": r.value, "true": r.true,
                             "ga_initial": m.get("ga/initial_fitness", np.nan),
                             "ga_best": m.get("ga/best_fitness", np.nan),
                             "ga_generations": m.get("ga/generations", np.nan),
                             "run_id": run.run_id})
    return pd.DataFrame(rows)


def _validation(runs: dict) -> pd.DataFrame:
    """Validation fitness (eq. 3.43, Figs 4.1-4.3) per run and manoeuvre; diverged flagged."""
    rows = []
    for experiment, (key, _, _) in GROUPS.items():
        for run in runs.get(experiment) or []:
            if run.status != "FINISHED" or key not in run.params:
                continue
            setup = _setup_of(run)
            for k, v in run.metrics.items():
                if k.endswith("/fitness") and not k.startswith(("training", "ga/")):
                    man = k.split("/")[0]
                    rows.append({"experiment": experiment, "setup": setup, "value": float(run.params[key]),
                                 "series": _series(run), "manoeuvre": man, "fitness": v,
                                 "diverged": bool(run.metrics.get(f"{man}/diverged", 0.0)),
                                 "start": run.start_time})
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    return (table.sort_values("start").groupby(["experiment", "setup", "value", "series", "manoeuvre"])
            .last().reset_index())


def _thesis() -> pd.DataFrame:
    return published("thesis", "deviations")


def _pair(ours: pd.DataFrame, thesis: pd.DataFrame, experiment: str, setup, method: str) -> pd.DataFrame:
    """Thesis and project deviations of one method (or GA variant, beside the
    thesis' GA) under one set-up, per condition and coefficient."""
    key, tables, _ = GROUPS[experiment]
    t = thesis[(thesis["table"].isin(tables)) & (thesis["method"] == method.partition(" ")[0])]
    o = ours[(ours["experiment"] == experiment) & (ours["setup"] == setup) & (ours["series"] == method)]
    if o.empty:
        return pd.DataFrame()
    merged = t.merge(o[["value", "coefficient", "deviation_pct"]], on=["value", "coefficient"],
                     suffixes=("_thesis", "_ours"))
    return merged


def agreement(pairs: pd.DataFrame) -> dict:
    """Sign agreement (both |dev| >= NEGLIGIBLE_PCT) and the median magnitude ratio."""
    both = pairs[(pairs["deviation_pct_thesis"].abs() >= NEGLIGIBLE_PCT)
                 & (pairs["deviation_pct_ours"].abs() >= NEGLIGIBLE_PCT)]
    if both.empty:
        return {"compared": 0, "sign": np.nan, "ratio": np.nan}
    sign = float(np.mean(np.sign(both["deviation_pct_thesis"]) == np.sign(both["deviation_pct_ours"])))
    ratio = float(np.median(both["deviation_pct_ours"].abs() / both["deviation_pct_thesis"].abs()))
    return {"compared": len(both), "sign": sign, "ratio": ratio}


def _fmt(x, digits: int = 2) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.{digits}f}"


def _setups(ours: pd.DataFrame) -> list:
    found = list(dict.fromkeys(ours["setup"])) if not ours.empty else []
    order = [THESIS_SETUP, THESIS_RK4_SETUP, PROJECT_SETUP]
    return [s for s in order if s in found] + [s for s in found if s not in order]


def _overview(ours: pd.DataFrame, thesis: pd.DataFrame) -> str:
    rows = []
    for experiment, (key, tables, what) in GROUPS.items():
        for setup in _setups(ours):
            for method in _columns(ours):
                pairs = _pair(ours, thesis, experiment, setup, method)
                if pairs.empty:
                    continue
                a = agreement(pairs)
                rows.append({"tables": f"{tables[0]}-{tables[-1]}: {what}", "set-up": _setup_label(setup),
                             "method": _series_label(method), "compared": a["compared"],
                             "same sign": _fmt(a["sign"]), "median abs(ours)/abs(thesis)": _fmt(a["ratio"])})
    if not rows:
        return "No finished runs of the thesis presets in the store.\n"
    text = ("Coefficients compared where both deviations are at least "
            f"{NEGLIGIBLE_PCT:g} % (smaller ones have no meaningful sign): the share with the same "
            "sign and the median ratio of magnitudes.\n\n")
    return text + markdown_table(pd.DataFrame(rows).set_index("tables"), "tables")


def _median_abs(frame: pd.DataFrame, column: str) -> pd.Series:
    return frame.groupby("value")[column].apply(lambda s: float(np.median(np.abs(s))))


def _trends(ours: pd.DataFrame, thesis: pd.DataFrame) -> str:
    """The trends the thesis describes, measured in both (LS columns)."""
    out = []
    setups = _setups(ours)
    for experiment, (key, tables, what) in GROUPS.items():
        t = thesis[(thesis["table"].isin(tables)) & (thesis["method"] == "ls")]
        rows = {"thesis": _median_abs(t, "deviation_pct")}
        for setup in setups:
            o = ours[(ours["experiment"] == experiment) & (ours["setup"] == setup) & (ours["series"] == "ls")]
            if not o.empty:
                rows[f"project, {_setup_label(setup)}"] = _median_abs(o, "deviation_pct")
        table = pd.DataFrame(rows).T
        table.columns = [_condition(key, c) for c in table.columns]
        out.append(f"**{what}** (Tables {tables[0]}-{tables[-1]}): median |deviation| of the LS "
                   "coefficients [%]\n\n" + markdown_table(table.round(2), "source"))
        out.append(_trend_sentences(experiment, t, ours, setups))
    return "\n".join(out)


def _condition(key: str, value: float) -> str:
    if key == "wind.speed":
        return f"{value:g} m/s"
    if key == "wind.direction":
        return f"{value:g} deg"
    return f"{100 * value:+g} %"


def _trend_sentences(experiment: str, t: pd.DataFrame, ours: pd.DataFrame, setups) -> str:
    """Whether each source shows the thesis' trend, in words."""
    lines = []
    sources = [("the thesis", t)]
    for setup in setups:
        o = ours[(ours["experiment"] == experiment) & (ours["setup"] == setup) & (ours["series"] == "ls")]
        if not o.empty:
            sources.append((f"the project ({_setup_label(setup)})", o))
    for name, frame in sources:
        pivot = frame.pivot_table(index="coefficient", columns="value", values="deviation_pct")
        if experiment == "thesis_wind_speed" and pivot.shape[1] >= 2:
            grows = (pivot.abs().iloc[:, -1] > pivot.abs().iloc[:, 0]).mean()
            lines.append(f"- {name}: |deviation| larger at {pivot.columns[-1]:g} m/s than at "
                         f"{pivot.columns[0]:g} m/s for {100 * grows:.0f} % of the coefficients.")
        elif experiment == "thesis_noise" and {-0.1, -0.05, 0.05, 0.1} <= set(pivot.columns):
            big = pivot[pivot[0.05].abs() >= NEGLIGIBLE_PCT]
            double = np.median(big[0.1] / big[0.05]) if len(big) else np.nan
            mirror = np.median(big[-0.05] / big[0.05]) if len(big) else np.nan
            lines.append(f"- {name}: deviation at +10 % / at +5 % = {_fmt(double)} (linear: 2), at -5 % / "
                         f"at +5 % = {_fmt(mirror)} (antisymmetric: -1), medians over {len(big)} coefficients.")
        elif experiment == "thesis_direction" and {-90.0, -45.0, 45.0, 90.0} <= set(pivot.columns):
            med = pivot.abs().median()
            worst = med.idxmax()
            beam = float(np.mean([med[-90.0], med[90.0]]))
            quarter = float(np.mean([med[-45.0], med[45.0]]))
            lines.append(f"- {name}: median |deviation| {beam:.1f} % at +-90 deg against {quarter:.1f} % at "
                         f"+-45 deg ({'beam winds worse' if beam > quarter else 'quartering winds worse'}); "
                         f"worst direction {worst:g} deg.")
    return "\n".join(lines) + "\n"


#: the strong-wind cells of Tables 4.6-4.8 where the thesis reports the GA's gains
STRONG_WIND = (12.0, 16.0)


def _new_tally() -> dict:
    return {"cells": 0, "ran": 0, "improved": 0, "changed": 0, "starts": [], "starts_improved": [],
            "starts_stuck": [], "moved": [], "closer": [], "strong": 0, "strong_changed": 0}


def _ga(ours: pd.DataFrame, thesis: pd.DataFrame) -> str:
    """What the GA did in each cell, beside what the thesis' tables show it did."""
    rows = []
    tally = defaultdict(_new_tally)
    for experiment, (key, tables, what) in GROUPS.items():
        t = thesis[thesis["table"].isin(tables)]
        pt = t.pivot_table(index=["value", "coefficient"], columns="method", values="deviation_pct")
        for base in ("ls", "svm"):
            for value in sorted(t["value"].unique()):
                strong = experiment == "thesis_wind_speed" and value in STRONG_WIND
                sub = pt.loc[value]
                changed = sub[(sub[f"{base}_ga"] - sub[base]).abs() > 1e-9]
                closer = int((changed[f"{base}_ga"].abs() < changed[base].abs()).sum())
                row = {"condition": _condition(key, value), "GA after": method_label(base),
                       "thesis: changed (closer to true)": f"{len(changed)} ({closer})"}
                counts = tally["thesis"]
                counts["cells"] += 1
                counts["changed"] += int(len(changed) > 0)
                counts["strong"] += int(strong)
                counts["strong_changed"] += int(strong and len(changed) > 0)
                if len(changed):
                    counts["moved"].append(len(changed))
                    counts["closer"].append(closer)
                for setup in _setups(ours):
                    o = ours[(ours["experiment"] == experiment) & (ours["setup"] == setup)
                             & (ours["value"] == value)]
                    s = o[o["series"] == base].set_index("coefficient")
                    for series in sorted(x for x in o["series"].unique() if x.startswith(f"{base}_ga")):
                        g = o[o["series"] == series].set_index("coefficient")
                        if g.empty or s.empty:
                            continue
                        variant = series.replace(f"{base}_ga", "GA")
                        label = f"{_setup_label(setup)}: {variant}"
                        moved = g.index[(g["value_identified"] - s["value_identified"].reindex(g.index)).abs()
                                        > 1e-9 * g["value_identified"].abs()]
                        near = int((g.loc[moved, "deviation_pct"].abs()
                                    < s.loc[moved, "deviation_pct"].abs()).sum())
                        first = g.iloc[0]
                        ran = bool(first["ga_initial"] > STOP_FITNESS)
                        counts = tally[label]
                        counts["cells"] += 1
                        counts["ran"] += int(ran)
                        improved = bool(ran and first["ga_best"] < first["ga_initial"])
                        counts["improved"] += int(improved)
                        counts["changed"] += int(len(moved) > 0)
                        counts["strong"] += int(strong)
                        counts["strong_changed"] += int(strong and ran and len(moved) > 0)
                        counts["starts"].append(float(first["ga_initial"]))
                        if len(moved):
                            counts["moved"].append(len(moved))
                            counts["closer"].append(near)
                        if ran:
                            counts["starts_improved" if improved else "starts_stuck"].append(
                                float(first["ga_initial"]))
                        row[label] = (f"{len(moved)} ({near}); fitness {first['ga_initial']:.2g} -> "
                                      f"{first['ga_best']:.2g}, {int(first['ga_generations'])} generations"
                                      if ran else f"not run: start {first['ga_initial']:.2g} <= {STOP_FITNESS:g}")
                rows.append(row)
    if not rows:
        return ""
    table = pd.DataFrame(rows).fillna("-").set_index("condition")
    text = ("Per cell: the coefficients the GA changed (in brackets those that moved closer to the true "
            f"value). The GA stops before its first generation when the start's fitness (eq. 3.43) is at "
            f"or below {STOP_FITNESS:g}. The thesis' GA refines 15 genes (5 per DOF).\n\n")
    lines = []
    for label, c in tally.items():
        if label == "thesis":
            line = (f"- the thesis: the GA changed the coefficients in {c['changed']} of {c['cells']} cells "
                    f"(its tables), at 12 and 16 m/s in {c['strong_changed']} of {c['strong']}")
        else:
            line = (f"- {label}: the GA ran in {c['ran']} of {c['cells']} cells, lowered the fitness in "
                    f"{c['improved']} and changed the coefficients in {c['changed']}"
                    + (f"; at 12 and 16 m/s it ran and changed them in {c['strong_changed']} of {c['strong']}"
                       if c["strong"] else "")
                    + (f"; median start fitness {np.median(c['starts']):.2g}" if c["starts"] else ""))
            if c["starts_improved"] and c["starts_stuck"]:
                line += (f" (the runs it improved started at a median of {np.median(c['starts_improved']):.2g}, "
                         f"those it could not at {np.median(c['starts_stuck']):.2g})")
        if c["moved"]:
            line += (f"; where it changed them, a median of {np.median(c['moved']):g} coefficients moved and "
                     f"{np.median(c['closer']):g} of them closer to the true value")
        lines.append(line + ".")
    return (text + markdown_table(table, "condition") + "\n" + "\n".join(lines) + "\n"
            + _ga_explanation(tally, ours, thesis))


def _above_stop(starts) -> str:
    """How many GA starts lie above the thesis' stop (:data:`STOP_FITNESS`), in words."""
    starts = np.asarray(list(starts), float)
    above = int(np.sum(starts > STOP_FITNESS))
    if above == len(starts):
        return f"every start lies above the stop {STOP_FITNESS:g} ({above} of {len(starts)})"
    return f"{above} of {len(starts)} starts lie above the stop {STOP_FITNESS:g}"


def _ga_explanation(tally: dict, ours: pd.DataFrame | None = None, thesis: pd.DataFrame | None = None) -> str:
    """Why the GA changes the coefficients or not, from the tally of the runs."""
    def find(setup_label, variant="GA"):
        return tally.get(f"{setup_label}: {variant}")
    thesis_ga = find(SETUP_LABEL[THESIS_SETUP])
    rk4_ga = find(SETUP_LABEL[THESIS_RK4_SETUP])
    project_ga = find(SETUP_LABEL[PROJECT_SETUP])
    out = [GA_MECHANISM]
    measured = []
    if project_ga and project_ga["starts"]:
        measured.append(f"on the project set-up, the fitness replays the recorded rudder, which a regression "
                        f"solution follows closely: median start {np.median(project_ga['starts']):.2g}, the GA "
                        f"ran in {project_ga['ran']} of {project_ga['cells']} cells")
    if rk4_ga and rk4_ga["starts"]:
        measured.append(f"with the zig-zag steered again on records stepped by the GA's own RK4 (the thesis "
                        f"set-up on RK4 records), {_above_stop(rk4_ga['starts'])} (median "
                        f"{np.median(rk4_ga['starts']):.2g}) and the random search changed the coefficients in "
                        f"{rk4_ga['changed']} of {rk4_ga['cells']} cells")
    if thesis_ga and thesis_ga["starts"]:
        moved = f", a median of {np.median(thesis_ga['moved']):g} genes" if thesis_ga["moved"] else ""
        measured.append(f"with the thesis' records (Euler steps as MSS `zigzag.m`, forward differences as its "
                        f"eq. 3.9) and the GA simulating by RK4, {_above_stop(thesis_ga['starts'])} (median "
                        f"{np.median(thesis_ga['starts']):.2g}) and the same random search changed the "
                        f"coefficients in {thesis_ga['changed']} of {thesis_ga['cells']} cells{moved}")
    th = tally.get("thesis")
    if measured:
        out.append("Measured in the runs above: " + "; ".join(measured) + "."
                   + (f" The thesis' GA changed {th['changed']} of {th['cells']} cells, a median of "
                      f"{np.median(th['moved']):g} genes each, {np.median(th['closer']):g} of them closer to "
                      "the true value: the pattern of a random search whose starts lie above the best of its "
                      "draws, which the project finds when the records and the GA's simulator differ and not "
                      "when they are the same." if th and th["moved"] else ""))
    if ours is not None and thesis is not None and thesis_ga and thesis_ga["starts"]:
        mine, theirs = svm_departure(ours, thesis, "thesis_wind_speed", THESIS_SETUP)
        if np.isfinite(mine) and np.isfinite(theirs):
            out.append(f"Where the thesis' GA left SVM unchanged (4 and 8 m/s, its start \"very close to the "
                       f"stopping criterion\", section 5.3) the project's GA starts from its SVM, which departs "
                       f"from its LS by a median of {mine:.2f} percentage points of deviation (the thesis' SVM "
                       f"from its LS by {theirs:.2f}): the project's SVM start is its LS start, lifted as the "
                       "LS start is, so its GA changes the SVM too.")
    out.append(GA_CAVEAT)
    return "\n".join(out)


GA_MECHANISM = """
Why the GA changes the coefficients or not. The thesis' GA simulates the
20/20 zig-zag again with each candidate (its appendix A.4,
`zigzag(..., 4000., 10., 0.1, [20., 20.], solution / 1e5)`), so the rudder is
reversed when the candidate's heading reaches 20 deg, and small coefficient
errors shift the reversals and add up over the record's 4000 s of cycles
(`objective.simulation=closed_loop`, part of `conventions=zhu2021`). With
the thesis' mutation probability 1 every gene of an offspring is redrawn
uniformly within its +-50 % bounds (pygad's mutation by gene space, in the
thesis' 2021 releases as in the current one): the GA is a random search of
a 15-dimensional box that keeps a draw only when it beats the start. Around
a regression solution whose records the GA's simulator reproduces, the
closed-loop fitness is a narrow valley that joint redraws of all 15 genes
seldom hit, while moving one gene alone can lower it several times
(`tests/test_thesis_reproduction.py`); a mutation probability of 0.1 (about
one gene redrawn per offspring, `method.mutation_probability=0.1`, its own
column when run) finds such moves. When the records come from another
simulator than the GA's (the thesis' from MSS, its GA from its own
`ga_opt_trajectory1.zigzag`), even the true model does not reproduce them,
its start lies above the valley's floor, and joint redraws can beat it; the
measured starts below say how often that happened.
"""

GA_CAVEAT = """
Neither makes the GA a tool for recovering the true coefficients: the
fitness compares the model with the record under the recorded (wrong) wind,
so its optimum is not the true model; the column of coefficients moved
closer to the true value shows how often it helps. The thesis does not give
its GA's zig-zag code, so the size of its records' difference from that
code cannot be checked; the project's Euler records against its RK4 GA are
a difference of this kind, not necessarily of the thesis' size.
"""


#: what the thesis says of its validation figures (section, figure, words)
THESIS_VALIDATION = {
    "thesis_wind_speed": "4.2.1, Fig. 4.1: \"SVM has best performance in the case of 4m/s, 8m/s and 12m/s in "
                         "three simulated manoeuvres while in the case of 16m/s in zigzag 20/20, SVM+GA "
                         "outperforms it with small margin\" (9 cells named for SVM: 4, 8 and 12 m/s in the three "
                         "manoeuvres; SVM+GA at 16 m/s in zig-zag 20/20)",
    "thesis_noise": "4.2.2, Fig. 4.2: \"generalization performance of SVM is the best when looking through "
                    "all 3 comparisons\"; SVM+GA best at +10 % in zig-zags 20/20 and 40/40",
    "thesis_direction": "4.2.3, Fig. 4.3: LS+GA and SVM+GA best at -45 deg in zig-zag 10/10, SVM+GA at -45 "
                        "and -90 deg in 20/20, LS+GA at 90 deg in 20/20; \"in zigzag 40/40, LS and SVM "
                        "have prominent compared with other two\"",
}


def svm_departure(ours: pd.DataFrame, thesis: pd.DataFrame, experiment: str, setup: str) -> tuple:
    """How far SVM's coefficients are from LS's in one experiment: the median
    over conditions and coefficients of |deviation(SVM) - deviation(LS)|
    [percentage points], the project's under ``setup`` and the thesis'."""
    key, tables, _ = GROUPS[experiment]
    t = thesis[thesis["table"].isin(tables)].pivot_table(index=["value", "coefficient"], columns="method",
                                                         values="deviation_pct")
    o = ours[(ours["experiment"] == experiment) & (ours["setup"] == setup)] if not ours.empty else ours
    o = o.pivot_table(index=["value", "coefficient"], columns="series", values="deviation_pct") \
        if len(o) else pd.DataFrame()
    theirs = float(np.median((t["svm"] - t["ls"]).abs())) if {"svm", "ls"} <= set(t.columns) else np.nan
    mine = float(np.median((o["svm"] - o["ls"]).dropna().abs())) if {"svm", "ls"} <= set(o.columns) else np.nan
    return mine, theirs


#: two validation fitnesses within this fraction of each other tie (the project's SVM often lands on its LS)
FIGURE_TIE = 0.01
#: the cells the thesis' text names for its Figs 4.1-4.3 (sections 4.2.1-4.2.3): (experiment, manoeuvre,
#: condition value, claim, methods): "best" = the lowest validation fitness of the four methods is one of
#: ``methods``; "below_ls" = the first method's fitness is below LS's
FIGURE_CLAIMS = tuple(
    [("thesis_wind_speed", f"zigzag_{a}_{a}", v, "best", ("svm",)) for v in (4.0, 8.0, 12.0) for a in (10, 20, 40)]
    + [("thesis_wind_speed", "zigzag_20_20", 16.0, "best", ("svm_ga",)),
       ("thesis_wind_speed", "zigzag_10_10", 12.0, "below_ls", ("ls_ga",)),
       ("thesis_wind_speed", "zigzag_20_20", 16.0, "below_ls", ("ls_ga",)),
       ("thesis_noise", "zigzag_20_20", 0.10, "best", ("svm_ga",)),
       ("thesis_noise", "zigzag_40_40", 0.10, "best", ("svm_ga",)),
       ("thesis_noise", "zigzag_10_10", -0.05, "below_ls", ("ls_ga",)),
       ("thesis_noise", "zigzag_10_10", 0.10, "below_ls", ("ls_ga",)),
       ("thesis_noise", "zigzag_20_20", 0.05, "below_ls", ("ls_ga",)),
       ("thesis_noise", "zigzag_20_20", 0.10, "below_ls", ("ls_ga",)),
       ("thesis_direction", "zigzag_10_10", -45.0, "best", ("ls_ga", "svm_ga")),
       ("thesis_direction", "zigzag_10_10", -90.0, "best", ("svm_ga",)),
       ("thesis_direction", "zigzag_20_20", -45.0, "best", ("svm_ga",)),
       ("thesis_direction", "zigzag_20_20", -90.0, "best", ("svm_ga",)),
       ("thesis_direction", "zigzag_20_20", 90.0, "best", ("ls_ga",))])


def figure_claims(table: pd.DataFrame, setup) -> pd.DataFrame:
    """Each cell of :data:`FIGURE_CLAIMS` judged on the validation fitnesses of ``setup`` (the latest
    bounded run per method; a diverged prediction loses): ``holds``, ``does not hold`` or ``not
    measured`` (a method of the claim, or LS, has no run in that cell)."""
    rows = []
    for experiment, manoeuvre, value, kind, methods in FIGURE_CLAIMS:
        sub = table[(table["experiment"] == experiment) & (table["setup"] == setup)
                    & (table["manoeuvre"] == manoeuvre) & np.isclose(table["value"], value)]
        sub = sub.sort_values("start").groupby("series").last()
        fitness = {m: (np.inf if r.diverged else float(r.fitness)) for m, r in sub.iterrows()
                   if m in ("ls", "ls_ga", "svm", "svm_ga")}
        claim = (f"{' or '.join(method_label(m) for m in methods)} lowest" if kind == "best"
                 else f"{method_label(methods[0])} below LS")
        needed = set(methods) | ({"ls"} if kind == "below_ls" else set())
        if kind == "best" and len(fitness) < 4 or not needed <= set(fitness):
            verdict, found = "not measured", "-"
        elif kind == "best":
            lowest = min(fitness, key=fitness.get)
            claimed = min(fitness[m] for m in methods)
            if lowest in methods:
                verdict = "holds"
            elif claimed <= (1.0 + FIGURE_TIE) * fitness[lowest]:
                verdict = "tied"
            else:
                verdict = "does not hold"
            found = f"{method_label(lowest)} lowest ({fitness[lowest]:.3g})" + (
                f", the claimed {claimed:.3g}" if lowest not in methods else "")
        else:
            ratio = fitness[methods[0]] / fitness["ls"] if fitness["ls"] > 0 else np.nan
            verdict = "holds" if fitness[methods[0]] < fitness["ls"] else "does not hold"
            found = f"{ratio:.3g} x LS" if np.isfinite(ratio) else "-"
        rows.append({"figure": {"thesis_wind_speed": "4.1", "thesis_noise": "4.2", "thesis_direction": "4.3"}[experiment],
                     "manoeuvre": manoeuvre, "condition": _condition(GROUPS[experiment][0], value),
                     "thesis": claim, "project": found, "verdict": verdict})
    return pd.DataFrame(rows)


def _validation_section(runs: dict, ours: pd.DataFrame | None = None, thesis: pd.DataFrame | None = None) -> str:
    table = _validation(runs)
    if table.empty:
        return ""
    out = []
    for setup in _setups(table):
        claims = figure_claims(table, setup)
        if (claims["verdict"] != "not measured").any():
            counts = claims.groupby("figure")["verdict"].value_counts().unstack(fill_value=0)
            summary = "; ".join(f"Fig. {f}: {int(c.get('holds', 0))} hold, {int(c.get('tied', 0))} tied, "
                                f"{int(c.get('does not hold', 0))} do not"
                                + (f", {int(c.get('not measured', 0))} not measured" if c.get("not measured", 0) else "")
                                for f, c in counts.iterrows())
            out.append(f"**The cells the thesis' text names for Figs 4.1-4.3, {_setup_label(setup)}** "
                       f"(sections 4.2.1-4.2.3; a diverged prediction loses; within {100 * FIGURE_TIE:g} % of the "
                       f"lowest the claimed method ties): {summary}.\n\n"
                       + markdown_table(claims.set_index("figure"), "figure") + "\n")
    for experiment, (key, tables, what) in GROUPS.items():
        for setup in _setups(table):
            sub = table[(table["experiment"] == experiment) & (table["setup"] == setup)]
            if sub.empty:
                continue
            bounded = sub[~sub["diverged"]]
            pivot = bounded.pivot_table(index=["manoeuvre", "value"], columns="series", values="fitness")
            diverged = sub[sub["diverged"]].groupby("series").size()
            wins = 0
            cells = 0
            if {"ls", "svm"} <= set(pivot.columns):
                both = pivot[["ls", "svm"]].dropna()
                cells = len(both)
                wins = int((both["svm"] < both["ls"]).sum())
            shown = pivot.copy()
            shown.index = [f"{m}, {_condition(key, v)}" for m, v in shown.index]
            shown.columns = [_series_label(c) for c in shown.columns]
            note = (f"Diverged predictions (counted, not averaged): "
                    + ", ".join(f"{_series_label(s)} {n}" for s, n in diverged.items()) + ". ") if len(diverged) else ""
            best = pivot.idxmin(axis=1) if len(pivot.columns) else pd.Series(dtype=str)
            best_count = best.value_counts()
            best_text = ", ".join(f"{_series_label(m)} {n}" for m, n in best_count.items())
            cause = ""
            if cells and ours is not None and thesis is not None:
                mine, theirs = svm_departure(ours, thesis, experiment, setup)
                gap = float(np.median(np.abs(both["svm"] - both["ls"]) / both["ls"]))
                if np.isfinite(mine) and np.isfinite(theirs):
                    cause = (f" Measured: the project's SVM coefficients depart from its LS ones by a median of "
                             f"{mine:.2f} percentage points of deviation, the thesis' by {theirs:.2f} (its "
                             f"LinearSVR, C = 1, epsilon = 0 on unscaled columns; see the substitutions); the two "
                             f"validation fitnesses differ by a median of {100 * gap:.0f} %, so which of SVM and LS "
                             "validates better is decided by "
                             + ("differences of that size, not by a property of the method"
                                if mine < 0.25 * theirs else "the SVM's own departure from LS") + ".")
            out.append(f"**{what}, {_setup_label(setup)}**: validation fitness (eq. 3.43) in 10 m/s wind from "
                       f"45 deg. {note}Lowest of the methods per cell: {best_text} (of {len(pivot)} cells); "
                       f"SVM below LS in {wins} of {cells}. The thesis, section "
                       f"{THESIS_VALIDATION[experiment]}.{cause}\n\n"
                       + markdown_table(shown.map(lambda x: f"{x:.3g}"), "manoeuvre, condition"))
    return "\n".join(out)


def _series_label(series: str) -> str:
    """``LS+GA``, or ``LS+GA (mutation 0.1)`` for a GA variant."""
    method, _, rest = series.partition(" ")
    return method_label(method) + (f" {rest}" if rest else "")


def _columns(ours: pd.DataFrame) -> list:
    """The four methods, each GA followed by its variants found in ``ours``."""
    found = set(ours["series"]) if not ours.empty else set()
    out = []
    for method in METHODS:
        out.append(method)
        out += sorted(s for s in found if s.startswith(f"{method} ("))
    return out


def _side_by_side(ours: pd.DataFrame, thesis: pd.DataFrame) -> list:
    """Tables 4.6-4.14: per table and condition, thesis / project under each
    set-up, for LS, LS+GA, SVM, SVM+GA and every GA variant the store holds
    (beside the thesis' GA column)."""
    sections = []
    setups = _setups(ours)
    columns = _columns(ours)
    for experiment, (key, tables, what) in GROUPS.items():
        for table_id in tables:
            t = thesis[thesis["table"] == table_id]
            page = int(t["page"].iloc[0])
            parts = []
            for value in sorted(t["value"].unique()):
                rows = {}
                tv = t[t["value"] == value].pivot_table(index="coefficient", columns="method",
                                                        values="deviation_pct", sort=False)
                for series in columns:
                    base = series.partition(" ")[0]
                    cells = [f"{tv.loc[c, base]:.2f}" for c in tv.index]
                    for setup in setups:
                        o = ours[(ours["experiment"] == experiment) & (ours["setup"] == setup)
                                 & (ours["value"] == value) & (ours["series"] == series)]
                        o = o.set_index("coefficient")["deviation_pct"]
                        cells = [f"{c} / {o[k]:.2f}" if k in o.index else f"{c} / -"
                                 for c, k in zip(cells, tv.index)]
                    rows[_series_label(series)] = cells
                frame = pd.DataFrame(rows, index=list(tv.index))
                parts.append(f"*{_condition(key, value)}*\n\n" + markdown_table(frame, "coefficient"))
            order = " / ".join(["thesis"] + [f"project ({_setup_label(s)})" for s in setups])
            sections.append((f"Table {table_id} (thesis p. {page}): deviation [%], {order}",
                             "A GA variant's column (mutation probability other than the thesis' 1) shows the "
                             "thesis' own GA column beside the project's variant.\n\n" + "\n".join(parts)))
    return sections


def _spread_by_condition(experiment: str, value: float, setup: str) -> dict:
    """How well the condition's training record pins each coefficient down
    (:func:`studies.workflows.reproduction.zhu2021.spread_by_condition`)."""
    return spread_by_condition(GROUPS[experiment][0], value, setup)


#: a disagreement within this many times the coefficient's spread over the quarters is ill-determined
SPREAD_FACTOR = 2.0


#: cause categories of a disagreement (the summary counts them)
ILL_DETERMINED = "ill-determined coefficient"
SVM_VARIANT = "the thesis' SVM (LinearSVR) differs from the project's"
NEGLIGIBLE = "below 2 % and within the record's spread"
UNEXPLAINED = "not explained"


def disagreements(ours: pd.DataFrame, thesis: pd.DataFrame, setup=THESIS_SETUP) -> list:
    """``(table, condition, method, coefficient, thesis, ours, category, cause)``
    of every LS/SVM deviation that differs in sign (both at least
    NEGLIGIBLE_PCT), by more than RATIO_OFF in size, or is negligible in one
    and not below 3 NEGLIGIBLE_PCT in the other."""
    out = []
    spreads = {}
    for experiment, (key, tables, what) in GROUPS.items():
        ls_pairs = _pair(ours, thesis, experiment, setup, "ls")
        svm_thesis = thesis[(thesis["table"].isin(tables)) & (thesis["method"] == "svm")]
        for method in ("ls", "svm"):
            pairs = _pair(ours, thesis, experiment, setup, method)
            if pairs.empty:
                continue
            for r in pairs.itertuples():
                a, b = r.deviation_pct_thesis, r.deviation_pct_ours
                small = min(abs(a), abs(b)) < NEGLIGIBLE_PCT
                opposite = np.sign(a) != np.sign(b)
                ratio = abs(b) / max(abs(a), 1e-12)
                if small and max(abs(a), abs(b)) < 3 * NEGLIGIBLE_PCT:
                    continue
                if not small and not opposite and 1 / RATIO_OFF <= ratio <= RATIO_OFF:
                    continue
                cell = (experiment, r.value)
                if cell not in spreads:
                    spreads[cell] = _spread_by_condition(experiment, r.value, setup)
                other = svm_thesis if method == "ls" else thesis[(thesis["table"].isin(tables))
                                                                 & (thesis["method"] == "ls")]
                other = other[(other["value"] == r.value) & (other["coefficient"] == r.coefficient)]
                own_other = float(other["deviation_pct"].iloc[0]) if len(other) else np.nan
                ls_row = ls_pairs[(ls_pairs["value"] == r.value) & (ls_pairs["coefficient"] == r.coefficient)] \
                    if not ls_pairs.empty else ls_pairs
                category, cause = _cause(a, b, spreads[cell].get(r.coefficient, np.nan), method, ls_row,
                                         own_other, small, opposite)
                out.append((r.table, _condition(key, r.value), method_label(method), r.coefficient, a, b,
                            category, cause))
    return out


def _cause(a, b, spread, method, ls_row, own_other, small, opposite) -> tuple:
    """``(category, sentence)`` of one disagreement, from measured properties."""
    what = ("opposite signs" if opposite and not small else
            "one of them below 2 %" if small else f"magnitudes {abs(b) / abs(a):.1f} times")
    if method == "svm" and len(ls_row):
        lt, lo = ls_row["deviation_pct_thesis"].iloc[0], ls_row["deviation_pct_ours"].iloc[0]
        if abs(a - lt) > max(NEGLIGIBLE_PCT, 0.2 * abs(lt)) and abs(b - lo) <= max(NEGLIGIBLE_PCT, 0.2 * abs(lo)):
            return SVM_VARIANT, (
                f"{what}; the thesis' SVM departs from its own LS here ({lt:.1f} -> {a:.1f} %) while the "
                f"project's SVM stays with its LS ({lo:.1f} -> {b:.1f} %): the thesis' LinearSVR (C = 1, "
                "epsilon = 0, its appendix A.2) fits a surge intercept that it drops and regularises the "
                "unscaled columns; the project's cross-validated SVR reproduces least squares on noise-free "
                "records")
        if abs(lt - lo) <= max(NEGLIGIBLE_PCT, 0.2 * abs(lt)):
            pinned = (f", on a coefficient the record does not pin down (it moves by {spread:.1f} points between "
                      "the record's quarters)" if np.isfinite(spread) and abs(a - b) <= SPREAD_FACTOR * spread
                      else "")
            return SVM_VARIANT, (
                f"{what}; the two least-squares solutions agree here (thesis {lt:.1f} %, project {lo:.1f} %), "
                f"so the records agree and the SVMs differ{pinned}: the thesis' LinearSVR (C = 1, epsilon = 0, "
                f"unscaled columns, its appendix A.2) moves it from its LS to {a:.1f} %, the project's "
                f"cross-validated SVR on scaled columns to {b:.1f} %")
    if np.isfinite(spread) and abs(a - b) <= SPREAD_FACTOR * spread:
        own = (f"; the thesis' own {'SVM' if method == 'ls' else 'LS'} gives {own_other:.1f} % for it"
               if np.isfinite(own_other) else "")
        return ILL_DETERMINED, (
            f"{what}; the record does not pin it down: its deviation moves by {spread:.1f} percentage points "
            f"(standard deviation) between the four 1000 s quarters of this condition's zig-zag, and the "
            f"thesis and the project differ by {abs(a - b):.1f}, so details of the record that the thesis "
            f"does not publish (it gives neither the record nor the precision it was stored with) decide how "
            f"the wind-error force is shared among the collinear terms{own}")
    if small and np.isfinite(spread) and abs(a - b) <= 2 * SPREAD_FACTOR * spread:
        return NEGLIGIBLE, (f"{what}; the smaller deviation has no meaningful sign and the two differ by "
                            f"{abs(a - b):.1f} points, within {2 * SPREAD_FACTOR:g} times the "
                            f"{spread:.1f} points the coefficient moves between the record's quarters")
    return UNEXPLAINED, (f"{what}; not explained: the record pins the coefficient down (it moves by "
                         f"{spread:.1f} points between the record's quarters) and both deviations are clear")


def _disagreement_section(ours: pd.DataFrame, thesis: pd.DataFrame) -> str:
    if ours.empty or not (ours["setup"] == THESIS_SETUP).any():
        return ("Run the presets with `conventions=zhu2021` to compare the deviations under the thesis' own "
                "set-up; under the project's set-up the side force of the wind is mirrored (see the "
                "conventions above), so sway and yaw deviations may differ in sign for that one reason "
                "(not measured: no run under the thesis set-up).\n")
    found = disagreements(ours, thesis)
    if not found:
        return "No LS or SVM deviation of the thesis set-up disagrees in sign or by more than 3 times.\n"
    counts = pd.Series([f[6] for f in found]).value_counts()
    summary = ", ".join(f"{n} {c}" for c, n in counts.items())
    frame = pd.DataFrame([f[:6] + (f[7],) for f in found],
                         columns=["table", "condition", "method", "coefficient", "thesis [%]", "project [%]",
                                  "cause"])
    frame["thesis [%]"] = frame["thesis [%]"].map(lambda x: f"{x:.2f}")
    frame["project [%]"] = frame["project [%]"].map(lambda x: f"{x:.2f}")
    return (f"Under the thesis set-up, {len(found)} of the LS and SVM deviations differ in sign (both at "
            f"least {NEGLIGIBLE_PCT:g} %), by more than {RATIO_OFF:g} times, or one is below "
            f"{NEGLIGIBLE_PCT:g} % where the other is at least {3 * NEGLIGIBLE_PCT:g} %. By cause: {summary}. "
            "The GA columns are not listed: each is one random search of the thesis and one of the project "
            "(see the GA section).\n\n" + markdown_table(frame.set_index("table"), "table"))


def substitutions(runs: dict) -> list:
    return [
        "Data: the thesis simulated its 20/20 zig-zag (4000 s at 0.1 s) in the Marine Systems Simulator, "
        "whose `zigzag.m` takes forward Euler steps of `mariner.m` and lays the rudder to starboard first "
        "(`mariner.m` takes the command with the opposite sign), and differenced it forward (its eq. 3.9). "
        "The thesis set-up (`conventions=zhu2021`) makes its records the same way (`data.scheme=euler`, "
        "`manoeuvre.first_sign=-1`, `data.derivative=forward`); the project set-up simulates by RK4 to port "
        "first and differences centrally. Not reproduced: `zigzag.m` holds the rudder amidships until its "
        "execute time (10 s in the thesis' GA call; the record's is not given) and the thesis' records as "
        "stored (`zigzag.m` returns r in deg/s; their precision is not given). The wind particulars are the "
        "thesis' (Table 4.1, Blendermann's loaded cargo ship, as MSS `blendermann94` vessel 2).",
        "SVM: the thesis used scikit-learn's LinearSVR with C = 1 and epsilon = 0 on the unscaled "
        "regressors (its appendix A.2); the project's `svm` chooses C and epsilon by time-blocked "
        "cross-validation on scaled columns and lands on least squares on these noise-free records, "
        "where the thesis' departs from its own LS on several surge terms (its LinearSVR fits an "
        "intercept in surge that the code then drops).",
        "GA: the thesis' settings (15 least Sobol-sensitive genes, +-50 % bounds, 200 generations, "
        "crossover 0.6, mutation probability 1, rank selection, 3 parents kept, stop at 1e-5) in pygad 3 "
        "(the thesis does not name its pygad version); the start solution plus 4 copies as in its text (its code passes 4 rows). "
        "Its fitness simulates the zig-zag by the project's RK4: the thesis' GA simulated with its own "
        "`ga_opt_trajectory1.zigzag` (appendix A.4), which it does not give.",
        "Validation (Figs 4.1-4.3): zig-zags 10/10, 20/20 and 40/40 of 600 s in 10 m/s wind from 45 deg, "
        "as the thesis; the thesis shows these as figures only, so they are compared in words.",
    ]


def conventions(runs: dict) -> list:
    return [
        "Wind (eq. 3.17): the thesis prints, and its code computes, v_rw = v - V_w sin(beta_w - psi) beside "
        "u_rw = u + V_w cos(beta_w - psi); with beta_w the direction the wind comes from, this mirrors the "
        "side force (a wind from starboard pushes the ship to starboard). The project's default "
        "(`wind.convention=downwind`) pushes the ship downwind; `conventions=zhu2021` uses the thesis' form "
        "and MSS `blendermann94`'s yaw moment in the data and in the identification alike. Which reading "
        "reproduces the thesis' numbers is measured in the first table below (sign agreement).",
        "Wind-speed error (eq. 4.1): in both, the identification sees V_w (1 + error) while V_w acted "
        "(the thesis' appendix code reads `v_p = v_w = 12 * (1 + n1[0])`: the regression's wind loads "
        "from the wind speed with its error).",
        "GA fitness (eq. 3.43): the thesis' code simulates the zig-zag again with each candidate; the "
        "project's default replays the recorded rudder (`objective.simulation=replay`); "
        "`conventions=zhu2021` steers the zig-zag again (`closed_loop`). The thesis' code compares r in "
        "deg/s (its records store deg/s), the project in rad/s: about twice the fitness in the thesis' "
        "units, the same order.",
    ]


#: the calm-water experiment of Tables 4.3-4.5
CALM = "thesis_calm"


def _printed_digits(value: float, digits: int = 3) -> float:
    """``value`` rounded to ``digits`` significant digits, as the thesis prints its tables."""
    if not np.isfinite(value) or value == 0:
        return value
    return float(f"{value:.{digits - 1}e}")


def calm_verdicts(paper: pd.DataFrame, ours: dict) -> pd.DataFrame:
    """Tables 4.3-4.5 beside the project's calm-water runs, one row per coefficient and method.

    ``ours`` maps ``(method, coefficient)`` to the project's identified value. A value agrees with
    the thesis' when both round to the same three significant digits (the tables' precision); for a
    value that does not, the deviations from the original are compared: ``both off`` when both
    depart from the original at its printed precision, else ``differs``."""
    rows = []
    for r in paper.itertuples():
        original = float(r.original)
        for method in ("ls", "svm"):
            theirs = float(getattr(r, method))
            mine = ours.get((method, r.coefficient), np.nan)
            if not np.isfinite(mine):
                verdict = "not measured"
            elif _printed_digits(mine) == _printed_digits(theirs):
                verdict = "same"
            elif _printed_digits(mine) != _printed_digits(original) and \
                    _printed_digits(theirs) != _printed_digits(original):
                verdict = "both off"
            else:
                verdict = "differs"
            cause = "-"
            if verdict == "differs":
                if _printed_digits(mine) == _printed_digits(original):
                    cause = ("the project's value is the original; the thesis' departs"
                             + (" (its LinearSVR: C = 1, epsilon = 0, unscaled regressors, appendix A.2)"
                                if method == "svm" else ""))
                elif _printed_digits(theirs) == _printed_digits(original):
                    cause = "the thesis' value is the original; the project's departs: not explained"
                else:
                    cause = "not explained"
            rows.append({"table": r.table, "coefficient": r.coefficient, "method": method.upper(),
                         "original": original, "thesis": theirs, "project": mine,
                         "thesis dev [%]": 100 * (theirs - original) / original,
                         "project dev [%]": 100 * (mine - original) / original if np.isfinite(mine) else np.nan,
                         "verdict": verdict, "cause": cause})
    return pd.DataFrame(rows)


def _calm_section(runs: list, scratch: Path) -> str | None:
    """Tables 4.3-4.5 (calm water, clean data) beside the latest finished LS and SVM runs of
    ``experiment=thesis_calm`` in the thesis' set-up; None without such runs."""
    ours = latest_coefficients(runs, scratch, "value", keep=lambda run: _setup_of(run) == THESIS_SETUP)
    if not ours:
        return None
    table = calm_verdicts(published("thesis", "calm"), ours)
    lines = [f"The thesis' Tables 4.3-4.5 (20/20 zig-zag in calm water, clean data) beside the project's "
             f"`{CALM}` runs in the thesis' set-up. A value agrees when it rounds to the thesis' three "
             "significant digits; `both off` when both depart from the original at that precision. "
             "Per table and method:", ""]
    for (t, method), part in table.groupby(["table", "method"], sort=True):
        counts = part["verdict"].value_counts()
        lines.append(f"- Table {t}, {method}: {counts.get('same', 0)} of {len(part)} the same, "
                     f"{counts.get('both off', 0)} both off the original, {counts.get('differs', 0)} differ"
                     + (f", {counts.get('not measured', 0)} not measured" if counts.get("not measured") else ""))
    off = table[table["verdict"] != "same"].copy()
    if len(off):
        for col in ("original", "thesis", "project"):
            off[col] = off[col].map(lambda x: f"{x:.3e}" if np.isfinite(x) else "-")
        for col in ("thesis dev [%]", "project dev [%]"):
            off[col] = off[col].map(lambda x: f"{x:+.2f}" if np.isfinite(x) else "-")
        lines += ["", "The coefficients that are not the same, with the measured cause (the thesis attributes "
                  "its SVM's departures to \"the instability of the method or selection of regularization "
                  "factor C\", section 4.1; the project's SVM chooses C by cross-validation):", "",
                  markdown_table(off.set_index("table"), "table")]
    return "\n".join(lines) + "\n"


def sections(runs: dict, out: Path) -> list:
    scratch = Path(tempfile.mkdtemp(prefix="studies-reproduce-"))
    try:
        ours = _collect(runs, scratch)
        calm = _calm_section(runs.get(CALM), scratch)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    thesis = _thesis()
    calm_part = [("Tables 4.3-4.5: calm water, clean data", calm)] if calm else []
    if ours.empty:
        return calm_part + [("No runs", "The store holds no finished run of the wind presets.\n")]
    result = calm_part + [("Agreement with Tables 4.6-4.14", _overview(ours, thesis)),
              ("Trends the thesis describes", _trends(ours, thesis))]
    ga = _ga(ours, thesis)
    if ga:
        result.append(("The GA refinement (thesis 5.2-5.3)", ga))
    validation = _validation_section(runs, ours, thesis)
    if validation:
        result.append(("Validation fitness (Figs 4.1-4.3)", validation))
    result.append(("Disagreements and their causes", _disagreement_section(ours, thesis)))
    result += _side_by_side(ours, thesis)
    return result
