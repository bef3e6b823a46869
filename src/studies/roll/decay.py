"""Decay analysis: extrema, period, noise level and the decay curve of a free roll decay.

Functions here work on plain arrays or on prepared decay records (a
``DataFrame`` with columns ``t`` [s] and ``phi`` [rad], released at ``t = 0``
and centred on the equilibrium; see :mod:`studies.roll.records`).

The decay curve is the classic Froude representation of a free decay: for
successive absolute extrema ``A_k`` (half-cycles) the decrement
``dA_k = A_k - A_{k+1}`` against the mean amplitude ``A_m = (A_k + A_{k+1})/2``.
For the model ``phi'' + b1 phi' + b2 |phi'| phi' + b3 phi'^3 + omega0^2 phi = 0``
an energy balance over a half-cycle gives

    dA = pi zeta_eq(A_m) A_m,   zeta_eq = b_eq / (2 omega0),
    b_eq(A) = b1 + 8/(3 pi) omega0 A b2 + 3/4 omega0^2 A^2 b3,

so that ``dA = (pi b1 / (2 omega0)) A_m + (4/3) b2 A_m^2 + (3 pi/8) omega0 b3 A_m^3``:
a linear least-squares fit of the decay curve gives ``b1, b2, b3`` directly
(used as the initial guess of the NLS method: "log decrement").

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd

__all__ = [
    "Extrema",
    "noise_std",
    "find_extrema",
    "estimate_period",
    "decay_curve",
    "fit_decay_curve",
    "zeta_from_curve",
]


# ------------------------------------------------------------------- peaks
@dataclass
class Extrema:
    """Alternating extrema of an oscillation (one per half-cycle).

    Attributes
    ----------
    index : ndarray of int
        Sample index of each extremum.
    t : ndarray
        Time of each extremum [s], refined by a local quadratic fit.
    value : ndarray
        Signed value of each extremum relative to the centre, refined likewise.
    centre : float
        Centre the extrema were taken about.
    hysteresis : float
        Dead band used to detect the zero crossings.
    """

    index: np.ndarray
    t: np.ndarray
    value: np.ndarray
    centre: float
    hysteresis: float

    @property
    def amplitude(self) -> np.ndarray:
        """Absolute amplitudes ``|value|``."""
        return np.abs(self.value)

    def __len__(self) -> int:
        return int(self.index.size)


def noise_std(y) -> float:
    """Robust estimate of white measurement noise from second differences.

    For a smooth, finely sampled signal plus white noise of standard deviation
    ``s`` the second difference has standard deviation ``sqrt(6) s``; the median
    absolute deviation makes the estimate insensitive to the signal.
    """
    y = np.asarray(y, dtype=float)
    if y.size < 5:
        return 0.0
    d2 = np.diff(y, 2)
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(1.4826 * mad / math.sqrt(6.0))


def _refine(t, y, i, half_width, sign):
    """Vertex of a least-squares parabola through ``y`` around sample ``i``."""
    n = y.size
    lo, hi = max(0, i - half_width), min(n, i + half_width + 1)
    if hi - lo < 3:
        return t[i], y[i]
    tt = t[lo:hi] - t[i]
    c = np.polyfit(tt, y[lo:hi], 2)
    if sign * c[0] >= 0:  # not a proper extremum shape
        return t[i], y[i]
    tv = float(np.clip(-c[1] / (2 * c[0]), tt[0], tt[-1]))  # a peak at the record's start stays there
    return t[i] + tv, float(np.polyval(c, tv))


def find_extrema(t, y, centre: float = 0.0, hysteresis: float | None = None,
                 refine_half_width: int | None = None) -> Extrema:
    """Alternating extrema of an oscillation about ``centre``.

    Zero crossings are detected with a dead band (hysteresis) so that noise
    near the centre does not create spurious half-cycles; in each half-cycle
    the extremum is the sample furthest from the centre, refined by a local
    least-squares parabola. An extremum at the very first sample is kept (a
    record that starts at the release); a last half-cycle whose extremum is the
    last sample (cut off by the end of the record) is dropped.

    Parameters
    ----------
    t : array_like
        Times [s], increasing.
    y : array_like
        Signal (e.g. roll angle [rad]).
    centre : float
        Value about which the signal oscillates.
    hysteresis : float, optional
        Dead band half-width. Default ``max(0.02 max|y - centre|, 4 noise_std(y))``.
    refine_half_width : int, optional
        Half-width in samples of the parabola fit; default a tenth of the
        median half-cycle (at least 1): the fitted vertex is then within 0.05 %
        of the peak of a sinusoid (a common factor on all extrema) and
        averages the noise over about a tenth of a period.

    Returns
    -------
    Extrema
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    z = y - centre
    amax = float(np.max(np.abs(z))) if z.size else 0.0
    if hysteresis is None:
        hysteresis = max(0.02 * amax, 4.0 * noise_std(y))
    h = float(hysteresis)
    empty = Extrema(np.zeros(0, int), np.zeros(0), np.zeros(0), float(centre), h)
    if amax <= h or z.size < 3:
        return empty
    s = np.where(z > h, 1, np.where(z < -h, -1, 0))
    nz = np.flatnonzero(s)
    if nz.size == 0:
        return empty
    sv = s[nz]
    change = np.flatnonzero(np.diff(sv) != 0) + 1
    starts = np.concatenate(([0], nz[change]))  # first segment starts at sample 0
    ends = np.concatenate((nz[change], [z.size]))
    signs = np.concatenate(([sv[0]], sv[change]))
    idx = []
    for a, b, sg in zip(starts, ends, signs):
        seg = sg * z[a:b]
        idx.append(a + int(np.argmax(seg)))
    idx = np.asarray(idx, dtype=int)
    signs = np.asarray(signs, dtype=int)
    if idx.size and idx[-1] == z.size - 1 and idx.size > 1:
        idx, signs = idx[:-1], signs[:-1]
    if refine_half_width is None:
        if idx.size > 2:
            half = float(np.median(np.diff(idx)))
            refine_half_width = max(1, int(round(half / 10.0)))
        else:
            refine_half_width = 1
    tv = np.empty(idx.size)
    vv = np.empty(idx.size)
    for k, (i, sg) in enumerate(zip(idx, signs)):
        if i == 0:
            tv[k], vv[k] = t[0], z[0]
        else:
            tv[k], vv[k] = _refine(t, z, int(i), int(refine_half_width), int(sg))
    return Extrema(idx, tv, vv, float(centre), h)


