"""Wind loads, sensor noise, anemometer error and disturbances."""

import numpy as np
import pandas as pd
import pytest

from studies.environment.noise import (NOISE_LEVELS, add_measurement_noise, disturbance_forces,
                                       noise_level, record_wind)
from studies.environment.wind import wind_coefficients, wind_load
from studies.errors import ConfigError


def test_blendermann_coefficients_have_the_expected_symmetries(vessel):
    w = vessel.wind
    args = (w.cd_t, w.cd_l_af_bow, w.cd_l_af_stern, w.cross_force, w.area_frontal,
            w.area_lateral, w.s_l, w.length_overall)
    cx0, cy0, _ = wind_coefficients(0.0, *args)
    assert cx0 == pytest.approx(-w.cd_l_af_bow) and cy0 == 0.0  # head wind: pure drag
    cxp, cyp, _ = wind_coefficients(np.pi, *args)
    assert cxp == pytest.approx(w.cd_l_af_stern)  # following wind pushes ahead
    for g in (0.3, 1.0, 2.0):
        a = np.array(wind_coefficients(g, *args))
        b = np.array(wind_coefficients(-g, *args))
        np.testing.assert_allclose(a, b * [1, -1, -1], rtol=1e-12)
    _, cy90, _ = wind_coefficients(np.pi / 2, *args)
    assert cy90 == pytest.approx(w.cd_t)


def test_wind_from_starboard_pushes_to_port(vessel):
    # ship at rest heading north, wind from east (90 deg): force to the west = negative Y
    fx, fy, fn = wind_load(0.0, 0.0, 0.0, 12.0, np.pi / 2, vessel.wind.as_array())
    q = 0.5 * 1.224 * 144.0
    assert fy == pytest.approx(-q * 0.85 * 1874.0, rel=1e-9)
    assert abs(fx) < 1e-6 * abs(fy)


def _record(n=2000):
    t = np.arange(n) * 0.1
    return pd.DataFrame({"t": t, "x0": t, "y0": 0 * t, "psi": 0.2 * np.sin(0.01 * t),
                         "u": 7.0 + 0.5 * np.cos(0.01 * t), "v": 0.3 * np.sin(0.02 * t),
                         "r": 0.01 * np.sin(0.01 * t), "delta": 0.3 * np.sign(np.sin(0.02 * t)),
                         "wind_speed": 12.0, "wind_direction": 0.5})


def test_measurement_noise_follows_eq_22_and_is_seeded():
    rec = _record()
    a = add_measurement_noise(rec, 0.05, 7.7, np.random.default_rng(1))
    b = add_measurement_noise(rec, 0.05, 7.7, np.random.default_rng(1))
    pd.testing.assert_frame_equal(a, b)
    # std = max|clean| * k0 * k_zeta: 1 for v, 0.05 for delta, surge about U0
    assert np.std(a["v"] - rec["v"]) == pytest.approx(0.3 * 0.05, rel=0.1)
    assert np.std(a["delta"] - rec["delta"]) == pytest.approx(0.3 * 0.05 * 0.05, rel=0.1)
    assert np.std(a["u"] - rec["u"]) == pytest.approx(np.max(np.abs(rec["u"] - 7.7)) * 0.05 * 0.05, rel=0.1)
    assert (a["t"] == rec["t"]).all()
    with pytest.raises(ConfigError):
        add_measurement_noise(rec, 5.0, 7.7, np.random.default_rng(0))


def test_anemometer_error_scales_the_recorded_speed_only():
    rec = record_wind(_record(), -0.05)
    assert rec["wind_speed"].iloc[0] == pytest.approx(12.0 * 0.95)
    assert rec["wind_direction"].iloc[0] == 0.5


