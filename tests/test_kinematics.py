"""Velocities checked against the record's own track: coloured noise is told
from white noise, and velocities derived from the track from measured ones,
on an analytic turn, on the noise families and on the MARIN KVLCC2 records."""

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter, savgol_filter

from conftest import marin_file
from studies.discovery.kinematics import (coloured_velocity_noise, derived_share, derived_velocities,
                                         integration_mismatch, kinematic_noise_levels)


def _steady_turn(n: int = 6001, dt: float = 0.1) -> pd.DataFrame:
    """A steady turn in closed form: constant u, v [m/s] and r [rad/s]."""
    t = np.arange(n) * dt
    u, v, r = 7.0, -0.4, 0.012
    psi = r * t
    speed, drift = np.hypot(u, v), np.arctan2(v, u)
    x0 = speed / r * (np.sin(psi + drift) - np.sin(drift))
    y0 = -speed / r * (np.cos(psi + drift) - np.cos(drift))
    return pd.DataFrame({"t": t, "x0": x0, "y0": y0, "psi": psi, "u": u, "v": v, "r": r,
                         "delta": 0.1})


def _noisy(record: pd.DataFrame, coloured: bool, seed: int) -> pd.DataFrame:
    """Noise on every channel: white, or first-order autoregressive with a 5 s correlation time."""
    rng = np.random.default_rng(seed)
    out = record.copy()
    sd = {"x0": 0.1, "y0": 0.1, "psi": np.deg2rad(0.2), "u": 0.05, "v": 0.05, "r": 3e-4}
    a = np.exp(-0.1 / 5.0)
    for col, s in sd.items():
        w = rng.standard_normal(len(record))
        if coloured:
            w[1:] *= np.sqrt(1 - a * a)
            w = lfilter([1.0], [1.0, -a], w)
        out[col] = record[col] + s * w
    return out


@pytest.mark.parametrize("seed", [3, 17])
def test_coloured_noise_is_told_from_white_noise_on_an_analytic_turn(seed):
    turn = _steady_turn()
    white, coloured = _noisy(turn, False, seed), _noisy(turn, True, seed)
    assert not coloured_velocity_noise([white])
    assert coloured_velocity_noise([coloured])
    ratio_white = integration_mismatch(white)[0]
    assert np.all((ratio_white > 0.5) & (ratio_white < 2.0)), ratio_white
    assert np.median(integration_mismatch(coloured)[0]) > 5.0


def test_a_record_without_noise_is_not_called_coloured():
    assert not coloured_velocity_noise([_steady_turn()])


def test_kinematic_levels_see_the_coloured_noise():
    """The level from the track includes the coloured noise the smoothing
    misses: at least the true level, an upper bound within ten times it."""
    coloured = _noisy(_steady_turn(), True, 5)
    sigma = kinematic_noise_levels([coloured])
    true = np.array([0.05, 0.05, 3e-4])
    assert np.all(sigma > 0.8 * true) and np.all(sigma < 10 * true), sigma


@pytest.mark.parametrize("family, coloured", [("white_all", False), ("gnss", False), ("li2023", False),
                                              ("quantised_rudder", False), ("ar1", True)])
def test_noise_families(vessel, family, coloured):
    from studies.scenarios.hidden import hidden_records

    records, _ = hidden_records(vessel, "none", seed=7, noise=0.03, noise_family=family)
    assert coloured_velocity_noise(records[:2]) is coloured


def test_the_marin_records_are_not_called_coloured():
    """Positions and heading rounded to three significant digits are white at the smoothing's scale."""
    from studies.workflows.measured import load_measured

    records = load_measured([marin_file(m) for m in ("zz_10", "zz_20", "tc_35")])
    for i in range(3):
        assert not coloured_velocity_noise([r for j, r in enumerate(records) if j != i])


def _derived(record: pd.DataFrame, scheme: str, seed: int) -> pd.DataFrame:
    """White noise on the track and heading (0.1 m, 0.2 deg) and ``u, v, r``
    derived from them by ``scheme``: ``backward`` differences, ``central``
    differences smoothed by a 3 s moving average, or the derivative of a
    1.5 s quadratic Savitzky-Golay fit; rotated into body axes with the noisy heading."""
    rng = np.random.default_rng(seed)
    out = record.copy()
    dt = float(record["t"].iloc[1] - record["t"].iloc[0])
    for col, s in (("x0", 0.1), ("y0", 0.1), ("psi", np.deg2rad(0.2))):
        out[col] = record[col] + s * rng.standard_normal(len(record))

    def rate(x):
        if scheme == "backward":
            return np.diff(x, prepend=2.0 * x[0] - x[1]) / dt
        if scheme == "central":
            d = np.gradient(x, dt)
            n = int(round(3.0 / dt)) | 1
            return np.convolve(d, np.ones(n) / n, mode="same")
        return savgol_filter(x, int(round(1.5 / dt)) | 1, 2, deriv=1, delta=dt, mode="interp")

    north, east, r = (rate(out[c].to_numpy(float)) for c in ("x0", "y0", "psi"))
    psi = out["psi"].to_numpy(float)
    out["u"] = north * np.cos(psi) + east * np.sin(psi)
    out["v"] = -north * np.sin(psi) + east * np.cos(psi)
    out["r"] = r
    return out


@pytest.mark.parametrize("scheme", ["backward", "central", "savgol"])
def test_velocities_derived_from_the_track_are_told_from_measured_ones(scheme):
    """Three ways of deriving velocities from a noisy track (none the
    ``gnss`` family's): called derived, most of each velocity's noise
    explained by the track's; measured velocities with noise of their own
    (white or coloured) are not, and nothing is explained beyond chance."""
    turn = _steady_turn(n=4001)
    derived = _derived(turn, scheme, 11)
    assert derived_velocities([derived])
    assert np.nanmedian(derived_share(derived)) > 0.8, derived_share(derived)
    for coloured in (False, True):
        measured = _noisy(turn, coloured, 11)
        assert not derived_velocities([measured])
        assert np.all(derived_share(measured) < 0.1), derived_share(measured)


def test_a_record_without_noise_is_not_called_derived():
    assert not derived_velocities([_steady_turn()])


@pytest.mark.parametrize("family", ["white_all", "gnss", "li2023", "quantised_rudder", "ar1"])
def test_noise_families_derived(vessel, family):
    from studies.scenarios.hidden import hidden_records

    records, _ = hidden_records(vessel, "none", seed=7, noise=0.03, noise_family=family)
    assert derived_velocities(records[:2]) is (family == "gnss")


def test_the_marin_records_velocities_are_not_called_derived():
    from studies.workflows.measured import load_measured

    records = load_measured([marin_file(m) for m in ("zz_10", "zz_20", "tc_35")])
    assert not derived_velocities(records)
    assert all(np.nanmax(derived_share(r)) < 0.5 for r in records)
