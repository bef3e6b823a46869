"""Bayesian roll identification (``model=roll method=bayes``) and the predictive bands of a decay.

The posterior must cover known coefficients on simulated decays with noise
(over seeds, not one lucky seed); its bands must be calibrated when the
model is right, and the bands must be flagged when they are overconfident
(a wrong model taken as exact) or uselessly wide (wider than the decay).

Measured with 4000 samples (burn-in 300, thin 6): 1 % noise, 60 s decays
at 10 deg, omega0 = 2.5 rad/s, b1 = 0.06 1/s, b2 = 0.4, seeds 0-39: the
90 % intervals covered the truth in 89 % of the 120 coefficient intervals
(omega0 80 %, b1 93 %, b2 95 %; 85 % with independent residuals). The 90 %
band of a second decay (8 deg, 0.5 % noise) covered 89-90 % (seeds 0-2).
With a softening restoring moment (c3 = -3 1/s^2, 20 deg) the ``b1 + b2``
model is wrong: taken as exact its band covers 25 % of a second decay, with
the AR(2) likelihood alone 36 %, with the coefficient wander as well 99 %
at a quarter of the decay's amplitude.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.analysis.bands import LEVELS
from studies.errors import ConfigError
from studies.roll.bands import (band_statistics, covered_until_period, predictive_replays, trust_verdict)
from studies.roll.bayes import BayesRollEstimator, DecayPosterior, ar2_fit, pacf_to_ar
from studies.roll.discrepancy import RollDiscrepancy, estimate_wander, innovation_loglik
from studies.roll.estimators import NLSEstimator
from studies.roll.methods import ROLL_METHODS, make_method
from studies.roll.model import RollModel
from studies.roll.records import initial_state_covariance, prepare_decay
from studies.roll.simulate import simulate_decay_record

from conftest import SHARED_DATA, mlflow_runs, run_studies

TRUTH = {"omega0": 2.5, "b1": 0.06, "b2": 0.4}
#: a softening restoring moment the b1 + b2 model lacks: the period drifts with the amplitude
WRONG = {"omega0": 2.5, "b1": 0.02, "b2": 0.1, "c3": -3.0}
#: short chains for the tests (the run's defaults are 10 000 samples)
QUICK = {"n_samples": 1500, "burn_in": 200, "thin": 4}
KVLCC2 = SHARED_DATA / "kvlcc2_roll_decay" / "model_test_21337.csv"


def _decay(params, terms=("b1", "b2"), phi0_deg=10.0, noise=0.01, seed=0, duration=60.0):
    return prepare_decay(simulate_decay_record(params, terms, duration=duration, dt=0.01,
                                               phi0=math.radians(phi0_deg), noise=noise, seed=seed))


# ------------------------------------------------------------------ pieces

def test_wander_of_the_coefficients_enters_the_simulation():
    """No wander leaves the decay unchanged; a constant wander is a shifted omega0^2 and b1."""
    model = RollModel(("b1", "b2"))
    t = np.arange(0.0, 20.0, 0.01)
    plain, _ = model.simulate(TRUTH, 0.15, 0.0, t)
    zero, _ = model.simulate(TRUTH, 0.15, 0.0, t, wander=(np.zeros(t.size - 1), np.zeros(t.size - 1)))
    np.testing.assert_array_equal(plain, zero)
    shifted = {"omega0": math.sqrt(2.5**2 + 0.3), "b1": 0.06 + 0.02, "b2": 0.4}
    expected, _ = model.simulate(shifted, 0.15, 0.0, t)
    wandered, _ = model.simulate(TRUTH, 0.15, 0.0, t, wander=(np.full(t.size - 1, 0.3), np.full(t.size - 1, 0.02)))
    np.testing.assert_allclose(wandered, expected, atol=1e-9)
    with pytest.raises(ValueError):
        model.simulate(TRUTH, 0.15, 0.0, t, wander=(np.zeros(3), np.zeros(3)))


def test_initial_state_error_model_matches_the_scatter_over_noise():
    """The covariance of the initial-state fit predicts its scatter over noise realisations."""
    clean = _decay(TRUTH, noise=0.0)
    t = clean["t"].to_numpy()
    rng = np.random.default_rng(0)
    noise = math.radians(0.1)
    estimates, predicted = [], []
    for _ in range(200):
        noisy = clean.copy()
        noisy["phi"] = clean["phi"].to_numpy() + noise * rng.standard_normal(t.size)
        mean, cov = initial_state_covariance(noisy, noise)
        estimates.append(mean)
        predicted.append(np.sqrt(np.diag(cov)))
    ratio = np.std(estimates, axis=0) / np.mean(predicted, axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def test_ar2_partial_autocorrelations_round_trip():
    rng = np.random.default_rng(1)
    a1, a2 = 1.8, -0.9                       # a narrow-band oscillation
    r = np.zeros(20000)
    e = rng.standard_normal(r.size)
    for i in range(2, r.size):
        r[i] = a1 * r[i - 1] + a2 * r[i - 2] + e[i]
    pacf = ar2_fit([r])
    np.testing.assert_allclose(pacf_to_ar(*pacf), (a1, a2), atol=0.01)
    assert ar2_fit([rng.standard_normal(5000)]) == pytest.approx((0.0, 0.0), abs=0.05)


def test_posterior_is_centred_on_the_output_error_fit():
    """The sampled coordinates are (marginal) standard errors about the NLS
    solution: three of them away in any direction the log-posterior has fallen
    by at least the z^2 / 2 of a standard error (more along correlated
    coefficients, whose conditional spread is smaller); its peak, on a
    subsample of the record, lies within that box."""
    rec = _decay(TRUTH, seed=3)
    params, meta = NLSEstimator(("b1", "b2"))._fit([rec])
    for autoregressive in (False, True):
        post = DecayPosterior(RollModel(("b1", "b2")), [rec], params, meta["initial_states"],
                              autoregressive=autoregressive)
        centre = post.log_prob(np.zeros((1, post.ndim)))[0]
        k = post.n_states
        steps = 3.0 * np.vstack([np.eye(post.ndim)[:k], -np.eye(post.ndim)[:k]])
        drop = centre - post.log_prob(steps)
        assert np.all(drop > 0.5), drop
        assert post.log_prob(np.full((1, post.ndim), -1e9))[0] == -np.inf   # omega0 <= 0
    assert abs(post.pacf_ls[0]) < 0.2 and abs(post.pacf_ls[1]) < 0.2     # white noise: no AR to speak of


def test_bayes_is_a_roll_method_and_refuses_bad_settings():
    assert "bayes" in ROLL_METHODS and isinstance(make_method("bayes", ("b1",)), BayesRollEstimator)
    for bad in ({"discrepancy": "gp"}, {"n_walkers": 5}, {"thin": 0}, {"init_scale": 0.0}):
        with pytest.raises(ConfigError):
            BayesRollEstimator(**bad)


def test_holdout_setting_is_checked(refused_in_process, tmp_path):
    refused_in_process("config", ["model=roll", "method=bayes", "model.holdout=0.95"], tmp_path, "run",
                       "model.holdout")


def test_wander_is_found_on_a_wrong_model_and_not_on_a_right_one():
    """The prediction-error estimate: no wander to speak of on a decay of the model,
    a clear one on a decay with a restoring moment the model lacks."""
    right = _decay(TRUTH, noise=0.005, seed=4)
    found = estimate_wander(TRUTH, ("b1", "b2"), [right], max_evaluations=150)
    assert found.frequency_sd(2.5) < 1e-3
    wrong = _decay(WRONG, ("b1", "b2", "c3"), phi0_deg=20.0, noise=0.005, seed=4)
    params, _ = NLSEstimator(("b1", "b2"))._fit([wrong])
    found = estimate_wander(params, ("b1", "b2"), [wrong], max_evaluations=150)
    assert found.frequency_sd(params["omega0"]) > 2e-3
    assert found.loglik > found.info["loglik_exact"] + 50
    exact = innovation_loglik(params, ("b1", "b2"), [wrong], 0.0, 0.0, 1.0)
    assert exact == pytest.approx(found.info["loglik_exact"])


# ------------------------------------------------------------------ band scores

def _ensemble(spread=1.0, offset=0.0, n=1000, draws=60, seed=0):
    """A decay measured as one more member of an ensemble of decays whose
    amplitude and phase scatter, the ensemble's scatter scaled by ``spread``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    def member(a, p):
        return (0.17 + a) * np.exp(-0.03 * t) * np.cos(2.5 * t + p)
    record = pd.DataFrame({"t": t, "phi": member(0.004 * rng.standard_normal(), 0.05 * rng.standard_normal())})
    record.attrs["period"] = 2 * math.pi / 2.5
    replays = np.array([member(spread * 0.004 * rng.standard_normal() + offset,
                               spread * 0.05 * rng.standard_normal()) for _ in range(draws)])
    return replays, np.zeros(draws, bool), record


