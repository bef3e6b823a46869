"""Fitting and scoring the causes of ``studies discover``.

For a cause with parameters theta, the hydrodynamic coefficients are
profiled out: for every trial theta the training records are read as the
cause says (:meth:`Cause.setup`) and the model is identified by least
squares; the residuals of the three DOFs, each scaled by the baseline's
residual standard deviation, are minimised over theta with
``scipy.optimize.least_squares`` from a few starting points.

Score (lower is better): a BIC on the regression with the effective number
of independent rows ``n_eff = n / tau`` (regression residuals of a time
series are autocorrelated; ``tau`` is their integrated autocorrelation time,
measured on the baseline)::

    score = n_eff * sum_dof ln(RSS_dof / n) + k ln(n_eff)

with ``k`` the number of the cause's own parameters. The extended model must
also predict the records it was not fitted to better than the baseline.

References
----------
Schwarz, G. (1978). Estimating the dimension of a model. Annals of Statistics
6(2), 461-464.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import emcee
import numpy as np
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from ..data.derivatives import choose_window
from ..identify import LeastSquares, build_problems
from ..identify.bayes import run_with_progress
from .causes.base import Cause, Setup

__all__ = ["Context", "CauseFit", "regression_fit", "setup_problems", "scored_fit", "nominal_residuals", "fit_cause",
           "kinematic_smoothing",
           "validate", "training_error", "posterior", "sample_intervals"]

log = logging.getLogger(__name__)


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
    #: baseline: :class:`studies.discover.causes.propulsion.MMGDynamics`); None: ``model``'s own
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
    #: the output-error refinement's solution (:func:`studies.discover.output_error.refine`), if any
    refined: dict | None = None
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
    """Baseline fit: sets the residual scales, ``n_eff`` and ``tau`` of ``ctx``."""
    params, residuals, problems = regression_fit(ctx, Setup(ctx.model, ctx.train))
    scored = nominal_residuals(ctx, residuals, problems)
    ctx.sigma = np.array([max(np.std(r), 1e-300) for r in scored])
    ctx.n_rows = len(scored[0])
    ctx.tau = max(integrated_time(r) for r in scored)
    ctx.n_eff = max(10.0, ctx.n_rows / ctx.tau)
    return params, residuals


def rescore(ctx: Context, fits: list) -> None:
    """Re-estimate the residuals' autocorrelation time from the fit that whitens
    them most, and score every fit again with it.

    The baseline's residual carries whatever effect the baseline lacks: a
    slowly varying, heading-dependent error makes its autocorrelation time
    hundreds of rows long, and ``n_eff`` measured on it would hide the very
    effect that causes it. The residual of the cause that explains the effect
    shows the correlation of the measurement errors alone.
    """
    tau = min([f.tau for f in fits if np.isfinite(f.tau)] + [ctx.tau])
    if tau < ctx.tau:
        log.info("residual autocorrelation time %.1f rows (baseline's %.1f)", tau, ctx.tau)
        ctx.tau = tau
        ctx.n_eff = max(10.0, ctx.n_rows / tau)
    for f in fits:
        f.score = _score(ctx, f.rss, f.cause.n_params())


def _score(ctx: Context, rss: np.ndarray, k: int) -> float:
    return float(ctx.n_eff * np.sum(np.log(rss / ctx.n_rows)) + k * np.log(ctx.n_eff))


def _vector(ctx: Context, cause: Cause, theta) -> np.ndarray:
    _, residuals, _ = scored_fit(ctx, cause.setup(ctx, theta))
    return np.concatenate([r / s for r, s in zip(residuals, ctx.sigma)])


def fit_cause(ctx: Context, cause: Cause) -> CauseFit:
    """Profile least squares over the cause's parameters from its starting points."""
    t0 = time.perf_counter()
    if not cause.nl_params:
        theta = np.zeros(0)
    else:
        low, high = cause.bounds(ctx)
        best = None
        starts = [np.clip(st, low + 1e-9, high - 1e-9) for st in cause.starts(ctx)]
        if len(starts) > 2:
            # a coarse look at every start, then the two most promising are refined
            costs = []
            for st in starts:
                try:
                    costs.append(float(np.sum(_vector(ctx, cause, st) ** 2)))
                except (ValueError, np.linalg.LinAlgError):
                    costs.append(np.inf)
            starts = [starts[i] for i in np.argsort(costs)[:2]]
        for start in starts:
            start = np.clip(start, low + 1e-9, high - 1e-9)
            try:
                res = least_squares(lambda th: _vector(ctx, cause, th), start, bounds=(low, high),
                                    x_scale="jac", max_nfev=60, diff_step=1e-4)
            except (ValueError, np.linalg.LinAlgError) as exc:
                log.info("cause %s: start %s failed (%s)", cause.id, start, exc)
                continue
            if best is None or res.cost < best.cost:
                best = res
        theta = best.x if best is not None else np.zeros(len(cause.nl_params))
    setup = cause.setup(ctx, theta)
    params, residuals, _ = scored_fit(ctx, setup)
    rss = np.array([float(np.sum(r ** 2)) for r in residuals])
    fit = CauseFit(cause, np.asarray(theta, float), params, rss, setup=setup,
                   tau=max(integrated_time(r) for r in residuals))
    fit.score = _score(ctx, rss, cause.n_params())
    fit.undecidable = cause.undecidable(ctx)
    fit.seconds = time.perf_counter() - t0
    return fit


