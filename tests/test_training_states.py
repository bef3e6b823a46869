"""Which states the training records cover, and the verdict ``outside_training_states``.

Records from the tests' own Mariner program (:mod:`reference_mariner`, no code of
``studies``): zig-zags 10/10 and 20/20 train; a 35 deg turning circle, whose
steady turn reaches drift and yaw rates no zig-zag does, is held out. The
"baseline's predictions" are the records with an error put where the test
says, so that what is judged is where the departure lies.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import reference_mariner as ref
from studies.analysis.state_ranges import beyond, training_ranges
from studies.discovery.held_out import judge_held_out, whole_record_gain
from studies.discovery.training_states import outside_training
from studies.vessels import get_vessel


def _record(data: dict, name: str) -> pd.DataFrame:
    frame = pd.DataFrame(data)
    frame.attrs["name"] = name
    return frame


@pytest.fixture(scope="module")
def mariner():
    return get_vessel("mariner")


@pytest.fixture(scope="module")
def records():
    train = [_record(ref.zigzag_record(10.0, 10.0, duration=600.0, dt=0.5), "zz10"),
             _record(ref.zigzag_record(20.0, 20.0, duration=600.0, dt=0.5), "zz20")]
    turn = _record(ref.turning_record(35.0, duration=600.0, dt=0.5, execute=60.0), "tc35")
    zz15 = _record(ref.zigzag_record(15.0, 15.0, duration=600.0, dt=0.5), "zz15")
    return train, turn, zz15


def _with_error(record: pd.DataFrame, rows: np.ndarray, du: float) -> pd.DataFrame:
    """The record with ``du`` [m/s] added to u on ``rows`` and the track integrated again."""
    out = record.copy()
    u = out["u"].to_numpy(float) + np.where(rows, du, 0.0)
    psi = out["psi"].to_numpy(float)
    dt = np.gradient(out["t"].to_numpy(float))
    out["u"] = u
    out["x0"] = record["x0"].iloc[0] + np.cumsum((u * np.cos(psi) - out["v"] * np.sin(psi)) * dt)
    out["y0"] = record["y0"].iloc[0] + np.cumsum((u * np.sin(psi) + out["v"] * np.cos(psi)) * dt)
    out.attrs = dict(record.attrs)
    return out


def test_the_turn_goes_beyond_the_zig_zags_in_drift_yaw_rate_and_rudder(records, mariner):
    train, turn, zz15 = records
    ranges = training_ranges(train, mariner)
    assert set(ranges) == {"drift_deg", "yaw_rate_prime", "speed_ratio", "rudder_deg"}
    assert ranges["rudder_deg"][1] == pytest.approx(20.0, abs=0.5)
    found = beyond(turn, ranges, mariner)
    assert {"drift_deg", "yaw_rate_prime", "rudder_deg"} <= set(found.states)
    assert found.states["rudder_deg"]["record"][1] == pytest.approx(35.0, abs=0.5)
    assert found.share > 0.5
    # a zig-zag between the two trained ones stays inside
    assert beyond(zz15, ranges, mariner).states == {}


def test_a_departure_in_the_steady_turn_is_named_outside_training_states(records, mariner):
    train, turn, _ = records
    where = beyond(turn, training_ranges(train, mariner), mariner).outside
    predicted = _with_error(turn, where, -0.3)          # the speed loss missed in the turn alone
    verdict = outside_training(train, [turn], [predicted], mariner)
    assert verdict is not None and verdict["departure_share"] > 0.95
    assert "yaw_rate_prime" in verdict["states"] and "turning circle with 35 deg" in verdict["manoeuvre"]
    held_low, held_high = verdict["states"]["yaw_rate_prime"]["held_out"]
    train_low, train_high = verdict["states"]["yaw_rate_prime"]["training"]
    assert held_high > train_high or held_low < train_low


def test_a_departure_where_training_went_is_not(records, mariner):
    """The same turn, its error on the approach run (inside the zig-zags' states): a
    cause may explain it, so the verdict is not this one."""
    train, turn, zz15 = records
    where = beyond(turn, training_ranges(train, mariner), mariner).outside
    predicted = _with_error(turn, ~where, -0.3)
    assert outside_training(train, [turn], [predicted], mariner) is None
    # a held-out record inside the envelope never is, however wrong the prediction
    assert outside_training(train, [zz15], [_with_error(zz15, np.ones(len(zz15), bool), -0.5)], mariner) is None


def test_the_whole_record_gain_has_an_interval_and_a_worse_extension_is_not_a_gain(records):
    _, turn, zz15 = records
    small = _with_error(turn, np.ones(len(turn), bool), -0.05)
    large = _with_error(turn, np.ones(len(turn), bool), -0.2)
    better = whole_record_gain([turn], [large], [small])
    assert better["gain_pct"] > 50.0 and better["interval"][0] > 0.0
    assert better["interval"][0] <= better["gain_pct"] <= better["interval"][1]
    worse = judge_held_out([turn], [small], [large])
    assert worse["whole"]["gain_pct"] < 0.0 and worse["whole"]["interval"][1] < 0.0
    assert not worse["explains"] and worse["worse"][0] == "position over the whole records"
    # the characteristics of the turn are judged too: the slower ship turns tighter
    quantities = {r["quantity"] for r in worse["characteristics"]}
    assert {"advance_m", "tactical_diameter_m"} <= quantities
    same = judge_held_out([turn], [turn], [turn])
    assert same["explains"] and same["whole"]["gain_pct"] == 0.0 and same["whole"]["interval"] == [0.0, 0.0]
    # a zig-zag is left to the windowed error: its open-loop replay is not the test as run
    zigzag = judge_held_out([zz15, turn], [_with_error(zz15, np.ones(len(zz15), bool), -0.3), small],
                            [zz15, small])
    assert zigzag["not_judged"] == ["zz15"] and zigzag["judged"] == ["tc35"]
    assert zigzag["whole"]["gain_pct"] == 0.0 and zigzag["explains"]


def test_the_headline_is_the_most_probable_verdict():
    """When the records as measured name one cause but the reweightings name
    another more often, the headline is the more probable one (as its table ranks it)."""
    from types import SimpleNamespace

    from studies.discovery.inference import _most_probable

    variants = [SimpleNamespace(cause=SimpleNamespace(id=cid)) for cid in ("current", "propeller_asymmetry")]
    chosen = {"current": 0, "propeller_asymmetry": 1}
    fits = {(): "none", (0,): "current", (1,): "propeller asymmetry"}
    verdicts = {"propeller_asymmetry": 0.35, "current": 0.31, "none": 0.34}
    assert _most_probable(variants, (0,), verdicts, chosen, fits) == (1,)
    assert _most_probable(variants, (0,), {"none": 0.6, "current": 0.4}, chosen, fits) == ()
    assert _most_probable(variants, (0,), {"current": 0.6, "none": 0.4}, chosen, fits) == (0,)


def test_a_rudder_the_training_reached_is_not_beyond_it(records, mariner):
    """Trained on a 35/5 zig-zag, a 35 deg turn's rudder is where training went (the
    turn's drift and its speed loss still are not)."""
    _, turn, _ = records
    train = [_record(ref.zigzag_record(35.0, 5.0, duration=400.0, dt=0.5), "zz35_5")]
    found = beyond(turn, training_ranges(train, mariner), mariner)
    assert "rudder_deg" not in found.states
    assert {"drift_deg", "speed_ratio"} <= set(found.states)