def test_calibrated_overconfident_and_useless_bands_are_told_apart():
    # one record is one draw of the phase and amplitude: pool a few to judge the calibration
    good = [band_statistics(*_ensemble(seed=s), noise=1e-5, seed=s) for s in range(8)]
    for level in LEVELS:
        key = f"coverage_{int(round(100 * level))}"
        assert np.mean([g[key] for g in good]) == pytest.approx(level, abs=0.12), key
    narrow = band_statistics(*_ensemble(spread=0.1, seed=2), noise=1e-5)
    assert narrow["coverage_90"] < 0.5
    trusted, text = trust_verdict("rec", narrow)
    assert not trusted and "overconfident" in text
    wide = band_statistics(*_ensemble(spread=1.0, seed=2), noise=math.radians(20.0))
    assert wide["width_over_amplitude"] > 1.0 and wide["coverage_90"] > 0.97
    trusted, text = trust_verdict("rec", wide)
    assert not trusted and "as wide as the decay" in text
    assert wide["interval_score_deg"] > 3 * np.median([g["interval_score_deg"] for g in good])


def test_covered_until_counts_whole_periods():
    t = np.arange(0.0, 10.0, 0.01)
    inside = np.ones(t.size, bool)
    assert covered_until_period(t, inside, 2.0) == pytest.approx(t[-1])
    inside[(t >= 4.0) & (t < 6.0)] = False          # the third period is lost
    assert covered_until_period(t, inside, 2.0) == pytest.approx(4.0)
    inside[:] = True
    inside[::2] = False                              # half in, half out: not lost
    assert covered_until_period(t, inside, 2.0) == pytest.approx(t[-1])


