"""``studies discover`` on records with sensor-like noise of every family,
any missing term and two causes at once (3 % noise).

Each test writes the records of a hidden effect as files and runs the
discovery on them as a user would (files in, ``discovery.json`` out, the
command line's configuration). The noise families are those of
:mod:`studies.environment.sensor_noise`: white per Li et al. (2023) eq. 22,
white on every channel (heading and positions included), coloured AR(1)
with a correlation time of several seconds, a quantised rudder signal, and
velocities differenced from noisy GNSS positions. Parameters must come out
within 20 % (angles within 0.2 rad); the seeds are not the development ones
(100, 101) except for the pair, a case a user reported. These tests run the
earlier search (``discover.method=search``); its rule that names a cause on
strong training evidence is tested in ``test_discover.py``.
"""

import pytest

from studies.scenarios.hidden import hidden_records, parameters_match
from test_discover import _discover

LEVEL = 0.03


def _named(d, cause, truth):
    assert d["cause"] == cause, (d["cause"], d["ranking"][:4])
    if cause != "none":
        assert parameters_match(cause, d["parameters"], truth), (d["parameters"], truth)
    # the named model predicts the held-out record about as well as its own
    assert d["explains_validation"], (d["baseline"], d["extended"])


@pytest.mark.slow
@pytest.mark.parametrize("family,cause,seed", [
    ("li2023", "wind_speed_bias", 7),
    ("white_all", "wind_unmodelled", 7),
    ("ar1", "current", 7),
    ("quantised_rudder", "rudder_offset", 7),
    ("gnss", "none", 7),
    ("gnss", "environmental_bias", 7),
])
def test_each_noise_family_names_the_hidden_cause_and_no_second(tmp_path, vessel, family, cause, seed):
    """One noise family each, a different cause each; pairs are tried and none
    is named (only one effect is hidden). GNSS-derived velocities twice: no
    cause stays none, and an environmental bias is named (the filter reads
    the track and heading alone, not the velocities differenced from them:
    :func:`studies.discover.innovations.innovation_design`)."""
    records, truth = hidden_records(vessel, cause, seed=seed, noise=LEVEL, noise_family=family)
    d = _discover(tmp_path, records, ["discover.posterior_steps=10"])
    _named(d, cause, truth)
    assert d["second_cause"] is None, d["second_cause"]


@pytest.mark.slow
@pytest.mark.parametrize("missing,family,seed", [("X", "white_all", 7), ("Y", "li2023", 7), ("Nrrr", "white_all", 7)])
def test_a_missing_term_is_named_in_each_dof(tmp_path, vessel, missing, family, seed):
    """A term drawn from the extended library of one DOF (X, Y: 5-15 % of its
    force, either sign) or the cubic yaw damping Nrrr is named with its
    coefficient within 20 %. Not yet held: N terms drawn from the library
    (seed 7 draws Nudd, which these manoeuvres do not tell from Ndd, u'
    falling where delta^2 is large; seed 8's Nuvd is named a rudder offset
    under AR(1) noise and nothing on GNSS velocities, where Nrrr at seed 7
    is missed too)."""
    records, truth = hidden_records(vessel, "missing_term", seed=seed, noise=LEVEL, noise_family=family,
                                    missing=missing)
    d = _discover(tmp_path, records, ["discover.second_cause=false", "discover.posterior_steps=10"])
    _named(d, "missing_term", truth)


@pytest.mark.slow
@pytest.mark.parametrize("pair,family", [("wind_unmodelled+rudder_offset", "white_all")])
def test_two_hidden_causes_are_both_named(tmp_path, vessel, pair, family):
    """Two causes at once: the first named alone, the rudder offset as the
    second cause with its angle within 20 %. The baseline's asymmetric terms
    absorb the offset on the training manoeuvres, so the offset alone does not
    beat the baseline; beside the first cause it does."""
    records, truth = hidden_records(vessel, pair, seed=100, noise=LEVEL, noise_family=family)
    d = _discover(tmp_path, records, ["discover.posterior_steps=10"])
    first, second = pair.split("+")
    _named(d, first, truth[first])
    assert d["second_cause"] is not None and d["second_cause"]["cause"] == pair, d["second_cause"]
    assert parameters_match(second, d["second_cause"]["parameters"][second], truth[second]), \
        (d["second_cause"], truth)
