"""The records' measurement noise per channel, as the prediction-error
filter starts from it (:mod:`.prediction_error`, :mod:`.innovations`): each
channel minus its smoothing, optionally averaged over the filter's step,
with a floor of the channel's natural unit."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.signal import savgol_filter

from ..data.resample import block_means
from .fitting import Context, smoothing_window
from .kinematics import coloured_velocity_noise, kinematic_noise_levels

__all__ = ["CHANNELS", "noise_floors", "noise_levels"]

#: measured channels, in this order
CHANNELS = ("x0", "y0", "psi", "u", "v", "r")


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    return savgol_filter(x, n, 3, mode="interp") if n < len(x) else x


def noise_floors(vessel) -> np.ndarray:
    """The smallest noise standard deviation a channel of :data:`CHANNELS` is
    credited with: 1e-4 of its natural unit (``L`` [m], 1 rad, ``U0`` [m/s],
    ``U0 / L`` [rad/s]). A record cleaner than that (a simulation's) is still
    compared with a model integrated at a finite step, whose own error is of
    that order."""
    L, U = float(vessel.length), float(vessel.speed)
    return np.array([1e-4 * L, 1e-4 * L, 1e-4, 1e-4 * U, 1e-4 * U, 1e-4 * U / L])


def noise_levels(ctx: Context, records, step: float | None = None) -> np.ndarray:
    """Noise standard deviation per channel of :data:`CHANNELS`: the record
    minus its smoothing (window by the discrepancy principle), pooled over the
    records, floored at 1e-4 of the natural unit (L, 1 rad, U0, U0/L). With
    ``step`` [s], of the noise averaged over blocks of that length
    (:func:`studies.data.resample.block_means`, what the filter compares at its step): white noise shrinks by the square root of the block's
    samples, noise correlated over seconds hardly at all.

    Noise correlated over seconds looks like signal to the smoothing; when
    the velocities disagree with the records' own track and heading by more
    than white noise explains (:func:`.kinematics.coloured_velocity_noise`),
    the levels of ``u, v, r`` are their RMS difference from the velocities
    derived from the track (:func:`.kinematics.kinematic_noise_levels`), if
    larger."""
    floors = noise_floors(ctx.vessel)
    sums, count = np.zeros(len(CHANNELS)), 0
    for rec in records:
        n = smoothing_window(rec)
        noise = {"t": rec["t"].to_numpy(float)}
        for c in CHANNELS:
            x = rec[c].to_numpy(float)
            if c == "psi":
                x = np.unwrap(x)
            noise[c] = x - _smooth(x, n)
        noise = pd.DataFrame(noise)
        if step is not None:
            noise = block_means(noise, step)
        for k, c in enumerate(CHANNELS):
            sums[k] += float(np.sum(noise[c].to_numpy() ** 2))
        count += len(noise)
    sigma = np.sqrt(sums / max(count, 1))
    if coloured_velocity_noise(records):
        sigma[3:6] = np.maximum(sigma[3:6], kinematic_noise_levels(records))
    return np.maximum(sigma, floors)
