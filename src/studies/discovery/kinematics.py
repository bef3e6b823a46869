"""Whether a record's velocities agree with its own track and heading.

A record holds both the track (``x0``, ``y0`` [m], heading ``psi`` [rad])
and the velocities (body-fixed over-ground ``u``, ``v`` [m/s], yaw rate
``r`` [rad/s]), and the first is the integral of the second:
``x0' = u cos psi - v sin psi``, ``y0' = u sin psi + v cos psi``,
``psi' = r``. Over a stretch of ``span`` seconds the change of position or
heading minus the integral of the velocity is the integrated velocity error
plus the difference of two position errors. White velocity noise of standard
deviation ``s_v`` sampled every ``dt`` integrates to about ``s_v sqrt(dt
span)``, which is small; noise correlated over seconds (a drifting log or
gyro, a filtered sensor: coloured noise) integrates to much more, and it is
invisible to the smoothing-based noise estimate because it looks like
signal. The ratio of the observed mismatch to what white noise of the
estimated levels explains tells them apart (:func:`integration_mismatch`):
about 1 for white noise on every channel, for velocities derived from the
positions and for the MARIN KVLCC2 records (whose positions and heading are
rounded to three significant digits; the rounding is white at the smoothing's
scale), several times more for coloured noise.

Velocities may also not be measured at all but derived from the track (a
satellite receiver's positions differenced and smoothed): their noise is
then a filtered copy of the position and heading noise, not an independent
sensor's. :func:`derived_share` finds that filter: per channel, the
velocity's noise (record minus smoothing) regressed on the position's noise
over +-:data:`DERIVED_LAG` seconds of lags (any linear, time-invariant
derivative and smoothing shorter than that is such a filter) explains nearly
all of it (0.88-1.0 for the ``gnss`` family, whatever the level), and no
more than chance (the share of regressors in the samples, 0.015 at 0.1 s
over 690 s) for independent sensors: 0.00-0.03 for the other noise
families, 0.01-0.23 for the MARIN KVLCC2 records.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.signal import savgol_filter

from .fitting import smoothing_window

__all__ = ["MISMATCH_SPAN", "COLOURED_RATIO", "COLOURED_SHARE", "DERIVED_LAG", "DERIVED_SHARE",
           "integration_mismatch", "coloured_velocity_noise", "derived_share", "derived_velocities",
           "kinematic_velocities", "kinematic_noise_levels"]

#: stretch over which velocities are integrated and compared with the track [s]
MISMATCH_SPAN = 30.0

#: mismatch ratio (observed over white-noise expectation) above which the
#: velocity noise is called coloured; white noise gives 0.7-1.5
COLOURED_RATIO = 3.0

#: and the unexplained mean velocity error over :data:`MISMATCH_SPAN` must
#: exceed this share of the channel's standard deviation (a record without
#: noise has ratios of no meaning: both terms are at rounding level)
COLOURED_SHARE = 0.002


def _noise(x: np.ndarray, n: int) -> np.ndarray:
    """``x`` minus its cubic Savitzky-Golay smoothing over ``n`` samples (``4 < n < len(x)``)."""
    return x - savgol_filter(x, n, 3, mode="interp")


def _white(x: np.ndarray, n: int) -> float:
    """Standard deviation of :func:`_noise` (0 when ``n`` does not fit the record)."""
    return float(np.std(_noise(x, n))) if 4 < n < len(x) else 0.0


def _earth_rates(record) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``t`` and the measured velocities as rates of ``x0``, ``y0``, ``psi``."""
    t = record["t"].to_numpy(float)
    psi = np.unwrap(record["psi"].to_numpy(float))
    u, v, r = (record[c].to_numpy(float) for c in ("u", "v", "r"))
    c, s = np.cos(psi), np.sin(psi)
    return t, u * c - v * s, u * s + v * c, r


def integration_mismatch(record, span: float = MISMATCH_SPAN) -> np.ndarray:
    """``(ratio, share)`` per channel ``x0, y0, psi`` (array of shape (2, 3)).

    Over consecutive stretches of ``span`` seconds, ``d`` = change of the
    channel minus the integral (trapezoid) of its measured rate. ``ratio`` is
    the RMS of ``d`` over its expectation under white noise,
    ``sqrt(2 s_p^2 + s_v^2 dt span)``, with ``s_p``, ``s_v`` the channel's and
    its rate's noise levels (record minus smoothing, window by the
    discrepancy principle); ``share`` is the unexplained part as a mean rate
    error over the stretch, ``sqrt(max(RMS^2 - expected^2, 0)) / span``,
    over the standard deviation of the rate.
    """
    t, north, east, r = _earth_rates(record)
    dt = float(np.median(np.diff(t)))
    m = int(round(span / dt))
    out = np.full((2, 3), np.nan)
    if m < 2 or len(t) <= m:
        return out
    n = smoothing_window(record)
    starts = np.arange(0, len(t) - m, m)
    channels = (record["x0"].to_numpy(float), record["y0"].to_numpy(float),
                np.unwrap(record["psi"].to_numpy(float)))
    for k, (position, rate) in enumerate(zip(channels, (north, east, r))):
        d = position - cumulative_trapezoid(rate, t, initial=0.0)
        change = d[starts + m] - d[starts]
        observed = float(np.mean(change ** 2))
        expected = 2.0 * _white(position, n) ** 2 + _white(rate, n) ** 2 * dt * span
        out[0, k] = np.sqrt(observed / expected) if expected > 0 else np.inf
        out[1, k] = np.sqrt(max(observed - expected, 0.0)) / span / max(float(np.std(rate)), 1e-300)
    return out


