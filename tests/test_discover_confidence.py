"""How sure a verdict is: confidence from the scores, rivals and the manoeuvre that separates them."""

import numpy as np
import pytest

from studies.discovery.confidence import (DEFAULT_SEPARATING, certainty, confidence, posterior_probabilities,
                                         separating_manoeuvre)


def _ranking(**scores):
    return [{"cause": c, "score": s} for c, s in scores.items()]


def test_probabilities_follow_the_bayes_factor_scale():
    p = posterior_probabilities(_ranking(rudder_offset=0.0, none=2 * np.log(9.0)))
    assert p["rudder_offset"] == pytest.approx(0.9) and p["none"] == pytest.approx(0.1)
    # decisive evidence: confidence close to one; a tie: one half
    assert confidence(_ranking(current=0.0, none=40.0), "current") > 0.999
    assert confidence(_ranking(current=0.0, wind_unmodelled=0.0), "current") == pytest.approx(0.5)


def test_a_cause_judged_on_held_out_records_carries_its_test():
    ranking = _ranking(none=0.0, missing_term=5.0) + [{"cause": "propulsion", "score": None}]
    d = {"cause": "propulsion", "ranking": ranking}
    certainty(d, held_out_p=8e-10)
    assert d["confidence"] == pytest.approx(1.0) and d["confidence_basis"] == "1 - p of the held-out test"


def test_rivals_within_the_margin_are_undecided_with_the_manoeuvre_that_separates_them():
    d = {"cause": "rudder_offset", "ranking": _ranking(rudder_offset=0.0, propeller_asymmetry=1.0, none=30.0),
         "indistinguishable_from": ["propeller_asymmetry"]}
    certainty(d)
    assert d["undecided"] == ["rudder_offset", "propeller_asymmetry"]
    assert d["next_manoeuvre"].startswith("turning circles to both sides")
    assert 0.5 < d["confidence"] < 0.7


def test_a_cause_the_records_cannot_decide_for_is_kept_with_new_rivals():
    d = {"cause": "missing_term", "ranking": _ranking(missing_term=0.0, rudder_offset=1.5, none=50.0),
         "indistinguishable_from": ["rudder_offset"]}
    certainty(d, undecidable=[("propeller_asymmetry", "a turning circle to starboard")])
    assert d["undecided"] == ["missing_term", "propeller_asymmetry", "rudder_offset"]
    assert d["next_manoeuvre"].startswith("a turning circle to starboard; a zig-zag started to the other side")


def test_a_clear_verdict_has_no_rivals():
    d = {"cause": "current", "ranking": _ranking(current=0.0, none=500.0), "indistinguishable_from": []}
    certainty(d)
    assert "undecided" not in d and "next_manoeuvre" not in d and d["confidence"] > 0.999
    assert separating_manoeuvre("current", ["hull_fouling"]) == DEFAULT_SEPARATING
