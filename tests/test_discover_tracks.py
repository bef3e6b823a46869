"""The statistic discovery judges causes by on the tracks
(:func:`studies.discovery.innovations.judge`): the fall in the squared
standardised innovations a cause's columns give (a likelihood ratio), or the
Wald statistic with a covariance robust to innovations correlated within
blocks where smaller.

Innovations here are drawn with numpy, not by the project's filter: white
ones, where the likelihood ratio is right and the robust statistic must
agree with it, and ones correlated over tens of samples (what a sensor
whose noise is correlated over seconds leaves when the filter takes it for
white), where the likelihood ratio of a slowly varying column overstates the
evidence many times and the robust statistic must not.
"""

import numpy as np
from scipy.stats import chi2

from studies.discovery.innovations import InnovationDesign, judge

N_ROWS, BLOCK_ROWS = 3000, 60


def _design(residual: np.ndarray, coefficient_columns: np.ndarray) -> InnovationDesign:
    basis, _ = np.linalg.qr(coefficient_columns)
    projected = residual - basis @ (basis.T @ residual)
    blocks = np.arange(len(residual)) // BLOCK_ROWS
    return InnovationDesign(residual, basis, projected, coefficient_columns, blocks, len(residual), 0.0,
                            fit=None, scorer=None, ctx=None)


def _ar1(rng, n: int, rho: float) -> np.ndarray:
    e = np.empty(n)
    e[0] = rng.standard_normal()
    w = rng.standard_normal(n) * np.sqrt(1.0 - rho ** 2)
    for i in range(1, n):
        e[i] = rho * e[i - 1] + w[i]
    return e


def _columns(rng):
    t = np.linspace(0.0, 1.0, N_ROWS)
    coefficients = np.column_stack([np.ones(N_ROWS), t, rng.standard_normal(N_ROWS)])
    slow = np.sin(2.0 * np.pi * 3.0 * t + 0.4)[:, None]        # a cause acting slowly along the records
    return coefficients, slow


def test_on_white_innovations_the_robust_statistic_agrees_with_the_likelihood_ratio():
    rng = np.random.default_rng(3)
    coefficients, slow = _columns(rng)
    effect = 0.15
    d = _design(rng.standard_normal(N_ROWS) + effect * slow[:, 0], coefficients)
    j = judge(d, slow)
    assert abs(j.coefficients[0] - effect) < 0.1
    assert j.likelihood_ratio > 20.0
    assert 0.5 < j.wald / j.likelihood_ratio < 2.0, (j.wald, j.likelihood_ratio)
    assert j.evidence == min(j.wald, j.likelihood_ratio)


def test_correlated_innovations_do_not_pass_for_evidence():
    """No effect at all: the likelihood ratio of a slow column on innovations
    correlated over ~20 samples exceeds the 1 % quantile of its chi-square far
    more often than 1 % of the time; the evidence the discovery credits does not."""
    rng = np.random.default_rng(11)
    coefficients, slow = _columns(rng)
    quantile = chi2.isf(0.01, 1)
    lr_over, evidence_over = 0, 0
    draws = 200
    for _ in range(draws):
        j = judge(_design(_ar1(rng, N_ROWS, 0.95), coefficients), slow)
        lr_over += j.likelihood_ratio > quantile
        evidence_over += j.evidence > quantile
    assert lr_over > 0.3 * draws, lr_over
    assert evidence_over < 0.06 * draws, evidence_over


def test_a_second_column_is_tested_beside_the_first():
    """``tested`` judges some columns with the others fitted beside them: a
    second column that merely repeats the first earns nothing."""
    rng = np.random.default_rng(5)
    coefficients, slow = _columns(rng)
    d = _design(rng.standard_normal(N_ROWS) + 0.2 * slow[:, 0], coefficients)
    alone = judge(d, slow)
    repeated = judge(d, np.hstack([slow, 0.5 * slow + 1e-3 * rng.standard_normal((N_ROWS, 1))]),
                     tested=slice(1, None))
    assert alone.likelihood_ratio > 30.0
    assert repeated.likelihood_ratio < chi2.isf(0.01, 1), repeated.likelihood_ratio


def test_the_first_cause_is_differentiated_within_its_bounds():
    """A first cause at a bound (a current of nearly no speed) is re-fitted
    beside a second through one-sided differences: the filter is never asked
    for a negative current speed, which the environment refuses."""
    from dataclasses import dataclass

    from studies.discovery.causes import Current
    from studies.discovery.innovations import own_columns

    asked = []

    @dataclass
    class Recording(InnovationDesign):
        def innovations(self, cause, theta, extra=None, coefficients=None):
            asked.append(np.asarray(theta, float).copy())
            return np.full(len(self.residual), float(np.sum(theta)))

    rng = np.random.default_rng(2)
    coefficients, _ = _columns(rng)
    base = _design(rng.standard_normal(N_ROWS), coefficients)
    d = Recording(**{f: getattr(base, f) for f in base.__dataclass_fields__})
    d.ctx = None
    d.base = (Current(), np.array([1e-4, 0.3]), {})
    cols = own_columns(d, np.array([0.01, 0.05]))
    assert cols.shape == (N_ROWS, 2)
    assert min(t[0] for t in asked) >= 0.0, asked
    assert np.allclose(cols[0], [-1.0, -1.0])        # -d(sum theta)/d theta_j, one-sided or not
