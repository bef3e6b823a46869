"""Rates of the discovery bench: Wilson intervals, confusion, reliability."""

import numpy as np
import pytest
from hypothesis import given, strategies as st

from studies.scenarios.rates import confusion, rate, reliability, wilson


def test_wilson_interval_matches_the_published_values():
    # 27 of 40 at 90 %: centre (p + z^2/2n) / (1 + z^2/n) = 0.6639, half-width 0.1184 (z = 1.6449)
    low, high = wilson(27, 40)
    assert abs(low - 0.5455) < 1e-3 and abs(high - 0.7823) < 1e-3
    low, high = wilson(0, 10)
    assert low == 0.0 and 0.19 < high < 0.22
    low, high = wilson(10, 10)
    assert high == 1.0 and 0.78 < low < 0.81


@given(st.integers(1, 400), st.data())
def test_wilson_interval_holds_the_proportion_and_shrinks_with_n(n, data):
    k = data.draw(st.integers(0, n))
    low, high = wilson(k, n)
    assert 0.0 <= low <= k / n <= high <= 1.0
    low4, high4 = wilson(4 * k, 4 * n)
    assert high4 - low4 < high - low + 1e-12


def test_rate_confusion_and_reliability_count_what_they_are_given():
    results = [{"hidden": "current", "named": "current", "right": True, "confidence": 0.95},
               {"hidden": "current", "named": "none", "right": False, "confidence": 0.6},
               {"hidden": "none", "named": "none", "right": True, "confidence": 0.92},
               {"hidden": "none", "named": "rudder_offset", "right": False, "confidence": 0.97}]
    r = rate([x["right"] for x in results])
    assert (r["hits"], r["n"], r["rate"]) == (2, 4, 0.5)
    assert confusion(results) == {"current": {"current": 1, "none": 1}, "none": {"none": 1, "rudder_offset": 1}}
    table = {(row["low"], row["high"]): row for row in reliability(results)}
    top = table[(0.9, 1.0)]
    assert top["n"] == 3 and abs(top["share_right"] - 2 / 3) < 1e-12
    assert table[(0.5, 0.7)]["n"] == 1 and table[(0.5, 0.7)]["share_right"] == 0.0
    assert table[(0.0, 0.5)]["n"] == 0


def test_an_injected_current_beside_the_records_own_cause_is_judged_against_its_fit_beside_it():
    """The nothing-injected records name a missing term; a current injected
    into them comes out beside that term, and must equal what those records
    give for a current beside the term plus the injection (not the current
    fitted alone)."""
    from studies.bench_discovery import judge_real

    reference = {"named": "missing_term", "candidates": {"current": {"speed": 0.3, "direction": 0.0}},
                 "candidates_beside": {"current": {"speed": 0.05, "direction": 0.0}}}
    injected = {"current": {"speed": 0.5, "direction": 0.0}}

    def case(speed, named="current+missing_term"):
        return {"injected": injected, "named": named,
                "parameters": {"current": {"speed": speed, "direction": 0.0},
                               "missing_term": {"terms": {"Nrrr": 0.01}}}}

    assert judge_real(case(0.55), reference)["right"]            # 0.05 beside the term + 0.5
    assert not judge_real(case(0.80), reference)["right"]        # 0.3 alone + 0.5: the wrong reference
    alone = judge_real({**case(0.8, "current"), "parameters": {"speed": 0.8, "direction": 0.0}}, reference)
    assert not alone["right"] and alone["exactly_injected"]      # the records' own term is lost


def test_the_bench_judges_the_confidence_on_the_causes_and_on_the_parameters_apart():
    """A verdict with the right cause and a parameter 30 % off counts as right
    in the causes' reliability table and wrong in the whole one."""
    from studies.bench_discovery import _summary

    def case(named, right, cause_right, confidence):
        return {"kind": "single", "family": "white_all", "hidden": "current", "named": named, "right": right,
                "cause_right": cause_right, "spurious_second": False, "confidence": confidence, "elapsed": 1.0}

    out = _summary([case("current", True, True, 0.95), case("current", False, True, 0.97),
                    case("rudder_offset", False, False, 0.93)])
    assert out["right_when_confidence_at_least_0.9"]["hits"] == 1
    assert out["causes_right_when_confidence_at_least_0.9"]["hits"] == 2
    top = {(row["low"], row["high"]): row for row in out["reliability_causes"]}[(0.9, 1.0)]
    assert top["n"] == 3 and abs(top["share_right"] - 2 / 3) < 1e-12


