"""The one inference of ``studies discover`` (``discover/inference.py``): its
signatures, its comparison and its refusals."""

import numpy as np
import pytest

from studies.discovery import inference as inf
from studies.discovery.causes import EnvironmentalBias, RudderOffset
from studies.discovery.fitting import Context
from studies.models.abkowitz import abkowitz
from studies.scenarios.hidden import hidden_records


@pytest.fixture(scope="module")
def clean(vessel_module):
    records, _ = hidden_records(vessel_module, "none", seed=5)
    return records


@pytest.fixture(scope="module")
def vessel_module():
    from studies.vessels import get_vessel

    return get_vessel("mariner")


def _every(vessel, records):
    return Context(vessel, abkowitz(), records[:2], [], "central")


def test_an_earth_fixed_force_has_its_exact_signature(vessel_module, clean):
    """A linear cause's signature by central differences through its own hooks
    equals the column written out: the bias turned to body axes with the heading."""
    ctx = _every(vessel_module, clean)
    design = inf._design(ctx, inf._baseline_setup(ctx))
    (variant,) = [v for v in inf._variants(ctx, design, [EnvironmentalBias(fit_moment=False)])
                  if v.cause.id == "environmental_bias"]
    n = design.n_data
    x_bx = variant.columns[:n[0], 0] * design.sigma[0] / design.nominal[0]
    y_by = variant.columns[n[0]:n[0] + n[1], 1] * design.sigma[1] / design.nominal[1]
    y_bx = variant.columns[n[0]:n[0] + n[1], 0] * design.sigma[1] / design.nominal[1]
    assert np.allclose(x_bx, np.cos(design.states[0]["psi"]), atol=1e-6)
    assert np.allclose(y_by, np.cos(design.states[1]["psi"]), atol=1e-6)
    assert np.allclose(y_bx, -np.sin(design.states[1]["psi"]), atol=1e-6)
    # the yaw rows carry no earth-fixed force when bn is not fitted
    assert np.allclose(variant.columns[n[0] + n[1]:n[0] + n[1] + n[2]], 0.0)


def test_the_residualised_comparison_equals_least_squares_on_the_whole_design(vessel_module, clean):
    ctx = _every(vessel_module, clean)
    design = inf._design(ctx, inf._baseline_setup(ctx))
    variants = inf._variants(ctx, design, [RudderOffset()])
    extra = variants[0].columns
    res = inf._Residualised(design, extra)
    x = np.hstack([design.x, extra])
    beta, *_ = np.linalg.lstsq(x, design.y, rcond=None)
    resid = design.y - x @ beta
    per_dof = [float(np.sum(resid[design.dof == k] ** 2)) for k in range(3)]
    assert np.allclose(res.rss(np.arange(extra.shape[1])), per_dof, rtol=1e-6)
    assert res.fit(np.arange(extra.shape[1]))[0] == pytest.approx(beta[-1], rel=1e-6)


def test_blocks_cut_each_record_and_are_shared_by_the_dofs():
    from studies.discovery.selection import row_blocks

    record = np.concatenate([np.repeat([0, 1], [50, 30])] * 3 + [np.full(4, -1)])
    dof = np.concatenate([np.full(80, k) for k in range(3)] + [np.full(4, 3)])
    blocks = row_blocks(record, dof, 20)
    assert np.all(blocks[-4:] == -1)                            # prior rows are never held out
    per_dof = blocks[:240].reshape(3, 80)
    assert np.all(per_dof == per_dof[0])                        # the same rows of every DOF together
    assert len(np.unique(per_dof[0, :50])) == 2                 # 50 rows: two blocks, the rest joins the last
    assert not set(per_dof[0, :50]) & set(per_dof[0, 50:])      # no block spans two records


