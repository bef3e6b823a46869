"""The prediction-error filter with the MMG model as its process model
(:mod:`studies.identification.mmg_filter`), and the track's own process noise of
:mod:`studies.identification.filter_error`."""

from __future__ import annotations

import numpy as np
import pytest

from studies.data.resample import block_means
from studies.discovery.prediction_error import _measured
from studies.identification.filter_error import innovation_likelihood
from studies.identification.mmg_filter import MMGFilterPlan
from studies.models.mmg import KVLCC2_HULL, mmg
from studies.scenarios.injected import Injection, inject
from studies.simulate import zigzag
from studies.simulate.mmg import self_propulsion_rps, simulate_mmg
from studies.vessels.kvlcc2_mmg import kvlcc2_mmg

#: measurement noise of the thinned record: x0, y0 [m], psi [rad], u, v [m/s], r [rad/s]
SD = np.array([0.02, 0.02, 1e-3, 2e-3, 2e-3, 2e-4])


@pytest.fixture(scope="module")
def setting():
    ship = kvlcc2_mmg()
    model = mmg()
    n = self_propulsion_rps(model, KVLCC2_HULL, ship)
    rec = simulate_mmg(model, KVLCC2_HULL, ship, zigzag(20.0, duration=120.0, dt=0.05), rps=n)
    rng = np.random.default_rng(5)
    thin = block_means(rec, 0.5)
    z = _measured(thin) + rng.standard_normal((len(thin), 6)) * SD
    return ship, model, rec, thin, z


def _loglik(ship, model, record, z, values, current=(0.0, 0.0), q=None):
    plan = MMGFilterPlan(model, ship, record, current)
    q = np.full(3, 1e-10) if q is None else q
    ll, e, S = innovation_likelihood(plan, model.vector(values), z, SD ** 2, q)
    return ll, e / np.sqrt(S)


def test_the_mmg_filter_predicts_its_own_model_to_the_noise(setting):
    ship, model, _, thin, z = setting
    ll, w = _loglik(ship, model, thin, z, KVLCC2_HULL)
    assert np.isfinite(ll)
    # standardised innovations of the right model: unit variance on every channel
    spread = np.nanmean(w ** 2, axis=0)
    assert np.all(spread < 2.0) and np.all(spread > 0.5), spread
    wrong = dict(KVLCC2_HULL, Nr=1.5 * KVLCC2_HULL["Nr"])
    ll_wrong, _ = _loglik(ship, model, thin, z, wrong)
    assert ll - ll_wrong > 50.0


def test_the_mmg_filter_sees_a_current_only_where_it_is(setting):
    ship, model, rec, _, _ = setting
    speed = 0.1                                   # [m/s] at the record's (model) scale, flowing east
    drifted = inject(rec, Injection(current_speed=speed, current_direction=0.5 * np.pi))
    thin = block_means(drifted, 0.5)
    z = _measured(thin) + np.random.default_rng(6).standard_normal((len(thin), 6)) * SD
    right, _ = _loglik(ship, model, thin, z, KVLCC2_HULL, current=(0.0, speed))
    none, _ = _loglik(ship, model, thin, z, KVLCC2_HULL)
    opposite, _ = _loglik(ship, model, thin, z, KVLCC2_HULL, current=(0.0, -speed))
    assert right - none > 50.0 and none > opposite


def test_the_track_noise_of_zero_leaves_the_filter_as_it_was(setting):
    ship, model, _, thin, z = setting
    base, _ = _loglik(ship, model, thin, z, KVLCC2_HULL)
    six, _ = _loglik(ship, model, thin, z, KVLCC2_HULL, q=np.r_[np.full(3, 1e-10), 0.0, 0.0, 0.0])
    assert six == pytest.approx(base, rel=1e-12)
    # a drifting track makes its positions less informative: the likelihood changes
    drift, _ = _loglik(ship, model, thin, z, KVLCC2_HULL, q=np.r_[np.full(3, 1e-10), 1.0, 1.0, 1e-3])
    assert drift != pytest.approx(base, rel=1e-6)


def _best_over_scales(plan, model, z, tau):
    """The filter's highest log-likelihood over process-noise densities 1e-12..1e-3 (yaw: per L^2)."""
    v, length = model.vector(KVLCC2_HULL), plan.length
    return max(innovation_likelihood(plan, v, z, SD ** 2, 10.0 ** e * np.array([1.0, 1.0, length ** -2]),
                                     tau=tau)[0] for e in range(-12, -2))


def test_a_slowly_wandering_push_is_likelier_as_coloured_process_noise(setting):
    """The MMG ship under a push of slow sinusoids (periods 45-90 s, not an
    autoregression): the filter with disturbance states of 30 s correlation
    time explains it far better than white process noise at its best
    density; on the record without the push neither gains."""
    ship, model, _, _, _ = setting
    n = self_propulsion_rps(model, KVLCC2_HULL, ship)
    dt, duration = 0.05, 300.0
    t = np.arange(int(duration / dt)) * dt
    push = np.stack([3e-3 * np.sin(2 * np.pi * t / 70 + 1), 3e-3 * np.sin(2 * np.pi * t / 45),
                     1e-4 * np.sin(2 * np.pi * t / 90 + 2)], axis=1)
    gains = []
    for external in (None, push):
        rec = simulate_mmg(model, KVLCC2_HULL, ship, zigzag(20.0, duration=duration, dt=dt), rps=n,
                           external=external)
        thin = block_means(rec, 0.5)
        z = _measured(thin) + np.random.default_rng(5).standard_normal((len(thin), 6)) * SD
        plan = MMGFilterPlan(model, ship, thin)
        gains.append(_best_over_scales(plan, model, z, 30.0) - _best_over_scales(plan, model, z, 0.0))
    assert abs(gains[0]) < 5.0 and gains[1] > 100.0, gains
