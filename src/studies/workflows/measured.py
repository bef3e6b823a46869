"""Identification and validation on measured manoeuvres (e.g. the MARIN KVLCC2 tests).

What differs from simulated studies:

Loading
    MARIN ``.dat`` files are read with ``uniform_time=True``. The files print
    every number with three significant digits, the time included, so up to
    ten consecutive rows share a stamp although the samples are uniform
    (0.1353 s at full scale). Keeping the first row of each stamp (the
    loader's default) throws away most rows, leaves an uneven time axis
    that the derivative estimators refuse, and stamps the kept samples up
    to half a printed step late (0.45 s between 100 and 1000 s, 4.9 s
    beyond 1000 s, which shifts a 0.0075 rad/s turn by 2 deg of heading).
    Rebuilding the uniform axis keeps every sample at its true time (the
    loader refuses files whose stamps disagree with a uniform axis). Other
    files go through :func:`studies.data.load_manoeuvre`; a record that is
    not uniformly sampled is resampled (linear) to its median step, and
    ``data.resample=DT`` resamples every record to ``DT`` seconds.
States and accelerations (``data.derivative``)
    ``savgol``/``central``/``auto`` as for simulated data
    (:mod:`studies.data.derivatives`); ``ekf``: the extended Kalman filter
    and RTS smoother of :mod:`studies.identification.kalman`, first with the
    kinematic process model, then ``kalman.iterations`` times with the
    identified ship model as process model, re-identifying (least squares)
    on the smoothed states and accelerations each time (Alexandersson et
    al. 2022); the configured method makes the final fit.
    ``ekf_kinematic``: the first pass only.
Validation
    each record of ``validate.path`` is replayed with its measured rudder
    from its measured initial state; with a posterior (``method=bayes``)
    ``band_draws`` coefficient sets drawn from it are replayed as well (with
    ``method.discrepancy=process_noise`` each with its own realisation of the
    model discrepancy estimated on the training records) and the 5-95 % band
    of ``x0, y0, psi`` is compared with the measurement, with its
    calibration at 50/80/90/95 %, width, interval score and CRPS
    (:mod:`studies.analysis.bands`).

References
----------
Alexandersson, M., Mao, W., Ringsberg, J.W. (2022). System identification
of vessel manoeuvring models. Ocean Engineering 266, 112940.
"""

from __future__ import annotations

import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

from ..config import RunConfig
from ..data import load_manoeuvre
from ..data.derivatives import DerivativeEstimate, estimate_derivatives
from ..data.io import read_dat
from ..data.scaling import froude_scale
from ..data.resample import resample as resample_record, uniform_grid
from ..identification.kalman import KalmanSettings, ekf_derivatives, measurement_variance
from ..environment.wind import wind_loads_prime
from ..errors import ConfigError, DataError
from ..identification.base import Identification
from ..identification.ls import LeastSquares
from ..identification.regression import assemble_problems, prime_states
from ..models.abkowitz import ManoeuvringModel
from ..models.terms import DOFS
from ..analysis.bands import band_statistics, predictive_draws
from ..analysis.characteristics import steady_turn_rows
from ..plotting import pyplot
from ..simulate.simulator import replay_many
from ..vessels.base import Vessel
from ..config import WEIGHTINGS

__all__ = ["steady_turn", "EKF_METHODS", "load_measured", "load_study_records", "one_scale", "resample", "estimate_all", "problems_from_estimates",
           "identify_measured", "posterior_vectors", "posterior_band", "kalman_options",
           "mirror_record"]

#: ``data.derivative`` values handled here (the others go to build_problems)
EKF_METHODS = ("ekf", "ekf_kinematic")
#: seconds left out at both ends of each smoothed record
EKF_TRIM = 5.0


# ------------------------------------------------------------------ loading

def resample(record: pd.DataFrame, dt: float | None = None) -> pd.DataFrame:
    """Linear resampling onto a uniform grid of step ``dt`` (default: the median step).

    The heading is continuous in the data contract, so linear interpolation
    of every column is safe. Attributes are kept.
    """
    t = record["t"].to_numpy(float)
    step = float(np.median(np.diff(t))) if dt is None else float(dt)
    if not step > 0:
        raise ConfigError(f"data.resample must be a positive step [s], got {dt}")
    return resample_record(record, uniform_grid(t[0], t[-1], step))


def _uniform(t: np.ndarray) -> bool:
    dt = np.diff(t)
    step = float(np.median(dt))
    return bool(np.max(np.abs(dt - step)) <= 1e-6 * step + 1e-9)


