"""Roll-decay causes: what damping or restoring the baseline lacks.

Baseline: the linear model ``phi'' + b1 phi' + omega0^2 phi = 0``, either
identified from the training decay or, when a record of another simulator is
given (``simulation.path``, e.g. a potential-flow decay), identified from
that simulation: the simulation is then what is judged against the
measurements. Each cause adds one term to the baseline (``b2 |phi'| phi'``,
``b3 phi'^3`` or ``c3 phi^3``), fitted to the measured training decay by
simulation least squares (with the baseline's own parameters refitted too
when the baseline came from the data, held when it came from the simulation).
Scored like the manoeuvring causes (BIC with the effective number of
independent samples), and validated by predicting the other decays from
their initial state.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ..roll.decay import find_extrema
from ..roll.simulate import predict_record
from .fitting import sample_intervals

__all__ = ["ROLL_CAUSES", "roll_search", "peak_decay", "PEAK_CYCLES"]

ROLL_CAUSES = {
    "none": (None, "The linear roll model already explains the decay."),
    "roll_quadratic_damping": ("b2", "Viscous roll damping grows with the square of the roll rate "
                                     "(eddy making, bilge keels, hull skin friction): an inviscid or "
                                     "linear model decays too slowly at large angles."),
    "roll_cubic_damping": ("b3", "Damping that grows with the cube of the roll rate (strongly "
                                 "non-linear viscous damping at large amplitudes)."),
    "roll_nonlinear_restoring": ("c3", "The righting arm is not linear in the heel angle (GZ curve "
                                       "curvature): the roll period changes with the amplitude."),
}


#: full cycles after the release at which the peak amplitude is reported
PEAK_CYCLES = (0, 5, 10, 20, 40)


def _peaks(t, phi) -> dict:
    """Period [s], peak amplitudes [deg] after :data:`PEAK_CYCLES` cycles and the
    time [s] to half the release amplitude of one decay (NaN where not reached)."""
    ex = find_extrema(np.asarray(t, float), np.asarray(phi, float))
    a, te = ex.amplitude, ex.t - float(np.asarray(t, float)[0])
    out = {"period_s": 2.0 * float(np.median(np.diff(te))) if len(te) > 1 else np.nan}
    for k in PEAK_CYCLES:
        out[f"peak_after_{k}_cycles_deg"] = float(np.degrees(a[2 * k])) if 2 * k < len(a) else np.nan
    half = np.flatnonzero(a <= 0.5 * a[0]) if len(a) else []
    out["time_to_half_amplitude_s"] = float(te[half[0]]) if len(half) else np.nan
    return out


def peak_decay(record, predictions: dict) -> pd.DataFrame:
    """Roll peak decay of a measured decay and of its predictions.

    ``predictions`` maps a label to ``(t, phi)`` (``t`` [s], ``phi`` [rad]);
    one row per source, measured first: roll period [s], peak amplitude
    [deg] after 0, 5, 10, 20, 40 full cycles (columns only for the cycles
    the measured record covers) and the time [s] to half the release
    amplitude.
    """
    rows = {"measured": _peaks(record["t"], record["phi"])}
    for label, (t, phi) in predictions.items():
        rows[label] = _peaks(t, phi)
    table = pd.DataFrame(rows).T
    keep = [c for c in table if not (c.startswith("peak_after") and np.isnan(table.loc["measured", c]))]
    table = table[keep]
    table.index.name = str(record.attrs.get("name", "decay"))
    return table


def _fit(terms, free, fixed, records, start):
    def resid(x):
        params = {**fixed, **dict(zip(free, x))}
        out = []
        for rec in records:
            phi = predict_record(params, terms, rec)
            out.append(np.nan_to_num(phi - rec["phi"].to_numpy(float), nan=1.0))
        return np.concatenate(out)

    res = least_squares(resid, start, x_scale="jac", max_nfev=200)
    params = {**fixed, **dict(zip(free, res.x))}
    return params, resid(res.x)


def _tau(x):
    """Integrated autocorrelation time [samples] of residuals ``x`` (at least 1)."""
    import emcee  # about 0.2 s to load: only when roll causes are scored

    return float(max(1.0, emcee.autocorr.integrated_time(np.asarray(x), c=5, tol=0, quiet=True)[0]))


def roll_search(train, validation, simulation=None) -> dict:
    """Fit the baseline and every roll cause; rank; validate (RMSE in degrees)."""
    base_terms = ["b1"]
    if simulation is not None:
        sim_params, _ = _fit(base_terms, ["omega0", "b1"], {}, [simulation],
                             [2 * np.pi / simulation.attrs.get("period", 2 * np.pi), 0.01])
        base_fixed = dict(sim_params)
    else:
        base_fixed = None
    fits = []
    for cause, (term, explanation) in ROLL_CAUSES.items():
        terms = base_terms + ([term] if term else [])
        if base_fixed is not None:
            free = [term] if term else []
            fixed = dict(base_fixed)
            start = [0.0] if term else []
            if free:
                params, resid = _fit(terms, free, fixed, train, start)
            else:
                params = dict(fixed)
                resid = np.concatenate([predict_record(params, terms, r) - r["phi"].to_numpy(float) for r in train])
        else:
            period = train[0].attrs.get("period") or 2 * np.pi
            free = ["omega0", "b1"] + ([term] if term else [])
            params, resid = _fit(terms, free, {}, train, [2 * np.pi / period, 0.02] + ([0.0] if term else []))
        val = []
        for rec in validation:
            phi = predict_record(params, terms, rec)
            val.append(float(np.sqrt(np.nanmean((phi - rec["phi"].to_numpy(float)) ** 2))))
        fits.append({"cause": cause, "terms": terms, "params": params, "resid": resid,
                     "k": 1 if term else 0, "explanation": explanation,
                     "validation_rmse_deg": float(np.rad2deg(np.mean(val))) if val else np.nan})
    n = len(fits[0]["resid"])
    tau = _tau(fits[0]["resid"])
    n_eff = max(10.0, n / tau)
    for f in fits:
        rss = float(np.sum(f["resid"] ** 2))
        f["score"] = n_eff * np.log(rss / n) + f["k"] * np.log(n_eff)
    baseline = fits[0]
    eligible = [f for f in fits if f is baseline or (
        f["score"] < baseline["score"] - 10.0
        and (np.isnan(f["validation_rmse_deg"]) or f["validation_rmse_deg"] < baseline["validation_rmse_deg"]))]
    best = min(eligible, key=lambda f: f["score"])
    return {"fits": fits, "best": best, "baseline": baseline, "n_eff": n_eff, "tau": tau,
            "simulation_params": base_fixed}


def roll_interval(best, train, simulation_fixed, steps: int = 80, seed: int = 0) -> dict:
    """90 % interval of the winning term by emcee on the profile likelihood."""
    term = ROLL_CAUSES[best["cause"]][0]
    if term is None:
        return {}
    terms = best["terms"]
    rss0 = float(np.sum(best["resid"] ** 2))
    n = len(best["resid"])
    n_eff = max(10.0, n / _tau(best["resid"]))

    def log_prob(x):
        params = dict(best["params"])
        params[term] = x[0]
        r = np.concatenate([predict_record(params, terms, rec) - rec["phi"].to_numpy(float) for rec in train])
        if not np.all(np.isfinite(r)):
            return -np.inf
        return -0.5 * n_eff * np.log(np.sum(r ** 2) / rss0)

    value = best["params"][term]
    rng = np.random.default_rng(seed)
    start = value * (1 + 0.01 * rng.standard_normal((6, 1)))
    chain = sample_intervals(log_prob, start, steps // 3, steps - steps // 3, seed)["samples"][:, 0]
    return {term: [float(np.percentile(chain, 5)), float(np.percentile(chain, 95))]}
