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
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.signal import savgol_filter

from .fitting import smoothing_window

__all__ = ["MISMATCH_SPAN", "COLOURED_RATIO", "COLOURED_SHARE", "integration_mismatch",
           "coloured_velocity_noise", "kinematic_velocities", "kinematic_noise_levels"]

#: stretch over which velocities are integrated and compared with the track [s]
MISMATCH_SPAN = 30.0

#: mismatch ratio (observed over white-noise expectation) above which the
#: velocity noise is called coloured; white noise gives 0.7-1.5
COLOURED_RATIO = 3.0

#: and the unexplained mean velocity error over :data:`MISMATCH_SPAN` must
#: exceed this share of the channel's standard deviation (a record without
#: noise has ratios of no meaning: both terms are at rounding level)
COLOURED_SHARE = 0.002


def _white(x: np.ndarray, n: int) -> float:
    """Standard deviation of ``x`` minus its cubic Savitzky-Golay smoothing over ``n`` samples."""
    return float(np.std(x - savgol_filter(x, n, 3, mode="interp"))) if 4 < n < len(x) else 0.0


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
