"""Sparse regression (SINDy / STLSQ) on the model's terms and on the extended library."""

import json
from dataclasses import asdict

import numpy as np
import pytest

from conftest import deviations
from studies.config import compose_settings
from studies.identification.objective import TrajectoryObjective
from studies.identification.regression import build_problems
from studies.identification.sindy import SparseRegression, term_library
from studies.models.terms import Term, candidate_terms
from studies.simulate import simulate, zigzag


NRRR = Term("Nrrr", "N", (0, 0, 3, 0))
NRRR_VALUE = -0.003


def _relative_contributions(problem, truth):
    """RMS contribution of each true term over the RMS of y: the scaled coefficient."""
    y_rms = np.sqrt(np.mean(problem.y ** 2))
    return {n: abs(truth[n]) * np.sqrt(np.mean(problem.theta[:, j] ** 2)) / y_rms
            for j, n in enumerate(problem.names)}


def test_term_library_reads_as_the_model(model):
    x = np.random.default_rng(0).normal(scale=0.2, size=(50, 4))
    for dof in "XYN":
        lib = term_library(model.terms_of(dof))
        lib.fit(x)
        assert lib.get_feature_names(["u", "v", "r", "d"]) == model.names_of(dof)
        assert np.allclose(np.asarray(lib.transform(x)), model.features(x, dof))


