"""Families of measurement noise for manoeuvring records. All seeded.

A record follows the data contract (SI units, radians): ``t`` [s], ``x0``
(north) and ``y0`` (east) [m], the continuous heading ``psi`` [rad], the
body-fixed over-ground velocities ``u``, ``v`` [m/s], the yaw rate ``r``
[rad/s] and the rudder angle ``delta`` [rad]. Other columns (wind, propeller
rate, roll) are left as they are. :func:`add_sensor_noise` returns a noisy
copy; ``level`` is the degree of noise as a fraction (0.03 = 3 %), and every
family returns the record unchanged at level 0 (a perfect sensor: no noise,
no quantisation, no rederived velocities), drawing nothing from ``rng``.

Sensor-like scales: about 3 % of each velocity channel's largest
excursion, 0.2 deg on the heading, 0.1 deg on the rudder and 0.1 m on the
positions (a carrier-phase satellite fix or a model basin's optical
tracking) at the reference
level of 3 %. With ``s = level / 0.03`` the
standard deviations are

============== ======================================= =========================
channel        standard deviation                      at 3 %
============== ======================================= =========================
``u``          ``level * max|u - U0|``                 3 % of the surge excursion
``v``, ``r``   ``level * max|channel|``                3 % of the largest value
``psi``        ``s * 0.2 deg``                         0.2 deg
``delta``      ``s * 0.1 deg``                         0.1 deg
``x0``, ``y0`` ``s * 0.1 m``                           0.1 m
============== ======================================= =========================

Families (:data:`NOISE_FAMILIES`):

``li2023``
    Li et al. (2023) eq. 22 on ``u``, ``v``, ``r``, ``delta`` only
    (:func:`studies.environment.noise.add_measurement_noise` with ``k0 =
    level``; the same random draws). Its reduction factor 0.05 on surge and
    rudder makes that noise 20 times smaller than the table's on ``u`` at
    the same level.
``white_all``
    White Gaussian noise on every contract channel with the scales above.
``ar1``
    Coloured noise: a stationary first-order autoregression per channel,
    ``e_k = a e_(k-1) + sqrt(1 - a^2) sd w_k`` with ``a = exp(-dt / tau)``,
    ``tau`` = 5 s (:data:`AR1_TIME_CONSTANT`), the first sample drawn from
    the stationary distribution; stationary sd as for ``white_all``, lag-one
    autocorrelation ``a``.
``quantised_rudder``
    ``white_all`` on every channel but the rudder (the same draws), the
    rudder signal without noise rounded to steps of 0.5 deg
    (:data:`RUDDER_STEP`) at any level above 0: an encoder's resolution,
    which does not scale with the level. While the rudder moves through
    the steps the rounding error is uniform within +-0.25 deg (sd
    ``0.5 deg / sqrt(12)`` = 0.14 deg); a steady rudder angle is recorded
    with a constant error of up to 0.25 deg.
``gnss``
    A satellite receiver and a compass: white noise on the positions
    (0.1 m at 3 %), the heading (0.2 deg at 3 %) and the rudder (0.1 deg at
    3 %); ``u``, ``v`` derived from the noisy positions (central
    differences, rotated into body axes with the noisy heading,
    ``u = x0' cos psi + y0' sin psi``, ``v = -x0' sin psi + y0' cos psi``)
    and ``r`` from central differences of the noisy heading, each smoothed
    by a centred moving average over ``N = 2 round(1 s / dt) + 1`` samples
    (:data:`GNSS_WINDOW` of 2 s; 21 samples, 2.1 s, at 0.1 s). The
    moving average is a Savitzky-Golay filter of order 1, so the first and
    last ``N // 2`` samples come from a straight line fitted to the first
    and last window. A moving average of central differences telescopes to
    four samples, so away from the ends the noise on each velocity is
    ``sd_position / (N dt)`` (0.048 m/s at 3 % and 0.1 s, a few per cent of
    the sway velocity's largest value) and on ``r``
    ``sd_psi / (N dt)`` (0.0017 rad/s); the heading noise adds about
    ``U sd_psi / sqrt(N)`` to ``v`` (rotation error, averaged). A real
    receiver's Doppler velocity is more accurate than differenced
    positions; this family is the pessimistic case of velocities that are
    not measured but derived.

The references of eq. 22 are those of :mod:`studies.environment.noise`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import ConfigError
from .noise import add_measurement_noise

__all__ = ["NOISE_FAMILIES", "REFERENCE_LEVEL", "SENSOR_SD", "AR1_TIME_CONSTANT", "RUDDER_STEP",
           "GNSS_WINDOW", "add_sensor_noise", "check_sensor_noise", "sensor_sd", "ar1_noise",
           "gnss_window_samples"]

NOISE_FAMILIES = ("li2023", "white_all", "ar1", "quantised_rudder", "gnss")

#: the level at which the sensor scales of :data:`SENSOR_SD` hold (3 %)
REFERENCE_LEVEL = 0.03

#: standard deviation at :data:`REFERENCE_LEVEL` of the channels with a physical scale [m, rad]
SENSOR_SD = {"x0": 0.1, "y0": 0.1, "psi": np.deg2rad(0.2), "delta": np.deg2rad(0.1)}

#: channels whose noise is a fraction ``level`` of their largest excursion (u about U0)
VELOCITY_CHANNELS = ("u", "v", "r")

#: the channels that ``white_all`` and ``ar1`` pollute, in the order of the random draws
CHANNELS = ("x0", "y0", "psi", "u", "v", "r", "delta")

#: correlation time of the ``ar1`` noise [s]
AR1_TIME_CONSTANT = 5.0

#: resolution of the ``quantised_rudder`` rudder signal [rad]
RUDDER_STEP = np.deg2rad(0.5)

#: length of the ``gnss`` velocity smoothing [s]
GNSS_WINDOW = 2.0


def sensor_sd(record: pd.DataFrame, level: float, speed0: float) -> dict[str, float]:
    """Standard deviation per channel of :data:`CHANNELS` at ``level`` (module table)."""
    scale = level / REFERENCE_LEVEL
    sd = {col: scale * value for col, value in SENSOR_SD.items()}
    for col in VELOCITY_CHANNELS:
        x = record[col].to_numpy(float)
        sd[col] = level * float(np.max(np.abs(x - speed0 if col == "u" else x)))
    return {col: sd[col] for col in CHANNELS}


def ar1_noise(shape: tuple[int, int], dt: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary AR(1) sequences of unit variance along axis 0, lag-one correlation ``exp(-dt/tau)``."""
    a = np.exp(-dt / tau)
    w = rng.standard_normal(shape)
    w[1:] *= np.sqrt(1.0 - a * a)       # the first sample from the stationary distribution
    from scipy.signal import lfilter  # loads scipy.stats: only when this noise is drawn
    return lfilter([1.0], [1.0, -a], w, axis=0)