def read_record(path, min_samples: int = 10) -> pd.DataFrame:
    """One record as its file holds it (a facility's ``.dat`` on a uniform time
    base, anything else through the data contract), named by its file's stem."""
    if str(path).lower().endswith(".dat"):
        rec = read_dat(path, min_samples=min_samples, uniform_time=True)
    else:
        rec = load_manoeuvre(path, min_samples=min_samples)
    rec.attrs.setdefault("name", Path(str(path)).stem)
    return rec


def _on_grid(rec: pd.DataFrame, resample_dt: float | None) -> pd.DataFrame:
    if resample_dt is not None:
        return resample(rec, resample_dt)
    if not _uniform(rec["t"].to_numpy(float)):
        return resample(rec)
    return rec


def load_measured(paths, min_samples: int = 10, resample_dt: float | None = None) -> list:
    """Load records for identification or validation (see the module docstring),
    each at the scale of its file."""
    return [_on_grid(read_record(path, min_samples), resample_dt) for path in paths]


def load_study_records(training_paths, validation_paths, min_samples: int = 10,
                       resample_dt: float | None = None, scale: str = "auto") -> tuple[list, list]:
    """Training and validation records loaded, brought to one scale (:func:`one_scale`,
    ``data.scale``) and then put on a uniform grid (``data.resample`` seconds at that scale)."""
    training = [read_record(p, min_samples) for p in training_paths]
    validation = [read_record(p, 10) for p in validation_paths]
    training, validation = one_scale(training, validation, scale)
    return ([_on_grid(r, resample_dt) for r in training], [_on_grid(r, None) for r in validation])


def one_scale(training: list, validation: list, setting: str = "auto") -> tuple[list, list]:
    """Training and validation records brought to one scale (``data.scale``).

    ``auto``: as recorded when every record that states its scale is at the
    same one, full scale when they mix; ``model``/``full``: that scale.
    Records that do not state their scale (CSV files) are left as they are.
    """
    everything = training + validation
    stated = {bool(r.attrs["model_scale"]) for r in everything if "model_scale" in r.attrs}
    _refuse_unstated_mix(everything, setting)
    if setting == "auto":
        if len(stated) < 2:
            return training, validation
        setting = "full"
    return ([froude_scale(r, setting) for r in training], [froude_scale(r, setting) for r in validation])


def _approach(record: pd.DataFrame) -> float:
    return float(np.hypot(record["u"].iloc[0], record["v"].iloc[0]))


def _refuse_unstated_mix(records: list, setting: str) -> None:
    """Refuse records that do not state their scale beside records at another scale.

    A CSV record does not say whether it is the model or the ship; beside
    records that do (MARIN and HSVA files), one whose approach speed differs
    from theirs, once they are at the scale the study uses, by more than a
    factor 2 (Froude scales differ by sqrt(45.7) = 6.8 for the KVLCC2) is
    at another scale and would be mixed silently.
    """
    stated = [r for r in records if "model_scale" in r.attrs]
    unstated = [r for r in records if "model_scale" not in r.attrs]
    if not stated or not unstated:
        return
    target = setting if setting != "auto" else (
        "full" if len({bool(r.attrs["model_scale"]) for r in stated}) > 1 else
        ("model" if stated[0].attrs["model_scale"] else "full"))
    reference = float(np.median([_approach(froude_scale(r, target)) for r in stated]))
    for rec in unstated:
        ratio = _approach(rec) / reference
        if not 0.5 < ratio < 2.0:
            name = rec.attrs.get("source", rec.attrs.get("name", "record"))
            raise DataError(str(name), f"its approach speed {_approach(rec):.3g} m/s is {ratio:.2g} times that "
                            f"of the records that state their scale ({target} scale): it is at another scale; "
                            "Froude scale it to match them (studies.data.froude_scale)")


def mirror_record(record: pd.DataFrame) -> pd.DataFrame:
    """Port/starboard mirror image: negate ``y0, psi, v, r, delta`` (and roll).

    The mirror of a starboard turn is the port turn of the mirrored ship;
    used to check that nothing assumes the sign of a manoeuvre.
    """
    out = record.copy()
    for col in ("y0", "psi", "v", "r", "delta", "phi", "p"):
        if col in out:
            out[col] = -out[col]
    out.attrs = dict(record.attrs)
    out.attrs["name"] = f"{record.attrs.get('name', 'record')}_mirror"
    return out


# ------------------------------------------------------------------ estimation

