"""Linear epsilon-SVR identification (thesis section 3.2.2, Wang et al. 2021)."""

import logging
from dataclasses import asdict

import numpy as np
import pytest

from conftest import deviations
from studies.config import compose_settings
from studies.identification.regression import RegressionProblem, build_problems
from studies.identification.svm import (SupportVectorRegression, scale_problem, search_rows,
                                  time_blocked_splits)



@pytest.fixture(scope="module")
def svm_clean(problems_4000):
    return SupportVectorRegression().fit(problems_4000)


@pytest.mark.slow
def test_clean_rk4_zigzag_recovers_all_40(svm_clean, vessel):
    dev = np.abs(list(deviations(svm_clean.params, vessel.coefficients).values()))
    assert np.median(dev) < 0.5
    assert dev.max() < 10.0
    for dof in "XYN":
        assert svm_clean.metrics[f"svm/{dof}/converged"] == 1.0
        assert svm_clean.metrics[f"svm/{dof}/search_nonconverged"] == 0.0
        # clean data: no tube and little regularisation win the cross-validation
        assert svm_clean.metrics[f"svm/{dof}/epsilon"] == 0.0
        assert svm_clean.metrics[f"svm/{dof}/C"] >= 1e4
        assert svm_clean.metrics[f"regression/{dof}/r2"] > 0.999999


def _problem(n=600, n_records=2, seed=0, constant=True):
    """Synthetic problem with columns of very different scales and known coefficients."""
    rng = np.random.default_rng(seed)
    t = np.tile(np.arange(n // n_records) * 0.1, n_records)
    rec = np.repeat(np.arange(n_records), n // n_records)
    cols = [1e-3 * rng.normal(size=n), 30.0 * rng.normal(size=n), rng.normal(size=n) ** 3]
    names = ["Ya", "Yb", "Yc"]
    coef = [2.0e2, -4.0e-5, 7.0e-3]
    if constant:
        cols.append(np.ones(n))
        names.append("Y0")
        coef.append(-3.0e-4)
    theta = np.column_stack(cols)
    return RegressionProblem("Y", theta, theta @ np.array(coef), names, {}, rec, t), np.array(coef)


@pytest.mark.parametrize("constant", [True, False])
def test_scaling_and_constant_term_map_back_exactly(constant):
    """Columns six orders of magnitude apart and a constant column (the model's
    Y0, no separate intercept) come back to 1e-6 on exact data."""
    problem, truth = _problem(constant=constant)
    x, y, col, ys = scale_problem(problem)
    assert np.allclose(np.sqrt(np.mean(x ** 2, axis=0)), 1.0)
    svm = SupportVectorRegression(c_grid=[1e8], epsilon_grid=[0.0], folds=2)
    assert svm.estimator().fit_intercept is False
    result = svm.fit({"Y": problem})
    got = np.array([result.params[n] for n in problem.names])
    assert np.allclose(got, truth, rtol=1e-6, atol=0.0)


def test_search_uses_contiguous_time_blocks(monkeypatch):
    """Rows given out of time order are searched in record/time order and
    every test fold is one contiguous stretch of time, never interleaved."""
    problem, _ = _problem(n=1000, n_records=2)
    perm = np.random.default_rng(1).permutation(problem.n_rows)
    shuffled = RegressionProblem("Y", problem.theta[perm], problem.y[perm], problem.names, {},
                                 problem.record[perm], problem.time[perm])
    rows = search_rows(shuffled, 400)
    assert len(rows) == 400
    key = np.column_stack([shuffled.record[rows], shuffled.time[rows]])
    assert np.all(np.diff(key[:, 0]) >= 0)
    assert np.all((np.diff(key[:, 1]) > 0) | (np.diff(key[:, 0]) > 0))
    splits = time_blocked_splits(len(rows), 5)
    covered = np.sort(np.concatenate([test for _, test in splits]))
    assert np.array_equal(covered, np.arange(len(rows)))
    for train, test in splits:
        assert np.all(np.diff(test) == 1)                       # one contiguous block
        assert not np.any((train > test.min()) & (train < test.max()))
    # and the grid search is given exactly these folds
    seen = []
    import studies.identification.svm as svm_module

    def spy(n_rows, folds):
        out = time_blocked_splits(n_rows, folds)
        seen.append(out)
        return out

    monkeypatch.setattr(svm_module, "time_blocked_splits", spy)
    result = SupportVectorRegression(c_grid=[1e4], epsilon_grid=[0.0], folds=5,
                                     max_rows=400).fit({"Y": shuffled})
    assert len(seen) == 1 and len(seen[0]) == 5
    assert result.metrics["svm/Y/search_rows"] == 400


@pytest.fixture(scope="module")
def problems_600(model, vessel, zigzag_600):
    return build_problems(model, vessel, zigzag_600)


def test_nonconvergence_is_reported_and_logged(problems_600, caplog):
    svm = SupportVectorRegression(c_grid=[1e4, 1e6], epsilon_grid=[0.0], folds=2, max_iter=1)
    with caplog.at_level(logging.WARNING, logger="studies.identification.svm"):
        result = svm.fit(problems_600)
    for dof in "XYN":
        assert result.metrics[f"svm/{dof}/converged"] == 0.0
        assert result.metrics[f"svm/{dof}/search_nonconverged"] == 4.0
    messages = [r.getMessage() for r in caplog.records]
    assert sum("final fit" in m and "did not converge" in m for m in messages) == 3
    assert sum("grid-search fits did not converge" in m for m in messages) == 3


def test_default_liblinear_tolerance_would_be_silently_wrong(problems_4000, vessel):
    """Why ``tol`` is 1e-9: sklearn's default 1e-4 stops the primal Newton
    solver early *without* a ConvergenceWarning and leaves errors of tens of
    percent; 1e-9 reaches least-squares accuracy at the same C."""
    loose = SupportVectorRegression(c_grid=[1e6], epsilon_grid=[0.0], folds=2, tol=1e-4)
    tight = SupportVectorRegression(c_grid=[1e6], epsilon_grid=[0.0], folds=2)
    dev_loose = np.abs(list(deviations(loose.fit(problems_4000).params, vessel.coefficients).values()))
    res = tight.fit(problems_4000)
    dev_tight = np.abs(list(deviations(res.params, vessel.coefficients).values()))
    assert all(res.metrics[f"svm/{d}/converged"] == 1.0 for d in "XYN")
    assert np.median(dev_loose) > 5.0
    assert np.median(dev_tight) < 0.01 and dev_tight.max() < 1.0


def test_config_keys_are_constructor_options():
    """The typed ``method=svm`` settings, as a run passes them, build the estimator."""
    cfg = compose_settings("config", ["method=svm", "seed=3"])
    options = {k: v for k, v in asdict(cfg.method).items() if k != "name"}
    assert cfg.method.name == SupportVectorRegression.name == "svm"
    svm = SupportVectorRegression(**options)
    assert svm.c_grid == tuple(options["c_grid"]) and svm.seed == 3