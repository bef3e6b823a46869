"""Output-error refinement of ``studies discover``: with 5 % measurement noise the
equation-error coefficients are biased (errors in variables); simulating the
records instead of regressing on them removes the bias, and the refined cause
carries intervals that cover the hidden value."""

import numpy as np
import pytest

from studies.discover.causes import NoCause, RudderOffset, extended_library
from studies.errors import ConfigError
from studies.discover.fitting import Context, calibrate, fit_cause, validate
from studies.scenarios.hidden import hidden_records
from studies.discover.output_error import needs_refinement, refine, refined_posterior, score_terms
from studies.discover.search import TERM_TRIALS, search, terms_by_output_error
from studies.models.abkowitz import abkowitz


def _context(vessel, cause, seed, noise):
    records, truth = hidden_records(vessel, cause, seed=seed, noise=noise)
    ctx = Context(vessel, abkowitz(), records[:2], records[2:])
    calibrate(ctx)
    return ctx, truth


def _median_deviation(params, truth):
    return float(np.median([abs(params[n] - v) / abs(v) for n, v in truth.items() if v]))


def test_auto_refines_noisy_records_only(vessel):
    clean, _ = _context(vessel, "none", 100, 0.0)
    noisy, _ = _context(vessel, "none", 100, 0.05)
    assert not needs_refinement(clean, "auto") and needs_refinement(noisy, "auto")
    assert needs_refinement(clean, True) and not needs_refinement(noisy, False)


def test_the_setting_is_normalised_once_by_the_settings():
    from studies.config import compose_settings

    assert compose_settings("discover", []).discover.output_error == "auto"
    assert compose_settings("discover", ["discover.output_error=false"]).discover.output_error is False
    assert compose_settings("discover", ["discover.output_error=true"]).discover.output_error is True
    with pytest.raises(ConfigError, match="output_error"):
        compose_settings("discover", ["discover.output_error=sometimes"])


@pytest.mark.slow
def test_output_error_removes_the_noise_bias_of_the_regression(vessel):
    """The model is exact (nothing hidden): the regression's coefficients are off
    through the noise alone, the refined ones must predict the unseen zig-zag at
    least twice as well and be much closer to the true coefficients."""
    ctx, _ = _context(vessel, "none", 100, 0.05)
    regression = fit_cause(ctx, NoCause())
    validate(ctx, regression)
    refined = refine(ctx, regression)
    validate(ctx, refined)
    assert refined.validation_rmse < 0.5 * regression.validation_rmse, (
        regression.validation_rmse, refined.validation_rmse)
    truth = dict(vessel.coefficients)
    before, after = _median_deviation(regression.params, truth), _median_deviation(refined.params, truth)
    assert after < 0.3 and after < 0.5 * before, (before, after)


@pytest.mark.slow
def test_refined_rudder_offset_beats_the_refined_baseline_and_its_interval_covers_the_truth(vessel):
    """Seed 100 at 5 % noise: with equation error alone the offset won the score but
    its biased coefficients predicted the unseen zig-zag worse than the baseline's
    (3.7 m against 2.8 m), so ``none`` was named."""
    ctx, truth = _context(vessel, "rudder_offset", 100, 0.05)
    base = refine(ctx, fit_cause(ctx, NoCause()))
    offset = refine(ctx, fit_cause(ctx, RudderOffset()))
    validate(ctx, base)
    validate(ctx, offset)
    assert offset.validation_rmse < 0.5 * base.validation_rmse
    assert abs(offset.theta[0] - truth["delta0"]) < 0.1 * abs(truth["delta0"])
    post = refined_posterior(ctx, offset, steps=20)
    np.random.seed(12345)           # whatever else drew from numpy's global generator before
    again = refined_posterior(ctx, offset, steps=20)
    assert np.array_equal(post["samples"], again["samples"]), "the interval must not depend on global state"
    assert post["q05"][0] <= truth["delta0"] <= post["q95"][0], (post["q05"], post["q95"], truth)
    assert post["q95"][0] - post["q05"][0] < 0.5 * abs(truth["delta0"])


@pytest.mark.slow
@pytest.mark.parametrize("cause", ["missing_term", "none"])
def test_terms_chosen_by_output_error_name_the_hidden_term_and_nothing_when_none_is_hidden(vessel, cause):
    """At 5 % noise the equation-error score cannot tell a hidden Nrrr from the noise
    (adding it scores worse than the baseline). At the refined baseline the score test
    puts Nrrr among terms of the same shape in turns (Nuvd, Nurr, Nurd score a little
    higher to first order, far above the BIC price of a term); refining the extension
    by each of the best picks Nrrr, with the right value. With nothing hidden no
    library term reaches that price."""
    ctx, truth = _context(vessel, cause, 100, 0.05)
    base = refine(ctx, fit_cause(ctx, NoCause()))
    ranked = score_terms(ctx, base, extended_library(ctx.model, 3))
    price = np.log(base.refined["n"] / base.refined["tau"])
    top, evidence, value = ranked[0]
    if cause == "none":
        assert evidence < price, [(t.name, e) for t, e, _ in ranked[:3]]
        return
    assert evidence > price + 10 and "Nrrr" in [t.name for t, _, _ in ranked[:TERM_TRIALS]]
    terms, fit, _ = terms_by_output_error(ctx, base, base.refined["windows"], base.refined["sigma"],
                                          max_terms=1)
    assert [t.name for t in terms] == ["Nrrr"], [(t.name, e) for t, e, _ in ranked[:TERM_TRIALS]]
    assert abs(fit.params["Nrrr"] - truth["Nrrr"]) < 0.2 * abs(truth["Nrrr"]), (fit.params["Nrrr"], truth)