def test_leave_one_block_out_fits_equal_least_squares_without_the_block():
    from studies.discovery.selection import BlockGrams

    rng = np.random.default_rng(3)
    x = rng.standard_normal((120, 4))
    y = x @ np.array([0.5, 0.0, -1.0, 0.2]) + rng.standard_normal(120)
    blocks = np.repeat(np.arange(6), 20)
    grams = BlockGrams(x, y, blocks)
    index = np.array([[0, 2], [1, 3]])
    fits = grams.folds(index)
    for k in range(6):
        out = blocks == k
        for m, cols in enumerate(index):
            beta = np.linalg.lstsq(x[~out][:, cols], y[~out], rcond=None)[0]
            assert np.allclose(fits.beta[k, m], beta, rtol=1e-6)
            held = 0.5 * (y[out] @ y[out] - np.sum((y[out] - x[out][:, cols] @ beta) ** 2))
            assert fits.held[k, m] == pytest.approx(held, rel=1e-6)


def test_noise_a_cause_fits_does_not_predict_other_blocks_and_a_real_effect_does():
    """A slowly varying column that coloured noise happens to follow in-sample
    (the row-by-row evidence for it is large) is not named; a column that acts
    everywhere is."""
    from studies.discovery.selection import BlockGains, BlockGrams, bayesian_bootstrap, name_per_draw

    rng = np.random.default_rng(11)
    n, blocks = 2400, np.repeat(np.arange(40), 60)
    coloured = np.convolve(rng.standard_normal(n + 59), np.ones(60) / np.sqrt(60), mode="valid")
    effect = np.sin(np.arange(n) / 37.0)
    spurious = np.cos(np.arange(n) / 150.0)
    x = np.column_stack([effect, spurious])
    beta = np.linalg.lstsq(x[:, 1:], coloured, rcond=None)[0]
    naive_t = beta[0] / np.sqrt(np.var(coloured - x[:, 1] * beta[0]) / (x[:, 1] @ x[:, 1]))
    assert abs(naive_t) > 2.5                                    # rows taken as independent: "significant"
    weights = np.vstack([np.ones(40), bayesian_bootstrap(40, draws=500, seed=1)])
    quiet = BlockGains.of(BlockGrams(x, coloured, blocks), {"effect": [[0]], "spurious": [[1]]})
    named = name_per_draw(quiet.held, weights, 2.5)
    assert named[0] == -1                                        # nothing acts: nothing named
    acting = BlockGains.of(BlockGrams(x, coloured + effect, blocks), {"effect": [[0]], "spurious": [[1]]})
    named = name_per_draw(acting.held, weights, 2.5)
    assert named[0] == 0 and np.mean(named[1:] == 0) > 0.8


def test_blocks_follow_the_error_not_the_effect_and_few_blocks_ask_more():
    """The blocks' length is four correlation times of the error: an effect
    that acts slowly along the records (here a slow sway and yaw force the
    cause's column holds) lengthens the baseline's residual's correlation
    many times, but what the cause's fit leaves of it is the noise, and the
    blocks cut from it stay as many as without the effect. The naming
    threshold over few blocks is Student's, higher than the normal quantile
    and falling towards it as the blocks grow in number."""
    from types import SimpleNamespace

    from scipy.stats import norm

    rng = np.random.default_rng(4)
    n = 1500
    t = np.arange(3 * n) % n
    slow = np.sin(2.0 * np.pi * t / 400.0)[:, None]              # 400 rows per period
    noise = rng.standard_normal(3 * n)

    def tau_with(effect):
        residual = noise + effect * slow[:, 0]
        design = SimpleNamespace(residual=residual, n_data=[n, n, n])
        res = SimpleNamespace(y=residual, x=slow,
                              fit=lambda idx: np.linalg.lstsq(slow[:, idx], residual, rcond=None)[0])
        return inf._tau(residual, design), inf._residual_tau(design, res, [np.array([0])])

    plain_none, plain = tau_with(0.0)
    effect_none, effect = tau_with(3.0)
    assert effect_none > 10.0 * plain_none, (effect_none, plain_none)      # the baseline's residual alone
    assert effect < 1.5 * max(plain, 1.0), (effect, plain)
    assert inf._threshold(7, 3) > inf._threshold(7, 5) > inf._threshold(7, 27) > norm.ppf(1.0 - 0.05 / 7)
    assert inf._threshold(7, 10_000) == pytest.approx(norm.ppf(1.0 - 0.05 / 7), rel=1e-3)
