"""Measurement-noise families: their statistics are those of the module docstring.

The statistics are checked on a long synthetic record whose positions, heading
and velocities agree (the positions integrate the body-fixed velocities
rotated by the heading, the heading integrates the yaw rate), so the ``gnss``
family's derived velocities can be compared with the clean ones.
"""

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import cumulative_trapezoid

from studies.environment.noise import add_measurement_noise
from studies.environment.sensor_noise import (AR1_TIME_CONSTANT, NOISE_FAMILIES, RUDDER_STEP,
                                              add_sensor_noise, gnss_window_samples)
from studies.errors import ConfigError

SPEED0 = 7.0
CONTRACT = ["x0", "y0", "psi", "u", "v", "r", "delta"]


def _record(n=100_000, dt=0.1):
    """A consistent manoeuvre: n samples at dt [s], u about 7 m/s, psi = 1 - cos(0.01 t)."""
    t = np.arange(n) * dt
    psi = 1.0 - np.cos(0.01 * t)
    u, v = SPEED0 + 0.5 * np.cos(0.01 * t), 0.3 * np.sin(0.02 * t)
    north = u * np.cos(psi) - v * np.sin(psi)
    east = u * np.sin(psi) + v * np.cos(psi)
    return pd.DataFrame({"t": t, "x0": cumulative_trapezoid(north, t, initial=0.0),
                         "y0": cumulative_trapezoid(east, t, initial=0.0), "psi": psi, "u": u, "v": v,
                         "r": 0.01 * np.sin(0.01 * t), "delta": 0.3 * np.sign(np.sin(0.02 * t)) + 0.01,
                         "wind_speed": 12.0})


@pytest.fixture(scope="module")
def record():
    return _record()


def _sensor_sd(level):
    """The module table, computed here from the clean record's excursions."""
    s = level / 0.03
    return {"x0": s * 0.1, "y0": s * 0.1, "psi": s * np.deg2rad(0.2), "u": level * 0.5, "v": level * 0.3,
            "r": level * 0.01, "delta": s * np.deg2rad(0.1)}


def _error(noisy, clean, trim=0):
    end = len(clean) - trim
    return (noisy[CONTRACT] - clean[CONTRACT]).iloc[trim:end]


@pytest.mark.parametrize("family", NOISE_FAMILIES)
def test_level_zero_leaves_the_record_unchanged_and_draws_nothing(record, family):
    rng = np.random.default_rng(3)
    before = rng.bit_generator.state
    pd.testing.assert_frame_equal(add_sensor_noise(record, family, 0.0, SPEED0, rng), record)
    assert rng.bit_generator.state == before


@pytest.mark.parametrize("family", NOISE_FAMILIES)
def test_families_are_seeded_and_leave_time_and_other_columns(record, family):
    a = add_sensor_noise(record, family, 0.03, SPEED0, np.random.default_rng(1))
    b = add_sensor_noise(record, family, 0.03, SPEED0, np.random.default_rng(1))
    pd.testing.assert_frame_equal(a, b)
    assert (a["t"] == record["t"]).all() and (a["wind_speed"] == record["wind_speed"]).all()
    assert list(a.columns) == list(record.columns)


def test_li2023_is_eq_22_with_the_same_draws(record):
    a = add_sensor_noise(record, "li2023", 0.05, SPEED0, np.random.default_rng(2))
    b = add_measurement_noise(record, 0.05, SPEED0, np.random.default_rng(2))
    pd.testing.assert_frame_equal(a, b)


@pytest.mark.parametrize("level", [0.03, 0.05])
def test_white_all_has_the_sensor_scales_on_every_channel(record, level):
    err = _error(add_sensor_noise(record, "white_all", level, SPEED0, np.random.default_rng(4)), record)
    for col, sd in _sensor_sd(level).items():
        assert err[col].std() == pytest.approx(sd, rel=0.1), col
        assert abs(np.corrcoef(err[col].iloc[:-1], err[col].iloc[1:])[0, 1]) < 0.02, col