def kinematic_smoothing(record, settings=None, rates: bool = False):
    """The record with its velocities and heading replaced by their EKF/RTS
    estimates with a kinematic process model (positions, rudder and other
    columns kept; :func:`studies.identify.kalman.ekf_derivatives` with
    ``settings``, default :class:`~studies.identify.kalman.KalmanSettings`):
    states consistent with the record's own track, estimated without a ship
    model. ``rates``: the smoother's ``u_dot, v_dot, r_dot`` added as columns."""
    from ..identify.kalman import ekf_derivatives

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


def posterior(ctx: Context, fit: CauseFit, walkers: int = 6, steps: int = 40, burn: int = 15,
              seed: int = 0) -> dict:
    """90 % intervals of the cause's parameters from emcee on the profile likelihood
    ``-n_eff / 2 sum_dof ln RSS_dof(theta)`` (flat prior within the bounds)."""
    cause = fit.cause
    k = len(fit.theta)
    if k == 0:
        return _linear_intervals(ctx, fit)
    low, high = cause.bounds(ctx)
    scale = np.maximum(np.abs(fit.theta) * 0.05, 1e-6 * (1 + np.abs(fit.theta)))

    def log_prob(theta):
        if np.any(theta < low) or np.any(theta > high):
            return -np.inf
        _, residuals, _ = scored_fit(ctx, cause.setup(ctx, theta))
        rss = np.array([np.sum(r ** 2) for r in residuals])
        return -0.5 * ctx.n_eff * float(np.sum(np.log(rss)))

    walkers = max(walkers, 2 * k + 2)
    rng = np.random.default_rng(seed)
    start = fit.theta + scale * rng.standard_normal((walkers, k)) * 0.1
    start = np.clip(start, low + 1e-12, high - 1e-12)
    return sample_intervals(log_prob, start, burn, steps, seed)


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


def _linear_intervals(ctx: Context, fit: CauseFit) -> dict:
    """90 % intervals of LS-identified added terms (Gaussian posterior of a linear
    regression, widened by the residual autocorrelation time)."""
    names = [n for n in fit.cause.params]
    if not names:
        return {}
    _, residuals, problems = regression_fit(ctx, fit.setup)
    lo, mid, hi = {}, {}, {}
    for k, dof in enumerate(("X", "Y", "N")):
        p = problems[dof]
        mine = [j for j, n in enumerate(p.names) if n in names]
        if not mine:
            continue
        s2 = float(np.sum(residuals[k] ** 2)) / max(1, p.n_rows - p.theta.shape[1]) * ctx.tau
        cov = s2 * np.linalg.pinv(p.theta.T @ p.theta)
        for j in mine:
            c = fit.params[p.names[j]]
            half = 1.645 * np.sqrt(max(cov[j, j], 0.0))
            lo[p.names[j]], mid[p.names[j]], hi[p.names[j]] = c - half, c, c + half
    return {"names": names, "q05": np.array([lo[n] for n in names]),
            "q50": np.array([mid[n] for n in names]), "q95": np.array([hi[n] for n in names]),
            "method": "linear"}
