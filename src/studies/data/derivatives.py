"""State and acceleration estimation from a sampled record.

Identification works on the inverse dynamics, so it needs accelerations.
The thesis' forward difference (eq. 3.9, ``forward``) is exact only on data
produced by a forward-Euler simulation (the Marine Systems Simulator's, or
``data.scheme=euler``); on anything else it leaves an O(dt) error that
biases the regression. Besides it:

``central``
    Fourth-order central differences on a uniform grid (error O(dt^4));
    for clean records, e.g. RK4 simulations or well-filtered measurements.
    The stencil assumes the states are smooth over five samples; where the
    rudder angle has a corner (the start or end of a rate-limited rudder
    movement, visible as a spike of its second difference) the states'
    second derivative jumps and the stencil is wrong there, so the rows whose
    stencil straddles such a corner are left out (a fraction of a percent of
    a zig-zag; nothing is left out when the corners are not isolated).
``savgol``
    Savitzky-Golay filtering of the states and their first derivative
    (local polynomial fit), for noisy records.

``auto`` picks ``savgol`` when the record's high-frequency content shows
sensor noise, ``central`` otherwise.

These estimators need no ship model. The extended Kalman filter, which can
use the manoeuvring model as its process model, lives one layer up in
:mod:`studies.identification.kalman`; its ``estimate_derivatives`` accepts every
method of this module and ``"ekf"`` / ``"ekf_kinematic"`` besides.

References
----------
Savitzky, A., Golay, M.J.E. (1964). Smoothing and differentiation of data by
simplified least squares procedures. Analytical Chemistry 36(8), 1627-1639.
doi:10.1021/ac60214a047
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .resample import uniform_step

__all__ = ["DerivativeEstimate", "estimate_derivatives", "noise_ratio", "choose_window",
           "MODEL_FREE_METHODS", "STATE_COLUMNS"]


def savgol_filter(*args, **kwargs):
    """:func:`scipy.signal.savgol_filter`, imported on first use (importing
    ``scipy.signal`` loads ``scipy.stats``: 1-2 s a run without measured
    records does not need)."""
    from scipy.signal import savgol_filter as _savgol_filter
    return _savgol_filter(*args, **kwargs)


#: the velocities whose time derivatives are estimated
STATE_COLUMNS = ("u", "v", "r")
#: estimators of this module (``method=`` of :func:`estimate_derivatives`)
MODEL_FREE_METHODS = ("auto", "central", "savgol", "forward", "recorded")


@dataclass(frozen=True)
class DerivativeEstimate:
    """States and their time derivatives on the rows that were kept.

    Attributes
    ----------
    index : ndarray of int
        Rows of the record the estimate covers (end rows are dropped where
        the stencil does not fit).
    states : dict of ndarray
        Possibly smoothed ``u, v, r, delta, psi`` on those rows.
    rates : dict of ndarray
        ``u_dot`` [m/s^2], ``v_dot`` [m/s^2], ``r_dot`` [rad/s^2].
    method : str
        Estimator actually used.
    """

    index: np.ndarray
    states: dict
    rates: dict
    method: str


def noise_ratio(x: np.ndarray) -> float:
    """Roughness of a signal: std of its third difference over its std.

    A smooth signal sampled finely has tiny third differences; white noise
    of standard deviation s has third differences of std ``sqrt(20) s``.
    """
    x = np.asarray(x, float)
    scale = np.std(x)
    if scale == 0:
        return 0.0
    return float(np.std(np.diff(x, 3)) / (np.sqrt(20.0) * scale))


#: Savitzky-Golay windows tried by :func:`choose_window` [s]
WINDOWS = (2.0, 4.0, 6.0, 8.0, 11.0, 15.0, 20.0, 30.0)


def choose_window(signals, dt: float, polyorder: int = 3, tolerance: float = 1.02) -> int:
    """Savitzky-Golay window (odd number of samples) by the discrepancy principle.

    The noise standard deviation ``s`` of each signal is estimated from its
    third difference (white noise of std s gives third differences of std
    ``sqrt(20) s``, a smooth signal almost none). Smoothing with a growing
    window removes more and more of the noise, so the part it removes grows
    towards ``s``; past the right window it starts removing signal too and
    grows beyond ``s``. The window is the largest of :data:`WINDOWS` (at
    least 11 samples) that removes no more than ``tolerance * s`` from any
    signal.
    """
    lengths = []
    for w in WINDOWS:
        n = max(11, int(round(w / dt)))
        lengths.append(n + 1 - n % 2)
    chosen = lengths[-1]
    for x in signals:
        x = np.asarray(x, float)
        sigma = np.std(np.diff(x, 3)) / np.sqrt(20.0)
        best = lengths[0]
        for n in lengths:
            if n >= len(x):
                break
            removed = np.std(x - savgol_filter(x, n, polyorder, mode="interp"))
            if removed > tolerance * sigma:
                break
            best = n
        chosen = min(chosen, best)
    return chosen


#: a corner is a second difference of the rudder above this fraction of the largest one
CORNER_FRACTION = 0.1
#: corners are only left out when they concern at most this fraction of the rows
MAX_CORNER_ROWS = 0.05


def _near_rudder_corners(delta: np.ndarray, reach: int = 3) -> np.ndarray:
    """Rows within ``reach`` samples of an isolated corner of the rudder signal."""
    second = np.abs(np.diff(delta, 2))
    top = second.max() if len(second) else 0.0
    near = np.zeros(len(delta), dtype=bool)
    if top < 1e-9:
        return near
    corners = np.flatnonzero(second > CORNER_FRACTION * top) + 1
    for k in corners:
        near[max(0, k - reach):k + reach + 1] = True
    if near.mean() > MAX_CORNER_ROWS:
        near[:] = False
    return near


def estimate_derivatives(record, method: str = "auto", window: float | None = None,
                         polyorder: int = 3) -> DerivativeEstimate:
    """Estimate ``u_dot, v_dot, r_dot`` of a uniformly sampled record.

    Parameters
    ----------
    record : DataFrame
        Data contract record (t, u, v, r, delta, psi, ...), uniformly
        sampled (see :mod:`studies.data.resample`).
    method : {"auto", "central", "savgol", "forward", "recorded"}
        ``"recorded"`` takes the record's own ``u_dot, v_dot, r_dot`` columns
        (e.g. a smoother's estimates), every row.
    window : float or "auto", optional
        Savitzky-Golay window [s]; default 4 s or 11 samples, whichever is
        longer; ``"auto"`` chooses it per record by the discrepancy principle
        (:func:`choose_window`).
    polyorder : int
        Savitzky-Golay polynomial order.
    """
    t = record["t"].to_numpy(float)
    cols = {c: record[c].to_numpy(float) for c in ("u", "v", "r", "delta", "psi")}
    if method == "recorded":
        missing = [c + "_dot" for c in STATE_COLUMNS if c + "_dot" not in record]
        if missing:
            raise ValueError(f"derivative method 'recorded' needs the columns {missing} in the record")
        index = np.arange(len(t))
        index = index[~_near_rudder_corners(cols["delta"])]
        return DerivativeEstimate(index, {c: x[index] for c, x in cols.items()},
                                  {c + "_dot": record[c + "_dot"].to_numpy(float)[index]
                                   for c in STATE_COLUMNS}, "recorded")
    dt = uniform_step(t)
    if method == "auto":
        method = "savgol" if max(noise_ratio(cols[c]) for c in STATE_COLUMNS) > 1e-3 else "central"
    n = len(t)
    if method == "forward":
        if n < 2:
            raise ValueError("forward differences need at least 2 samples")
        index = np.arange(n - 1)
        rates = {c + "_dot": (cols[c][index + 1] - cols[c][index]) / dt for c in STATE_COLUMNS}
        states = {c: x[index] for c, x in cols.items()}
        return DerivativeEstimate(index, states, rates, "forward")
    if method == "central":
        if n < 5:
            raise ValueError("central differences need at least 5 samples")
        index = np.arange(2, n - 2)
        index = index[~_near_rudder_corners(cols["delta"])[2:-2]]
        rates = {}
        for c in STATE_COLUMNS:
            x = cols[c]
            rates[c + "_dot"] = (x[index - 2] - 8.0 * x[index - 1] + 8.0 * x[index + 1]
                                 - x[index + 2]) / (12.0 * dt)
        states = {c: x[index] for c, x in cols.items()}
        return DerivativeEstimate(index, states, rates, "central")
    if method == "savgol":
        if window is None:
            length = max(11, int(round(4.0 / dt)))
        elif window == "auto":
            length = choose_window([cols[c] for c in STATE_COLUMNS], dt, polyorder)
        else:
            length = int(round(window / dt))
        length = min(length, n if n % 2 else n - 1)
        length += 1 - length % 2
        if length <= polyorder + 1:
            raise ValueError("record too short for the Savitzky-Golay window")
        half = length // 2
        index = np.arange(half, n - half)
        states, rates = {}, {}
        for c, x in cols.items():
            smooth = savgol_filter(x, length, polyorder, mode="interp")
            states[c] = smooth[index]
            if c in STATE_COLUMNS:
                rates[c + "_dot"] = savgol_filter(x, length, polyorder, deriv=1, delta=dt,
                                                  mode="interp")[index]
        return DerivativeEstimate(index, states, rates, "savgol")
    raise ValueError(f"unknown derivative method '{method}' (auto, central, savgol; the "
                     "Kalman estimators are studies.identification.kalman.estimate_derivatives)")