def test_the_bench_divides_the_misses_by_what_the_records_can_show():
    """Hit rates among the effects the records show (the hidden effect's own
    score above 0), and the misses counted by kind: not shown, the right cause
    with a parameter off, another cause named; and the setting that states
    each hidden effect."""
    from studies.bench_discovery import _summary, injected_override

    def case(hidden, named, right, cause_right, shown, family="ar1", seed=1):
        return {"kind": "single", "family": family, "hidden": hidden, "named": named, "right": right,
                "cause_right": cause_right, "spurious_second": False, "confidence": 0.9, "elapsed": 1.0,
                "injected_shown": shown, "seed": seed}

    out = _summary([case("current", "current", True, True, True),
                    case("missing_term", "none", False, False, False),
                    case("rudder_offset", "none", False, False, False),
                    case("rudder_offset", "rudder_offset", False, True, True),
                    case("current", "environmental_bias", False, False, True, family="gnss", seed=2),
                    case("none", "none", True, True, None)])
    assert out["singles"]["hits"] == 1 and out["singles"]["n"] == 5
    assert out["singles_shown"]["hits"] == 3 and out["singles_shown"]["n"] == 5
    assert out["singles_right_when_shown"]["hits"] == 1 and out["singles_right_when_shown"]["n"] == 3
    assert out["singles_by_family_when_shown"]["gnss"]["n"] == 1
    assert out["singles_misses"] == {"not_shown_by_the_records": 2, "shown_causes_right_parameter_off": 1,
                                     "shown_other_causes_named": 1}
    # the rates per seed (the cases of one seed share its scenario)
    assert out["singles_by_seed"]["1"]["n"] == 4 and out["singles_by_seed"]["2"]["hits"] == 0
    assert out["none_by_seed"]["1"]["hits"] == 1
    # the setting that states a hidden effect: the cause's own parameters, a missing term by its name
    assert injected_override("wind_speed_bias", {"k": -0.2, "wind_speed": 12.0, "wind_direction": 1.0}) == [
        "discover.injected={wind_speed_bias:{k:-0.2}}"]
    assert injected_override("missing_term", {"Nrrr": -0.002}) == ["discover.injected={missing_term:{Nrrr:-0.002}}"]
    assert injected_override("current+rudder_offset", {"current": {"speed": 0.5, "direction": 1.0},
                                                        "rudder_offset": {"delta0": 0.02}}) == [
        "discover.injected={current:{speed:0.5,direction:1.0},rudder_offset:{delta0:0.02}}"]
    assert injected_override("none", {}) == []


def test_an_injected_effect_found_beside_more_of_the_records_own_error_is_found_but_not_right():
    """The nothing-injected records name nothing; with a current injected the
    verdict is the current (right parameters) beside an earth-fixed force:
    the injected effect is found, but the verdict is not the one the grid
    counts right. A rudder offset named beside it is not found."""
    from studies.bench_discovery import judge_real

    reference = {"named": "none", "candidates": {"current": {"speed": 0.1, "direction": 0.0}}}
    injected = {"current": {"speed": 0.5, "direction": 0.0}}
    params = {"current": {"speed": 0.6, "direction": 0.0}, "environmental_bias": {"bx": 1e-4, "by": 0.0, "bn": 0.0}}
    beside = judge_real({"injected": injected, "named": "current+environmental_bias", "parameters": params},
                        reference)
    assert beside["found"] and not beside["right"]
    off = judge_real({"injected": injected, "named": "current+rudder_offset",
                      "parameters": {"current": params["current"], "rudder_offset": {"delta0": 0.01}}}, reference)
    assert not off["found"]
    wrong = judge_real({"injected": injected, "named": "current+environmental_bias",
                        "parameters": {**params, "current": {"speed": 0.9, "direction": 0.0}}}, reference)
    assert not wrong["found"]
    nothing = judge_real({"injected": {}, "named": "environmental_bias", "parameters": {}}, reference)
    assert nothing["found"] and nothing["right"]


def test_calibration_error_weights_each_bin_by_its_verdicts():
    from studies.scenarios.rates import calibration_error

    results = ([{"confidence": 0.95, "right": True}] * 9 + [{"confidence": 0.95, "right": False}]
               + [{"confidence": 0.55, "right": True}] * 2 + [{"confidence": 0.55, "right": False}] * 8)
    rows = reliability(results)
    # 10 verdicts at 0.95, 9 right: 0.05 off; 10 at 0.55, 2 right: 0.35 off
    assert calibration_error(rows) == pytest.approx((10 * 0.05 + 10 * 0.35) / 20)
    assert np.isnan(calibration_error(reliability([])))


def test_a_real_case_is_judged_by_class_and_counted_apart_below_the_detection_limit():
    """An injected offset named inside a class of look-alikes is in the class
    though another member heads it; an offset smaller than what the
    nothing-injected records could show is counted apart."""
    from studies.bench_discovery import judge_real

    reference = {"named": "none", "candidates": {"rudder_offset": {"delta0": 0.0}},
                 "detection_limits": {"rudder_offset": {"delta0": 0.03}, "current": {"speed": 0.2}}}
    offset = {"rudder_offset": {"delta0": 0.05}}
    headed = judge_real({"injected": offset, "named": "environmental_bias", "parameters": {},
                         "class": ["environmental_bias", "rudder_offset"]}, reference)
    assert headed["in_class"] and not headed["right"] and not headed["below_detection_limit"]
    missed = judge_real({"injected": offset, "named": "current", "parameters": {}, "class": ["current"]},
                        reference)
    assert not missed["in_class"]
    small = judge_real({"injected": {"rudder_offset": {"delta0": 0.01}}, "named": "none", "parameters": {},
                        "class": None}, reference)
    assert small["below_detection_limit"] and not small["in_class"]