def kalman_options(cfg: RunConfig | None) -> tuple[KalmanSettings, int]:
    """The smoother's settings (``kalman.*``, those given) and the number of
    model iterations (``kalman.iterations``)."""
    if cfg is None:
        return KalmanSettings.from_config({}), 2
    node = {k: v for k, v in asdict(cfg.kalman).items() if v is not None}
    iterations = int(node.pop("iterations", 2))
    return KalmanSettings.from_config(node), iterations


def estimate_all(records, method: str, settings: KalmanSettings | None = None, model=None,
                 values=None, vessel=None) -> list[DerivativeEstimate]:
    """States and accelerations of every record with one estimator."""
    if method in EKF_METHODS:
        return [ekf_derivatives(rec, settings, model, values, vessel, trim=EKF_TRIM) for rec in records]
    return [estimate_derivatives(rec, method) for rec in records]




def problems_from_estimates(model: ManoeuvringModel, vessel: Vessel, records, estimates,
                            fixed: dict | None = None, weights: str = "none") -> dict:
    """Regression problems from given state/acceleration estimates.

    The same algebra as :func:`studies.identification.regression.build_problems`
    (which estimates the derivatives itself), for estimators that need
    more than a record, such as the model-based Kalman smoother, plus an
    optional row weighting (rows of ``theta`` and ``y`` multiplied by
    ``sqrt(w)``):

    ``speed``
        ``w = (U / U0)^4``: the error of a measured acceleration is about
        the same in SI units whatever the speed, so in prime units (divided
        by ``U^2 / L``) its variance grows as ``U^-4``; weighted least
        squares with the inverse variance is then the maximum-likelihood
        fit, and the slow part of a turning circle (U = 0.4 U0, prime
        errors six times larger) no longer dominates the fit.
    ``record``
        every record gets the same total weight, so that one long record
        (a turning circle is four times as long as a zig-zag, mostly in
        steady turning) does not outweigh the others.
    ``speed_record``
        both.
    """
    if weights not in WEIGHTINGS:
        raise ConfigError(f"identify.weights must be one of {', '.join(WEIGHTINGS)}, got '{weights}'")
    fixed = dict(fixed or {})
    L = vessel.length
    M = vessel.mass_matrix()
    primes, lhs, times, which, speed2s = [], [], [], [], []
    method = estimates[0].method if estimates else "none"
    for i, (rec, est) in enumerate(zip(records, estimates)):
        s, a = est.states, est.rates
        p = prime_states(s["u"], s["v"], s["r"], s["delta"], vessel)
        speed2 = s["u"] ** 2 + s["v"] ** 2
        acc = np.column_stack([a["u_dot"] * L / speed2, a["v_dot"] * L / speed2,
                               a["r_dot"] * L * L / speed2])
        y = acc @ M.T
        if "wind_speed" in rec and "wind_direction" in rec:
            rows = est.index
            y = y - wind_loads_prime(s["u"], s["v"], s["psi"], rec["wind_speed"].to_numpy(float)[rows],
                                     rec["wind_direction"].to_numpy(float)[rows], vessel)
        primes.append(p)
        lhs.append(y)
        times.append(rec["t"].to_numpy(float)[est.index])
        which.append(np.full(len(est.index), i))
        speed2s.append(speed2)
    primes = np.vstack(primes)
    lhs = np.vstack(lhs)
    times = np.concatenate(times)
    which = np.concatenate(which)
    w = np.ones(len(times))
    if weights in ("speed", "speed_record"):
        w *= (np.concatenate(speed2s) / vessel.speed ** 2) ** 2
    if weights in ("record", "speed_record"):
        total = w.sum()
        for i in range(len(records)):
            rows = which == i
            w[rows] *= total / (len(records) * w[rows].sum())
    root = np.sqrt(w / w.mean())
    problems = assemble_problems(model, primes, lhs, fixed, which, times, row_weights=root)
    for problem in problems.values():
        problem.meta = {"derivative": method, "weights": weights}
    return problems


