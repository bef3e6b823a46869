"""Wang et al. (2021) reproduced: the published Table 4, the comparison report, and the paper's trends.

The fast tests hold the report to what it reads: runs standing in for the
store (params, metrics and a ``coefficients.csv`` artifact, as
:class:`studies.runtime.tracking.StoredRun` gives them). The slow test runs a
reduced ``svm_disturbance`` sweep and the report through the command line,
as a user would, and checks the paper's findings on it.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import mlflow_runs, run_studies
from studies.analysis.characteristics import TURNING_KEYS, turning_geometry
from studies.models.abkowitz import abkowitz
from studies.papers import PAPERS, published
from studies.report.reproduction import REPRODUCTIONS, build_reproduction
from studies.report.reproduction import svm_paper
from studies.simulate import simulate
from studies.vessels import get_vessel
from studies.workflows.reproduction import wang2021

VESSEL = get_vessel("mariner")
TRUTH = {n: VESSEL.coefficients[n] for n in abkowitz().names}
TRAIN = "['zigzag_10_10', 'zigzag_20_20_600', 'zigzag_30_30']"
#: the project's reference 18 deg turning circle [m] (as the runs log it)
REFERENCE = {"steady_radius_m": 667.3, "max_transfer_m": 1279.3, "max_advance_m": 755.8, "transfer_m": 552.0,
             "advance_m": 751.7, "tactical_diameter_m": 1275.5}


def test_table4_is_registered_and_its_deviations_follow_from_its_values():
    assert "svm_paper" in PAPERS and REPRODUCTIONS["svm_paper"] is svm_paper
    table = published("svm_paper", "table4")
    assert set(table["table"]) == {"Table 4"} and set(table["section"]) == {"section 4.3"}
    assert set(table["characteristic"]) == set(TURNING_KEYS)
    ref = table[table["level"] == 0].set_index("characteristic")["value_m"]
    rows = table[table["level"] > 0]
    signed = 100 * (rows["value_m"] - rows["characteristic"].map(ref)) / rows["characteristic"].map(ref)
    np.testing.assert_allclose(signed.abs(), rows["deviation_pct"], atol=0.06)
    assert set(rows["process"]) == {1} and sorted(set(rows["level"])) == [1, 2, 3]


class FakeRun:
    """A stored run: params, metrics, tags and a coefficients.csv artifact."""

    def __init__(self, run_id, level, method, seed, errors=None, diverged=False, scaling="record",
                 coefficients=None, status="FINISHED"):
        self.run_id, self.status, self.start_time = run_id, status, seed
        self.tags = {"method": method}
        self.params = {"disturbance.level": str(level), "disturbance.process": "1", "method.name": method,
                       "seed": str(seed), "train.manoeuvres": TRAIN, "data.derivative": "savgol",
                       "validate.manoeuvres": "['turning_18', 'zigzag_10_10']", "validate.duration": "null",
                       "vessel.name": "mariner", "model.name": "abkowitz"}
        if scaling is not None:
            self.params["disturbance.scaling"] = scaling
        self.metrics = {"turning_18/diverged": float(diverged)}
        for key in TURNING_KEYS:
            self.metrics[f"turning_18/{key}_reference"] = REFERENCE[key]
            if errors is not None and not diverged:
                self.metrics[f"turning_18/{key[:-2]}_error_pct"] = errors[key]
                self.metrics[f"turning_18/{key}"] = REFERENCE[key] * (1 + errors[key] / 100)
        self.coefficients = coefficients or TRUTH

    def artifact(self, path, destination):
        if path != "coefficients.csv" or self.status != "FINISHED":
            return None
        Path(destination).mkdir(parents=True, exist_ok=True)
        local = Path(destination) / path
        pd.DataFrame({"name": list(self.coefficients), "value": list(self.coefficients.values())}).to_csv(
            local, index=False)
        return local


def _errors(value: float) -> dict:
    return {key: value for key in TURNING_KEYS}


def test_per_trial_statistics_count_diverged_and_missing_trials_and_never_average_them():
    runs = [FakeRun("a", 1, "svm", 0, _errors(1.0)), FakeRun("b", 1, "svm", 1, _errors(-3.0)),
            FakeRun("c", 1, "svm", 2, _errors(2.0)), FakeRun("d", 1, "svm", 3, diverged=True),
            FakeRun("e", 2, "svm", 0, _errors(5.0)), FakeRun("f", 2, "svm", 3, _errors(6.0)),
            FakeRun("g", 2, "svm", 4, _errors(7.0)),
            # logged before disturbance.scaling existed: the per-second reading
            FakeRun("h", 1, "svm", 0, _errors(40.0), scaling=None)]
    trials = svm_paper.collect({"svm_disturbance": runs})
    stats = svm_paper.cell_statistics(trials)
    record = stats[stats["setup"].map(lambda s: s[0]) == "record"].set_index("level")
    assert record.loc[1, "runs"] == 4 and record.loc[1, "bounded"] == 3 and record.loc[1, "diverged"] == 1
    assert record.loc[1, "steady_radius_m/median_abs"] == 2.0          # of 1, 3, 2: the diverged left out
    assert record.loc[1, "steady_radius_m/min"] == -3.0 and record.loc[1, "steady_radius_m/max"] == 2.0
    assert record.loc[1, "missing"] == 1                               # seed 4 ran at NL2 only
    assert record.loc[2, "missing"] == 2                               # seeds 1, 2
    legacy = stats[stats["setup"].map(lambda s: s[0]) == "per_second"]
    assert len(legacy) == 1 and legacy["steady_radius_m/median_abs"].iloc[0] == 40.0


def test_the_papers_procedure_averages_the_coefficients_then_predicts(tmp_path):
    """Two trials whose Nr is 10 % too large and 10 % too small turn differently
    (their own errors are not zero), but their mean model is the reference:
    its errors are zero, as averaging the errors would not give."""
    high = dict(TRUTH, Nr=TRUTH["Nr"] * 1.1)
    low = dict(TRUTH, Nr=TRUTH["Nr"] * 0.9)
    runs = [FakeRun("a", 1, "svm", 0, _errors(9.0), coefficients=high),
            FakeRun("b", 1, "svm", 1, _errors(-4.0), coefficients=low)]
    averaged, records = svm_paper.averaged_models(svm_paper.collect({"svm_disturbance": runs}), tmp_path)
    row = averaged.iloc[0]
    assert row["averaged"] == 2 and not row["diverged"]
    for key in TURNING_KEYS:
        assert abs(row[key]) < 1e-6, key
    # one trial alone is not the reference: the mean model's zero is the averaging
    alone, _ = svm_paper.averaged_models(svm_paper.collect({"svm_disturbance": runs[:1]}), tmp_path)
    assert abs(alone.iloc[0]["steady_radius_m"]) > 1.0


def test_the_comparison_gives_ratios_to_the_paper_and_the_within_twice_verdict(tmp_path):
    paper = published("svm_paper", "table4").set_index(["level", "characteristic"])["deviation_pct"]
    runs = [FakeRun(f"r{s}", 1, "svm", s, {k: 1.5 * paper[(1, k)] for k in TURNING_KEYS}) for s in range(3)]
    runs += [FakeRun(f"t{s}", 3, "svm", s, {k: 2.5 * paper[(3, k)] for k in TURNING_KEYS}) for s in range(3)]
    trials = svm_paper.collect({"svm_disturbance": runs})
    averaged, _ = svm_paper.averaged_models(trials, tmp_path)
    comp = svm_paper.comparison(svm_paper.cell_statistics(trials), averaged)
    per_trial = comp[comp["statistic"] == "trials"].set_index(["level", "characteristic"])
    for key in TURNING_KEYS:
        assert per_trial.loc[(1, key), "ratio"] == pytest.approx(1.5, rel=0.02)
        assert per_trial.loc[(1, key), "within"]
        assert per_trial.loc[(3, key), "ratio"] == pytest.approx(2.5, rel=0.02)
        assert not per_trial.loc[(3, key), "within"]
    # the mean model is the reference here: zero error, far below the paper's, so it disagrees
    # (agreement is two-sided: within a factor two of the paper's either way)
    mean = comp[comp["statistic"] == "averaged"]
    assert (mean["project_pct"].abs() < 1e-6).all() and not mean["within"].any()
    runs = [FakeRun(f"q{s}", 1, "svm", s, {k: 0.3 * paper[(1, k)] for k in TURNING_KEYS}) for s in range(3)]
    trials = svm_paper.collect({"svm_disturbance": runs})
    averaged, _ = svm_paper.averaged_models(trials, tmp_path)
    comp = svm_paper.comparison(svm_paper.cell_statistics(trials), averaged)
    assert not comp[comp["statistic"] == "trials"]["within"].any()        # 0.3 times the paper's


def test_the_page_shows_both_readings_side_by_side(tmp_path, monkeypatch):
    """A store holding runs of both scalings gives each its own tables; the
    per-second NL1 trials without a bounded prediction are a disagreement
    whose measured cause is the size of the bias. (The re-identifications
    that find which part of the disturbance makes an error systematic have
    their own slow test.)"""
    monkeypatch.setattr(svm_paper, "systematic_source", lambda *args, **kwargs: "")
    paper = published("svm_paper", "table4").set_index(["level", "characteristic"])["deviation_pct"]
    runs = []
    for level in (1, 2, 3):
        runs += [FakeRun(f"r{level}{s}", level, "svm", s, {k: 0.5 * level ** 2 * paper[(1, k)]
                                                           for k in TURNING_KEYS}) for s in range(3)]
    runs += [FakeRun("p0", 1, "svm", 0, diverged=True, scaling="per_second"),
             FakeRun("p1", 1, "svm", 1, _errors(50.0), scaling="per_second"),
             FakeRun("r33", 3, "svm", 3, diverged=True)]
    index = build_reproduction("svm_paper", {"svm_disturbance": runs}, tmp_path)
    text = index.read_text()
    assert "`disturbance.scaling=record`" in text and "`disturbance.scaling=per_second`" in text
    assert "NL1, SVM: 1 of 2 trials have no bounded 18 deg turning prediction" in text
    # a lost trial at NL3 is a disagreement too: the paper reports only its averaged model
    assert "NL3, SVM: 1 of 4 trials have no bounded 18 deg turning prediction that turned 450 deg" in text
    assert "the paper reports only the model averaged over its trials, and the project's averaged model" in text
    assert "times the largest clean sway force or yaw moment" in text
    table = pd.read_csv(index.parent / svm_paper.COMPARISON_FILE)
    assert set(table["scaling"]) == {"record", "per_second"}
    assert (index.parent / "turning_18_mean_models_0.png").is_file()


def test_the_reference_run_and_read_as_mss_turncircle_gives_the_papers_transfer_at_90_deg():
    """Table 4's model reference is MSS ``turncircle.m``'s reading of a port
    turn started soon after the run begins: the transfer at 90 deg within
    0.2 % of the paper's 546 m (1 % short of the interpolated 552 m); to
    starboard the steady radius is 5 % off, and with ``ExTurnCircle.m``'s
    execute at 100 s the transfer is 10 % off."""
    paper = published("svm_paper", "table4")
    paper = paper[paper["level"] == 0].set_index("characteristic")["value_m"]
    port = wang2021.mss_reference(VESSEL)
    assert port["transfer_m"] == pytest.approx(paper["transfer_m"], rel=0.002)
    assert REFERENCE["transfer_m"] > 1.008 * paper["transfer_m"]
    for key in ("steady_radius_m", "max_transfer_m", "tactical_diameter_m"):
        assert port[key] == pytest.approx(paper[key], rel=0.001), key
    starboard = wang2021.mss_reference(VESSEL, side=-1)
    assert abs(starboard["steady_radius_m"] / paper["steady_radius_m"] - 1) > 0.03
    assert wang2021.mss_reference(VESSEL, execute=100.0)["transfer_m"] < 0.92 * paper["transfer_m"]


def test_the_scatter_of_the_averaged_model_shrinks_to_its_one_model_when_the_trials_agree():
    """Bootstrap of the paper's procedure: trials that all identified the same
    model (Nr 5 % too large) scatter nowhere, their range is that model's
    error; half 5 % too large and half 5 % too small average to the
    reference within a range that holds zero and lies inside the two. The
    range holds the uncertainty of the six trials' own mean (two-level
    bootstrap): far wider than 100 trials drawn from those six alone would
    give (about 0.33 times the single model's error), and it narrows, less
    than in proportion, with the number of trials averaged."""
    model = abkowitz()
    names = list(model.names)
    high = np.array([TRUTH[n] * (1.05 if n == "Nr" else 1.0) for n in names])
    low = np.array([TRUTH[n] * (0.95 if n == "Nr" else 1.0) for n in names])
    manoeuvre = svm_paper._manoeuvre(FakeRun("a", 1, "svm", 0))
    reference = turning_geometry(wang2021.reference_turn("mariner", manoeuvre))
    same = wang2021.averaged_scatter(np.vstack([high] * 6), model, VESSEL, manoeuvre, reference, draws=8)
    one = turning_geometry(simulate(model, dict(zip(names, high)), VESSEL, manoeuvre))
    single = 100 * (one["steady_radius_m"] / reference["steady_radius_m"] - 1)
    assert abs(single) > 1.0
    assert same["steady_radius_m/scatter_lo"] == pytest.approx(single, abs=1e-9)
    assert same["steady_radius_m/scatter_hi"] == pytest.approx(single, abs=1e-9)
    mixed = wang2021.averaged_scatter(np.vstack([high] * 3 + [low] * 3), model, VESSEL, manoeuvre, reference,
                                       draws=20)
    lo, hi = mixed["steady_radius_m/scatter_lo"], mixed["steady_radius_m/scatter_hi"]
    assert mixed["scatter_draws"] == 20 and mixed["scatter_trials"] == wang2021.PAPER_TRIALS
    assert lo < 0.0 < hi and -abs(single) - 0.5 < lo and hi < abs(single) + 0.5
    assert hi - lo > 0.8 * abs(single)
    # four trials average less of the scatter away than the paper's hundred
    few = wang2021.averaged_scatter(np.vstack([high] * 3 + [low] * 3), model, VESSEL, manoeuvre, reference,
                                     trials=4, draws=20)
    assert few["steady_radius_m/scatter_hi"] - few["steady_radius_m/scatter_lo"] > 1.2 * (hi - lo)


S3 = "['zigzag_20_20_300', 'zigzag_15_15_300', 'zigzag_10_10_300']"


def test_the_sign_of_the_radius_error_is_traced_to_the_training_excitation(tmp_path, monkeypatch):
    """Two training sets whose averaged models err with opposite signs on the
    steady radius: each is its own set-up, and the disagreement of the one
    whose sign is not the paper's says the sign follows the training
    excitation, with the 18 deg turn's speed loss beside each set's."""
    monkeypatch.setattr(svm_paper, "systematic_source", lambda *args, **kwargs: "")
    monkeypatch.setattr(svm_paper, "SCATTER_DRAWS", 0)
    damped = dict(TRUTH, Nr=TRUTH["Nr"] * 1.05)          # more yaw damping: a wider circle
    lively = dict(TRUTH, Nr=TRUTH["Nr"] * 0.95)
    runs = []
    for s in range(3):
        runs.append(FakeRun(f"p{s}", 1, "ls", s, _errors(2.0), coefficients=damped))
        s3 = FakeRun(f"q{s}", 1, "ls", s, _errors(-3.0), coefficients=lively)
        s3.params["train.manoeuvres"] = S3
        runs.append(s3)
    trials = svm_paper.collect({"svm_disturbance": runs})
    assert len(svm_paper._setups(trials)) == 2
    averaged, _ = svm_paper.averaged_models(trials, tmp_path)
    signs = {row["setup"][2]: np.sign(row["steady_radius_m"]) for row in averaged.to_dict("records")}
    assert signs == {TRAIN: 1.0, S3: -1.0}
    setups = svm_paper._setups(trials)
    stats = svm_paper.cell_statistics(trials)
    comp = svm_paper.comparison(stats, averaged)
    found = svm_paper.disagreements(comp, stats, setups[0], trials, averaged, tmp_path, setups)
    assert setups[0][2] == TRAIN and len(found) == 1
    line = found[0]
    assert line.startswith("NL1, LS: ")
    assert "the averaged model's error has the opposite sign to the paper's for the steady" in line
    # errors far below the paper's are listed too (agreement is two-sided), judged on the averaged model,
    # the paper's own quantity (the per-trial median is not judged)
    assert "maximum advance averaged model 2.9 % (0.4 times)" in line
    assert "per-trial median 2.0 %" not in line
    assert "the sign of the systematic error follows the training excitation" in line
    assert "zigzag_20_20_300" in line and "the 18 deg steady turn runs at u' -0.19" in line
    assert "`train.manoeuvres=" in svm_paper._setup_label(setups[1], setups)


def test_the_record_bias_is_small_beside_the_ships_forces_and_the_per_second_one_is_not():
    """Measured on the preset's training zig-zags: the NL1 bias's peak over the
    largest clean sway force or yaw moment (the report's table)."""
    record = wang2021.bias_peaks(("record", "1", TRAIN, "savgol"), 1)
    per_second = wang2021.bias_peaks(("per_second", "1", TRAIN, "savgol"), 1)
    assert set(record) == {"zigzag_10_10", "zigzag_20_20_600", "zigzag_30_30"}
    assert max(record.values()) < 0.15
    assert min(per_second.values()) > 1.0


# ------------------------------------------------------------------ the paper's trends, through the CLI

REDUCED = ["run", "-m", "experiment=svm_disturbance", "disturbance.level=1,3", "method=svm", "seed=0,1,2",
           "validate.manoeuvres=[turning_18]"]


@pytest.mark.slow
def test_a_reduced_svm_disturbance_sweep_shows_the_papers_findings(tmp_path):
    """Three trials of the SVM at NL1 and NL3 (the preset, with the 18 deg turning
    circle as its only validation), then the reproduction report: at NL1 no
    prediction diverges and every characteristic's error, per-trial median
    and averaged model, is at most twice the paper's (Table 4; several are
    far below it, which the two-sided agreement lists as disagreements);
    from NL1 to NL3 the errors grow, as the paper's do. The report's numbers
    are those of the store."""
    proc = run_studies([*REDUCED, f"hydra.sweep.dir={tmp_path / 'multirun'}"], cwd=tmp_path, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    runs = mlflow_runs(tmp_path)
    assert len(runs) == 6 and {status for _, status, _ in runs} == {"FINISHED"}
    proc = run_studies(["report", "report.compare=svm_paper"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    page = tmp_path / "reports" / "reproduce_svm_paper" / "index.md"
    table = pd.read_csv(page.parent / svm_paper.COMPARISON_FILE)
    text = page.read_text()
    assert set(table["scaling"]) == {"record"}
    # the store's own numbers: NL1 predictions bounded, their median |error| per characteristic
    with sqlite3.connect(tmp_path / "mlruns" / "mlflow.db") as con:
        metrics = pd.DataFrame(con.execute(
            "select m.run_uuid, m.key, m.value, p.value from latest_metrics m join params p "
            "on p.run_uuid = m.run_uuid and p.key = 'disturbance.level'").fetchall(),
            columns=["run", "key", "value", "level"])
    nl1 = metrics[metrics["level"] == "1"]
    diverged = nl1[nl1["key"] == "turning_18/diverged"]["value"]
    assert len(diverged) == 3 and (diverged == 0).all()
    assert "NL1, SVM | 3/3 bounded" in text
    nl1_table = table[table["level"] == 1]
    assert len(nl1_table) == 2 * len(TURNING_KEYS)
    for row in nl1_table.itertuples():
        assert abs(row.project_pct) <= 2 * abs(row.paper_pct), (row.characteristic, row.statistic,
                                                                row.project_pct, row.paper_pct)
        assert row.within == (0.5 <= row.ratio <= 2.0)
        if row.statistic == "trials":
            logged = nl1[nl1["key"] == f"turning_18/{row.characteristic[:-2]}_error_pct"]["value"]
            assert row.project_pct == pytest.approx(np.median(np.abs(logged)), rel=1e-9)
    # errors grow from NL1 to NL3, per trial and for the averaged model
    for statistic in ("trials", "averaged"):
        mean = table[table["statistic"] == statistic].groupby("level")["project_pct"].apply(
            lambda s: s.abs().mean())
        assert mean[3] > 2 * mean[1], (statistic, mean.to_dict())
    assert "- SVM, per-trial median: the errors grow from NL1 to NL3" in text
    assert "- SVM, averaged model: the errors grow from NL1 to NL3" in text
    assert "- paper: the errors grow from NL1 to NL3" in text


@pytest.mark.slow
def test_the_systematic_turning_error_at_nl1_is_the_bias_s():
    """The preset's training zig-zags, LS, four mirrored pairs each (a draw
    and its mirror image, whose mean keeps what averaging over trials keeps):
    with the NL1 bias alone the 18 deg steady turning radius comes out larger
    in every pair (by over 1 % on average), with the NL1 process noise alone
    it stays within 0.2 %; the report names the bias as the systematic part."""
    setup = ("record", "1", "['zigzag_10_10', 'zigzag_20_20_600', 'zigzag_30_30']", "savgol")
    bias, noise = wang2021.source_errors(setup, 1, seeds=4)
    assert len(bias) == 4 and (bias > 0).all() and bias.mean() > 1.0
    assert np.abs(noise).max() < 0.2
    assert "the systematic part is the bias's" in svm_paper.systematic_source(setup, 1, seeds=4)


def test_table_1_deviations_are_judged_two_sided_with_a_cause():
    """Wang et al. Table 1: the same page from altered deviations changes its verdicts."""
    paper = published("svm_paper", "table1")
    assert len(paper) == 40 and paper.groupby("dof").size().to_dict() == {"X": 10, "Y": 15, "N": 15}
    theirs = {r.coefficient: 100.0 * (r.svm - r.pmm) / r.pmm for r in paper.itertuples()}
    same = {(m, c): d for c, d in theirs.items() for m in ("ls", "svm")}
    found = svm_paper.table1_verdicts(paper, same)
    assert (found["verdict"] == "agrees").all()
    altered = dict(same)
    altered[("svm", "N0uu")] = 0.1          # the paper's -113 %: the project recovers it
    altered[("svm", "Xu")] = 5.0            # the paper's +0.65 %: the project departs
    altered[("svm", "Nuud")] = theirs["Nuud"] / 3   # one third of the paper's -36.8 %
    found = svm_paper.table1_verdicts(paper, altered).set_index(["coefficient", "method"])
    assert found.loc[("N0uu", "SVM"), "verdict"] == "differs"
    assert found.loc[("N0uu", "SVM"), "cause"].startswith("the project recovers it")
    assert found.loc[("Xu", "SVM"), "cause"].startswith("the paper's SVM recovers it")
    assert found.loc[("Nuud", "SVM"), "verdict"] == "differs"
    assert found.loc[("Nuud", "LS"), "verdict"] == "agrees"


def test_the_extrapolation_mechanism_is_stated_only_when_the_errors_follow_it():
    assert "as an extrapolation of the u'-terms would make it" in \
        svm_paper.extrapolation_sentence([0.05, 0.15], [2.0, 6.0])
    assert "not explained" in svm_paper.extrapolation_sentence([0.05, 0.15], [6.0, 2.0])
