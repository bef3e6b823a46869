"""``studies report report.compare=li2023``: Li et al. (2023) beside the project's runs.

Each verdict is computed from the runs: the same page built from altered runs
changes its verdicts (groups, PAWN means, the simplified model's terms, which
model predicts better after each training manoeuvre).
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd

from studies.papers import published
from studies.report.reproduction import build_reproduction
from studies.report.reproduction import li2023

PAPER_GROUPS = {"X": [["Xu", "Xuu", "Xuuu"], ["Xvv", "Xrr", "Xdd", "Xudd"], ["Xrv"], ["Xvd", "Xuvd"]],
                "Y": [["Yv"], ["Yr"], ["Yvvv", "Yvvr"], ["Yvu", "Yru"], ["Yd", "Yddd"], ["Yud", "Yuud"],
                      ["Yvdd", "Yvvd"]],
                "N": [["Nv", "Nr"], ["Nvvv", "Nvvr"], ["Nvu", "Nru"], ["Nd", "Nddd"], ["Nud", "Nuud"], ["Nvdd"],
                      ["Nvvd"]]}
PAPER_KEEP = {"X": ["Xu", "Xrr"], "Y": ["Yv", "Yr", "Yru", "Yd", "Yud"], "N": ["Nv", "Nr", "Nru", "Nd", "Nud"]}


class _Run:
    def __init__(self, name, params=None, metrics=None, artifacts=None, start=1):
        self.run_id = name.ljust(32, "0")[:32]
        self.name, self.status, self.start_time, self.tags = name, "FINISHED", start, {}
        self.url = "http://127.0.0.1:5000/"
        self.params, self.metrics = params or {}, metrics or {}
        self._artifacts = artifacts or {}

    def artifact(self, path, destination):
        if path not in self._artifacts:
            return None
        destination = __import__("pathlib").Path(destination)
        destination.mkdir(parents=True, exist_ok=True)
        (destination / path).write_text(self._artifacts[path])
        return destination / path


def _simplify_run(groups, keep, pawn_means, pawn_sd=0.01):
    selection = {t: {"frequency": 1.0, "pawn_mean": 0.2, "pawn_sd": pawn_sd}
                 for dof in groups for g in groups[dof] for t in g}
    analysis = {"groups": groups, "rule_keep": keep, "keep": keep, "selection": selection}
    metrics = {f"simplify/{dof}/mean_pawn": value for dof, value in pawn_means.items()}
    return _Run("simplify abkowitz", metrics=metrics, artifacts={"simplification.json": json.dumps(analysis)})


def _excitation_runs(mae):
    """``mae[(manoeuvre, model)]`` -> three seeds' runs at 5 % noise (and one at 10 % that must be ignored)."""
    runs = []
    for (manoeuvre, model), value in mae.items():
        for seed in range(3):
            runs.append(_Run(f"{manoeuvre}{model}{seed}", params={"manoeuvre.name": manoeuvre, "model.name": model,
                                                                  "noise.measurement": "0.05", "seed": str(seed)},
                             metrics={"validation/mae_speed": value * (1 + 0.01 * seed),
                                      "validation/diverged": 0.0}))
        runs.append(_Run(f"{manoeuvre}{model}noisy", params={"manoeuvre.name": manoeuvre, "model.name": model,
                                                             "noise.measurement": "0.1"},
                         metrics={"validation/mae_speed": 100.0, "validation/diverged": 0.0}))
    return runs


def test_the_paper_file_holds_table_2_the_pawn_means_and_eq_23_to_25():
    table = published("li2023", "tables")
    groups = table[table["kind"] == "group"]
    assert groups.groupby("dof").size().to_dict() == {"X": 4, "Y": 7, "N": 7}      # "4, 7, and 7 groups"
    assert dict(zip(table[table["kind"] == "pawn_mean"]["dof"], table[table["kind"] == "pawn_mean"]["value"])) \
        == {"X": "0.239", "Y": "0.232", "N": "0.211"}
    simplified = table[table["kind"] == "simplified"]
    assert {r.dof: r.terms.split() for r in simplified.itertuples()} == PAPER_KEEP


def test_verdicts_follow_the_runs(tmp_path):
    same = _simplify_run(PAPER_GROUPS, PAPER_KEEP, {"X": 0.239, "Y": 0.232, "N": 0.211})
    mae = {("zigzag_20_20", "abkowitz"): 0.01, ("zigzag_20_20", "simplified"): 0.02,
           ("zigzag_like", "abkowitz"): 0.01, ("zigzag_like", "simplified"): 0.02,
           ("random", "abkowitz"): 0.03, ("random", "simplified"): 0.02,
           ("circle", "abkowitz"): 0.05, ("circle", "simplified"): 0.02}
    page = build_reproduction("li2023", {"simplification": [same], "excitation": _excitation_runs(mae)},
                              tmp_path / "a").read_text()
    assert "18 of 18 agree, 0 disagree" in page                     # Table 2
    assert "3 of 3 agree, 0 disagree. PAWN" in page                 # the PAWN means
    assert "3 of 3 agree, 0 disagree. A difference follows" in page  # eq. 23-25
    assert "4 of 4 agree, 0 disagree" in page                       # Fig. 10's words

    # altered runs: two X groups merged, a PAWN mean far off, a term dropped, one manoeuvre reversed
    groups = dict(PAPER_GROUPS, X=[["Xu", "Xuu", "Xuuu", "Xrv"], ["Xvv", "Xrr", "Xdd", "Xudd"], ["Xvd", "Xuvd"]])
    keep = dict(PAPER_KEEP, X=["Xu"])
    other = _simplify_run(groups, keep, {"X": 0.09, "Y": 0.232, "N": 0.211})
    mae[("circle", "abkowitz")] = 0.01
    page = build_reproduction("li2023", {"simplification": [other], "excitation": _excitation_runs(mae)},
                              tmp_path / "b").read_text()
    assert "16 of 18 agree, 2 disagree" in page
    assert "| X | 1 | Xu Xuu Xuuu | Xu Xuu Xuuu Xrv | joined |" in page
    assert "2 of 3 agree, 1 disagree. PAWN" in page and "| X | 0.239 | 0.090 | 0.020 | differs |" in page
    assert "2 of 3 agree, 1 disagree. A difference follows" in page
    assert "3 of 4 agree, 1 disagree" in page


def test_a_split_group_gives_the_measured_correlation_and_missing_runs_say_not_measured(tmp_path):
    rho = pd.DataFrame(np.eye(2), index=["Yvdd", "Yvvd"], columns=["Yvdd", "Yvvd"])
    rho.loc["Yvdd", "Yvvd"] = rho.loc["Yvvd", "Yvdd"] = -0.31
    found = li2023.group_verdicts(li2023._paper("group").query("dof == 'Y' and group == 7"),
                                  {"Y": [["Yvdd"], ["Yvvd"]]}, {"Y": rho})
    assert found["verdict"].tolist() == ["split"]
    assert "smallest |rho| between them is 0.31, below 0.7" in found["evidence"].iloc[0]
    page = build_reproduction("li2023", {"simplification": [], "excitation": []}, tmp_path).read_text()
    assert "Not measured: the store holds no finished `studies simplify` run" in page
    assert "0 of 4 agree, 0 disagree, 4 not measured" in page