def identify_measured(model: ManoeuvringModel, vessel: Vessel, records, derivative: str,
                      identifier, objective=None, settings: KalmanSettings | None = None,
                      iterations: int = 2, weights: str = "speed") -> tuple[Identification, dict]:
    """Identify from measured records with any estimator, EKF iterations included.

    Returns the identifier's result and diagnostics (``ekf/...`` metrics:
    the process-noise scale chosen, the sensor biases found, the change of
    the coefficients between iterations) with the final estimates under
    ``info["estimates"]``.
    """
    started = time.perf_counter()
    info = {}
    settings = settings or KalmanSettings()
    first = "ekf_kinematic" if derivative in EKF_METHODS else derivative
    estimates = estimate_all(records, first, settings)
    passes = iterations if derivative == "ekf" else 0
    previous = None
    for it in range(passes):
        problems = problems_from_estimates(model, vessel, records, estimates, weights=weights)
        params = LeastSquares().fit(problems).params
        if previous is not None:
            change = max(abs(params[n] - previous[n]) / (abs(previous[n]) + 1e-12) for n in params)
            info[f"ekf/iteration{it}/max_rel_change"] = float(change)
        previous = params
        estimates = estimate_all(records, "ekf", settings, model, params, vessel)
    problems = problems_from_estimates(model, vessel, records, estimates, weights=weights)
    if objective is not None:
        # another term set on the same estimates and weights (SINDy's extended library)
        objective.problems_for = lambda other, fixed=None: problems_from_estimates(
            other, vessel, records, estimates, fixed, weights=weights)
    result = identifier.fit(problems, objective=objective)
    if derivative in EKF_METHODS:
        info["ekf/iterations"] = float(passes)
        info["ekf/runtime_s"] = time.perf_counter() - started
    info["estimates"] = estimates
    return result, info


# ------------------------------------------------------------------ steady turn

def _steady_rows(record: pd.DataFrame) -> np.ndarray | None:
    """Rows of the steady phase of a turning record (see :func:`steady_turn`)."""
    return steady_turn_rows(record)


def _steady_values(record: pd.DataFrame, rows: np.ndarray) -> dict:
    u = record["u"].to_numpy(float)[rows]
    v = record["v"].to_numpy(float)[rows]
    r = np.abs(record["r"].to_numpy(float)[rows])
    speed = np.hypot(u, v)
    return {"steady_speed_m_s": float(np.median(speed)),
            "steady_yaw_rate_deg_s": float(np.rad2deg(np.median(r))),
            "steady_drift_deg": float(np.rad2deg(np.median(np.abs(np.arctan2(v, u))))),
            "steady_diameter_m": float(2.0 * np.median(speed / np.maximum(r, 1e-9)))}


#: error key of each steady-turn quantity
STEADY_ERROR_KEYS = {"steady_speed_m_s": "steady_speed_error_pct",
                     "steady_yaw_rate_deg_s": "steady_yaw_rate_error_pct",
                     "steady_drift_deg": "steady_drift_error_pct",
                     "steady_diameter_m": "steady_diameter_error_pct"}


def steady_turn(record: pd.DataFrame) -> dict:
    """Steady phase of a turning circle: speed, yaw rate, drift angle and diameter.

    The steady phase is taken as the samples with the rudder on its
    plateau after the heading has changed by 360 deg from the execute (the
    speed has settled by then); the diameter is ``2 U / |r|`` (medians
    over the phase). Empty when the record does not hold the rudder for at
    least 450 deg of heading change. These complement advance and tactical
    diameter, which are reached while the ship is still losing speed.
    """
    rows = _steady_rows(record)
    return {} if rows is None else _steady_values(record, rows)


def steady_turn_errors(prediction: pd.DataFrame, record: pd.DataFrame, name: str) -> dict:
    """:func:`steady_turn` of a prediction and a measurement, with % errors.

    The prediction's steady phase is taken on the measurement's rows, so
    both describe the same time span.
    """
    rows = _steady_rows(record)
    if rows is None or "diverged_at" in prediction.attrs:
        return {}
    n = min(len(prediction), len(record))
    measured = _steady_values(record.iloc[:n], rows[:n])
    predicted = _steady_values(prediction.iloc[:n], rows[:n])
    out = {}
    for key, value in predicted.items():
        out[f"{name}/{key}"] = value
        out[f"{name}/{key}_measured"] = measured[key]
        out[f"{name}/{STEADY_ERROR_KEYS[key]}"] = 100.0 * (value - measured[key]) / measured[key]
    return out


# ------------------------------------------------------------------ posterior band

