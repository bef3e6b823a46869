"""The hidden-effect generator of the discovery tests and bench: pairs of causes,
missing terms drawn from the whole library, refusals. No discovery runs here."""

import numpy as np
import pytest

from studies.scenarios.hidden import HIDDEN_CAUSES, hidden_pairs, hidden_records
from studies.errors import ConfigError
from studies.identification.regression import prime_states
from studies.models import abkowitz
from studies.models.terms import candidate_terms
from studies.simulate import simulate, zigzag

SHORT = [zigzag(20, 20, duration=120.0), zigzag(10, 10, duration=120.0)]


def test_pairs_are_every_two_causes_that_can_act_together():
    pairs = hidden_pairs()
    single = [c for c in HIDDEN_CAUSES if c != "none"]
    assert len(pairs) == len(single) * (len(single) - 1) // 2 - 1
    assert "wind_speed_bias+wind_unmodelled" not in pairs
    assert all(a != b and "none" not in (a, b) for a, b in (p.split("+") for p in pairs))


def test_a_pair_hides_both_causes_drawn_as_alone(vessel):
    records, truth = hidden_records(vessel, "current+rudder_offset", seed=4, manoeuvres=SHORT)
    current, _ = hidden_records(vessel, "current", seed=4, manoeuvres=SHORT)
    assert set(truth) == {"current", "rudder_offset"}
    # the first cause is drawn first from the same seed: the same current as when alone
    assert truth["current"] == hidden_records(vessel, "current", seed=4, manoeuvres=SHORT)[1]
    # the rudder offset is added to the recorded rudder on top of the current's records
    assert not np.allclose(records[0]["delta"], current[0]["delta"])
    np.testing.assert_allclose(records[0]["delta"].iloc[0] - current[0]["delta"].iloc[0],
                               truth["rudder_offset"]["delta0"], atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_any_missing_term_is_outside_the_model_and_sized_to_its_dof(vessel, seed):
    records, truth = hidden_records(vessel, "missing_term", seed=seed, missing="any", manoeuvres=SHORT)
    (name, value), = truth.items()
    model = abkowitz()
    assert name not in {t.name for t in model.terms}
    term = next(t for dof in "XYN" for t in candidate_terms(dof, 3) if t.name == name)
    clean = simulate(model, vessel.coefficients, vessel, SHORT[0])
    primes = prime_states(clean["u"], clean["v"], clean["r"], clean["delta"], vessel)
    force = sum(vessel.coefficients[t.name] * t.feature(primes) for t in model.terms_of(term.dof))
    share = np.sqrt(np.mean((value * term.feature(primes)) ** 2)) / np.sqrt(np.mean(force ** 2))
    assert 0.05 - 1e-9 <= share <= 0.15 + 1e-9
    # and it acts: the records differ from the reference model's
    assert not np.allclose(records[0]["r"], clean["r"])


def test_any_missing_term_covers_every_dof(vessel):
    dofs = {next(iter(hidden_records(vessel, "missing_term", seed=s, missing="any",
                                     manoeuvres=SHORT[:1])[1]))[0] for s in range(40)}
    assert dofs == {"X", "Y", "N"}


@pytest.mark.parametrize("cause", ["wind_speed_bias+wind_unmodelled", "none+current", "current+current",
                                   "current+rudder_offset+wind_unmodelled", "hull_fouling"])
def test_impossible_hidden_causes_are_refused(vessel, cause):
    with pytest.raises(ConfigError, match="hidden cause"):
        hidden_records(vessel, cause, manoeuvres=SHORT)
