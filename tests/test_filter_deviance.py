"""The prediction-error filter's deviance residuals
(:meth:`studies.identification.filter_error.PredictionError.deviance_residuals`):
their sum of squares is the whole ``-2 ln L`` less a constant of the filter,
so a fit or a likelihood ratio on them counts the innovations' variances,
which the standardised innovations alone leave out."""

from __future__ import annotations

import numpy as np
import pytest

from studies.data.resample import block_means
from studies.discovery.prediction_error import _measured
from studies.identification.filter_error import PredictionError
from studies.models import abkowitz
from studies.simulate import simulate, zigzag
from studies.simulate.simulator import ReplayPlan
from studies.vessels import get_vessel

#: measurement noise of the thinned record: x0, y0 [m], psi [rad], u, v [m/s], r [rad/s]
SD = np.array([0.1, 0.1, 3e-3, 0.02, 0.02, 3e-4])


@pytest.fixture(scope="module")
def filtered():
    ship = get_vessel("mariner")
    model = abkowitz()
    rec = block_means(simulate(model, ship.coefficients, ship, zigzag(20.0, duration=300.0, dt=0.1)), 1.0)
    z = _measured(rec) + np.random.default_rng(11).standard_normal((len(rec), 6)) * SD
    plan = ReplayPlan(model, ship, rec, max_step=1.0 + 1e-6)
    q = np.array([1e-6, 1e-6, 1e-10])
    return model, ship, PredictionError([plan], [z], SD ** 2, q, tau=20.0), z


def _minus_two_ln_l_less_constant(like, vector, z, log_scale=0.0):
    return -2.0 * like.loglik(vector, log_scale) - float(np.sum(np.isfinite(z) * np.log(2.0 * np.pi * SD ** 2)))


def test_the_deviance_residuals_square_to_the_whole_likelihood(filtered):
    model, ship, like, z = filtered
    right = model.vector(ship.coefficients)
    # a yaw damping 40 % weaker: the filter's state covariance, hence its innovations' variances, grow
    weak = model.vector(dict(ship.coefficients, Nr=0.6 * ship.coefficients["Nr"]))
    for vector in (right, weak):
        d = like.deviance_residuals(vector, 0.0)
        assert d.shape == (2 * z.size,)
        assert float(d @ d) == pytest.approx(_minus_two_ln_l_less_constant(like, vector, z), rel=1e-9)
    # the likelihood ratio of the two models is the fall in the squared deviance residuals; the
    # standardised innovations alone give another number (their variances differ between the models)
    ratio = _minus_two_ln_l_less_constant(like, weak, z) - _minus_two_ln_l_less_constant(like, right, z)
    dw, dr = like.deviance_residuals(weak, 0.0), like.deviance_residuals(right, 0.0)
    assert float(dw @ dw - dr @ dr) == pytest.approx(ratio, rel=1e-9)
    sw, sr = like.residuals(weak, 0.0), like.residuals(right, 0.0)
    assert abs(float(sw @ sw - sr @ sr) - ratio) > 1.0


def test_the_deviance_residuals_carry_the_standardised_innovations_first(filtered):
    model, ship, like, z = filtered
    vector = model.vector(ship.coefficients)
    d = like.deviance_residuals(vector, 0.0).reshape(len(z), 12)
    w = like.residuals(vector, 0.0).reshape(len(z), 6)
    np.testing.assert_allclose(d[:, :6], w)
    # sqrt(ln(S / R)) of each channel: S >= R, nothing negative, and the first sample's above nothing
    assert np.all(d[:, 6:] >= 0.0) and np.all(d[0, 6:] > 0.0)


def test_records_filtered_side_by_side_keep_their_order(filtered, monkeypatch):
    """Three records of different lengths and noise filtered on threads give
    each record's own innovations, in the records' order, as one by one."""
    import studies.identification.filter_error as filter_error

    model, ship, one, z = filtered
    plans, measured = [], []
    for i, (angle, duration) in enumerate(((10.0, 200.0), (20.0, 300.0), (30.0, 250.0))):
        rec = block_means(simulate(model, ship.coefficients, ship, zigzag(angle, duration=duration, dt=0.1)), 1.0)
        measured.append(_measured(rec) + np.random.default_rng(20 + i).standard_normal((len(rec), 6)) * SD * (1 + i))
        plans.append(ReplayPlan(model, ship, rec, max_step=1.0 + 1e-6))
    like = PredictionError(plans, measured, SD ** 2, np.array([1e-6, 1e-6, 1e-10]), tau=20.0)
    vector = model.vector(ship.coefficients)
    monkeypatch.setattr(filter_error, "FILTER_THREADS", 1)
    serial, ll_serial = like.deviance_residuals(vector, 0.0), like.loglik(vector, 0.0)
    monkeypatch.setattr(filter_error, "FILTER_THREADS", 2)
    threaded, ll_threaded = like.deviance_residuals(vector, 0.0), like.loglik(vector, 0.0)
    np.testing.assert_array_equal(threaded, serial)
    assert ll_threaded == ll_serial
    # each record's block of residuals is its own: the second record alone gives the second block
    alone = PredictionError(plans[1:2], measured[1:2], SD ** 2, np.array([1e-6, 1e-6, 1e-10]), tau=20.0)
    start = 2 * measured[0].size
    np.testing.assert_array_equal(threaded[start:start + 2 * measured[1].size], alone.deviance_residuals(vector, 0.0))


def test_models_filtered_together_give_each_its_own_records(filtered, monkeypatch):
    """Several models' records filtered in one batch (a Jacobian's columns)
    give each model what it gives alone."""
    import studies.identification.filter_error as filter_error

    model, ship, like, z = filtered
    monkeypatch.setattr(filter_error, "FILTER_THREADS", 2)
    vectors = [model.vector(dict(ship.coefficients, Nr=f * ship.coefficients["Nr"])) for f in (1.0, 0.8, 0.6)]
    other = like.with_noises(like.q0 * 10.0, like.R * 2.0, 5.0)
    jobs = [(like, vectors[0], 0.0), (other, vectors[1], 0.5), (like, vectors[2], -1.0)]
    for (job_like, vector, a), results in zip(jobs, filter_error.filter_all(jobs)):
        np.testing.assert_array_equal(job_like.deviance_of(results), job_like.deviance_residuals(vector, a))
        assert job_like.total(results) == job_like.loglik(vector, a)
    # the three models differ: the batch did not hand one model's records to another
    firsts = [like.deviance_of(r) for r in filter_error.filter_all(jobs)]
    assert not np.array_equal(firsts[0], firsts[2])
