"""Roll-decay records: loading, release detection, offset removal, resampling, refusal, scaling.

Formats read (CSV, one row per sample):

- the data contract: ``t`` [s], ``phi`` [rad];
- SSPA model tests (``../shared/data/kvlcc2_roll_decay/model_test_*.csv``):
  ``time`` [s, model scale], ``phi`` [rad] (other columns ignored);
- the fully non-linear potential-flow simulation
  (``fnpf_kvlcc2_rolldecay_0kn.csv``): ``Time`` [s], ``phi`` [rad].

:func:`load_roll_decay` returns a *prepared* record: a ``DataFrame`` with
``t`` [s] starting at 0 at the release instant and ``phi`` [rad] about the
equilibrium, on a uniform time step. Metadata are in ``DataFrame.attrs``
(``file``, ``name``, ``t_release``, ``offset``, ``dt``, ``period``,
``n_extrema``, and ``speed`` [m/s] when the record says it). Every refused input raises :class:`studies.errors.DataError`
naming the file and the reason. :func:`initial_state` estimates the state a
record starts from (:func:`initial_state_covariance` also the error of that
estimate); :func:`froude_scale_record` brings a record's time to
another geometric scale; :func:`find_particulars` reads the ship particulars
filed beside a record; :func:`split_cycles` cuts a decay into its first and
its later cycles (a single record's time-blocked hold-out).

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479
(free decay tests, Section 4.3: the model is held at an initial angle and
released).
"""

from __future__ import annotations

import math
import logging
import re
from pathlib import Path

import numpy as np
import pandas as pd

from studies.data.resample import resample, uniform_grid
from studies.errors import DataError
from studies.roll.decay import find_extrema, noise_std

__all__ = [
    "read_roll_decay_csv",
    "find_release",
    "estimate_offset",
    "resample_uniform",
    "prepare_decay",
    "load_roll_decay",
    "read_model_test_parameters",
    "read_fnpf_parameters",
    "find_particulars",
    "initial_state",
    "initial_state_covariance",
    "froude_scale_record",
    "record_speed",
    "record_vessel",
    "split_cycles",
]

log = logging.getLogger(__name__)

_TIME_COLUMNS = ("t", "time", "Time")
_MAX_ROLL_RAD = math.pi / 2  # a roll record beyond 90 deg is in degrees, not radians
MIN_SAMPLES = 20


