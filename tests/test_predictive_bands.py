"""Posterior predictive bands with a model discrepancy (method.discrepancy=process_noise).

The bands replay a validation record with coefficient sets drawn from the
posterior and, with a discrepancy, a realisation of the accelerations the
model misses (an AR(1) per DOF whose intensity and correlation time the
Kalman filter's prediction error estimates on the training records). They
must neither be overconfident (coverage far below nominal) nor uselessly
wide (as wide as the manoeuvre).

Measured on simulated Mariner records (full Abkowitz model as the truth,
SVM-paper NL1 process noise, zig-zag 20/20 of 1200 s to train, another
realisation of a 600 s zig-zag 20/20 to validate; 90 % band of x0 and y0):

* identified with the model that made the data (40 terms): the discrepancy
  barely widens the band (the coefficients' posterior already spreads the
  replays more than the process noise does);
* identified with the 2 + 5 + 5-term model of Li et al. (2023) eq. 23-25
  (a wrong model), seeds 0-3: without the discrepancy the band covers
  16-31 % of the record (about 50 m wide), with it 90-100 % (460-630 m
  wide, the manoeuvre's extent is 3960 m).
"""

from __future__ import annotations

import json
import logging

import numpy as np
import pandas as pd
import pytest

from studies.analysis.bands import (band_statistics, crps_ensemble, interval_score, plot_calibration,
                                    trust_verdict)
from studies.environment.noise import disturbance_forces
from studies.errors import ConfigError
from studies.identification import build_problems
from studies.identification.bayes import BayesianRegression
from studies.identification.discrepancy import Discrepancy, estimate_process_noise
from studies.identification.objective import TrajectoryObjective
from studies.identification.regression import prime_states
from studies.models import abkowitz
from studies.models.registry import get_model
from studies.simulate import simulate, zigzag
from studies.workflows.measured import posterior_band, posterior_vectors

from conftest import marin_file

#: SVM paper Table 2: k0 of NL1
NL1 = 0.05


# ------------------------------------------------------------------ scores

def test_interval_score_of_known_cases():
    lower, upper = np.zeros(4), np.full(4, 2.0)
    y = np.array([1.0, -1.0, 3.0, 2.0])
    # inside: the width; outside: the width plus 2/alpha times the miss
    np.testing.assert_allclose(interval_score(lower, upper, y, 0.1), [2.0, 22.0, 22.0, 2.0])
    np.testing.assert_allclose(interval_score(lower, upper, y, 0.5), [2.0, 6.0, 6.0, 2.0])


def test_crps_of_an_ensemble():
    # one member: the absolute error
    np.testing.assert_allclose(crps_ensemble([[1.0, -2.0]], [0.5, 1.0]), [0.5, 3.0])
    # a large standard normal ensemble: the closed form of Gneiting & Raftery (2007, eq. 21)
    from scipy.stats import norm
    rng = np.random.default_rng(0)
    y = np.array([0.0, 0.5, 2.0])
    samples = rng.standard_normal((20000, 1)) * np.ones((1, 3))
    exact = y * (2 * norm.cdf(y) - 1) + 2 * norm.pdf(y) - 1 / np.sqrt(np.pi)
    np.testing.assert_allclose(crps_ensemble(samples, y), exact, atol=0.01)


# ------------------------------------------------------------------ the discrepancy process