# ------------------------------------------------------------------ posterior and bands (slow)

@pytest.mark.slow
def test_posterior_covers_known_coefficients_over_seeds():
    """Simulated decays with 1 % noise: the 90 % intervals of omega0, b1, b2
    cover the truth at a sane rate over seeds, and are not uselessly wide."""
    hits, widths = [], []
    for seed in range(8):
        fit = BayesRollEstimator(("b1", "b2"), seed=seed, **QUICK).fit(_decay(TRUTH, seed=seed))
        for name, value in TRUTH.items():
            lo, hi = fit.meta["lower"][name], fit.meta["upper"][name]
            hits.append(lo <= value <= hi)
            widths.append((hi - lo) / value)
        assert fit.meta["metrics"]["bayes/roll/acceptance_fraction"] > 0.15
    coverage = float(np.mean(hits))
    assert 0.7 <= coverage <= 1.0, coverage
    assert max(widths) < 0.2, widths          # b2 within +-10 % at 1 % noise


@pytest.mark.slow
def test_bands_of_a_right_model_are_calibrated():
    train = _decay(TRUTH, noise=0.005, seed=0)
    fit = BayesRollEstimator(("b1", "b2"), seed=0, discrepancy="process_noise", **QUICK).fit(train)
    cover = []
    for seed in (1, 2):
        other = _decay(TRUTH, phi0_deg=8.0, noise=0.005, seed=seed)
        replays, diverged = predictive_replays(fit.meta["samples"]["values"], fit.meta["samples"]["names"],
                                               ("b1", "b2"), other, 60, fit.meta["discrepancy"], seed)
        cover.append(band_statistics(replays, diverged, other, seed=seed))
    assert 0.8 <= np.mean([c["coverage_90"] for c in cover]) <= 0.97
    assert 0.35 <= np.mean([c["coverage_50"] for c in cover]) <= 0.65
    assert all(trust_verdict("rec", c)[0] for c in cover)