@pytest.mark.slow
def test_model_library_recovers_all_40_like_ls(problems_4000, vessel):
    result = SparseRegression(library="model").fit(problems_4000)
    dev = np.abs(list(deviations(result.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5 and dev.max() < 10.0
    for dof, n in (("X", 10), ("Y", 15), ("N", 15)):
        assert result.metrics[f"sindy/{dof}/n_selected"] == n
        assert result.metrics[f"sindy/{dof}/n_extra"] == 0
        assert result.metrics[f"sindy/{dof}/converged"] == 1


@pytest.mark.slow
def test_threshold_is_the_relative_rms_contribution(problems_4000, vessel):
    """Terms contributing less than ``threshold`` of the RMS force are pruned
    and reported as 0.0: between Yvdd (4.2e-4) and the next weakest term
    Y0uu (9.4e-4), exactly Yvdd goes."""
    contrib = _relative_contributions(problems_4000["Y"], vessel.coefficients)
    weakest = sorted(contrib, key=contrib.get)[:2]
    assert weakest == ["Yvdd", "Y0uu"]
    threshold = float(np.sqrt(contrib["Yvdd"] * contrib["Y0uu"]))
    result = SparseRegression(threshold=threshold).fit(problems_4000)
    assert result.params["Yvdd"] == 0.0
    assert result.metrics["sindy/Y/n_dropped"] == 1
    assert result.metrics["sindy/N/n_dropped"] == result.metrics["sindy/X/n_dropped"] == 0


def test_extended_library_needs_the_objective(problems_4000):
    with pytest.raises(ValueError, match="objective"):
        SparseRegression(library="extended").fit(problems_4000)


@pytest.mark.slow
def test_extended_library_selects_exactly_the_model_terms(model, vessel, zigzag_4000,
                                                          problems_4000, tmp_path):
    """Clean data, 35 candidates per DOF: the 40 model terms and nothing else.

    Threshold 1e-4: the weakest true term contributes 4.2e-4 of its DOF's
    RMS force (Yvdd), the spurious candidates < 2e-5 once STLSQ's first
    pass has removed the rest (see the module notes). (The cross-validated
    default trades such a term for sparsity: on clean data its held-out
    error is within one standard error.)"""
    for dof in "XYN":
        assert len(candidate_terms(dof, 3)) == 35
    objective = TrajectoryObjective(model, vessel, [zigzag_4000])
    result = SparseRegression(library="extended", threshold=1e-4).fit(problems_4000, objective)
    assert set(result.params) == set(model.names)
    dev = np.abs(list(deviations(result.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5 and dev.max() < 10.0
    for dof in "XYN":
        assert result.metrics[f"sindy/{dof}/n_candidates"] == 35
        assert result.metrics[f"sindy/{dof}/n_extra"] == 0
        assert result.metrics[f"sindy/{dof}/n_selected"] == len(model.names_of(dof))
    result.writers["sindy_terms.json"](tmp_path / "sindy_terms.json")
    terms = json.loads((tmp_path / "sindy_terms.json").read_text())
    assert terms["Y"]["selected"] == model.names_of("Y")   # thesis names (Yvu), not canonical (Yuv)
    assert all(terms[d]["extra"] == [] and terms[d]["dropped"] == [] for d in "XYN")


@pytest.mark.slow
def test_extended_library_finds_a_hidden_term(model, vessel, tmp_path):
    """Data from the Mariner plus Nrrr = -0.003: identified with the plain
    Abkowitz model as the run's model, SINDy lists Nrrr (and only Nrrr) as
    extra, at its value, and keeps the 40 model terms."""
    truth = dict(vessel.coefficients, Nrrr=NRRR_VALUE)
    rec = simulate(model.extended([NRRR]), truth, vessel, zigzag(20, 20, duration=1500.0))
    problems = build_problems(model, vessel, rec)
    result = SparseRegression(library="extended", threshold=1e-4).fit(
        problems, TrajectoryObjective(model, vessel, [rec]))
    assert set(result.params) - set(model.names) == {"Nrrr"}
    assert result.params["Nrrr"] == pytest.approx(NRRR_VALUE, rel=1e-3)
    assert result.metrics["sindy/N/n_extra"] == 1
    assert result.metrics["sindy/X/n_extra"] == result.metrics["sindy/Y/n_extra"] == 0
    dev = np.abs(list(deviations(result.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5 and dev.max() < 10.0
    result.writers["sindy_terms.json"](tmp_path / "sindy_terms.json")
    assert json.loads((tmp_path / "sindy_terms.json").read_text())["N"]["extra"] == ["Nrrr"]


def test_config_keys_are_constructor_options():
    """The typed ``method=sindy`` settings, as a run passes them, build the estimator."""
    cfg = compose_settings("config", ["method=sindy"])
    options = {k: v for k, v in asdict(cfg.method).items() if k != "name"}
    assert cfg.method.name == SparseRegression.name
    sindy = SparseRegression(**options)
    assert sindy.library == "model" and sindy.max_order == 3


def test_choose_rules_pick_the_best_the_sparsest_within_one_se_or_the_paired_one():
    """Three candidates on four folds whose difficulty varies a lot from fold to fold: the
    sparsest (threshold 0.1) is worse than the best in every fold by 1, far less than the
    spread of the folds (one_se keeps it) but far more than the spread of the difference
    (paired_se does not); a diverged candidate never qualifies."""
    from studies.identification.sindy import choose

    folds = np.array([10.0, 50.0, 90.0, 130.0])
    errors = np.vstack([folds, folds + 0.01 * np.array([1, -1, 1, -1]), folds + 1.0])
    terms, thresholds = [17, 15, 10], [0.0, 0.01, 0.1]
    assert choose(errors, terms, thresholds, "min") == 0
    assert choose(errors, terms, thresholds, "one_se") == 2
    assert choose(errors, terms, thresholds, "paired_se") == 1
    errors[2, 0] = np.inf
    assert choose(errors, terms, thresholds, "one_se") == 1


def test_unknown_selection_options_are_refused():
    from studies.errors import ConfigError

    for bad in ({"selection": "track"}, {"rule": "two_se"}, {"coefficients": "mean"}, {"folds": "rows"},
                {"selection": "simulation", "library": "extended"}):
        with pytest.raises(ConfigError):
            SparseRegression(**bad)


@pytest.mark.slow
def test_simulation_selection_replays_held_out_blocks(model, vessel, zigzag_1500, tmp_path):
    """``selection="simulation"``: one threshold for all DOFs from the replayed positions of
    held-out time blocks; on a clean zig-zag the least-squares model replays the blocks to
    within centimetres, and the threshold table is written beside the per-DOF results."""
    problems = build_problems(model, vessel, zigzag_1500)
    objective = TrajectoryObjective(model, vessel, [zigzag_1500])
    with pytest.raises(ValueError, match="objective"):
        SparseRegression(selection="simulation", ensemble=0).fit(problems)
    sindy = SparseRegression(selection="simulation", rule="paired_se", ensemble=0,
                             thresholds=[0.0, 1e-3, 0.1])
    result = sindy.fit(problems, objective)
    chosen = result.metrics["sindy/simulated_threshold"]
    assert chosen in (0.0, 1e-3, 0.1)
    assert all(result.metrics[f"sindy/{dof}/threshold"] == chosen for dof in "XYN")
    result.writers["sindy_terms.json"](tmp_path / "sindy_terms.json")
    table = json.loads((tmp_path / "sindy_terms.json").read_text())["Y"]["cv_simulated"]
    assert [row[0] for row in table] == [0.0, 1e-3, 0.1]
    assert table[0][1] < 0.1 ** 2 and table[0][3] == len(model.names)   # m^2; all 40 terms


def test_median_coefficients_keep_the_same_terms_as_the_refit(problems_4000):
    """E-SINDy bragging changes the kept terms' values, not which terms are kept; on clean
    data the median of the draws is the refit within 1 %."""
    refit = SparseRegression(threshold=1e-4, ensemble=5).fit(problems_4000)
    median = SparseRegression(threshold=1e-4, ensemble=5, coefficients="median").fit(problems_4000)
    assert {n for n, v in refit.params.items() if v} == {n for n, v in median.params.items() if v}
    for n, v in refit.params.items():
        if v:
            assert median.params[n] == pytest.approx(v, rel=1e-2, abs=1e-8)
