"""Li et al. (2023) beside the project's runs: ``studies report report.compare=li2023``.

The paper simplifies the Mariner's Abkowitz model by correlation and
sensitivity analysis and shows the simplified model identified better under
weak excitation. The project derives its own simplified model from data
(``studies simplify``, :mod:`studies.workflows.simplify`, MLflow experiment
``simplification``) and runs the paper's excitation experiment
(``experiment=excitation``). This page compares, each with a computed
verdict:

- **Table 2**, the groups of strongly correlated coefficients (Spearman
  > 0.7): per paper group, whether the project's groups hold the same
  terms, split them, or join them with others; for a split, the project's
  measured |rho| between the group's terms;
- **the mean PAWN index per DOF** (0.239, 0.232, 0.211 in the text): agrees
  when the paper's value lies within the project's mean +- twice the mean
  of its coefficients' standard deviations over the stability-selection
  draws (a conservative band: the deviations of the coefficients are not
  independent);
- **eq. 23-25**, the simplified model, term by term against the model the
  rule derives on the project's data (before the admissibility additions)
  and the model it keeps;
- **Fig. 10**: its bars are not in the text copy, only what the text says
  of them (which model predicts better after training on each manoeuvre);
  the project's verdict is the lower median speed MAE over the seeds at 5 %
  noise of the full model and the simplified ones, a model whose
  predictions diverged in most seeds counting as the worse.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from ...markdown import markdown_table
from ...papers import published

__all__ = ["EXPERIMENTS", "COMMANDS", "sections", "substitutions", "conventions", "group_verdicts",
           "pawn_verdicts", "term_verdicts", "excitation_verdicts"]

EXPERIMENTS = ("simplification", "excitation")
COMMANDS = ["studies simplify", "studies run experiment=excitation"]
#: Spearman |rho| above which the paper puts coefficients in one group
GROUP_THRESHOLD = 0.7
#: the paper's noise level of Fig. 10's main comparison
NOISE = 0.05
DOFS = ("X", "Y", "N")
MODELS = {"abkowitz": "complete (Abkowitz)", "simplified": "simplified (project's rule)",
          "simplified_li2023": "simplified (eq. 23-25)"}
#: the paper's words for its two models
PAPER_WORDS = {"abkowitz": "complete", "simplified": "simplified"}


def _paper(kind: str) -> pd.DataFrame:
    table = published("li2023", "tables")
    return table[table["kind"] == kind].reset_index(drop=True)


def _latest(runs: list):
    done = [r for r in runs or [] if r.status == "FINISHED"]
    return max(done, key=lambda r: r.start_time) if done else None


def _analysis(run, scratch: Path) -> dict | None:
    local = run.artifact("simplification.json", scratch)
    return json.loads(local.read_text()) if local is not None else None


def _spearman(run, dof: str, scratch: Path) -> pd.DataFrame | None:
    local = run.artifact(f"spearman_{dof}.csv", scratch)
    return pd.read_csv(local, index_col=0) if local is not None else None


# ------------------------------------------------------------------ Table 2
def group_verdicts(paper_groups: pd.DataFrame, project_groups: dict, spearman: dict | None = None) -> pd.DataFrame:
    """One row per paper group: ``dof``, ``group``, ``paper`` (its terms), ``project`` (the project's groups
    holding them), ``verdict`` (``same``, ``split``, ``joined``: the project's group holds more terms,
    ``not in the model``) and ``evidence`` (for a split, the project's smallest |rho| between the paper
    group's terms, against :data:`GROUP_THRESHOLD`)."""
    rows = []
    for row in paper_groups.itertuples():
        terms = str(row.terms).split()
        found = [g for g in project_groups.get(row.dof, []) if set(g) & set(terms)]
        held = {t for g in found for t in g}
        if not found:
            verdict, evidence = "not in the model", "the project's groups do not hold these terms"
        elif len(found) == 1 and set(found[0]) == set(terms):
            verdict, evidence = "same", ""
        elif len(found) == 1:
            verdict = "joined"
            evidence = f"the project's group also holds {', '.join(sorted(set(found[0]) - set(terms)))}"
        else:
            verdict, evidence = "split", ""
            rho = (spearman or {}).get(row.dof)
            if rho is not None and all(t in rho.index for t in terms):
                pairs = [abs(float(rho.loc[a, b])) for i, a in enumerate(terms) for b in terms[i + 1:]]
                evidence = (f"the project's smallest |rho| between them is {min(pairs):.2f}"
                            + (f", below {GROUP_THRESHOLD:g}" if min(pairs) <= GROUP_THRESHOLD else ""))
        missing = set(terms) - held
        if missing and verdict != "not in the model":
            evidence = (evidence + "; " if evidence else "") + f"{', '.join(sorted(missing))} in no project group"
        rows.append({"dof": row.dof, "group": int(row.group), "paper": " ".join(terms),
                     "project": "; ".join(" ".join(g) for g in found) or "-", "verdict": verdict,
                     "evidence": evidence or "-"})
    return pd.DataFrame(rows)


# ------------------------------------------------------------------ PAWN
def pawn_verdicts(paper_means: pd.DataFrame, metrics: dict, analysis: dict) -> pd.DataFrame:
    """Per DOF: the paper's and the project's mean PAWN index, the project's band (mean +- 2 x the mean
    of its coefficients' standard deviations over the draws) and whether the paper's value is in it."""
    selection = analysis.get("selection", {})
    rows = []
    for row in paper_means.itertuples():
        mine = float(metrics.get(f"simplify/{row.dof}/mean_pawn", np.nan))
        sds = [float(v["pawn_sd"]) for name, v in selection.items() if name.startswith(row.dof)]
        half = 2.0 * float(np.mean(sds)) if sds else np.nan
        theirs = float(row.value)
        ok = bool(np.isfinite(mine) and np.isfinite(half) and abs(mine - theirs) <= half)
        rows.append({"dof": row.dof, "paper": theirs, "project": mine, "band": half,
                     "verdict": "agrees" if ok else ("not measured" if not np.isfinite(mine) else "differs")})
    return pd.DataFrame(rows)


# ------------------------------------------------------------------ eq. 23-25
def term_verdicts(paper_terms: pd.DataFrame, analysis: dict) -> pd.DataFrame:
    """Per DOF: the terms of eq. 23-25, those the project's rule keeps on its data
    (``rule_keep``) and those its model keeps (``keep``: with the admissibility additions), and the
    terms in which they differ."""
    rows = []
    for row in paper_terms.itertuples():
        paper = set(str(row.terms).split())
        rule = set(analysis.get("rule_keep", {}).get(row.dof, []))
        keep = set(analysis.get("keep", {}).get(row.dof, []))
        rows.append({"dof": row.dof, "paper": " ".join(sorted(paper)), "rule": " ".join(sorted(rule)) or "-",
                     "model": " ".join(sorted(keep)) or "-",
                     "both": len(paper & rule), "paper only": " ".join(sorted(paper - rule)) or "-",
                     "project only": " ".join(sorted(rule - paper)) or "-",
                     "verdict": "same" if paper == rule else "differs"})
    return pd.DataFrame(rows)


# ------------------------------------------------------------------ Fig. 10
def excitation_verdicts(paper_words: pd.DataFrame, runs: list, noise: float = NOISE) -> pd.DataFrame:
    """Per training manoeuvre: the median ``validation/mae_speed`` [m/s] of each model over its seeds
    at ``noise``, how many of its runs had diverged predictions, the model the project finds better
    (full against the project's simplified model; the lower median, a model whose runs diverged in
    most seeds counting as worse) and the paper's words."""
    cells: dict = {}
    for run in runs or []:
        if run.status != "FINISHED":
            continue
        try:
            level = float(run.params.get("noise.measurement", "nan"))
        except ValueError:
            continue
        if not np.isclose(level, noise):
            continue
        key = (run.params.get("manoeuvre.name"), run.params.get("model.name"))
        cells.setdefault(key, []).append(run.metrics)
    rows = []
    for row in paper_words.itertuples():
        manoeuvre = row.dof
        out = {"trained on": manoeuvre, "paper: better": PAPER_WORDS.get(str(row.value), str(row.value))}
        score = {}
        for model in MODELS:
            found = cells.get((manoeuvre, model), [])
            mae = [m["validation/mae_speed"] for m in found if "validation/mae_speed" in m]
            diverged = sum(1 for m in found if m.get("validation/diverged", 0.0) > 0)
            out[f"{model} MAE [m/s]"] = float(np.median(mae)) if mae else np.nan
            out[f"{model} runs diverged"] = f"{diverged}/{len(found)}" if found else "-"
            score[model] = (diverged > len(found) / 2 if found else True,
                            float(np.median(mae)) if mae else np.inf)
        if not cells.get((manoeuvre, "abkowitz")) or not cells.get((manoeuvre, "simplified")):
            out["project: better"], out["verdict"] = "not measured", "not measured"
        else:
            better = min(("abkowitz", "simplified"), key=lambda m: score[m])
            out["project: better"] = MODELS[better]
            out["verdict"] = "agrees" if better == str(row.value) else "differs"
        rows.append(out)
    return pd.DataFrame(rows)


def _counts(frame: pd.DataFrame, agree: str) -> str:
    n = len(frame)
    a = int((frame["verdict"] == agree).sum())
    unmeasured = int((frame["verdict"] == "not measured").sum())
    return (f"{a} of {n} agree, {n - a - unmeasured} disagree"
            + (f", {unmeasured} not measured" if unmeasured else ""))


def sections(runs: dict, out: Path) -> list:
    """The page's sections (module docstring)."""
    result = []
    simplify = _latest(runs.get("simplification"))
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        analysis = _analysis(simplify, scratch) if simplify is not None else None
        if analysis is not None:
            rho = {dof: _spearman(simplify, dof, scratch / dof) for dof in DOFS}
            groups = group_verdicts(_paper("group"), analysis.get("groups", {}), rho)
            text = (f"Table 2 against the groups of the project's run `{simplify.name}` (the groups found "
                    f"most often over its stability-selection draws; Spearman |rho| > {GROUP_THRESHOLD:g}). "
                    f"{_counts(groups, 'same')}. A split or joined group's cause is the correlation the "
                    "project measures on its own realisations (evidence column); why it differs from the "
                    "paper's is not explained (the paper gives neither its realisations nor its "
                    "correlation matrices; Fig. 2 is not in the text copy).\n\n")
            result.append(("Table 2: groups of strongly correlated coefficients",
                           text + markdown_table(groups.set_index("dof"), "dof")))
            pawn = pawn_verdicts(_paper("pawn_mean"), simplify.metrics, analysis)
            shown = pawn.copy()
            for col in ("paper", "project", "band"):
                shown[col] = shown[col].map(lambda x: "-" if not np.isfinite(x) else f"{x:.3f}")
            text = ("The mean PAWN index of each DOF's coefficients (section 4.2; the paper keeps a "
                    "group's best coefficient only above it). The band is the project's mean +- twice the "
                    "mean standard deviation of its coefficients' indices over the draws. "
                    f"{_counts(pawn, 'agrees')}. PAWN indices depend on the design (sample size, slices, "
                    "ranges of the inputs), which the paper does not give: a difference is not explained.\n\n")
            result.append(("PAWN: mean sensitivity per DOF", text + markdown_table(shown.set_index("dof"), "dof")))
            terms = term_verdicts(_paper("simplified"), analysis)
            text = ("The simplified model of eq. 23-25 against the one the same rule derives on the project's "
                    "data (rule) and the one the project keeps after putting back what a manoeuvring model "
                    f"needs (model; `model=simplified`). {_counts(terms, 'same')}. A difference follows from "
                    "the groups and PAWN indices above.\n\n")
            result.append(("Eq. 23-25: the simplified model", text + markdown_table(terms.set_index("dof"), "dof")))
        else:
            result.append(("Table 2, PAWN and eq. 23-25",
                           "Not measured: the store holds no finished `studies simplify` run with its "
                           "analysis (`simplification.json`).\n"))
    excitation = runs.get("excitation") or []
    fig = excitation_verdicts(_paper("fig10"), excitation)
    shown = fig.copy()
    for col in [c for c in shown.columns if c.endswith("[m/s]")]:
        shown[col] = shown[col].map(lambda x: "-" if not np.isfinite(x) else f"{x:.4f}")
    text = ("Fig. 10's bars are not in the text copy; what the text says of them is compared: which model "
            f"predicts the other manoeuvres better after training on each one. The project's verdict: the "
            f"lower median `validation/mae_speed` over its seeds at {100 * NOISE:g} % noise of the complete "
            "model and the project's simplified model (eq. 23-25 beside them), a model whose predictions "
            f"diverged in most seeds counting as the worse. {_counts(fig, 'agrees')}.\n\n")
    result.append(("Fig. 10: which model predicts better after each training manoeuvre",
                   text + markdown_table(shown.set_index("trained on"), "trained on")))
    return result


def substitutions(runs: dict) -> list:
    return ["Ship and model: the Mariner and its 40-coefficient Abkowitz model (the paper's complete model "
            "has 34 of them: no Y0/N0 terms); the groups and the simplified model are compared on the "
            "coefficients the paper lists.",
            "Data: the project's RK4 simulator with the paper's eq. 22 measurement noise; the paper's "
            "realisations are not published.",
            "PAWN: the project's own implementation (checked against SALib), its design "
            "(`simplify.pawn_samples`, slices) chosen by the project; the paper does not give its design."]


def conventions(runs: dict) -> list:
    return ["Table 2 as printed in the text copy: some of its values repeat other rows' values (Y_vu, Y_ru "
            "print Y_v's and Y_r's; N_vu, N_ru print N_v's and N_r's); only its groups are compared.",
            "Fig. 10: only the text's statements are compared; the figure is missing from the copy."]
