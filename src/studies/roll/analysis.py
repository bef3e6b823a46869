"""Roll-decay analysis: peaks, decay curves, equivalent linear damping, errors.

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
using an intelligent machine learning method. Ocean Engineering 191, 106479
(MAE and RMSE: eq. 17-18; prediction error: eq. 19; Figs 5 and 8).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

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
    "mae",
    "rmse",
    "compare_simulation_with_tests",
    "plot_prediction",
    "plot_decay_curves",
    "plot_simulation_vs_tests",
]


# ------------------------------------------------------------------ errors
def mae(measured, predicted) -> float:
    """Mean absolute error (Chen et al. 2019, eq. 17), in the units of the input."""
    m = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    return float(np.mean(np.abs(m - p)))


def rmse(measured, predicted) -> float:
    """Root-mean-square error (Chen et al. 2019, eq. 18), in the units of the input."""
    m = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    return float(np.sqrt(np.mean((m - p) ** 2)))


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


# ----------------------------------------------- simulation vs measurement
def compare_simulation_with_tests(simulation, tests: Sequence, reference_amplitude: float | None = None,
                                  terms: Sequence[str] = ("b1", "b2"),
                                  scale_note: str = "model scale",
                                  inertia: float | None = None,
                                  figure_path: str | None = None,
                                  labels: Sequence[str] | None = None) -> tuple[dict[str, float], dict]:
    """Compare the damping of a simulated decay with measured decays at one scale.

    Both must already be at the same scale (angles are scale-free; periods and
    damping coefficients with units are not, ``zeta`` is).

    Parameters
    ----------
    simulation : DataFrame
        Prepared simulated decay (``t`` [s], ``phi`` [rad]).
    tests : sequence of DataFrame
        Prepared measured decays of the same condition; their half-cycles are pooled.
    reference_amplitude : float, optional
        Amplitude [rad] at which the equivalent damping is compared. Default:
        the middle of the amplitude range covered by both.
    terms : sequence of str
        Damping terms of the decay-curve fits.
    scale_note : str
        Text for the figure saying at which scale the comparison is made.
    inertia : float, optional
        Total roll inertia [kg m^2] at the scale wanted for a dimensional
        missing damping ``missing_B44_eq`` [kg m^2/s] (= 2 omega0 I d zeta).
    figure_path : str, optional
        Where to write the PNG (decay curves and time series).
    labels : sequence of str, optional
        Names of the measured records (legend).

    Returns
    -------
    metrics : dict
        ``simulation/zeta_eq``, ``measured/zeta_eq`` (decay-curve fits at the
        reference amplitude), ``simulation/zeta_overlap``, ``measured/zeta_overlap``
        (linear fit of the half-cycles in the common amplitude range),
        ``simulation/b_eq_1_s``, ``measured/b_eq_1_s``, ``simulation/missing_zeta``
        (absolute), ``simulation/missing_damping_pct`` (of the measured),
        ``simulation/period_s``, ``measured/period_s``,
        ``reference_amplitude_deg``, and the decay-curve coefficients.
    details : dict
        Decay curves and fits, for reports.
    """
    from studies.roll.model import damping_ratio, equivalent_linear_damping

    c_sim = decay_curve(simulation)
    curves_m = [decay_curve(r) for r in tests]
    c_meas = pd.concat(curves_m, ignore_index=True)
    if len(c_sim) < 2 or len(c_meas) < 2:
        raise ValueError("too few half-cycles to compare decays")
    lo = max(c_sim["amplitude"].min(), c_meas["amplitude"].min())
    hi = min(c_sim["amplitude"].max(), c_meas["amplitude"].max())
    if reference_amplitude is None:
        reference_amplitude = 0.5 * (lo + hi) if hi > lo else float(c_meas["amplitude"].median())
    fit_sim = fit_decay_curve(c_sim, terms)
    fit_meas = fit_decay_curve(c_meas, terms)
    a = float(reference_amplitude)
    z_sim = damping_ratio(fit_sim, a)
    z_meas = damping_ratio(fit_meas, a)
    zo_sim = zeta_from_curve(c_sim, lo, hi) if hi > lo else float("nan")
    zo_meas = zeta_from_curve(c_meas, lo, hi) if hi > lo else float("nan")
    m = {
        "reference_amplitude_deg": math.degrees(a),
        "overlap_amplitude_min_deg": math.degrees(lo),
        "overlap_amplitude_max_deg": math.degrees(hi),
        "simulation/zeta_eq": z_sim,
        "measured/zeta_eq": z_meas,
        "simulation/zeta_overlap": zo_sim,
        "measured/zeta_overlap": zo_meas,
        "simulation/b_eq_1_s": equivalent_linear_damping(fit_sim, a),
        "measured/b_eq_1_s": equivalent_linear_damping(fit_meas, a),
        "simulation/period_s": 2 * math.pi / fit_sim["omega0"],
        "measured/period_s": 2 * math.pi / fit_meas["omega0"],
        "simulation/missing_zeta": z_meas - z_sim,
        "simulation/missing_damping_pct": 100.0 * (z_meas - z_sim) / z_meas,
        "simulation/missing_zeta_overlap": zo_meas - zo_sim,
        "simulation/missing_damping_overlap_pct": 100.0 * (zo_meas - zo_sim) / zo_meas,
    }
    for k, v in fit_sim.items():
        m[f"simulation/decay_curve_{k}"] = v
    for k, v in fit_meas.items():
        m[f"measured/decay_curve_{k}"] = v
    if inertia is not None:
        w0 = fit_meas["omega0"]
        m["simulation/missing_B44_eq_kgm2_s"] = 2.0 * w0 * float(inertia) * (z_meas - z_sim)
    details = {"curve_simulation": c_sim, "curves_measured": curves_m, "fit_simulation": fit_sim,
               "fit_measured": fit_meas, "reference_amplitude": a, "overlap": (lo, hi)}
    if figure_path is not None:
        plot_simulation_vs_tests(simulation, tests, details, figure_path, scale_note=scale_note,
                                 labels=labels)
    return m, details


# ------------------------------------------------------------------- plots
def _figure(nrows: int, ncols: int = 1, figsize=(8.0, 6.0)):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, constrained_layout=True)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def plot_prediction(t, measured, predictions: Mapping[str, np.ndarray], path: str,
                    title: str | None = None) -> str:
    """Prediction and error figure like Chen et al. (2019), Figs 5(b) and 8.

    Parameters
    ----------
    t : array_like
        Time [s].
    measured : array_like
        Measured roll angle [rad].
    predictions : mapping label -> array
        Predicted roll angles [rad] at ``t``.
    path : str
        PNG file to write.
    title : str, optional
        Figure title.

    Returns
    -------
    str
        ``path``.
    """
    t = np.asarray(t, float)
    meas = np.degrees(np.asarray(measured, float))
    fig, ax = _figure(2, 1, (9.0, 6.5))
    ax[0, 0].plot(t, meas, color="k", lw=1.6, label="measured")
    for lab, p in predictions.items():
        ax[0, 0].plot(t, np.degrees(np.asarray(p, float)), lw=0.9, label=lab)
        ax[1, 0].plot(t, meas - np.degrees(np.asarray(p, float)), lw=0.8, label=lab)
    ax[0, 0].set_ylabel("roll angle [deg]")
    ax[0, 0].legend(loc="upper right", fontsize=8)
    ax[0, 0].set_title("(a) measured and predicted roll" if title is None else f"(a) {title}")
    ax[1, 0].axhline(0.0, color="k", lw=0.5)
    ax[1, 0].set_xlabel("t [s]")
    ax[1, 0].set_ylabel("error = measured - predicted [deg]")
    ax[1, 0].set_title("(b) prediction error (Chen et al. 2019, eq. 19)")
    ax[1, 0].legend(loc="upper right", fontsize=8)
    fig.savefig(path, dpi=110)
    return str(path)


def plot_decay_curves(curves: Mapping[str, pd.DataFrame], path: str,
                      models: Mapping[str, Mapping[str, float]] | None = None,
                      title: str | None = None) -> str:
    """Decay curves (decrement against mean amplitude, both in degrees).

    Parameters
    ----------
    curves : mapping label -> DataFrame
        Outputs of :func:`decay_curve`.
    path : str
        PNG file to write.
    models : mapping label -> params, optional
        Identified models whose decay curve ``pi zeta_eq(A) A`` is drawn.
    title : str, optional
        Figure title.

    Returns
    -------
    str
        ``path``.
    """
    from studies.roll.model import damping_ratio

    fig, ax = _figure(1, 1, (7.5, 5.0))
    a = ax[0, 0]
    amax = 0.0
    for lab, c in curves.items():
        a.plot(np.degrees(c["amplitude"]), np.degrees(c["decrement"]), "o", ms=3, label=lab)
        if len(c):
            amax = max(amax, float(c["amplitude"].max()))
    if models:
        A = np.linspace(0.0, amax if amax > 0 else math.radians(10), 100)
        for lab, p in models.items():
            a.plot(np.degrees(A), np.degrees(math.pi * damping_ratio(p, A) * A), lw=1.2, label=lab)
    a.set_xlabel("mean amplitude of the half-cycle [deg]")
    a.set_ylabel("decrement per half-cycle [deg]")
    a.set_title(title or "roll decay curves")
    a.grid(alpha=0.3)
    a.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    return str(path)


def plot_simulation_vs_tests(simulation, tests: Sequence, details: dict, path: str,
                             scale_note: str = "model scale", labels: Sequence[str] | None = None) -> str:
    """Figure of the simulation-vs-test comparison: time series and decay curves.

    Parameters
    ----------
    simulation : DataFrame
        Prepared simulated decay.
    tests : sequence of DataFrame
        Prepared measured decays.
    details : dict
        Second output of :func:`compare_simulation_with_tests`.
    path : str
        PNG file to write.
    scale_note : str
        Scale at which both are shown.
    labels : sequence of str, optional
        Names of the measured records.

    Returns
    -------
    str
        ``path``.
    """
    from studies.roll.model import damping_ratio

    labels = list(labels) if labels is not None else [f"test {i + 1}" for i in range(len(tests))]
    fig, ax = _figure(2, 1, (9.0, 8.0))
    a0 = ax[0, 0]
    for lab, r in zip(labels, tests):
        a0.plot(r["t"], np.degrees(r["phi"]), lw=0.7, label=f"model test {lab}")
    a0.plot(simulation["t"], np.degrees(simulation["phi"]), lw=0.7, color="k", label="potential flow (FNPF)")
    a0.set_xlabel(f"t after release [s] ({scale_note})")
    a0.set_ylabel("roll angle [deg]")
    a0.set_title("(a) free roll decay: model tests vs inviscid simulation")
    a0.legend(fontsize=8, loc="upper right")
    a1 = ax[1, 0]
    for lab, c in zip(labels, details["curves_measured"]):
        a1.plot(np.degrees(c["amplitude"]), np.degrees(c["decrement"]), "o", ms=3, label=f"model test {lab}")
    cs = details["curve_simulation"]
    a1.plot(np.degrees(cs["amplitude"]), np.degrees(cs["decrement"]), "s", ms=3, color="k",
            label="potential flow (FNPF)")
    amax = max(float(cs["amplitude"].max()), max(float(c["amplitude"].max()) for c in details["curves_measured"]))
    A = np.linspace(0.0, amax, 100)
    for lab, p, col in (("fit, model tests", details["fit_measured"], "C3"),
                        ("fit, FNPF", details["fit_simulation"], "k")):
        a1.plot(np.degrees(A), np.degrees(math.pi * damping_ratio(p, A) * A), color=col, lw=1.2, label=lab)
    ref = details["reference_amplitude"]
    a1.axvline(math.degrees(ref), color="grey", ls="--", lw=0.8, label="reference amplitude")
    a1.set_xlabel("mean amplitude of the half-cycle [deg]")
    a1.set_ylabel("decrement per half-cycle [deg]")
    a1.set_title(f"(b) decay curves ({scale_note})")
    a1.grid(alpha=0.3)
    a1.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    return str(path)