@pytest.mark.slow
def test_noisy_search_refines_every_cause_and_claims_no_second_cause_when_one_is_hidden(vessel):
    """Wind not modelled, 5 % noise, seed 100: every cause and every pair tried is
    refined and ranked by output error; the wind wins, and no pair gains on it by the
    evidence margin (only one effect is hidden)."""
    records, truth = hidden_records(vessel, "wind_unmodelled", seed=100, noise=0.05)
    ctx = Context(vessel, abkowitz(), records[:2], records[2:])
    res = search(ctx, posterior_steps=10)
    assert res["output_error"] and all(f.refined is not None for f in res["fits"] + res["pairs"])
    assert res["best"].cause.id == "wind_unmodelled", [(f.cause.id, f.score) for f in res["fits"]]
    assert abs(res["best"].theta[0] - truth["speed"]) < 0.2 * truth["speed"]
    miss = np.angle(np.exp(1j * (res["best"].theta[1] - truth["direction"])))   # wrapped to +-pi
    assert abs(miss) < 0.2, (res["best"].theta, truth)
    assert res["pairs"] and res["second"] is None, [(f.cause.id, f.score) for f in res["pairs"]]


@pytest.mark.slow
def test_a_side_force_the_baseline_absorbs_is_found_from_a_small_start(vessel):
    """Refined from the symmetric baseline's coefficients at no effect, the
    propeller's side force stays at zero: those coefficients fit the turns to
    both sides as a compromise, a valley the fit does not leave (cost 5274
    against 2925 from a small side force, on these records). Started also at
    a small side force to either side (the cause's nudges), both parameters
    come out within 20 %. Turning circles to both sides, 3 % white noise on
    every channel."""
    from studies.discover.causes import PropellerAsymmetry
    from studies.scenarios.hidden import parameters_match, turning_to_starboard
    from studies.discover.output_error import refine_cause
    from studies.models.registry import symmetric
    from studies.simulate import turning

    mans = [turning(35, pullout=0.0, duration=500.0), turning_to_starboard(35, duration=500.0)]
    records, truth = hidden_records(vessel, "propeller_asymmetry", seed=31, noise=0.03, manoeuvres=mans,
                                    noise_family="white_all")
    ctx = Context(vessel, symmetric(), records, [])
    calibrate(ctx)
    base = refine(ctx, fit_cause(ctx, NoCause()))
    fit = refine_cause(ctx, fit_cause(ctx, PropellerAsymmetry()), base, base.refined["windows"],
                       base.refined["sigma"], own=False)
    assert parameters_match("propeller_asymmetry", fit.cause.parameters(fit.theta, fit.params), truth), \
        (fit.theta, truth)
    assert fit.refined["cost"] < 0.7 * base.refined["cost"], (fit.refined["cost"], base.refined["cost"])


@pytest.mark.slow
def test_a_pair_holding_a_cause_the_training_records_cannot_decide_is_undecided(vessel):
    """A propeller's side force cannot be told from asymmetric hull terms on a
    turn to one side: tried as a second cause beside a rudder offset, by the
    filter-error method, the pair is undecided too and never named (before,
    the pair's fit was built without it and named on the held-out records)."""
    from studies.discover.causes import PropellerAsymmetry
    from studies.discover.output_error import noise_levels, refine_cause, training_windows
    from studies.discover.prediction_error import FilterScores
    from studies.discover.search import _filter_pair, _gains, second_held_out
    from studies.simulate import turning, zigzag

    mans = [turning(35, pullout=0.0, duration=400.0), zigzag(20, 20, duration=400.0), zigzag(10, 10, duration=400.0)]
    records, _ = hidden_records(vessel, "rudder_offset", seed=100, noise=0.03, manoeuvres=mans)
    ctx = Context(vessel, abkowitz(), records[:2], records[2:])
    calibrate(ctx)
    windows = training_windows(ctx, ctx.train)
    sigma = noise_levels(ctx, ctx.train, windows[0].step)
    base = refine(ctx, fit_cause(ctx, NoCause()), windows, sigma)
    best = refine_cause(ctx, fit_cause(ctx, RudderOffset()), base, windows, sigma, own=False)
    side = fit_cause(ctx, PropellerAsymmetry())
    assert side.undecidable is not None
    scorer = FilterScores(ctx, windows[0].step, sigma)
    scorer.score([base, best])
    pair = _filter_pair(ctx, scorer, best, side)
    assert pair.undecidable is not None
    assert not _gains(pair, best) and not second_held_out(pair, best)