def gnss_window_samples(dt: float, n: int) -> int:
    """Samples of the ``gnss`` moving average at step ``dt`` [s]: ``2 round(GNSS_WINDOW / (2 dt)) + 1``
    (odd), at most ``n``; 0 (no smoothing) when fewer than 3."""
    window = 2 * int(round(GNSS_WINDOW / (2 * dt))) + 1
    window = min(window, n if n % 2 else n - 1)
    return window if window >= 3 else 0


def _record_dt(record: pd.DataFrame, dt) -> float:
    dt = float(np.median(np.diff(record["t"].to_numpy(float)))) if dt is None else float(dt)
    if not dt > 0:
        raise ConfigError(f"the sample interval dt must be positive, got {dt}")
    return dt


def _with_noise(record: pd.DataFrame, sd: dict, draws: np.ndarray) -> pd.DataFrame:
    """Copy of ``record`` with ``sd[col] * draws[:, j]`` added to the j-th channel of ``sd``."""
    out = record.copy()
    for j, (col, scale) in enumerate(sd.items()):
        out[col] = record[col].to_numpy(float) + scale * draws[:, j]
    return out


def _li2023(record, level, speed0, rng, dt):
    return add_measurement_noise(record, level, speed0, rng)


def _white_all(record, level, speed0, rng, dt):
    draws = rng.standard_normal((len(record), len(CHANNELS)))
    return _with_noise(record, sensor_sd(record, level, speed0), draws)