def test_ar1_noise_is_coloured_with_a_5_s_correlation_time(record):
    err = _error(add_sensor_noise(record, "ar1", 0.03, SPEED0, np.random.default_rng(5)), record)
    lag1 = np.exp(-0.1 / AR1_TIME_CONSTANT)
    for col, sd in _sensor_sd(0.03).items():
        assert err[col].std() == pytest.approx(sd, rel=0.1), col
        assert np.corrcoef(err[col].iloc[:-1], err[col].iloc[1:])[0, 1] == pytest.approx(lag1, abs=0.003), col


def test_ar1_uses_the_given_sample_interval():
    rec = _record(n=50_000, dt=1.0)
    err = _error(add_sensor_noise(rec, "ar1", 0.03, SPEED0, np.random.default_rng(6)), rec)
    assert np.corrcoef(err["v"].iloc[:-1], err["v"].iloc[1:])[0, 1] == pytest.approx(np.exp(-0.2), abs=0.02)
    err = _error(add_sensor_noise(rec, "ar1", 0.03, SPEED0, np.random.default_rng(6), dt=0.1), rec)
    assert np.corrcoef(err["v"].iloc[:-1], err["v"].iloc[1:])[0, 1] == pytest.approx(np.exp(-0.02), abs=0.005)


def test_quantised_rudder_is_in_half_degree_steps_and_the_rest_white(record):
    noisy = add_sensor_noise(record, "quantised_rudder", 0.03, SPEED0, np.random.default_rng(7))
    steps = noisy["delta"] / np.deg2rad(0.5)
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    assert RUDDER_STEP == pytest.approx(np.deg2rad(0.5))
    assert np.max(np.abs(noisy["delta"] - record["delta"])) <= RUDDER_STEP / 2 + 1e-12
    # the other channels carry white_all's noise, drawn alike
    white = add_sensor_noise(record, "white_all", 0.03, SPEED0, np.random.default_rng(7))
    others = [c for c in CONTRACT if c != "delta"]
    pd.testing.assert_frame_equal(noisy[others], white[others])


def test_gnss_velocities_follow_the_clean_ones_within_the_documented_sd(record):
    n_window = gnss_window_samples(0.1, len(record))
    assert n_window == 21
    # without noise the derivation (differences, rotation, 2 s moving average) returns the clean velocities
    exact = _error(add_sensor_noise(record, "gnss", 1e-12, SPEED0, np.random.default_rng(8)), record)
    assert np.abs(exact[["u", "v"]]).to_numpy().max() < 2e-3 and np.abs(exact["r"]).max() < 1e-5
    level, trim = 0.03, n_window // 2
    err = _error(add_sensor_noise(record, "gnss", level, SPEED0, np.random.default_rng(8)), record, trim)
    sd = _sensor_sd(level)
    for col in ("x0", "y0", "psi", "delta"):
        assert err[col].std() == pytest.approx(sd[col], rel=0.1), col
    for col, source in (("u", "x0"), ("v", "x0"), ("r", "psi")):
        documented = sd[source] / (n_window * 0.1)
        assert err[col].std() == pytest.approx(documented, rel=0.1), col
        assert abs(err[col].mean()) < 0.05 * documented, col


@pytest.mark.parametrize("family,level,match", [
    ("pink", 0.03, "li2023, white_all, ar1, quantised_rudder, gnss"),
    ("white_all", 1.5, r"\[0, 1\]"),
    ("gnss", -0.01, r"\[0, 1\]"),
])
def test_bad_family_or_level_is_refused(record, family, level, match):
    with pytest.raises(ConfigError, match=match):
        add_sensor_noise(record, family, level, SPEED0, np.random.default_rng(0))


def test_hidden_records_refuse_a_bad_family_before_simulating(vessel):
    from studies.scenarios.hidden import hidden_records

    with pytest.raises(ConfigError, match="noise family must be one of"):
        hidden_records(vessel, "rudder_offset", seed=1, noise=0.03, noise_family="coloured")