def coloured_velocity_noise(records, span: float = MISMATCH_SPAN) -> bool:
    """Whether the records' velocities carry coloured noise: in the median
    record, the median channel's mismatch ratio exceeds :data:`COLOURED_RATIO`
    and its unexplained share :data:`COLOURED_SHARE`
    (:func:`integration_mismatch`)."""
    stats = [integration_mismatch(rec, span) for rec in records]
    stats = [s for s in stats if np.all(np.isfinite(s))]
    if not stats:
        return False
    ratio = float(np.median([np.median(s[0]) for s in stats]))
    share = float(np.median([np.median(s[1]) for s in stats]))
    return ratio > COLOURED_RATIO and share > COLOURED_SHARE


#: lags on each side over which a velocity's noise is regressed on its position's [s]
DERIVED_LAG = 5.0
#: share of a velocity channel's noise explained by its position's above which
#: the velocities are called derived from the track
DERIVED_SHARE = 0.5
#: rate noise below this share of the rate's standard deviation is numerical residue, not noise
NOISE_FLOOR = 1e-5


def derived_share(record, lag: float = DERIVED_LAG) -> np.ndarray:
    """Per channel (north, east and yaw rates against ``x0``, ``y0``, ``psi``),
    the share (R^2) of the rate's noise explained by a linear filter of the
    position's noise over +-``lag`` seconds (least squares on the lagged
    noise). Noise is the record minus its cubic Savitzky-Golay smoothing
    (window by the discrepancy principle). NaN when the record is shorter
    than a few filter lengths, or for a channel whose rate has no noise
    above :data:`NOISE_FLOOR` of its standard deviation."""
    t, north, east, r = _earth_rates(record)
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(lag / dt)))
    n = smoothing_window(record)
    out = np.full(3, np.nan)
    if len(t) < 10 * (2 * k + 1) or not 4 < n < len(t):
        return out
    rows = np.arange(k, len(t) - k)
    positions = (record["x0"].to_numpy(float), record["y0"].to_numpy(float),
                 np.unwrap(record["psi"].to_numpy(float)))
    for j, (position, rate) in enumerate(zip(positions, (north, east, r))):
        ep = _noise(position, n)
        y = _noise(rate, n)[rows]
        if not np.std(y) > NOISE_FLOOR * max(float(np.std(rate)), 1e-300):
            continue  # no noise to explain: numerical residue of the smoothing
        lagged = np.column_stack([ep[rows + i] for i in range(-k, k + 1)])
        coef, *_ = np.linalg.lstsq(lagged, y, rcond=None)
        out[j] = 1.0 - float(np.var(y - lagged @ coef)) / float(np.var(y))
    return out


def derived_velocities(records, lag: float = DERIVED_LAG) -> bool:
    """Whether the records' velocities are derived from their own track and
    heading: in the median record, the median channel's
    :func:`derived_share` exceeds :data:`DERIVED_SHARE`."""
    shares = [derived_share(rec, lag) for rec in records]
    shares = [float(np.nanmedian(s)) for s in shares if np.any(np.isfinite(s))]
    return bool(shares) and float(np.median(shares)) > DERIVED_SHARE


def kinematic_velocities(record) -> np.ndarray:
    """``u, v, r`` (columns) from the smoothed track and heading: the
    derivative of the cubic Savitzky-Golay fit (window by the discrepancy
    principle) rotated into body axes."""
    t = record["t"].to_numpy(float)
    dt = float(np.median(np.diff(t)))
    n = smoothing_window(record)
    n = n if 4 < n < len(t) else min(len(t) - (1 - len(t) % 2), 5)
    psi = np.unwrap(record["psi"].to_numpy(float))
    rates = [savgol_filter(x, n, 3, deriv=1, delta=dt, mode="interp")
             for x in (record["x0"].to_numpy(float), record["y0"].to_numpy(float), psi)]
    heading = savgol_filter(psi, n, 3, mode="interp")
    c, s = np.cos(heading), np.sin(heading)
    return np.column_stack([rates[0] * c + rates[1] * s, -rates[0] * s + rates[1] * c, rates[2]])


def kinematic_noise_levels(records) -> np.ndarray:
    """Noise standard deviation of ``u, v, r`` as their RMS difference from
    :func:`kinematic_velocities`, pooled over the records: a level that
    includes coloured noise (and the track's own differentiation noise, so
    it is an upper bound)."""
    sums, count = np.zeros(3), 0
    for rec in records:
        measured = rec[["u", "v", "r"]].to_numpy(float)
        sums += np.sum((measured - kinematic_velocities(rec)) ** 2, axis=0)
        count += len(rec)
    return np.sqrt(sums / max(count, 1))