def _ar1(record, level, speed0, rng, dt):
    draws = ar1_noise((len(record), len(CHANNELS)), _record_dt(record, dt), AR1_TIME_CONSTANT, rng)
    return _with_noise(record, sensor_sd(record, level, speed0), draws)


def _quantised_rudder(record, level, speed0, rng, dt):
    sd = sensor_sd(record, level, speed0)
    sd["delta"] = 0.0
    out = _with_noise(record, sd, rng.standard_normal((len(record), len(CHANNELS))))
    out["delta"] = np.round(record["delta"].to_numpy(float) / RUDDER_STEP) * RUDDER_STEP
    return out


def _moving_average(x: np.ndarray, window: int) -> np.ndarray:
    """Centred moving average over ``window`` samples along axis 0 (Savitzky-Golay of order 1:
    the ends from a straight line fitted to the first and last window); ``window`` 0: unchanged."""
    from ..data.derivatives import savgol_filter
    return savgol_filter(x, window, 1, axis=0, mode="interp") if window else x


def _gnss(record, level, speed0, rng, dt):
    scale = level / REFERENCE_LEVEL
    sd = {col: scale * SENSOR_SD[col] for col in ("x0", "y0", "psi", "delta")}
    out = _with_noise(record, sd, rng.standard_normal((len(record), len(sd))))
    t = record["t"].to_numpy(float)
    window = gnss_window_samples(_record_dt(record, dt), len(record))
    psi = out["psi"].to_numpy(float)
    north, east = (np.gradient(out[col].to_numpy(float), t) for col in ("x0", "y0"))
    c, s = np.cos(psi), np.sin(psi)
    rates = np.column_stack([north * c + east * s, -north * s + east * c, np.gradient(psi, t)])
    out[["u", "v", "r"]] = _moving_average(rates, window)
    return out


def check_sensor_noise(family: str, level: float) -> None:
    """Refuse (:class:`~studies.errors.ConfigError`) a family not in :data:`NOISE_FAMILIES`
    or a level outside [0, 1]."""
    if family not in NOISE_FAMILIES:
        raise ConfigError(f"noise family must be one of {', '.join(NOISE_FAMILIES)}; got {family!r}")
    if not (0.0 <= level <= 1.0):
        raise ConfigError(f"noise level is a fraction in [0, 1] (0.03 = 3 %), got {level}")


_FAMILIES = {"li2023": _li2023, "white_all": _white_all, "ar1": _ar1,
             "quantised_rudder": _quantised_rudder, "gnss": _gnss}


def add_sensor_noise(record: pd.DataFrame, family: str, level: float, speed0: float,
                     rng: np.random.Generator, dt: float | None = None) -> pd.DataFrame:
    """Copy of ``record`` with measurement noise of ``family`` (module docstring) at ``level``.

    Parameters
    ----------
    record : DataFrame
        A manoeuvre in the data contract (``t``, ``x0``, ``y0``, ``psi``,
        ``u``, ``v``, ``r``, ``delta``; SI units, radians).
    family : str
        One of :data:`NOISE_FAMILIES`.
    level : float
        Degree of noise as a fraction in [0, 1] (0.03 = 3 %); 0 returns an
        unchanged copy.
    speed0 : float
        Nominal speed U0 [m/s]; surge noise scales with ``max|u - U0|``.
    rng : numpy.random.Generator
        Source of every random draw.
    dt : float, optional
        Sample interval [s] for ``ar1`` and ``gnss``; the median step of
        ``t`` when omitted.
    """
    check_sensor_noise(family, level)
    if level == 0:
        return record.copy()
    return _FAMILIES[family](record, float(level), float(speed0), rng, dt)