@pytest.mark.slow
def test_wrong_model_bands_overconfident_without_discrepancy_and_honest_with_it():
    """The b1 + b2 model of a decay with a softening restoring moment: taken as exact
    (independent residuals, no discrepancy) its bands lose the held-out decay; with
    the AR(2) likelihood and the coefficient wander they hold it without being
    as wide as the decay."""
    train = _decay(WRONG, ("b1", "b2", "c3"), phi0_deg=20.0, noise=0.005, seed=0)
    held = _decay(WRONG, ("b1", "b2", "c3"), phi0_deg=16.0, noise=0.005, seed=1)
    stats = {}
    for label, settings in (("exact", {"autocorr_correction": False, "discrepancy": "none"}),
                            ("discrepancy", {"autocorr_correction": True, "discrepancy": "process_noise"})):
        fit = BayesRollEstimator(("b1", "b2"), seed=0, **settings, **QUICK).fit(train)
        replays, diverged = predictive_replays(fit.meta["samples"]["values"], fit.meta["samples"]["names"],
                                               ("b1", "b2"), held, 60, fit.meta["discrepancy"], 1)
        stats[label] = band_statistics(replays, diverged, held, seed=1)
    exact, honest = stats["exact"], stats["discrepancy"]
    assert exact["coverage_90"] < 0.7
    trusted, text = trust_verdict("held", exact)
    assert not trusted and "overconfident" in text
    assert honest["coverage_90"] >= 0.8
    assert honest["width_over_amplitude"] < 0.5
    assert honest["interval_score_deg"] < exact["interval_score_deg"]


@pytest.mark.slow
@pytest.mark.skipif(not KVLCC2.is_file(), reason=f"measured roll decays not found: {KVLCC2}")
def test_bayes_run_on_a_measured_decay_through_the_cli(tmp_path):
    """``studies run model=roll method=bayes`` on the SSPA KVLCC2 test 21337 with
    its last 30 % of half-cycles held out, as a user runs it."""
    run = tmp_path / "run"
    proc = run_studies(["run", "model=roll", "method=bayes", f"data.path={KVLCC2}", "model.holdout=0.3",
                        "method.discrepancy=process_noise", "method.n_samples=2000", "method.burn_in=200",
                        "method.thin=4", "validate.band_draws=30", f"hydra.run.dir={run}"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    table = pd.read_csv(run / "coefficients.csv").set_index("name")
    assert list(table.index) == ["omega0", "b1", "b2"]
    assert np.all(table["lower"] < table["value"]) and np.all(table["value"] < table["upper"])
    metrics = json.loads((run / "metrics.json").read_text())
    held = "model_test_21337_last"
    for key in ("coverage_50", "coverage_80", "coverage_90", "coverage_95", "covered_until_s", "width_deg",
                "interval_score_deg", "crps_deg", "envelope_coverage_90", "trusted", "outside_training"):
        assert f"{held}/band/{key}" in metrics, key
    for key in ("bayes/roll/acceptance_fraction", "bayes/roll/autocorr_time_max", "discrepancy/tau_s"):
        assert key in metrics, key
    assert 0.0 <= metrics[f"{held}/band/coverage_50"] <= metrics[f"{held}/band/coverage_95"] <= 1.0
    # the held-out cycles lie below the training amplitudes: the verdict says so
    assert metrics[f"{held}/band/outside_training"] > 0.5
    text = (run / "bands.md").read_text()
    assert held in text and "training decays' amplitudes" in text
    for name in (f"band_{held}.png", f"calibration_{held}.png", f"band_{held}.csv", "corner_roll.png",
                 "metric_history.json"):
        assert (run / name).is_file(), name
    runs = mlflow_runs(tmp_path)
    assert len(runs) == 1 and runs[0][1] == "FINISHED"