# -------------------------------------------------------------------- read
def read_roll_decay_csv(path) -> pd.DataFrame:
    """Read a raw roll record (any of the supported formats) and check the contract.

    Parameters
    ----------
    path : str or Path
        CSV file with a time column (``t``, ``time`` or ``Time``) [s] and ``phi`` [rad].

    Returns
    -------
    DataFrame
        Columns ``t`` [s] and ``phi`` [rad], as in the file.

    Raises
    ------
    DataError
        Missing file or column, non-numeric values, NaN, time not increasing,
        angles that look like degrees, or too few samples.
    """
    file = str(path)
    p = Path(path)
    if not p.is_file():
        raise DataError(file, "file not found")
    try:
        raw = pd.read_csv(p)
    except Exception as exc:  # pandas raises several types
        raise DataError(file, f"cannot be read as CSV ({exc.__class__.__name__}: {exc})") from None
    cols = [str(c).strip() for c in raw.columns]
    raw.columns = cols
    tcol = next((c for c in _TIME_COLUMNS if c in cols), None)
    if tcol is None:
        raise DataError(file, "no time column (expected one of 't', 'time', 'Time')", column="t")
    if "phi" not in cols:
        raise DataError(file, "no roll angle column", column="phi")
    out = {}
    for src, dst in ((tcol, "t"), ("phi", "phi")):
        vals = pd.to_numeric(raw[src], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:
            raise DataError(file, "NaN, missing or non-numeric value", column=src, row=int(bad[0]))
        out[dst] = vals
    t, phi = out["t"], out["phi"]
    speed = _speed_column(raw) if "speed" in cols else None
    if t.size < MIN_SAMPLES:
        raise DataError(file, f"too few samples ({t.size}, need at least {MIN_SAMPLES})")
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        raise DataError(file, "time is not increasing", column=tcol, row=int(bad[0] + 1))
    big = np.flatnonzero(np.abs(phi) > _MAX_ROLL_RAD)
    if big.size:
        raise DataError(file, f"roll angle {phi[big[0]]:g} exceeds 90 deg in radians: "
                              "looks like degrees, radians expected", column="phi", row=int(big[0]))
    df = pd.DataFrame({"t": t, "phi": phi})
    if speed is not None:
        df.attrs["speed"] = speed
    return df


def _speed_column(raw: pd.DataFrame) -> float | None:
    """Median of a ``speed`` column [m/s] (forward speed of the decay), None when not numeric."""
    vals = pd.to_numeric(raw["speed"], errors="coerce").to_numpy(dtype=float)
    vals = vals[np.isfinite(vals)]
    return float(np.median(vals)) if vals.size else None


# ---------------------------------------------------------- preprocessing
def find_release(t, phi, file: str = "<array>", min_peaks: int = 3) -> int:
    """Index of the release instant of a free decay.

    The release is the first extremum within 2 % of the largest one (the
    model is heeled to about 10 deg and let go: the first peak after which
    the signal oscillates with decaying amplitude; in the SSPA tests the model
    is swung over in about a second rather than held). When the model was
    held still at that angle (a plateau longer than a quarter of a
    half-period), the last sample still at the held angle is returned.
    Extrema are found with a dead band about the tail's median, so the part
    before the heeling (at rest, below the dead band) is skipped.

    Parameters
    ----------
    t, phi : ndarray
        Time [s] and roll angle [rad].
    file : str
        File name used in error messages.
    min_peaks : int
        Least number of extrema required after the release.

    Returns
    -------
    int
        Sample index of the release.

    Raises
    ------
    DataError
        Constant signal, no oscillation, growing amplitude, fewer than
        ``min_peaks`` extrema after the release, irregular (noise-like) or
        non-decaying oscillation.
    """
    t = np.asarray(t, float)
    phi = np.asarray(phi, float)
    span = float(np.ptp(phi))
    if span < 1e-6:
        raise DataError(file, "roll angle is constant: not a decay (no oscillation)", column="phi")
    n = phi.size
    c0 = float(np.median(phi[int(0.75 * n):]))  # equilibrium estimate: tail of the decay
    noise = noise_std(phi)
    ex = find_extrema(t, phi, c0)
    if len(ex) < 2:
        raise DataError(file, "no oscillation found: not a roll decay", column="phi")
    amp = ex.amplitude
    # the first extremum within 2 % of the largest: for a decay the largest itself,
    # for a steady or growing oscillation an early one, refused below
    k = int(np.flatnonzero(amp >= 0.98 * amp.max())[0])
    after = amp[k + 1:]
    if after.size < min_peaks:
        before = amp[:k + 1]
        if before.size >= min_peaks and np.all(np.diff(before[-min_peaks:]) > 0):
            raise DataError(file, "oscillation amplitude grows to the end of the record: not a decay",
                            column="phi")
        raise DataError(file, f"only {after.size} peaks after the release (need at least {min_peaks}): "
                              "not a roll decay", column="phi")
    if amp[k] < 10.0 * noise:
        raise DataError(file, f"oscillation amplitude {amp[k]:.3g} rad is not above the noise "
                              f"({noise:.3g} rad): not a roll decay", column="phi")
    seq = amp[k:]
    # regularity over the extrema that stand out of the noise (later ones are noise crossings);
    # the interval from a held plateau to the first extremum is not a half-period
    lost = np.flatnonzero(amp[k + 1:] < 5.0 * noise)
    end = k + 1 + (int(lost[0]) if lost.size else amp.size - k - 1)
    half = np.diff(ex.t[k + 1:end])
    if half.size >= 2:
        cv = float(np.std(half) / np.mean(half))
        if cv > 0.25:
            raise DataError(file, f"irregular oscillation (half-periods vary by {100 * cv:.0f} %): "
                                  "noise, not a roll decay", column="phi")
    slope = np.polyfit(np.arange(seq.size), np.log(seq), 1)[0]
    if slope >= 0 or seq[-1] >= seq[0]:
        raise DataError(file, "oscillation amplitude does not decay after the release: not a decay",
                        column="phi")
    # the sample nearest to the (parabola-refined) extremum
    i = int(np.clip(np.searchsorted(t, ex.t[k]), 0, n - 1))
    if i > 0 and abs(t[i - 1] - ex.t[k]) < abs(t[i] - ex.t[k]):
        i -= 1
    # plateau (model held still at the initial angle): take its last sample
    tol = max(4.0 * noise, 0.002 * amp[k], 1e-9)
    sgn = np.sign(ex.value[k])
    near = sgn * (phi - c0) >= amp[k] - tol
    j = int(ex.index[k])
    while j + 1 < n and near[j + 1]:
        j += 1
    lo = int(ex.index[k])
    while lo - 1 >= 0 and near[lo - 1]:
        lo -= 1
    half_period = float(np.median(half)) if half.size else float(np.median(np.diff(ex.t[k:])))
    if t[j] - t[lo] > 0.25 * half_period:  # much flatter than a dynamic peak: held, then let go
        # last sample still at the held angle (to within the noise): the release
        level = float(np.median(phi[lo:j + 1]))
        held = np.flatnonzero(np.abs(phi[lo:j + 1] - level) <= max(4.0 * noise, 1e-6 * amp[k]))
        i = lo + int(held[-1]) if held.size else j
    return i


def estimate_offset(t, phi, method: str = "centre") -> float:
    """Equilibrium (mean offset) of a decay that starts at the release.

    Parameters
    ----------
    t, phi : ndarray
        Time [s] and roll angle [rad], from the release on.
    method : {"centre", "tail"}
        ``"centre"``: median of the oscillation centres from three successive
        extrema, ``(e_k + 2 e_{k+1} + e_{k+2}) / 4``, which is unbiased to
        second order in the decrement; ``"tail"``: mean over the last whole
        periods (at least the last two, at most the last quarter of the record).

    Returns
    -------
    float
        Offset [rad].
    """
    t = np.asarray(t, float)
    phi = np.asarray(phi, float)
    c0 = float(np.median(phi[int(0.75 * phi.size):]))
    ex = find_extrema(t, phi, c0)
    e = ex.value + c0
    if method == "centre" and e.size >= 3:
        centres = (e[:-2] + 2 * e[1:-1] + e[2:]) / 4.0
        return float(np.median(centres))
    if method not in ("centre", "tail"):
        raise ValueError("method must be 'centre' or 'tail'")
    if ex.t.size >= 5:
        # the last even number of half-cycles: from an extremum to one of the same sign
        m = max(2, (ex.t.size // 4) // 2 * 2)
        lo, hi = ex.index[-1 - m], ex.index[-1]
        return float(np.mean(phi[lo:hi]))
    return c0


def resample_uniform(t, phi, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation on a uniform grid starting at ``t[0]``.

    Parameters
    ----------
    t, phi : ndarray
        Times [s] (increasing, possibly jittered) and values.
    dt : float, optional
        Step [s]; default the median sampling interval rounded to 1e-6 s.

    Returns
    -------
    tu, phiu : ndarray
        Uniform times and interpolated values.
    """
    t = np.asarray(t, float)
    phi = np.asarray(phi, float)
    if dt is None:
        dt = round(float(np.median(np.diff(t))), 6)
    tu = uniform_grid(t[0], t[-1], dt)
    return tu, resample(pd.DataFrame({"t": t, "phi": phi}), tu)["phi"].to_numpy()


def prepare_decay(raw: pd.DataFrame, file: str = "<data>", dt: float | None = None,
                  offset: str | float = "centre", max_duration: float | None = None,
                  min_peaks: int = 3) -> pd.DataFrame:
    """Cut a raw record at the release, remove the offset and resample uniformly.

    Parameters
    ----------
    raw : DataFrame
        Columns ``t`` [s] and ``phi`` [rad] (e.g. from :func:`read_roll_decay_csv`).
    file : str
        File name for error messages and ``attrs``.
    dt : float, optional
        Uniform time step [s]; default the median sampling interval.
    offset : {"centre", "tail"} or float
        How to estimate the equilibrium (see :func:`estimate_offset`), or its value [rad].
    max_duration : float, optional
        Keep at most this long after the release [s].
    min_peaks : int
        Least number of extrema after the release.

    Returns
    -------
    DataFrame
        Prepared record (``t`` from 0, ``phi`` about equilibrium) with ``attrs``.

    Raises
    ------
    DataError
        The record is not a decay (see :func:`find_release`).
    """
    t = raw["t"].to_numpy(float)
    phi = raw["phi"].to_numpy(float)
    if not np.all(np.isfinite(t)) or not np.all(np.isfinite(phi)):
        bad = int(np.flatnonzero(~(np.isfinite(t) & np.isfinite(phi)))[0])
        raise DataError(file, "NaN in the record", row=bad)
    if np.any(np.diff(t) <= 0):
        raise DataError(file, "time is not increasing", column="t",
                        row=int(np.flatnonzero(np.diff(t) <= 0)[0] + 1))
    i = find_release(t, phi, file=file, min_peaks=min_peaks)
    tr, pr = t[i:] - t[i], phi[i:]
    if max_duration is not None:
        keep = tr <= max_duration + 1e-12
        tr, pr = tr[keep], pr[keep]
    off = float(offset) if isinstance(offset, (int, float)) else estimate_offset(tr, pr, offset)
    tu, pu = resample_uniform(tr, pr - off, dt)
    ex = find_extrema(tu, pu, 0.0)
    if len(ex) < min_peaks + 1:
        raise DataError(file, f"fewer than {min_peaks} peaks after the release: not a roll decay",
                        column="phi")
    period = float(2.0 * np.median(np.diff(ex.t)))
    df = pd.DataFrame({"t": tu, "phi": pu})
    df.attrs.update({
        "file": str(file),
        "name": Path(str(file)).stem,
        "t_release": float(t[i]),
        "offset": off,
        "dt": float(tu[1] - tu[0]),
        "period": period,
        "n_extrema": int(len(ex)),
        "phi_release": float(pu[0]),
    })
    return df


def load_roll_decay(path, dt: float | None = None, offset: str | float = "centre",
                    max_duration: float | None = None, min_peaks: int = 3) -> pd.DataFrame:
    """Read and prepare a roll-decay CSV (data contract, SSPA model test or FNPF format).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    dt, offset, max_duration, min_peaks
        See :func:`prepare_decay`.

    Returns
    -------
    DataFrame
        Prepared record: ``t`` [s] from the release, ``phi`` [rad] about
        equilibrium, uniform step; ``attrs`` with ``file``, ``name``,
        ``t_release`` [s], ``offset`` [rad], ``dt`` [s], ``period`` [s],
        ``n_extrema``, ``phi_release`` [rad], ``particulars`` when
        :func:`find_particulars` finds them, and ``speed`` [m/s at the
        record's scale] when known (see :func:`record_speed`).

    Raises
    ------
    DataError
        Anything that is not a roll decay in the contract (see
        :func:`read_roll_decay_csv` and :func:`find_release`).
    """
    raw = read_roll_decay_csv(path)
    df = prepare_decay(raw, file=str(path), dt=dt, offset=offset, max_duration=max_duration,
                       min_peaks=min_peaks)
    part = find_particulars(path)
    if part is not None:
        df.attrs["particulars"] = part
    speed = record_speed(raw.attrs.get("speed"), part)
    if speed is not None:
        df.attrs["speed"] = speed
    return df


#: [m/s] per knot
KNOT = 1852.0 / 3600.0


def record_speed(column: float | None, particulars: dict | None) -> float | None:
    """Forward speed of a decay [m/s at the record's scale].

    From the record's ``speed`` column [m/s] when it has one, else from the
    test's ``ship_speed`` [kn, full scale] in the particulars, Froude-scaled
    to the record's scale (``U_model = U_full / sqrt(scale)``); None when
    neither says.
    """
    if column is not None:
        return float(column)
    if particulars and particulars.get("speed_kn") is not None:
        return float(particulars["speed_kn"]) * KNOT / math.sqrt(float(particulars.get("scale", 1.0)))
    return None


def record_vessel(particulars: dict | None) -> tuple[str | None, str]:
    """The ship a decay is of and where that came from: ``(name or None, source)``.

    The particulars (:func:`find_particulars`) carry ``vessel`` when a
    parameter file names the ship (``fnpf_parameters.csv``'s ``title`` for the
    test it was run for, and for every test of ``model_test_parameters.csv``
    with the same length, beam and displacement).
    """
    if particulars and particulars.get("vessel"):
        return str(particulars["vessel"]), str(particulars.get("vessel_source", ""))
    return None, "no parameter file beside the records names the ship"


def _first_period_fit(record: pd.DataFrame, period: float | None):
    """Least-squares fit of the record's first period (see :func:`initial_state`).

    Returns ``(coef (8,), X (m, 8), y (m,), J (2, 8))`` with ``J @ coef`` the
    initial angle and rate, or None when the record has no period estimate
    or is shorter than one period.
    """
    t = record["t"].to_numpy(float)
    phi = record["phi"].to_numpy(float)
    if period is None:
        period = float(record.attrs.get("period", np.nan))
    tt = t - t[0]
    if not (np.isfinite(period) and period > 0 and tt[-1] >= period):
        return None
    m = tt <= period
    w = 2 * math.pi / period
    u = tt[m]
    c, s = np.cos(w * u), np.sin(w * u)
    c3, s3 = np.cos(3 * w * u), np.sin(3 * w * u)
    X = np.column_stack((c, s, u * c, u * s, u * u * c, u * u * s, c3, s3))
    coef = np.linalg.lstsq(X, phi[m], rcond=None)[0]
    J = np.zeros((2, 8))
    J[0, 0] = J[0, 6] = 1.0
    J[1, 1], J[1, 2], J[1, 7] = w, 1.0, 3 * w
    return coef, X, phi[m], J


def initial_state(record: pd.DataFrame, period: float | None = None) -> tuple[float, float]:
    """Initial roll angle [rad] and rate [rad/s] of a prepared record.

    Over the first period the record is fitted by least squares with
    ``(a + c t + e t^2) cos(w t) + (b + d t + f t^2) sin(w t) + g cos(3 w t)
    + h sin(3 w t)`` (``w = 2 pi / T``; the polynomial factors follow the
    changing amplitude and phase, the third harmonic the distortion by
    nonlinear damping); then ``phi(0) = a + g`` and ``phi'(0) = w b + c + 3 w h``. Using a whole period averages
    the measurement noise: a local polynomial over a few samples gives a
    rate so noisy that a simulation started from it is visibly out of phase.
    Without a period estimate a cubic over the first samples is used.

    Parameters
    ----------
    record : DataFrame
        Prepared decay (``t`` [s] from the release, ``phi`` [rad]).
    period : float, optional
        Roll period [s]; default ``record.attrs["period"]``.

    Returns
    -------
    phi0, dphi0 : float
        [rad], [rad/s].
    """
    fit = _first_period_fit(record, period)
    if fit is not None:
        coef, _, _, J = fit
        phi0, dphi0 = J @ coef
        return float(phi0), float(dphi0)
    t = record["t"].to_numpy(float)
    phi = record["phi"].to_numpy(float)
    tt = t - t[0]
    n = min(8, t.size)
    c = np.polyfit(tt[:n], phi[:n], min(3, n - 1))
    return float(np.polyval(c, 0.0)), float(np.polyval(np.polyder(c), 0.0))


def initial_state_covariance(record: pd.DataFrame, noise: float = 0.0,
                             period: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Initial state of :func:`initial_state` and the covariance of its error.

    The error of the least-squares fit over the first period: ``J (X^T X)^-1
    J^T s^2`` with ``s^2`` the larger of the fit's residual variance (what
    the eight-term curve does not follow, noise and distortion alike) and
    ``noise^2``.

    Parameters
    ----------
    record : DataFrame
        Prepared decay.
    noise : float
        Standard deviation of the measurement noise [rad], a floor of ``s``.
    period : float, optional
        Roll period [s]; default ``record.attrs["period"]``.

    Returns
    -------
    mean : ndarray (2,)
        ``(phi0 [rad], dphi0 [rad/s])``, as :func:`initial_state`.
    cov : ndarray (2, 2)
        [rad^2, rad^2/s, rad^2/s^2]; zeros when the record is shorter than a
        period (the cubic fallback of :func:`initial_state` has no error model).
    """
    fit = _first_period_fit(record, period)
    if fit is None:
        return np.asarray(initial_state(record, period), float), np.zeros((2, 2))
    coef, X, y, J = fit
    dof = max(1, X.shape[0] - X.shape[1])
    var = max(float(np.sum((y - X @ coef) ** 2)) / dof, float(noise) ** 2)
    cov = J @ np.linalg.pinv(X.T @ X) @ J.T * var
    return J @ coef, 0.5 * (cov + cov.T)


def split_cycles(record: pd.DataFrame, share: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Cut a prepared decay at an extremum into its first cycles and its last ``share`` of them.

    Parameters
    ----------
    record : DataFrame
        Prepared decay (``t`` [s] from the release, ``phi`` [rad]).
    share : float
        Share of the half-cycles (extrema after the release) held out, in (0, 1).

    Returns
    -------
    first, last : DataFrame
        The record up to and including the extremum at the cut, and the
        record from it on with ``t`` restarting at 0. Both keep the
        record's ``attrs`` with ``name`` suffixed ``_first``/``_last``;
        ``last.attrs["t_from_release"]`` is the time [s] of the cut after the
        release, ``phi_release`` its angle [rad], and ``n_extrema`` counts
        each part's own extrema.

    Raises
    ------
    ValueError
        Fewer than four extrema on either side of the cut.
    """
    t = record["t"].to_numpy(float)
    ex = find_extrema(t, record["phi"].to_numpy(float), 0.0)
    n = len(ex)
    k = int(round(n * (1.0 - float(share))))
    if k < 4 or n - k < 4:
        raise ValueError(f"{n} extrema: too few to hold out {100 * share:.0f} % of them with four on each side")
    i = int(ex.index[k])
    first = record.iloc[:i + 1].reset_index(drop=True)
    last = record.iloc[i:].reset_index(drop=True)
    last["t"] = last["t"] - t[i]
    name = str(record.attrs.get("name", "decay"))
    first.attrs = {**record.attrs, "name": f"{name}_first", "n_extrema": k}
    last.attrs = {**record.attrs, "name": f"{name}_last", "n_extrema": n - k, "t_from_release": float(t[i]),
                  "phi_release": float(last["phi"].iloc[0])}
    return first, last


def froude_scale_record(record: pd.DataFrame, from_scale: float, to_scale: float) -> pd.DataFrame:
    """Froude-scale the time of a roll record (angles are unchanged).

    Parameters
    ----------
    record : DataFrame
        ``t`` [s], ``phi`` [rad].
    from_scale, to_scale : float
        Geometric scale factors (1 = full scale, 68 = model 1:68).

    Returns
    -------
    DataFrame
        Copy with ``t`` multiplied by ``sqrt(from_scale / to_scale)`` (and
        ``period``, ``dt`` in ``attrs`` likewise).
    """
    f = math.sqrt(float(from_scale) / float(to_scale))
    out = record.copy()
    out["t"] = record["t"] * f
    out.attrs = dict(record.attrs)
    for k in ("period", "dt"):
        if k in out.attrs:
            out.attrs[k] = out.attrs[k] * f
    out.attrs["scale"] = float(to_scale)
    return out


# ----------------------------------------------------------- particulars
def read_model_test_parameters(path, run_id: int | str | None = None) -> pd.DataFrame | dict:
    """Read ``model_test_parameters.csv`` (SSPA particulars at full scale).

    Parameters
    ----------
    path : str or Path
        The parameters file.
    run_id : int or str, optional
        Test id; when given the matching row is returned as a dict.

    Returns
    -------
    DataFrame or dict
        All rows, or the row of ``run_id`` (keys as in the file: ``scale_factor``,
        ``Volume`` [m^3], ``gm`` [m], ``KXX`` [m], ``rho`` [kg/m^3], ``g`` [m/s^2], ...).
    """
    file = str(path)
    if not Path(path).is_file():
        raise DataError(file, "file not found")
    df = pd.read_csv(path)
    if run_id is None:
        return df
    rows = df[df["id"].astype(str) == str(int(float(run_id)))]
    if rows.empty:
        raise DataError(file, f"no particulars for test id {run_id}", column="id")
    return rows.iloc[0].to_dict()


def read_fnpf_parameters(path) -> dict:
    """Read ``fnpf_parameters.csv`` (one row: LPP, B, V, KXX, ..., dt, maxtime, roll)."""
    file = str(path)
    if not Path(path).is_file():
        raise DataError(file, "file not found")
    return pd.read_csv(path).iloc[0].to_dict()


#: the columns of a potential-flow solver's roll decay (time, angle and the solver's own rate and
#: acceleration), as against a model test's motion record (time, x, y, z, phi, theta, psi)
SOLVER_COLUMNS = ("Time", "phi", "phi1d", "phi2d")


def is_solver_output(path) -> bool:
    """Whether a roll-decay file is a solver's simulation, judged by its columns
    (:data:`SOLVER_COLUMNS`: the rate and acceleration it computes beside the angle), not
    by its name."""
    try:
        header = pd.read_csv(path, nrows=0).columns
    except Exception as exc:  # noqa: BLE001 - an unreadable file is refused by the loader in its own words
        log.debug("%s: header not read (%s)", path, type(exc).__name__)
        return False
    return set(SOLVER_COLUMNS) <= {str(c).strip() for c in header}


def find_particulars(path) -> dict | None:
    """Ship particulars for a roll-decay file, from the parameter files beside it.

    For ``model_test_<id>.csv`` the row ``<id>`` of ``model_test_parameters.csv``;
    for a solver's simulation (its columns, :func:`is_solver_output`) the row of
    the test named by ``fnpf_parameters.csv`` (its ``id``), with the scale of
    the simulation inferred from its length (``LPP``) relative to the
    full-scale ``lpp``.

    Returns
    -------
    dict or None
        ``scale`` (geometric scale factor of the record: 1 = full scale, 68 =
        model 1:68), ``full`` (dict with ``displacement`` [m^3], ``gm`` [m],
        ``kxx`` [m], ``rho`` [kg/m^3], ``g`` [m/s^2], ``lpp`` [m] at full scale),
        ``model_scale_factor`` (the scale of the physical model tests),
        ``source`` (text), ``speed_kn`` (the test's ship speed [kn, full
        scale], when the file has ``ship_speed``) and ``vessel``,
        ``vessel_source`` (the ship's name and where it came from, when a
        parameter file names it). ``None`` when nothing is found.
    """
    p = Path(path)
    params = p.parent / "model_test_parameters.csv"
    if not params.is_file():
        return None
    try:
        table = pd.read_csv(params)
    except Exception as exc:  # noqa: BLE001 - any unreadable file: the record's scale is then unknown
        log.warning("%s beside %s cannot be read (%s: %s): the record's scale and ship are unknown",
                    params, p.name, type(exc).__name__, str(exc).strip().splitlines()[0] if str(exc).strip() else "")
        return None
    stem = p.stem
    run_id = None
    scale = None
    source = ""
    simulated = is_solver_output(p)
    if simulated:
        fp = p.parent / "fnpf_parameters.csv"
        if not fp.is_file():
            return None
        f = pd.read_csv(fp).iloc[0].to_dict()
        run_id = int(float(f["id"]))
        source = f"{fp.name} (test id {run_id})"
    else:
        m = re.search(r"(\d+)", stem)
        if m:
            run_id = int(m.group(1))
        source = params.name
    rows = table[table["id"].astype(str) == str(run_id)]
    if rows.empty:
        return None
    r = rows.iloc[0]
    lam_tests = float(r["scale_factor"])
    if simulated:
        ratio = float(r["lpp"]) / float(f["LPP"])
        scale = lam_tests if abs(ratio / lam_tests - 1) < 0.02 else (1.0 if abs(ratio - 1) < 0.02 else ratio)
    else:
        scale = lam_tests  # the SSPA model tests are at model scale
    full = {
        "displacement": float(r["Volume"]),
        "gm": float(r["gm"]),
        "kxx": float(r["KXX"]),
        "rho": float(r["rho"]),
        "g": float(r["g"]),
        "lpp": float(r["lpp"]),
    }
    out = {"scale": float(scale), "model_scale_factor": lam_tests, "full": full, "source": source,
           "run_id": run_id}
    if "ship_speed" in r and np.isfinite(pd.to_numeric(r["ship_speed"], errors="coerce")):
        out["speed_kn"] = float(r["ship_speed"])
    out.update(_vessel_name(p.parent, table, r))
    return out


def _vessel_name(folder: Path, table: pd.DataFrame, row) -> dict:
    """``vessel`` and ``vessel_source`` of a test: the ``title`` of ``fnpf_parameters.csv``
    when the test it names has the same length, beam and displacement as ``row``."""
    fp = folder / "fnpf_parameters.csv"
    try:
        f = pd.read_csv(fp).iloc[0].to_dict() if fp.is_file() else {}
    except Exception as exc:  # noqa: BLE001 - any unreadable file: the ship's name is then unknown
        log.warning("%s cannot be read (%s): the ship's name of the tests is unknown", fp, type(exc).__name__)
        return {}
    title = str(f.get("title") or "").strip()
    if not title or "id" not in f:
        return {}
    named = table[table["id"].astype(str) == str(int(float(f["id"])))]
    if named.empty:
        return {}
    keys = ("lpp", "beam", "Volume")
    same = all(k in row and k in named and np.isclose(float(named.iloc[0][k]), float(row[k]), rtol=1e-3)
               for k in keys)
    if not same:
        return {}
    return {"vessel": title, "vessel_source": f"title of {fp.name} (test {int(float(f['id']))}, same length, "
                                              "beam and displacement)"}
