"""The pieces every discovery fits with: the context of a discovery, a
cause's fit, the regression of the baseline (or a cause's setup) on the
smoothed records and its score, the records' smoothing, and the replays
that give the validation error.

A cause with parameters theta reads the records as it says
(:meth:`Cause.setup`) and the model's coefficients are identified on them
by least squares (:func:`scored_fit`); the residuals of the three DOFs are
each scaled by the baseline's residual standard deviation. Their score
(lower is better) is a BIC with the effective number of independent rows
``n_eff = n / tau`` (regression residuals of a time series are
autocorrelated; ``tau`` is their integrated autocorrelation time, measured
on the baseline)::

    score = n_eff * sum_dof ln(RSS_dof / n) + k ln(n_eff)

with ``k`` the number of the cause's own parameters.

References
----------
Schwarz, G. (1978). Estimating the dimension of a model. Annals of Statistics
6(2), 461-464.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import emcee
import numpy as np
from scipy.signal import savgol_filter

from ..data.derivatives import choose_window
from ..identification import LeastSquares, build_problems
from ..identification.bayes import run_with_progress
from ..models.mmg import ASYMMETRY_TERMS, STANDARD_TERMS
from .causes.base import Cause, Setup

__all__ = ["Context", "CauseFit", "regression_fit", "setup_problems", "scored_fit", "nominal_residuals",
           "calibrate", "kinematic_smoothing", "validate", "training_error", "sample_intervals"]

log = logging.getLogger(__name__)

#: the MMG hull's terms that are monomials of v', r' alone (fitted on either rows)
STANDARD_HULL = frozenset(STANDARD_TERMS + ASYMMETRY_TERMS)


@dataclass
class Context:
    """What every cause is fitted against."""

    vessel: object
    model: object
    train: list
    validation: list
    derivative: str = "auto"
    sigma: np.ndarray = field(default_factory=lambda: np.ones(3))
    n_rows: int = 0
    n_eff: float = 1.0
    tau: float = 1.0
    horizon: float | None = 120.0
    #: the baseline's dynamics when it is not the polynomial regression of ``model`` (an MMG
    #: baseline: :class:`studies.discovery.causes.propulsion.MMGDynamics`); None: ``model``'s own
    dynamics: object | None = None


@dataclass
class CauseFit:
    cause: Cause
    theta: np.ndarray
    params: dict
    rss: np.ndarray
    score: float = np.inf
    tau: float = np.inf
    validation: dict = field(default_factory=dict)
    setup: Setup | None = None
    seconds: float = 0.0
    #: ``(why, manoeuvre)``: the training records cannot decide for the cause, and which
    #: manoeuvre would (:meth:`Cause.undecidable`; None: they can)
    undecidable: tuple | None = None
    #: :func:`validate` of the whole validation records (one replay each, no windows)
    whole: dict = field(default_factory=dict)

    @property
    def validation_rmse(self) -> float:
        return float(self.validation.get("position_rmse", np.inf))


def setup_problems(ctx: Context, setup: Setup) -> tuple[dict, float]:
    """The setup's regression problems ``{dof: RegressionProblem}`` with its
    external forces (earth-fixed bias, body force) moved into ``y``, and the
    factor that turns their prime units into the Abkowitz prime units of the
    scores (1, or ``d / L`` for the MMG model's ``0.5 rho L d U^2``).

    Problems may carry prior rows after their data rows (``n_data``)."""
    if setup.dynamics is not None:
        problems, ratio = setup.dynamics.problems(ctx, setup)
    else:
        problems, ratio = build_problems(setup.model, ctx.vessel, setup.fit_records, ctx.derivative,
                                         setup.fixed), 1.0
    if setup.bias is not None:
        bx, by, bn = np.asarray(setup.bias, float) / ratio
        for dof, p in problems.items():
            n = int(getattr(p, "n_data", p.n_rows))
            psi = p.states["psi"][:n]
            if dof == "X":
                p.y[:n] = p.y[:n] - (np.cos(psi) * bx + np.sin(psi) * by)
            elif dof == "Y":
                p.y[:n] = p.y[:n] - (-np.sin(psi) * bx + np.cos(psi) * by)
            else:
                p.y[:n] = p.y[:n] - bn
    if setup.body is not None:
        speed0 = ctx.vessel.speed
        for k, dof in enumerate(("X", "Y", "N")):
            p = problems[dof]
            n = int(getattr(p, "n_data", p.n_rows))
            s = p.states
            p.y[:n] = p.y[:n] - setup.body[k] / ratio * speed0 ** 2 / (s["u"][:n] ** 2 + s["v"][:n] ** 2)
    return problems, ratio


def regression_fit(ctx: Context, setup: Setup):
    """LS on the setup's records; returns (params incl. fixed, prime residual per DOF, problems).

    Residuals are those of the data rows, in Abkowitz prime units
    (:func:`setup_problems`)."""
    problems, ratio = setup_problems(ctx, setup)
    ls = LeastSquares()
    params = dict(setup.fixed)
    residuals = []
    for dof in ("X", "Y", "N"):
        p = problems[dof]
        n = int(getattr(p, "n_data", p.n_rows))
        coef = ls.fit_one(p) if p.theta.shape[1] else np.zeros(0)
        params.update(p.fixed)              # known in the problem: the setup's, a family's tied terms
        params.update(dict(zip(p.names, coef.tolist())))
        residuals.append((p.y[:n] - p.theta[:n] @ coef if p.theta.shape[1] else p.y[:n]) * ratio)
    return params, residuals, problems


def nominal_residuals(ctx: Context, residuals: list, problems: dict) -> list:
    """Prime residuals re-expressed at the vessel's nominal speed U0.

    Prime forces are over ``0.5 rho L^2 U^2`` with the speed through the
    water *as the cause reads it*; scoring them at ``U0`` makes causes that
    read that speed differently comparable: otherwise a cause could shrink
    the residual by making the ship faster through the water (a current).
    """
    out = []
    for r, dof in zip(residuals, ("X", "Y", "N")):
        s = problems[dof].states
        out.append(r * (s["u"] ** 2 + s["v"] ** 2) / ctx.vessel.speed ** 2)
    return out


def scored_fit(ctx: Context, setup: Setup):
    """:func:`regression_fit` with its residuals at the nominal speed (what causes are scored on)."""
    params, residuals, problems = regression_fit(ctx, setup)
    return params, nominal_residuals(ctx, residuals, problems), problems


def integrated_time(x: np.ndarray) -> float:
    """Integrated autocorrelation time of a residual series (>= 1)."""
    x = np.asarray(x, float)
    if len(x) < 50 or np.std(x) == 0:
        return 1.0
    return float(max(1.0, emcee.autocorr.integrated_time(x, c=5, tol=0, quiet=True)[0]))


def calibrate(ctx: Context) -> tuple[dict, list]:
    """Baseline fit: sets the residual scales, ``n_eff`` and ``tau`` of ``ctx``.

    The baseline is fitted on the Abkowitz rows of the records; a hull family
    with terms of the MMG primes alone (``u' = u / U``, the thrust loading:
    ``model.hull=thrust|reduced|crossflow``) on the MMG model's rows (the standard MMG
    hull's terms are monomials of ``v', r'``, which both rows hold)."""
    needs_mmg_rows = ctx.dynamics is not None and not set(ctx.model.names) <= STANDARD_HULL
    params, residuals, problems = regression_fit(
        ctx, Setup(ctx.model, ctx.train, dynamics=ctx.dynamics if needs_mmg_rows else None))
    scored = nominal_residuals(ctx, residuals, problems)
    ctx.sigma = np.array([max(np.std(r), 1e-300) for r in scored])
    ctx.n_rows = len(scored[0])
    ctx.tau = max(integrated_time(r) for r in scored)
    ctx.n_eff = max(10.0, ctx.n_rows / ctx.tau)
    return params, residuals


def _score(ctx: Context, rss: np.ndarray, k: int) -> float:
    return float(ctx.n_eff * np.sum(np.log(rss / ctx.n_rows)) + k * np.log(ctx.n_eff))


def kinematic_smoothing(record, settings=None, rates: bool = False):
    """The record with its velocities and heading replaced by their EKF/RTS
    estimates with a kinematic process model (positions, rudder and other
    columns kept; :func:`studies.identification.kalman.ekf_derivatives` with
    ``settings``, default :class:`~studies.identification.kalman.KalmanSettings`):
    states consistent with the record's own track, estimated without a ship
    model. ``rates``: the smoother's ``u_dot, v_dot, r_dot`` added as columns."""
    from ..identification.kalman import ekf_derivatives

    est = ekf_derivatives(record, settings)
    out = record.iloc[est.index].copy()
    for c in ("u", "v", "r", "psi"):
        out[c] = est.states[c]
    if rates:
        for c in ("u", "v", "r"):
            out[c + "_dot"] = est.rates[c + "_dot"]
    out.attrs = dict(record.attrs)
    out.attrs["smoothed"] = "ekf"
    return out.reset_index(drop=True)


def smoothing_window(record) -> int:
    """Savitzky-Golay window [samples] of a record's u, v, r by the discrepancy principle."""
    t = record["t"].to_numpy(float)
    dt = float(np.median(np.diff(t)))
    return choose_window([record[c] for c in ("u", "v", "r")], dt)


def smoothed(record):
    """The record with u, v, r, psi smoothed (Savitzky-Golay, window by
    :func:`smoothing_window`) for use as initial states of replays."""
    n = smoothing_window(record)
    if n >= len(record):
        return record
    out = record.copy()
    for c in ("u", "v", "r", "psi"):
        out[c] = savgol_filter(record[c].to_numpy(float), n, 3, mode="interp")
    out.attrs = dict(record.attrs)
    return out


def validate(ctx: Context, fit: CauseFit, keep: bool = False, whole: bool = False) -> dict:
    """Prediction error of the fitted extension on the validation records.

    Each record is cut into windows of ``horizon`` seconds (starting every
    half horizon; the whole record when None) and every window is replayed
    from its own smoothed initial state with the measured rudder; the error
    is the RMSE of the position [m] (and of u, v, r) against the measurement,
    averaged over windows and records. Short horizons measure how well the
    dynamics are predicted without letting one early error grow for the rest
    of a long record (``whole=True``: one replay per record). A replay that
    diverges counts as the RMS distance from the window's start over the
    window (as wrong as a prediction that the ship does not move);
    ``validation["diverged"]`` names the records with such a replay.
    """
    horizon = None if whole else ctx.horizon
    setup = fit.setup
    errors = {"position_rmse": [], "rmse_u": [], "rmse_v": [], "rmse_r": []}
    predictions, diverged = [], []
    for rec in ctx.validation:
        smooth = smoothed(rec)
        t = rec["t"].to_numpy(float)
        if horizon and horizon < t[-1] - t[0]:
            starts = np.arange(t[0], t[-1] - horizon + 1e-9, horizon / 2)
        else:
            starts = [t[0]]
        for t0 in starts:
            rows = (t >= t0) & (t <= t0 + horizon) if (horizon and len(starts) > 1) else slice(None)
            part = rec[rows] if not isinstance(rows, slice) else rec
            init = smooth[rows] if not isinstance(rows, slice) else smooth
            seg = init.copy()
            seg["x0"], seg["y0"] = part["x0"].to_numpy(), part["y0"].to_numpy()
            seg.attrs = dict(rec.attrs)
            pred = setup.replay(fit.params, ctx.vessel, seg)
            if keep and len(starts) == 1:
                predictions.append(pred)
            if "diverged_at" in pred.attrs:
                diverged.append(str(rec.attrs.get("name", "record")))
                x, y = part["x0"].to_numpy(), part["y0"].to_numpy()
                lost = float(np.sqrt(np.mean((x - x[0]) ** 2 + (y - y[0]) ** 2)))
                errors["position_rmse"].append(lost)
                for c in ("u", "v", "r"):
                    errors[f"rmse_{c}"].append(float(np.sqrt(np.mean(part[c].to_numpy() ** 2))))
                continue
            dx = pred["x0"].to_numpy() - part["x0"].to_numpy()
            dy = pred["y0"].to_numpy() - part["y0"].to_numpy()
            errors["position_rmse"].append(float(np.sqrt(np.mean(dx ** 2 + dy ** 2))))
            for c in ("u", "v", "r"):
                errors[f"rmse_{c}"].append(
                    float(np.sqrt(np.mean((pred[c].to_numpy() - part[c].to_numpy()) ** 2))))
    fit.validation = {k: float(np.mean(v)) for k, v in errors.items()}
    fit.validation["windows"] = [float(x) for x in errors["position_rmse"]]
    fit.validation["diverged"] = sorted(set(diverged))
    if keep:
        fit.validation["predictions"] = predictions
    return fit.validation


def training_error(ctx: Context, fit: CauseFit) -> float:
    """Windowed position error [m] of ``fit`` replaying its own training
    records, windows as in :func:`validate`: how well the model predicts the
    motions it was fitted to, the yardstick for its error on held-out ones.
    ``fit`` itself is left unchanged."""
    return validate(replace(ctx, validation=ctx.train), replace(fit))["position_rmse"]


def sample_intervals(log_prob, start: np.ndarray, burn: int, steps: int, seed: int) -> dict:
    """emcee from the walkers' ``start`` (walkers, k) for ``burn + steps`` steps,
    its own moves seeded by ``seed`` (so that the intervals do not depend on
    numpy's global state); the chain after ``burn`` and its 5, 50 and 95 %
    quantiles per parameter."""
    sampler = emcee.EnsembleSampler(start.shape[0], start.shape[1], log_prob)
    sampler.random_state = np.random.RandomState(seed).get_state()
    run_with_progress(sampler, start, burn + steps)
    chain = sampler.get_chain(discard=burn, flat=True)
    q05, q50, q95 = np.percentile(chain, [5, 50, 95], axis=0)
    return {"samples": chain, "q05": q05, "q50": q50, "q95": q95,
            "acceptance_fraction": float(np.mean(sampler.acceptance_fraction))}
