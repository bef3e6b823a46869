"""Fitting and naming the roll-decay causes (:mod:`studies.discovery.causes.roll_decay`).

Baseline: the linear model ``phi'' + b1 phi' + omega0^2 phi = 0``, either
identified from the training decay or, when a record of another simulator is
given (``simulation.path``, e.g. a potential-flow decay), identified from
that simulation: the simulation is then what is judged against the
measurements. Each cause's terms are fitted to the measured training decays
by simulation least squares (with the baseline's own parameters refitted too
when the baseline came from the data, held when it came from the
simulation; the linear causes exist only in the latter case, since a
baseline fitted to the data already has its own ``b1``). Scored like the
manoeuvring causes (BIC with the effective number of independent samples),
every training decay's start fitted with the coefficients (:func:`_fit`),
and validated by predicting the held-out decays from the start that fits
their first periods (:func:`fitted_start`). A pair is named only with strong
evidence (score lower by 10) over each of its members.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ..decay import find_extrema
from ..records import initial_state
from ..simulate import predict_record
from ...discovery.causes.roll_decay import ROLL_CATALOGUE, RollCause
from ...discovery.fitting import sample_intervals

__all__ = ["roll_search", "roll_interval", "peak_decay", "PEAK_CYCLES", "predict_from_fitted_start", "fitted_start",
           "START_PERIODS"]

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


def _fit(free, fixed, records, start):
    """Simulation least squares of the ``free`` parameters (``fixed`` held) on ``records``,
    with every record's initial state fitted beside them; ``(params, residual [rad],
    initial states [(phi0 [rad], phi'0 [rad/s]) per record])``.

    The initial states start from :func:`studies.roll.records.initial_state` (a fit over
    the first period). Held there, the part of the measurement noise that such a fit
    keeps is an amplitude and phase error of the whole simulated decay; a cause that
    changes the period with the amplitude (nonlinear restoring) then takes it up, and
    was named on linear decays with 1 % white noise in 5 of 8 seeds. Fitted, the
    initial states cost every cause the same two parameters per record.
    """
    terms = ["b1"] + [t for t in ("b2", "b3", "c3") if t in free or t in fixed]
    k = len(free)
    x0 = np.concatenate([np.asarray(start, float),
                         np.ravel([initial_state(rec) for rec in records])])

    def resid(x):
        params = RollCause.model_params(fixed, dict(zip(free, x[:k])))
        out = []
        for i, rec in enumerate(records):
            phi = predict_record(params, terms, rec, initial=(x[k + 2 * i], x[k + 2 * i + 1]))
            out.append(np.nan_to_num(phi - rec["phi"].to_numpy(float), nan=1.0))
        return np.concatenate(out)

    res = least_squares(resid, x0, x_scale="jac", max_nfev=200 + 50 * len(records))
    params = RollCause.model_params(fixed, dict(zip(free, res.x[:k])))
    initial = [(float(res.x[k + 2 * i]), float(res.x[k + 2 * i + 1])) for i in range(len(records))]
    return params, resid(res.x), initial


def _tau(x):
    """Integrated autocorrelation time [samples] of residuals ``x`` (at least 1)."""
    import emcee  # about 0.2 s to load: only when roll causes are scored

    return float(max(1.0, emcee.autocorr.integrated_time(np.asarray(x), c=5, tol=0, quiet=True)[0]))


#: periods at the start of a decay over which its start is fitted for a prediction
START_PERIODS = 2.0


def fitted_start(params: dict, record) -> tuple[float, float]:
    """The start (roll angle [rad], rate [rad/s] at the first sample) from which the model
    (``params`` held) follows the first :data:`START_PERIODS` periods of ``record`` best.

    Fitted over the first periods only: over a whole decay a model with the wrong damping
    would pick a start that trades its first peaks against its last ones (a run that
    keeps too much roll would start lower), which is no prediction of the decay."""
    t = record["t"].to_numpy(float)
    period = float(record.attrs.get("period") or 2.0 * np.pi / float(params["omega0"]))
    head = record[t - t[0] <= START_PERIODS * period].reset_index(drop=True)
    head.attrs = dict(record.attrs)
    _, _, initial = _fit([], dict(params), [head], [])
    return initial[0]


def predict_from_fitted_start(params: dict, terms, record) -> np.ndarray:
    """``record``'s roll angle [rad] predicted by the model (``params``, ``terms`` held) from
    its :func:`fitted_start`: how discovery judges and draws a held-out decay."""
    return predict_record(params, terms, record, initial=fitted_start(params, record))


def _rmse_deg(params, terms, records) -> float:
    """Mean over ``records`` of the RMSE [deg] of their prediction from their fitted start
    (:func:`predict_from_fitted_start`)."""
    val = [float(np.sqrt(np.nanmean((predict_from_fitted_start(params, terms, rec)
                                      - rec["phi"].to_numpy(float)) ** 2))) for rec in records]
    return float(np.rad2deg(np.mean(val))) if val else np.nan


def roll_search(train, validation, simulation=None) -> dict:
    """Fit the baseline and every roll cause; rank; validate (RMSE in degrees).

    Returns a dict with ``fits`` (one per cause: ``cause``, ``terms``,
    ``params`` of the extended model, ``added`` (the cause's own parameters),
    ``resid`` [rad], ``initial`` (each training record's fitted initial state), ``k``,
    ``explanation``, ``validation_rmse_deg``, ``score``), ``best``, ``baseline``, ``n_eff``, ``tau`` and
    ``simulation_params`` (the baseline fitted to ``simulation``, or None).
    """
    if simulation is not None:
        sim_params, _, _ = _fit(["omega0", "b1"], {}, [simulation],
                                [2 * np.pi / simulation.attrs.get("period", 2 * np.pi), 0.01])
        base_fixed = dict(sim_params)
    else:
        base_fixed = None
    fits = []
    for cause_id, cause in ROLL_CATALOGUE.items():
        if base_fixed is None and cause.needs_simulation:
            continue                     # the data baseline's own b1 already holds it
        names, terms = cause.params, cause.terms()
        if base_fixed is not None:
            params, resid, initial = _fit(list(names), dict(base_fixed), train, [0.0] * len(names))
            added = {n: (params["b1"] - base_fixed["b1"] if n == "b1_added" else params[n]) for n in names}
        else:
            period = train[0].attrs.get("period") or 2 * np.pi
            free = ["omega0", "b1"] + list(names)
            params, resid, initial = _fit(free, {}, train, [2 * np.pi / period, 0.02] + [0.0] * len(names))
            added = {n: params[n] for n in names}
        fits.append({"cause": cause_id, "terms": terms, "params": params, "added": added, "resid": resid,
                     "initial": initial, "k": len(names), "explanation": cause.explanation,
                     "validation_rmse_deg": _rmse_deg(params, terms, validation)})
    n = len(fits[0]["resid"])
    tau = _tau(fits[0]["resid"])
    n_eff = max(10.0, n / tau)
    for f in fits:
        rss = float(np.sum(f["resid"] ** 2))
        f["score"] = n_eff * np.log(rss / n) + f["k"] * np.log(n_eff)
    baseline = fits[0]
    scores = {f["cause"]: f["score"] for f in fits}

    def eligible(f):
        if f is baseline:
            return True
        strong = f["score"] < baseline["score"] - 10.0 and all(
            f["score"] < scores[m] - 10.0 for m in ROLL_CATALOGUE[f["cause"]].members if m in scores)
        return strong and (np.isnan(f["validation_rmse_deg"])
                           or f["validation_rmse_deg"] < baseline["validation_rmse_deg"])

    best = min((f for f in fits if eligible(f)), key=lambda f: f["score"])
    return {"fits": fits, "best": best, "baseline": baseline, "n_eff": n_eff, "tau": tau,
            "simulation_params": base_fixed}


def roll_interval(best, train, simulation_fixed=None, steps: int = 80, seed: int = 0) -> dict:
    """90 % intervals of the winning cause's parameters by emcee on the profile
    likelihood (the baseline's parameters at their fitted values)."""
    names = list(best["added"])
    if not names:
        return {}
    terms = best["terms"]
    rss0 = float(np.sum(best["resid"] ** 2))
    n_eff = max(10.0, len(best["resid"]) / _tau(best["resid"]))
    base = {k: v for k, v in best["params"].items()}
    if "b1_added" in names:
        base["b1"] = best["params"]["b1"] - best["added"]["b1_added"]

    def log_prob(x):
        params = RollCause.model_params(base, dict(zip(names, x)))
        r = np.concatenate([predict_record(params, terms, rec, initial=start) - rec["phi"].to_numpy(float)
                            for rec, start in zip(train, best["initial"])])
        if not np.all(np.isfinite(r)):
            return -np.inf
        return -0.5 * n_eff * np.log(np.sum(r ** 2) / rss0)

    value = np.array([best["added"][n] for n in names])
    rng = np.random.default_rng(seed)
    walkers = 6 if len(names) == 1 else 4 * len(names)
    start = value * (1 + 0.01 * rng.standard_normal((walkers, len(names))))
    chain = sample_intervals(log_prob, start, steps // 3, steps - steps // 3, seed)["samples"]
    return {n: [float(np.percentile(chain[:, j], 5)), float(np.percentile(chain[:, j], 95))]
            for j, n in enumerate(names)}