def test_per_second_bias_is_the_wiener_process_it_was_and_noise_is_white():
    """``disturbance.scaling=per_second``: eq. 14 per square-root second,
    draw for draw the bias and noise the project made before the ``record``
    reading (the same generator calls, the same arithmetic)."""
    scale = np.array([1e-4, 2e-4, 5e-5])
    ext = disturbance_forces(200000, 0.1, scale, NOISE_LEVELS[2], NOISE_LEVELS[1],
                             np.random.default_rng(4), "per_second")
    bias, noise = ext[:, :3], ext[:, 3:]
    assert np.all(bias[0] == 0)
    steps = np.diff(bias, axis=0)
    expected = scale * [0.2, 1.0, 1.0] * 0.10 * np.sqrt(0.1)
    np.testing.assert_allclose(steps.std(axis=0), expected, rtol=0.02)
    np.testing.assert_allclose(noise.std(axis=0), scale * [0.2, 1.0, 1.0] * 0.05, rtol=0.02)
    assert abs(np.corrcoef(noise[:-1, 1], noise[1:, 1])[0, 1]) < 0.01
    # the former implementation, written out
    rng = np.random.default_rng(4)
    size = scale * np.array([0.2, 1.0, 1.0])
    old_steps = rng.standard_normal((200000, 3)) * (size * 0.10 * np.sqrt(0.1))
    old_bias = np.cumsum(old_steps, axis=0) - old_steps[0]
    old_noise = rng.standard_normal((200000, 3)) * (size * 0.05)
    np.testing.assert_array_equal(bias, old_bias)
    np.testing.assert_array_equal(noise, old_noise)
    assert noise_level("NL3") == 0.20
    with pytest.raises(ConfigError):
        noise_level(7)


def _end_spread(n_steps: int, dt: float, scaling: str, seeds: int = 4000) -> tuple:
    """Standard deviation over ``seeds`` records of the bias in the last row
    and in the middle row, and of the process noise, per DOF."""
    scale = np.array([3e-4, 1.6e-3, 5e-4])
    ends, middles, noise = [], [], []
    for seed in range(seeds):
        ext = disturbance_forces(n_steps, dt, scale, NOISE_LEVELS[1], NOISE_LEVELS[1],
                                 np.random.default_rng(seed), scaling)
        ends.append(ext[-1, :3])
        middles.append(ext[(n_steps - 1) // 2, :3])
        noise.append(ext[-1, 3:])
    size = scale * np.array([0.2, 1.0, 1.0]) * NOISE_LEVELS[1]     # eq. 14: max|phi| k0 k_i
    return (np.std(ends, axis=0) / size, np.std(middles, axis=0) / size, np.std(noise, axis=0) / size)


def test_record_bias_has_the_eq14_size_at_the_end_of_every_record():
    """``disturbance.scaling=record`` (the default): over many seeds the bias's
    standard deviation at the end of a record is the eq. 14 size
    ``max|clean force| k0 k_i`` for any record length and step (sampling
    error of 4000 seeds: 1.1 %), half-way it is sqrt(1/2) of it; the
    ``per_second`` bias of a 600 s record ends sqrt(600) = 24.5 times
    larger. The process noise is the eq. 14 size in both."""
    for n_steps, dt in ((601, 1.0), (361, 5.0)):
        end, middle, noise = _end_spread(n_steps, dt, "record")
        np.testing.assert_allclose(end, 1.0, rtol=0.05)
        np.testing.assert_allclose(middle, np.sqrt(0.5), rtol=0.05)
        np.testing.assert_allclose(noise, 1.0, rtol=0.05)
    end, _, noise = _end_spread(601, 1.0, "per_second", seeds=1000)
    np.testing.assert_allclose(end, np.sqrt(600.0), rtol=0.1)
    np.testing.assert_allclose(noise, 1.0, rtol=0.1)
    default = disturbance_forces(50, 0.1, np.ones(3), 0.05, 0.0, np.random.default_rng(1))
    record = disturbance_forces(50, 0.1, np.ones(3), 0.05, 0.0, np.random.default_rng(1), "record")
    np.testing.assert_array_equal(default, record)


def test_an_unknown_bias_scaling_is_refused():
    with pytest.raises(ConfigError, match="disturbance.scaling must be one of record, per_second"):
        disturbance_forces(10, 0.1, np.ones(3), 0.05, 0.0, np.random.default_rng(0), "per_minute")
