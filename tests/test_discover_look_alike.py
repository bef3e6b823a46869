"""Classes of look-alike causes and detection limits (:mod:`studies.discovery.look_alike`):
a rival joins the named cause's class when the records' evidence between them is
below what naming needs, whatever their numbers of parameters; a detection
limit is the fitted effect scaled to the naming threshold."""

from types import SimpleNamespace

import numpy as np
import pytest

from studies.discovery.causes import CATALOGUE
from studies.discovery.look_alike import (BlockSeparation, Detectability, LikelihoodSeparation, class_probability,
                                         detection_limits, look_alike_class, verdict_class)


def _blocks(rng, mean, k=24, spread=1.0):
    return mean + spread * rng.standard_normal(k)


def test_blocks_a_rival_that_predicts_the_blocks_as_well_is_in_the_class():
    rng = np.random.default_rng(5)
    named = _blocks(rng, 3.0)
    alike = named + 0.05 * np.resize([1.0, -1.0], 24)   # the same gains, block by block, on the whole
    apart = named - 2.0 + 0.3 * rng.standard_normal(24)  # clearly less in every block
    sep = BlockSeparation(["a", "b", "c"], 2.5, "paired t", held=np.vstack([named, alike, apart]))
    assert look_alike_class("a", sep) == ["a", "b"]
    assert sep.evidence("a", "c") > 2.5 > abs(sep.evidence("a", "b"))
    # antisymmetric
    assert sep.evidence("c", "a") == pytest.approx(-sep.evidence("a", "c"))


def test_tracks_equal_evidence_is_one_class_whatever_the_parameter_counts():
    """An offset (1 parameter) and a side force (2) that explain the tracks
    equally: the BIC's penalty would name the offset at 0.99; the records
    cannot, and the class holds both."""
    ln_n = np.log(5000.0)
    sep = LikelihoodSeparation(["rudder_offset", "propeller_asymmetry", "current"], ln_n, "2 ln LR",
                               values={"rudder_offset": 100.0, "propeller_asymmetry": 100.5, "current": 60.0})
    assert look_alike_class("rudder_offset", sep) == ["rudder_offset", "propeller_asymmetry"]
    # a rival that explains more (at a cost in parameters) always joins
    sep.values["propeller_asymmetry"] = 140.0
    assert "propeller_asymmetry" in look_alike_class("rudder_offset", sep)
    sep.values["propeller_asymmetry"] = 100.0 - 1.5 * ln_n
    assert look_alike_class("rudder_offset", sep) == ["rudder_offset"]


def test_class_probability_sums_members_and_their_pairs():
    verdicts = {"rudder_offset": 0.5, "propeller_asymmetry": 0.2, "rudder_offset+propeller_asymmetry": 0.1,
                "current": 0.15, "none": 0.05}
    assert class_probability(["rudder_offset", "propeller_asymmetry"], verdicts) == pytest.approx(0.8)
    pairs = {"current+rudder_offset": 0.6, "current+environmental_bias": 0.3, "current": 0.1}
    assert class_probability(["rudder_offset", "environmental_bias"], pairs, first="current") == pytest.approx(0.9)


def _inference(values, verdicts, named_id):
    ids = list(values)
    variants = [SimpleNamespace(cause=CATALOGUE[c]()) for c in ids]
    sep = LikelihoodSeparation(ids, np.log(5000.0), "2 ln LR", values=values)
    return SimpleNamespace(named=(ids.index(named_id),), variants=variants, verdicts=verdicts,
                           separations={"first": sep})


def test_verdict_class_gives_every_members_parameters_and_the_class_probability():
    inference = _inference({"rudder_offset": 50.0, "propeller_asymmetry": 49.0, "current": 10.0},
                           {"rudder_offset": 0.993, "propeller_asymmetry": 0.006, "current": 0.001},
                           "rudder_offset")
    candidates = {"rudder_offset": {"delta0": 0.02}, "propeller_asymmetry": {"Yp0": 1e-4, "Np0": -5e-5},
                  "current": {"speed": 0.1, "direction": 1.0}}
    out = verdict_class(inference, candidates)
    assert out["class"] == ["rudder_offset", "propeller_asymmetry"]
    assert out["parameters"] == {k: candidates[k] for k in out["class"]}
    assert out["probability"] == pytest.approx(0.999)
    assert out["evidence"]["current"] == pytest.approx(40.0)


def test_verdict_class_is_none_for_none():
    inference = _inference({"rudder_offset": 1.0}, {"none": 0.9, "rudder_offset": 0.1}, "rudder_offset")
    inference.named = ()
    assert verdict_class(inference, {}) is None


def test_detection_limits_scale_the_fitted_effect_to_the_threshold():
    causes = {c: CATALOGUE[c]() for c in ("rudder_offset", "current", "wind_unmodelled", "missing_term",
                                           "propulsion", "environmental_bias")}
    candidates = {"rudder_offset": {"delta0": 0.04}, "current": {"speed": 0.3, "direction": 2.0},
                  "wind_unmodelled": {"speed": 10.0, "direction": 1.0}, "missing_term": {"terms": {"N0": 0.002}},
                  "propulsion": {}, "environmental_bias": {"bx": 1e-4, "by": -2e-4, "bn": None}}
    detect = {"rudder_offset": Detectability(5.0, 2.5, 1),      # t twice the threshold: half the offset
              "current": Detectability(40.0, 10.0, 2),          # 2 ln LR four times: half the speed
              "wind_unmodelled": Detectability(40.0, 10.0, 2),  # loads as speed^2: speed / sqrt(2)
              "missing_term": Detectability(1.0, 2.0, 1),       # below the threshold: twice the term
              "propulsion": Detectability(30.0, 10.0, 2),
              "environmental_bias": Detectability(-1.0, 2.0, 1)}
    limits = detection_limits(causes, candidates, detect)
    assert limits["rudder_offset"]["delta0"] == pytest.approx(0.02)
    assert limits["current"] == pytest.approx({"speed": 0.15, "direction": 2.0})
    assert limits["wind_unmodelled"]["speed"] == pytest.approx(10.0 / np.sqrt(2.0))
    assert limits["wind_unmodelled"]["direction"] == 1.0
    assert limits["missing_term"] == {"terms": pytest.approx({"N0": 0.004})}
    assert limits["propulsion"] is None              # another model: no size to scale
    assert limits["environmental_bias"] is None      # its fit explains nothing