@pytest.mark.parametrize("tau, step", [(5.0, 0.1), (0.02, 0.1)])
def test_realisation_keeps_the_low_frequency_content(tau, step):
    """Step means of an Ornstein-Uhlenbeck process: correlation exp(-step/tau),
    and the variance of a long average (2 sigma^2 tau / T) whatever the step."""
    disc = Discrepancy("process_noise", np.array([1.0, 2.0, 0.5]), tau)
    a = disc.realise(200_000, step, np.random.default_rng(1))
    phi = np.exp(-step / tau)
    lag1 = np.mean(a[1:] * a[:-1], axis=0) / np.mean(a * a, axis=0)
    np.testing.assert_allclose(lag1, phi, atol=0.02)
    block = int(round(200.0 / step))                       # 200 s averages, >> tau
    means = a[: (len(a) // block) * block].reshape(-1, block, 3).mean(axis=1)
    expected = 2.0 * disc.sigma ** 2 * tau / 200.0
    np.testing.assert_allclose(np.var(means, axis=0), expected, rtol=0.35)


def test_external_forces_give_the_accelerations(vessel):
    """With every coefficient zero the integrator's accelerations are exactly
    the discrepancy's (columns 6-8 of the external forces, prime at U0)."""
    model = abkowitz()
    zero = {name: 0.0 for name in model.names}
    man = zigzag(10.0, 10.0, duration=10.0)
    acc = np.array([0.01, -0.02, 1e-4])
    ext = Discrepancy.external(np.tile(acc, (len(man.step_times()) - 1, 1)), vessel)
    rec = simulate(model, zero, vessel, man, external=ext)
    t = rec["t"].to_numpy()
    np.testing.assert_allclose(rec["u"].to_numpy() - vessel.speed, acc[0] * t, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(rec["v"].to_numpy(), acc[1] * t, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(rec["r"].to_numpy(), acc[2] * t, rtol=1e-6, atol=1e-12)


def test_bad_discrepancy_settings_are_refused(refused_in_process, tmp_path):
    for bad in ({"discrepancy": "gp"}, {"discrepancy_step": 0.0}, {"discrepancy_evaluations": 0}):
        with pytest.raises(ConfigError):
            BayesianRegression(**bad)
    refused_in_process("config", ["method=bayes", "method.discrepancy=gp"], tmp_path, "run",
                       "method.discrepancy")


# ------------------------------------------------------------------ calibration of synthetic bands

def _synthetic(n=2000, draws=300, spread=1.0, offset=0.0, seed=0):
    """A measured track that is one more member of the ensemble's distribution
    (x0 and y0 moved together), the ensemble scaled by ``spread`` and shifted
    by ``offset``; the manoeuvre extends over 100 m."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.5
    base = np.linspace(0.0, 100.0, n)
    noise = rng.standard_normal(n)
    record = pd.DataFrame({"t": t, "x0": base + noise, "y0": base + noise, "psi": np.zeros(n)})
    members = offset + spread * rng.standard_normal((draws, n))
    states = np.zeros((draws, n, 7))
    states[:, :, 3] = base + members
    states[:, :, 4] = base + members
    return states, np.full(draws, -1), record


@pytest.mark.slow
def test_calibrated_overconfident_and_useless_bands_are_told_apart(tmp_path):
    states, div, record = _synthetic()
    good = band_statistics(states, div, record, noise=False)
    for level in (50, 80, 90, 95):
        assert good[f"coverage_xy_{level}"] == pytest.approx(level / 100, abs=0.04)
    assert good["coverage_xy_90"] == good["coverage_xy"]
    trusted, text = trust_verdict("rec", good)
    assert trusted and "can be trusted" in text
    # overconfident: a band a fifth as wide
    narrow = band_statistics(*_synthetic(spread=0.2), noise=False)
    assert narrow["coverage_xy"] < 0.4
    assert narrow["interval_score_xy_m"] > 2 * good["interval_score_xy_m"]
    trusted, text = trust_verdict("rec", narrow)
    assert not trusted and "overconfident" in text
    # uselessly wide: wider than the manoeuvre
    wide = band_statistics(*_synthetic(spread=80.0), noise=False)
    assert wide["coverage_xy"] == 1.0 and wide["width_over_extent"] > 1.0
    assert wide["crps_xy_m"] > 10 * good["crps_xy_m"]
    trusted, text = trust_verdict("rec", wide)
    assert not trusted and "as wide as the manoeuvre" in text
    plot_calibration(narrow, tmp_path / "calibration.png", "narrow")
    assert (tmp_path / "calibration.png").stat().st_size > 5_000


def test_joint_band_holds_a_calibrated_ensemble_as_often_as_nominal():
    """Replays whose x0 and y0 errors are independent, and a measurement that
    is one more replay: the 5-95 % bands of x0 and y0 hold both about 0.9^2 of
    the time (less with 50 replays), the joint band as often as its level."""
    rng = np.random.default_rng(7)
    n, draws = 4000, 50
    t = np.arange(n) * 1.0
    states = np.zeros((draws, n, 7))
    states[:, :, 3] = rng.standard_normal((draws, n))
    states[:, :, 4] = 3.0 * rng.standard_normal((draws, n))
    record = pd.DataFrame({"t": t, "x0": rng.standard_normal(n), "y0": 3.0 * rng.standard_normal(n),
                           "psi": np.zeros(n)})
    stats = band_statistics(states, np.full(draws, -1), record, noise=False)
    assert 0.72 < stats["coverage_xy"] < 0.84
    for level in (50, 80, 90, 95):
        assert stats[f"coverage_joint_{level}"] == pytest.approx(level / 100, abs=0.03)
    assert stats["coverage_joint"] == stats["coverage_joint_90"]
    trusted, text = trust_verdict("rec", {**stats, "width_over_extent": 0.1, "diverged": 0.0})
    assert trusted and "joint 90 % band" in text


# ------------------------------------------------------------------ simulated records

def _noisy_zigzag(vessel, duration, seed, level=NL1):
    """A 20/20 zig-zag of the full Mariner model with SVM-paper process noise."""
    full = abkowitz()
    truth = {n: vessel.coefficients[n] for n in full.names}
    man = zigzag(20, 20, duration=duration)
    clean = simulate(full, truth, vessel, man)
    scale = np.max(np.abs(full.forces(prime_states(clean["u"], clean["v"], clean["r"],
                                                   clean["delta"], vessel), truth)), axis=0)
    rng = np.random.default_rng(seed)
    ext = disturbance_forces(len(man.step_times()) - 1, man.step, scale, 0.0, level, rng)
    record = simulate(full, truth, vessel, man, None, ext)
    record.attrs["name"] = man.name
    return record


def _bands(model, vessel, train, val, seed=0, evaluations=600):
    """Identify on ``train``; the bands of ``val`` (a record or a list) without
    and with the discrepancy (estimated with at most ``evaluations``
    likelihood evaluations)."""
    with _quiet():
        bayes = BayesianRegression(n_samples=800, burn_in=200, thin=4, seed=seed,
                                   discrepancy="process_noise", discrepancy_evaluations=evaluations)
        result = bayes.fit(build_problems(model, vessel, train, "auto"),
                           objective=TrajectoryObjective(model, vessel, [train]))
    vectors = posterior_vectors(model, result, 50, seed)
    disc = Discrepancy.from_sample(result.samples["discrepancy"])
    if isinstance(val, pd.DataFrame):
        return (result, disc, posterior_band(model, vectors, vessel, val),
                posterior_band(model, vectors, vessel, val, discrepancy=disc, seed=seed))
    return (result, disc, [posterior_band(model, vectors, vessel, v) for v in val],
            [posterior_band(model, vectors, vessel, v, discrepancy=disc, seed=seed) for v in val])


class _quiet:
    """Short chains: 'not converged' warnings expected."""

    def __enter__(self):
        logging.disable(logging.WARNING)

    def __exit__(self, *exc):
        logging.disable(logging.NOTSET)


@pytest.mark.slow
def test_discrepancy_makes_the_band_of_a_wrong_model_honest(vessel):
    """A wrong (simplified) model of process-noise records: without the
    discrepancy the 90 % band loses the held-out record most of the time;
    with it the band holds it about as often as nominal, narrower than the
    manoeuvre."""
    model = get_model("simplified_li2023")
    train = _noisy_zigzag(vessel, 1200.0, 10)
    val = _noisy_zigzag(vessel, 600.0, 20)
    result, disc, plain, band = _bands(model, vessel, train, val, evaluations=200)
    print(f"\nwithout discrepancy: coverage {plain['coverage_xy']:.2f}, width {plain['width_xy_m']:.0f} m;"
          f" with: {band['coverage_xy']:.2f}, {band['width_xy_m']:.0f} m "
          f"(extent {band['extent_m']:.0f} m); sigma {disc.sigma}, tau {disc.taus} s")
    assert plain["coverage_xy"] < 0.5                    # overconfident without the discrepancy
    assert band["coverage_xy"] >= 0.8                    # not far below nominal with it
    assert band["width_xy_m"] < 0.5 * band["extent_m"]   # and not as wide as the manoeuvre
    assert band["diverged"] < 0.1
    for key in ("discrepancy/sigma_v_m_s2", "discrepancy/tau_s", "discrepancy/initial_sd_v_m_s"):
        assert np.isfinite(result.metrics[key])


#: held-out records per seed in the slow tests (one record's coverage is nearly
#: all or nothing: its errors are correlated over the whole record)
HELD_OUT = 4


@pytest.mark.slow
def test_process_noise_is_recovered_and_bands_stay_calibrated(vessel):
    """The right model of process-noise records, seeds 0-5, four held-out
    records each: the estimate of the discrepancy is that of the simulated
    noise (spectral density of the sway and yaw forces within a factor 2, in
    prime units at U0: the SVM paper's noise is prime at the current speed,
    so it is scaled by the mean (U/U0)^4), the 90 % coefficient intervals
    cover the truth 80-97 % of the time, the discrepancy brings the 90 %
    bands closer to nominal and does not make them wide (less than twice
    the width without it, a fifth of the manoeuvre).

    Measured: coefficient coverage 0.83; mean band coverage (x0 and y0 both
    inside their 5-95 % bands) 0.72 with the discrepancy, 0.50 without,
    widened by a factor 1.32-1.65; the joint 90 % band (the region holding 90
    % of the replays jointly) covers 0.83 (estimated spectral densities 1.15,
    1.14 and 1.44 times the simulated ones for surge, sway and yaw). Why not
    0.9: (1) both channels inside their own 5-95 % bands is a smaller region
    than 90 % of the replays; (2) the short chains of this test (800
    samples after 200 steps of burn-in) give 0.72-0.74 where the default
    ones (10 000 samples) give 0.79 (joint 0.94); (3) seed 4's sway
    posterior misses the truth jointly (P(chi2_15 > d2) = 0.002), and its
    four held-out records share the error. Not the discrepancy: the true
    coefficients with the estimated discrepancy cover 0.83 (joint 0.93), the
    true process noise 0.88. On seeds 6-11, which development did not use,
    with the default chains: coefficient coverage 0.85, band 0.87 (joint
    0.91), without the discrepancy 0.79 (joint 0.83).
    """
    model = abkowitz()
    truth = {n: vessel.coefficients[n] for n in model.names}
    hits, cover, cover_plain, ratio, extent, joint = [], [], [], [], [], []
    for seed in range(6):
        train = _noisy_zigzag(vessel, 1200.0, 100 + seed)
        held = [_noisy_zigzag(vessel, 600.0, 200 + 10 * seed + k) for k in range(HELD_OUT)]
        result, disc, plain, bands = _bands(model, vessel, train, held, seed)
        hits += [result.lower[n] <= truth[n] <= result.upper[n] for n in model.names]
        cover += [b["coverage_xy"] for b in bands]
        joint += [b["coverage_joint"] for b in bands]
        cover_plain += [b["coverage_xy"] for b in plain]
        ratio += [b["width_xy_m"] / p["width_xy_m"] for b, p in zip(bands, plain)]
        extent += [b["width_over_extent"] for b in bands]
        if seed == 0:
            man = zigzag(20, 20, duration=1200.0)
            full = simulate(model, truth, vessel, man)
            scale = np.max(np.abs(model.forces(prime_states(full["u"], full["v"], full["r"],
                                                            full["delta"], vessel), truth)), axis=0)
            u4 = np.mean(((train["u"] ** 2 + train["v"] ** 2) / vessel.speed ** 2).to_numpy() ** 2)
            true_density = (scale * np.array([0.2, 1.0, 1.0]) * NL1) ** 2 * man.step * u4
            density = disc.force_density(vessel)
            print("\nspectral density (prime at U0) of X, Y, N: true", true_density, "estimated", density)
            assert np.all(np.abs(np.log(density[1:] / true_density[1:])) < np.log(2.0))
    print(f"coefficient coverage {np.mean(hits):.2f}; band coverage with discrepancy "
          f"{np.mean(cover):.2f} {np.round(cover, 2)} (joint band {np.mean(joint):.2f}), without "
          f"{np.mean(cover_plain):.2f}; "
          f"width ratio {np.min(ratio):.2f}-{np.max(ratio):.2f}")
    assert 0.80 <= np.mean(hits) <= 0.97
    assert 0.70 <= np.mean(cover) <= 0.97
    assert 0.80 <= np.mean(joint) <= 0.97
    assert np.mean(cover) > np.mean(cover_plain) + 0.1
    assert max(ratio) < 2.0 and max(extent) < 0.2


@pytest.mark.slow
def test_wrong_model_bands_over_seeds(vessel):
    """As the fast test, seeds 0-3, four held-out records each: mean 90 %
    coverage of at least 0.8 with the discrepancy (below 0.4 without), never
    wider than half the manoeuvre.

    Measured: 0.98 with the discrepancy (every record 0.89-1.00), 0.28
    without.
    """
    model = get_model("simplified_li2023")
    cover, cover_plain = [], []
    for seed in range(4):
        train = _noisy_zigzag(vessel, 1200.0, 100 + seed)
        held = [_noisy_zigzag(vessel, 600.0, 5000 + 10 * seed + k) for k in range(HELD_OUT)]
        _, _, plain, bands = _bands(model, vessel, train, held, seed)
        cover += [b["coverage_xy"] for b in bands]
        cover_plain += [b["coverage_xy"] for b in plain]
        assert all(b["width_over_extent"] < 0.5 for b in bands)
    print(f"\nwith discrepancy {np.mean(cover):.2f} {np.round(cover, 2)}, without "
          f"{np.mean(cover_plain):.2f} {np.round(cover_plain, 2)}")
    assert np.mean(cover) >= 0.8
    assert np.mean(cover_plain) < 0.4


# ------------------------------------------------------------------ KVLCC2

@pytest.mark.slow
def test_kvlcc2_bands_with_the_discrepancy(tmp_path):
    """``studies run vessel=kvlcc2 method=bayes method.discrepancy=process_noise``
    on zz_20 + tc_35, validated on zz_10: the files and metrics of the bands,
    and the measured figures (seed 0). The zig-zag is replayed as it was run
    (``validate.band_replay=steered``): the joint 90 % band holds the measured
    track 70 % of the time, the 90 % bands of x0 and y0 each 60 %, 81 m wide
    on a 3790 m manoeuvre (CRPS 15.3 m); one record says little about
    calibration (tests/test_band_calibration.py and docs/calibration.md judge
    it over many), and with two training records the discrepancy is
    estimated in sample, which the 16 KVLCC2 records show to be narrow for
    steered replays. Replayed with its measured rudder it held 84 % and 80 %,
    143 m wide (without the discrepancy 74 and 76 %). (Before the
    discrepancy had a correlation time per channel, a growth with |r'| and
    the initial spread of the start of the records: 82 % and 156 m; the
    initial spread then was the RMS of the sensor biases over whole records,
    which took in the turning circle's velocity-track departure in the turn,
    0.095 m/s in sway, several times the bias at the start of any record.)"""
    from conftest import REPO, run_studies

    zz10, zz20, tc = (marin_file(n) for n in ("zz_10", "zz_20", "tc_35"))
    out = tmp_path / "run"
    proc = run_studies(["run", "vessel=kvlcc2", "method=bayes", "method.discrepancy=process_noise",
                        f"data.path=[{zz20},{tc}]", f"validate.path=[{zz10}]",
                        "validate.compare_derivatives=false", f"hydra.run.dir={out}",
                        f"tracking.uri=sqlite:///{tmp_path}/m.db"], cwd=REPO, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    metrics = json.loads((out / "metrics.json").read_text())
    rec = "MARIN_FREE_KVLCC2_zz_10_m"
    for key in ("coverage_xy_50", "coverage_xy_80", "coverage_xy_90", "coverage_xy_95", "width_xy_m",
                "interval_score_xy_m", "crps_xy_m", "covered_until_s", "trusted", "outside_training"):
        assert f"{rec}/band/{key}" in metrics, key
    assert metrics[f"{rec}/band/discrepancy"] == 1.0
    assert metrics[f"{rec}/band/steered"] == 1.0
    assert 0.5 <= metrics[f"{rec}/band/coverage_xy"] <= 0.97
    assert 0.6 <= metrics[f"{rec}/band/coverage_joint"] <= 0.97
    assert metrics[f"{rec}/band/width_over_extent"] < 0.05
    assert metrics[f"{rec}/band/crps_xy_m"] < 30.0
    assert metrics["discrepancy/tau_s"] > 0
    text = (out / "bands.md").read_text()
    assert rec in text and "trusted" in text
    assert (out / f"calibration_{rec}.png").is_file()