def estimate_period(t, y, centre: float = 0.0) -> float:
    """Oscillation period [s] from the spacing of alternating extrema (twice the median half-cycle).

    Returns ``nan`` when fewer than three extrema are found.
    """
    ex = find_extrema(t, y, centre)
    if len(ex) < 3:
        return float("nan")
    return float(2.0 * np.median(np.diff(ex.t)))


# ------------------------------------------------------------- decay curve
def _record_arrays(record) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(record, pd.DataFrame):
        return record["t"].to_numpy(float), record["phi"].to_numpy(float)
    t, phi = record
    return np.asarray(t, float), np.asarray(phi, float)


def decay_curve(record, centre: float = 0.0) -> pd.DataFrame:
    """Decay curve of a free decay: decrement per half-cycle against mean amplitude.

    Parameters
    ----------
    record : DataFrame or (t, phi)
        Decay record, ``t`` [s], ``phi`` [rad], centred on equilibrium.
    centre : float
        Equilibrium angle [rad] (0 for a prepared record).

    Returns
    -------
    DataFrame
        One row per half-cycle: ``t`` [s] (mid time), ``amplitude`` [rad]
        (mean of the two extrema), ``decrement`` [rad], ``delta`` (logarithmic
        decrement per half-cycle) [-], ``zeta`` = delta / sqrt(pi^2 + delta^2) [-],
        ``half_period`` [s].
    """
    t, phi = _record_arrays(record)
    ex = find_extrema(t, phi, centre)
    a = ex.amplitude
    if a.size < 2:
        return pd.DataFrame(columns=["t", "amplitude", "decrement", "delta", "zeta", "half_period"])
    a0, a1 = a[:-1], a[1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.log(a0 / a1)
    return pd.DataFrame({
        "t": 0.5 * (ex.t[:-1] + ex.t[1:]),
        "amplitude": 0.5 * (a0 + a1),
        "decrement": a0 - a1,
        "delta": delta,
        "zeta": delta / np.sqrt(np.pi**2 + delta**2),
        "half_period": np.diff(ex.t),
    })


def fit_decay_curve(curve: pd.DataFrame, terms: Sequence[str] = ("b1", "b2"),
                    omega0: float | None = None) -> dict[str, float]:
    """Damping coefficients from a decay curve by linear least squares.

    Fits ``dA = (pi b1/(2 omega0)) A + (4/3) b2 A^2 + (3 pi/8) omega0 b3 A^3``
    (only the damping terms in ``terms``).

    Parameters
    ----------
    curve : DataFrame
        Output of :func:`decay_curve`.
    terms : sequence of str
        Damping terms to fit (``b1``, ``b2``, ``b3``; others ignored).
    omega0 : float, optional
        Natural frequency [rad/s]; default from the median half period,
        corrected for damping, ``omega0 = omega_d / sqrt(1 - zeta^2)``.

    Returns
    -------
    dict
        ``omega0`` [rad/s] and the fitted damping coefficients.
    """
    c = curve.replace([np.inf, -np.inf], np.nan).dropna()
    if len(c) < 2:
        raise ValueError("decay curve has fewer than two half-cycles")
    if omega0 is None:
        wd = math.pi / float(np.median(c["half_period"]))
        z = float(np.clip(np.median(c["zeta"]), 0.0, 0.9))
        omega0 = wd / math.sqrt(1.0 - z * z)
    A = c["amplitude"].to_numpy(float)
    cols, names = [], []
    if "b1" in terms:
        cols.append(math.pi / (2 * omega0) * A)
        names.append("b1")
    if "b2" in terms:
        cols.append(4.0 / 3.0 * A**2)
        names.append("b2")
    if "b3" in terms:
        cols.append(3 * math.pi / 8 * omega0 * A**3)
        names.append("b3")
    out = {"omega0": float(omega0)}
    if cols:
        X = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(X, c["decrement"].to_numpy(float), rcond=None)
        out.update({n: float(v) for n, v in zip(names, coef)})
    return out


def zeta_from_curve(curve: pd.DataFrame, lo: float = -np.inf, hi: float = np.inf) -> float:
    """Equivalent linear damping ratio of the half-cycles with mean amplitude in [lo, hi] [rad].

    Least-squares slope through the origin of ``decrement`` against
    ``pi * amplitude`` (i.e. a purely linear model fitted to that part of the
    decay), ``nan`` when no half-cycle qualifies.
    """
    c = curve[(curve["amplitude"] >= lo) & (curve["amplitude"] <= hi)]
    if len(c) == 0:
        return float("nan")
    x = math.pi * c["amplitude"].to_numpy(float)
    y = c["decrement"].to_numpy(float)
    return float(np.dot(x, y) / np.dot(x, x))