def posterior_vectors(model: ManoeuvringModel, result: Identification, n_draws: int,
                      seed: int = 0) -> np.ndarray | None:
    """``n_draws`` coefficient vectors (model term order) from a posterior.

    Each DOF's regression posterior is sampled independently (one joint
    draw of that DOF's coefficients per set); terms without samples keep
    their point estimate. None when the result has no samples.
    """
    dof_samples = {d: result.samples[d] for d in DOFS if d in result.samples}
    if not dof_samples:
        return None
    rng = np.random.default_rng(seed)
    base = model.vector(result.params)
    index = {name: i for i, name in enumerate(model.names)}
    out = np.tile(base, (n_draws, 1))
    for entry in dof_samples.values():
        values = np.asarray(entry["values"])
        rows = rng.integers(0, values.shape[0], n_draws)
        for j, name in enumerate(entry["names"]):
            if name in index:
                out[:, index[name]] = values[rows, j]
    traj = result.samples.get("trajectory")
    if traj is not None:
        values = np.asarray(traj["values"])
        rows = rng.integers(0, values.shape[0], n_draws)
        for j, name in enumerate(traj["names"]):
            if name in index:
                out[:, index[name]] = values[rows, j]
    return out


def posterior_band(model: ManoeuvringModel, vectors: np.ndarray, vessel: Vessel,
                   record: pd.DataFrame, quantiles=(0.05, 0.5, 0.95), noise: bool = True,
                   discrepancy=None, seed: int = 0, settings: KalmanSettings | None = None,
                   modules=None, steer: bool = False) -> dict:
    """Replay ``record`` with every vector; quantiles of ``x0, y0, psi`` per sample.

    Returns ``{"t", "x0", "y0", "psi"}`` (each channel an array (3, n):
    lower, median, upper), ``"paths"`` (the replayed ``x0, y0`` of every
    set, thinned to at most 500 samples, for plots), ``"diverged"`` (the
    fraction of sets that left the physical range; their rows are ignored)
    and the coverage of the measurement: ``coverage_<ch>`` (fraction of the
    samples inside the band), ``coverage_xy`` (``x0`` and ``y0`` both
    inside) and ``coverage_all``, and ``covered_until_s`` (time from the
    start until the measured position first stays outside the band for
    more than 10 s); also the calibration at 50/80/90/95 %, the band widths,
    the interval score and the CRPS
    (:func:`studies.analysis.bands.band_statistics`). A posterior
    predictive band of a *measurement* includes the sensor noise: with
    ``noise`` the band is widened by 1.645 times the measurement noise of
    the channel (:func:`studies.identification.kalman.measurement_variance`), which
    matters at the start where every replay begins at the measured state.
    With a ``discrepancy`` (:class:`studies.identification.discrepancy.Discrepancy`)
    every replay also carries a realisation of it and an initial state
    drawn from the sensor's uncertainty
    (:func:`studies.analysis.bands.predictive_draws`, seeded by ``seed``).
    The replays run on the model's own simulator: the MMG simulator for an
    MMG vessel (``modules`` its propeller and rudder parameters); with
    ``steer`` a zig-zag record is run by its rule (``validate.band_replay``).
    """
    states, diverged = predictive_draws(model, vectors, vessel, record, discrepancy, seed, settings,
                                        modules, steer)
    return band_statistics(states, diverged, record, noise, quantiles, seed=seed)


def plot_band(record: pd.DataFrame, prediction: pd.DataFrame, band: dict, path, title: str) -> None:
    """Trajectory and heading with the posterior predictive band."""
    plt = pyplot()
    fig, (ax_xy, ax_psi) = plt.subplots(1, 2, figsize=(12, 5.5))
    t = band["t"]
    # the trajectory band as the replayed posterior draws themselves
    for j, drawn in enumerate(band.get("paths", [])):
        ax_xy.plot(drawn[:, 1], drawn[:, 0], color="tab:orange", alpha=0.15, lw=0.6,
                   label="posterior draws" if j == 0 else None)
    ax_xy.plot(record["y0"], record["x0"], "k", lw=1.2, label="measured")
    ax_xy.plot(prediction["y0"], prediction["x0"], "tab:orange", lw=1.0, label="prediction (median coef.)")
    ax_xy.set_xlabel("y0 (east) [m]")
    ax_xy.set_ylabel("x0 (north) [m]")
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.legend(fontsize=8)
    k = 180.0 / np.pi
    ax_psi.fill_between(t, band["psi"][0] * k, band["psi"][-1] * k, color="tab:orange", alpha=0.3,
                        label="5-95 %")
    ax_psi.plot(record["t"], record["psi"] * k, "k", lw=1.2, label="measured")
    ax_psi.plot(prediction["t"], prediction["psi"] * k, "tab:orange", lw=1.0, label="prediction")
    ax_psi.set_xlabel("t [s]")
    ax_psi.set_ylabel("psi [deg]")
    ax_psi.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
