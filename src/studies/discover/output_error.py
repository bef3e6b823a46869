"""Output-error refinement of a fitted cause (simulation-based least squares).

The equation-error fit of :mod:`studies.discover.fitting` regresses forces
on the measured velocities. With noisy velocities the regressors carry the
noise and the coefficients are biased (errors in variables): at 5 %
measurement noise on the Mariner the median coefficient is off by about
100 % and replays of held-out manoeuvres drift by metres where the true
model stays within the noise. Output error does not regress on the noisy
states: it simulates them.

Every training record is thinned to :data:`RESOLUTION` (block means of
consecutive samples: white noise shrinks, the dynamics of a ship do not
change within a second) and cut into windows of ``ctx.horizon`` seconds.
Each window is replayed with the measured rudder (as the cause reads it)
from its own initial state, integrated by RK4 at the thinned step, and the
simulated track ``x0, y0``, heading ``psi`` and velocities ``u, v, r`` are
compared with the measured ones, each channel divided by its noise level
(the standard deviation of the record minus its Savitzky-Golay smoothing,
averaged over the same blocks, with a floor). The unknowns are

- the model's hydrodynamic coefficients (prime), started from the
  equation-error estimate, with a weak Gaussian prior centred there whose
  standard deviation is the coefficient's own size (it only steers
  directions the records do not determine);
- the cause's own parameters (started from the profile fit);
- the initial ``x0, y0, psi, u, v, r`` of every window (the measurement
  there is noisy; left alone, the coefficients would be bent to absorb its
  error: a heading 0.2 deg off puts a 120 s window metres off track).

``scipy.optimize.least_squares`` (trust region) minimises the sum of
squares; the coefficient and initial-state columns of the Jacobian come
from one parallel replay per window of all perturbed coefficient vectors
and initial states (:meth:`studies.simulate.simulator.ReplayPlan.run_states`;
a shift of the initial position moves the whole track, so its columns need
no replay).
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from ..data.resample import block_means
from ..identify.regression import prime_states
from ..simulate.simulator import ReplayPlan
from .fitting import (CauseFit, Context, integrated_time, sample_intervals, smoothed,
                      smoothing_window)
from .kinematics import coloured_velocity_noise, kinematic_noise_levels

__all__ = ["Window", "training_windows", "noise_levels", "relative_noise",
           "needs_refinement", "refine_cause", "restart_from", "refine", "output_error_scores", "score_terms", "refined_posterior"]

#: ``output_error=auto`` refines when the noise of v or r exceeds this share of
#: the signal's standard deviation (the Mariner records give about 0.017 at 1 %
#: measurement noise and 0.08-0.09 at 5 %; the MARIN KVLCC2 zig-zags 0.006 and 0.001)
AUTO_NOISE = 0.02

log = logging.getLogger(__name__)

#: measured channels compared with the replay, in this order; also the order of
#: each window's free initial state
CHANNELS = ("x0", "y0", "psi", "u", "v", "r")

#: sampling [s] of the records replayed and compared by the output-error fit
#: (block means of finer records, :func:`studies.data.resample.block_means`);
#: the replays integrate at this step
RESOLUTION = 1.0


class Window:
    """One stretch of a training record: the record part (thinned), its
    measured outputs and the smoothed measurement at its start."""

    def __init__(self, record, initial: dict, measured: np.ndarray):
        self.record = record          # rows of the window (rudder, wind, attrs), thinned
        self.initial = initial        # smoothed x0, y0, psi, u, v, r at the window's start (over ground)
        self.measured = measured      # (n, 6) in CHANNELS order, heading unwrapped
        self.step = float(np.median(np.diff(record["t"].to_numpy(float)))) if len(record) > 1 else 1.0


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
    (:func:`studies.data.resample.block_means`, what the output-error fit
    compares): white noise shrinks by the square root of the block's
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


def relative_noise(ctx: Context, records, sigma: np.ndarray | None = None) -> np.ndarray:
    """Noise level of ``u, v, r`` over the standard deviation of the signal."""
    sigma = noise_levels(ctx, records) if sigma is None else sigma
    spread = [np.std(np.concatenate([r[c].to_numpy(float) for r in records])) for c in ("u", "v", "r")]
    return sigma[3:6] / np.maximum(spread, 1e-300)


def needs_refinement(ctx: Context, setting, sigma: np.ndarray | None = None) -> bool:
    """Whether ``discover.output_error`` (``"auto"``, True or False: normalised by the settings) asks for
    the output-error refinement on these training records: ``auto`` when the
    sway or yaw-rate noise exceeds :data:`AUTO_NOISE` of the signal (below that
    the equation-error coefficients are not noise-limited, and on the MARIN
    KVLCC2 zig-zags the refinement predicts the turning circle worse)."""
    if setting == "auto":
        rel = relative_noise(ctx, ctx.train, sigma)
        return bool(max(rel[1], rel[2]) > AUTO_NOISE)
    return bool(setting)


def training_windows(ctx: Context, records, resolution: float = RESOLUTION) -> list[Window]:
    """Consecutive windows of ``ctx.horizon`` seconds (whole records when None;
    a last part shorter than half a horizon joins the window before it) of
    the records thinned to ``resolution`` seconds (block means; records
    sampled as coarsely or more are used as they are)."""
    out = []
    for rec in records:
        coarse = block_means(rec, resolution)
        smooth = block_means(smoothed(rec), resolution)
        t = coarse["t"].to_numpy(float)
        psi = np.unwrap(coarse["psi"].to_numpy(float))
        start = {c: (np.unwrap(smooth[c].to_numpy(float)) if c == "psi" else smooth[c].to_numpy(float))
                 for c in CHANNELS}
        h = ctx.horizon or (t[-1] - t[0])
        edges = list(np.arange(t[0], t[-1] - 0.5 * h + 1e-9, h)) or [t[0]]
        for i, t0 in enumerate(edges):
            t1 = edges[i + 1] if i + 1 < len(edges) else t[-1] + 1e-9
            rows = np.flatnonzero((t >= t0) & (t < t1 - 1e-9)) if i + 1 < len(edges) else \
                np.flatnonzero(t >= t0)
            if len(rows) < 10:
                continue
            part = coarse.iloc[rows].copy()
            part.attrs = dict(rec.attrs)
            first = rows[0]
            initial = {c: float(start[c][first]) for c in CHANNELS}
            # the track and heading at the start are the measurement itself (their noise is small)
            initial.update({"x0": float(coarse["x0"].iloc[first]), "y0": float(coarse["y0"].iloc[first]),
                            "psi": float(psi[first])})
            measured = np.column_stack([part["x0"].to_numpy(float), part["y0"].to_numpy(float), psi[rows],
                                        part["u"].to_numpy(float), part["v"].to_numpy(float),
                                        part["r"].to_numpy(float)])
            out.append(Window(part, initial, measured))
    return out


def _outputs(states: np.ndarray, speed0: float, current) -> np.ndarray:
    """Replayed states ``(sets, n, 7)`` as the measured channels (velocities over ground)."""
    psi = states[..., 5]
    u = speed0 + states[..., 0]
    v = states[..., 1]
    if current is not None:
        speed, direction = current
        u = u + speed * np.cos(direction - psi)
        v = v + speed * np.sin(direction - psi)
    return np.stack([states[..., 3], states[..., 4], psi, u, v, states[..., 2]], axis=-1)


class _Problem:
    """Residuals and Jacobian of the output-error fit of one cause.

    The unknowns ``x`` are, in this order: the model's coefficients (relative
    to their own size ``beta_scale``), the cause's nonlinear parameters
    (relative to ``theta_scale``) and, per window, the corrections to its
    initial ``x0, y0, psi, u, v, r`` (in units of the channels' noise).
    """

    #: initial-state columns replayed (psi, u, v, r); x0 and y0 shift the track only
    REPLAYED_STATES = (2, 3, 4, 5)

    def __init__(self, ctx: Context, fit: CauseFit, windows: list[Window], sigma: np.ndarray,
                 prior: float = 1.0):
        self.ctx, self.cause, self.windows, self.sigma = ctx, fit.cause, windows, sigma
        self.model = fit.setup.model
        self.names = [t.name for t in self.model.terms]
        self.beta0 = self.model.vector(fit.params, 0.0)
        self.beta_scale = np.maximum(np.abs(self.beta0), 1e-6)
        self.theta0 = np.asarray(fit.theta, float)
        low, high = self.cause.bounds(ctx) if len(self.theta0) else (np.zeros(0), np.zeros(0))
        self.theta_scale = np.maximum(np.abs(self.theta0), self.cause.scales(ctx)) if len(self.theta0) \
            else np.zeros(0)
        self.low, self.high = low, high
        self.state_scale = np.asarray(sigma, float)
        self.nb, self.nt, self.nw = len(self.beta0), len(self.theta0), len(windows)
        self.ns = len(CHANNELS)
        self.prior = float(prior)
        self._setups = {}
        # each window's replay prepared once per cause parameters and model (:class:`ReplayPlan`)
        self._plans = {}
        self._plain = {}
        # the setups need the cause's hooks only, not the training records read the cause's way
        self._bare = replace(ctx, train=[])

    def split(self, x):
        """``(coefficients, cause parameters, initial-state corrections (windows, 6))``."""
        b = self.beta0 + x[: self.nb] * self.beta_scale
        th = self.theta0 + x[self.nb: self.nb + self.nt] * self.theta_scale
        st = x[self.nb + self.nt:].reshape(self.nw, self.ns) * self.state_scale
        return b, th, st

    def bounds(self):
        lo = np.full(self.nb + self.nt + self.ns * self.nw, -np.inf)
        hi = -lo
        if self.nt:
            lo[self.nb: self.nb + self.nt] = (self.low - self.theta0) / self.theta_scale
            hi[self.nb: self.nb + self.nt] = (self.high - self.theta0) / self.theta_scale
        return lo, hi

    def _setup(self, theta):
        key = tuple(np.round(theta, 15))
        if key not in self._setups:
            if len(self._setups) > 8:
                self._setups.clear()
            self._setups[key] = self.cause.setup(self._bare, theta)
        return self._setups[key]

    def _plan(self, w: Window, theta, model) -> ReplayPlan:
        """The window's replay as the cause at ``theta`` reads it: a variant
        (:meth:`ReplayPlan.variant`) of the window's plain replay, prepared
        once per model."""
        key = (id(w), tuple(np.round(theta, 15)), id(model))
        if key not in self._plans:
            if len(self._plans) > 4 * max(self.nw, 16):
                self._plans.clear()
            plain_key = (id(w), id(model))
            if plain_key not in self._plain:
                # the entry holds its model, so the id in the key cannot be reused while it is cached
                self._plain[plain_key] = (model, ReplayPlan(model, self.ctx.vessel, w.record, max_step=w.step))
            setup = self._setup(theta)
            seen = setup.sim_record(w.record)
            plan = self._plain[plain_key][1].variant(None if seen is w.record else seen,
                                                     setup.environment(w.record), setup.external())
            self._plans[key] = (model, plan)
        return self._plans[key][1]

    def _window(self, w: Window, betas: np.ndarray, theta, states: np.ndarray, model=None) -> np.ndarray:
        """Residuals (noise units) of one window for every row of ``betas``
        (coefficients of ``model``, the fit's model by default), each from
        the window's initial state corrected by the matching row of
        ``states`` (physical units, :data:`CHANNELS` order; one row for all)."""
        plan = self._plan(w, theta, model or self.model)
        states = np.atleast_2d(states)
        if len(states) == 1 and len(betas) > 1:
            states = np.repeat(states, len(betas), axis=0)
        x0s = np.array([plan.initial_state({c: w.initial[c] + d for c, d in zip(CHANNELS, row)})
                        for row in states])
        replayed, _ = plan.run_states(betas, x0s)
        n = min(replayed.shape[1], len(w.measured))
        env = plan.environment
        current = (env.current_speed, env.current_direction) if env.current_speed else None
        out = _outputs(replayed[:, :n], float(self.ctx.vessel.speed), current)
        res = (out - w.measured[None, :n]) / self.sigma
        return np.nan_to_num(res, nan=1e3, posinf=1e3, neginf=-1e3).reshape(len(betas), -1)

    def residuals(self, x) -> np.ndarray:
        b, th, st = self.split(x)
        parts = [self._window(w, b[None], th, st[i])[0] for i, w in enumerate(self.windows)]
        return np.concatenate(parts + [np.sqrt(self.prior) * x[: self.nb]])

    def jacobian(self, x) -> np.ndarray:
        b, th, st = self.split(x)
        h = 1e-4
        blocks = []
        replayed = self.REPLAYED_STATES
        for i, w in enumerate(self.windows):
            # one parallel replay: the solution, each coefficient perturbed, each replayed state perturbed
            betas = np.vstack([b, b + np.diag(h * self.beta_scale), np.repeat(b[None], len(replayed), axis=0)])
            states = np.repeat(st[i][None], len(betas), axis=0)
            for j, k in enumerate(replayed):
                states[1 + self.nb + j, k] += h * self.state_scale[k]
            r = self._window(w, betas, th, states)
            base = r[0]
            block = np.zeros((len(base), len(x)))
            block[:, : self.nb] = ((r[1: 1 + self.nb] - base) / h).T
            for j in range(self.nt):
                e = np.zeros(self.nt)
                e[j] = h * self.theta_scale[j]
                block[:, self.nb + j] = (self._window(w, b[None], th + e, st[i])[0] - base) / h
            first = self.nb + self.nt + self.ns * i
            for j, k in enumerate(replayed):
                block[:, first + k] = (r[1 + self.nb + j] - base) / h
            # a shift of the initial position shifts the whole track: d(x0 residual)/d(x0 correction) = 1
            rows = len(base) // self.ns
            for k in (0, 1):
                block[np.arange(rows) * self.ns + k, first + k] = self.state_scale[k] / self.sigma[k]
            blocks.append(block)
        prior = np.zeros((self.nb, len(x)))
        prior[:, : self.nb] = np.sqrt(self.prior) * np.eye(self.nb)
        return np.vstack(blocks + [prior])


def _inherited_start(ctx: Context, fit: CauseFit, parent: CauseFit, windows: list[Window],
                     sigma: np.ndarray) -> CauseFit:
    """The refined ``parent``'s coefficients with the cause's parameters that
    replay the training windows best (from the parent's window states) among
    the equation-error estimate ``fit.theta``, no effect (zeros: the parent's
    own solution) and the cause's starting grid
    (:meth:`~studies.discover.causes.base.Cause.starts`, e.g. eight current
    directions). Each candidate costs one replay per window."""
    inherited = {**fit.params, **{k: v for k, v in parent.params.items() if k in fit.params}}
    low, high = fit.cause.bounds(ctx) if len(fit.theta) else (np.zeros(0), np.zeros(0))
    candidates = [np.asarray(fit.theta, float), np.zeros(len(fit.theta))]
    candidates += [np.asarray(c, float) for c in fit.cause.starts(ctx)] if len(fit.theta) else []
    states = parent.refined["states"]
    best, best_cost = None, np.inf
    for theta in candidates:
        trial = replace(fit, params=inherited, theta=np.clip(theta, low, high))
        prob = _Problem(ctx, trial, windows, sigma)
        x = np.zeros(prob.nb + prob.nt + prob.ns * prob.nw)
        x[prob.nb + prob.nt:] = states
        res = prob.residuals(x)
        cost = float(res @ res)
        if cost < best_cost:
            best, best_cost = trial, cost
    return best


def refine_cause(ctx: Context, fit: CauseFit, parent: CauseFit, windows: list[Window],
                 sigma: np.ndarray, own: bool = True) -> CauseFit:
    """The cause of the equation-error ``fit`` refined by output error from
    several starts, the best kept: its own equation-error solution
    (coefficients and parameters together: when the effect is large, the
    baseline's coefficients are bent by it and only the cause's own go with
    its parameters); the refined ``parent``'s coefficients (the baseline's)
    with the best of a few values of the cause's parameters
    (:func:`_inherited_start`; no effect among them, so the refined cause
    does not end worse than the parent); and the parent's coefficients with
    each of the cause's small effects
    (:meth:`~studies.discover.causes.base.Cause.nudges`). A cost after one
    replay does not tell which start ends lower (the windows' initial states
    fitted to one set of coefficients do not suit the other), so each is
    refined (``own=False``: all but the first)."""
    inherited = refine(ctx, _inherited_start(ctx, fit, parent, windows, sigma), windows, sigma,
                       states=parent.refined["states"])
    params = {**fit.params, **{k: v for k, v in parent.params.items() if k in fit.params}}
    for theta in (fit.cause.nudges(ctx) if len(fit.theta) else []):
        nudged = refine(ctx, replace(fit, params=params, theta=np.asarray(theta, float)), windows, sigma,
                        states=parent.refined["states"])
        inherited = nudged if nudged.refined["cost"] < inherited.refined["cost"] else inherited
    if not own:
        return inherited
    own = refine(ctx, fit, windows, sigma)
    return own if own.refined["cost"] < inherited.refined["cost"] else inherited


def _nested_theta(small, large) -> np.ndarray | None:
    """The parameters of ``small``'s cause within the solution of ``large``
    (whose cause is ``small``'s, the baseline's, or a pair holding it), or None."""
    cause = large.cause
    if cause.id == small.cause.id:
        return np.asarray(large.theta, float)
    if not len(small.theta):
        return np.zeros(0)
    first = getattr(cause, "first", None)
    second = getattr(cause, "second", None)
    n = len(first.nl_params) if first is not None else 0
    if first is not None and first.id == small.cause.id:
        return np.asarray(large.theta[:n], float)
    if second is not None and second.id == small.cause.id:
        return np.asarray(large.theta[n:], float)
    return None


def restart_from(ctx: Context, small: CauseFit, large: CauseFit, windows: list[Window],
                 sigma: np.ndarray) -> CauseFit:
    """``small`` (refined) refined again from the solution of ``large``, a richer
    model holding it (the baseline in a cause, a cause in a pair) with its extra
    effect left out: its coefficients, ``small``'s own parameters within it and
    its windows' initial states. Returns whichever of the two replays the
    training records better (data residual, prior left out).

    The output-error fit has local minima; a richer model, started elsewhere
    and with more freedom, may find a better one for the parameters the two
    share. Its gain would then be credited to its extra effect (a cause at no
    effect beating the baseline; a second cause that only lets the first's
    coefficients move on), unless the simpler model is given the same start.
    """
    theta = _nested_theta(small, large)
    if theta is None or large.refined is None or small.refined is None:
        return small
    params = {**small.params, **{k: v for k, v in large.params.items() if k in small.params}}
    trial = refine(ctx, replace(small, theta=theta, params=params), windows, sigma,
                   states=large.refined["states"])
    return trial if trial.refined["rss"] < small.refined["rss"] else small


def refine(ctx: Context, fit: CauseFit, windows: list[Window] | None = None,
           sigma: np.ndarray | None = None, max_nfev: int = 30,
           states: np.ndarray | None = None) -> CauseFit:
    """The cause's fit refined by output error on the training records.

    Returns a new :class:`CauseFit` with the refined coefficients and cause
    parameters, started from ``fit.params`` and ``fit.theta`` (and from the
    windows' initial-state corrections ``states``, noise units, when given:
    the ``refined["states"]`` of a related fit). ``fit.score`` and ``rss``
    are kept (the equation-error ones); ``fit.validation`` is not
    recomputed. ``refined`` holds the solution: ``cost`` (half the sum of
    squares, prior included), ``rss`` / ``n`` / ``tau`` of the data residual
    (noise units; ``tau`` its integrated autocorrelation time), ``states``,
    ``windows`` and ``sigma``. ``windows`` and ``sigma`` may be shared between
    causes (:func:`training_windows`, :func:`noise_levels` of the training
    records).
    """
    t0 = time.perf_counter()
    windows = windows if windows is not None else training_windows(ctx, ctx.train)
    sigma = sigma if sigma is not None else noise_levels(ctx, ctx.train, windows[0].step if windows else None)
    prob = _Problem(ctx, fit, windows, sigma)
    x0 = np.zeros(prob.nb + prob.nt + prob.ns * prob.nw)
    if states is not None and len(states) == prob.ns * prob.nw:
        x0[prob.nb + prob.nt:] = states
    lo, hi = prob.bounds()
    x0 = np.clip(x0, lo, hi)
    res = least_squares(prob.residuals, x0, jac=prob.jacobian, bounds=(lo, hi), method="trf",
                        max_nfev=max_nfev, x_scale=1.0, ftol=1e-4, xtol=1e-6)
    beta, theta, _ = prob.split(res.x)
    params = {**fit.params, **dict(zip(prob.names, beta.tolist()))}
    out = replace(fit, theta=theta, params=params, validation={}, setup=fit.cause.setup(ctx, theta))
    data = res.fun[: len(res.fun) - prob.nb]
    out.refined = {"states": res.x[prob.nb + prob.nt:].copy(), "cost": float(res.cost),
                   "rss": float(data @ data), "n": len(data), "tau": _autocorrelation_time(data),
                   "n_unknowns": len(res.x), "windows": windows, "sigma": sigma}
    out.seconds = fit.seconds + time.perf_counter() - t0
    log.info("cause %-18s output error: cost %.4g in %d evaluations (%.1f s)", fit.cause.id,
             res.cost, res.nfev, time.perf_counter() - t0)
    return out


def _scale(refined: dict) -> tuple[float, float]:
    """``(s2, n_eff)`` of a refined fit's data residual: the variance per
    residual times its autocorrelation time (the residuals of a replay are
    not independent samples), and the number of independent ones."""
    tau = max(1.0, refined["tau"])
    s2 = refined["rss"] / max(1, refined["n"] - refined["n_unknowns"]) * tau
    return max(s2, 1e-300), max(10.0, refined["n"] / tau)


def output_error_scores(fits: list, scale: tuple | None = None, ctx: Context | None = None) -> tuple | None:
    """Score the refined fits by output error (BIC on the replay's residual).

    ``score = rss / s2 + k ln n_eff`` with ``rss`` the sum of squares of the
    data residual (noise units; the coefficients' prior is a regulariser and
    not counted), ``k`` the parameters the cause
    adds and ``(s2, n_eff)`` = ``scale``, by default those of the refined fit
    whose residual is whitest (shortest autocorrelation time; as with the
    equation-error score, the residual of a model that lacks an effect is
    correlated by that effect and would hide it). Differences are on the
    2 ln Bayes-factor scale of the equation-error score. With ``ctx`` a cause
    chosen from many candidates also pays its search penalty
    (:meth:`~studies.discover.causes.base.Cause.search_penalty`). The
    equation-error score is kept in ``refined["equation_score"]``. Returns the scale used
    (None when no fit is refined).
    """
    refined = [f for f in fits if f.refined is not None]
    if not refined:
        return scale
    if scale is None:
        scale = _scale(min(refined, key=lambda f: f.refined["tau"]).refined)
    s2, n_eff = scale
    for f in refined:
        f.refined.setdefault("equation_score", f.score)
        f.score = f.refined["rss"] / s2 + f.cause.n_params() * np.log(n_eff)
        if ctx is not None:
            f.score += f.cause.search_penalty(ctx)
    return scale


def score_terms(ctx: Context, fit: CauseFit, terms: list) -> list[tuple]:
    """Score (Lagrange-multiplier) test of candidate terms at a refined fit.

    For every candidate term the replayed outputs' derivative with respect to
    its coefficient (at zero) is projected off the Jacobian of the fit's own
    unknowns (coefficients, cause parameters, initial states); the squared
    projection of the residual on it is the drop in the sum of squares that
    adding the term alone would give to first order. Returned as
    ``(term, evidence, coefficient)`` sorted by evidence, largest first, where
    ``evidence`` is that drop over ``s2`` (the fit's residual variance times
    its autocorrelation time, so on the scale of :func:`output_error_scores`)
    and ``coefficient`` the term's prime value of the linearised step (a
    start for the refinement). Costs one replay of all candidates per window
    and the fit's Jacobian.
    """
    ref = fit.refined
    prob = _Problem(ctx, fit, ref["windows"], ref["sigma"])
    x = np.concatenate([np.zeros(prob.nb + prob.nt), ref["states"]])
    jac, res = prob.jacobian(x), prob.residuals(x)
    b, theta, states = prob.split(x)
    model = prob.model.extended(terms, f"{prob.model.name}+candidates")
    names = [t.name for t in model.terms]
    beta = model.vector(dict(zip(prob.names, b)), 0.0)
    # perturbation of each coefficient: a tenth of the regression residual's force level
    rows = [w.record for w in prob.windows]
    columns = (np.concatenate([r[c].to_numpy(float) for r in rows]) for c in ("u", "v", "r", "delta"))
    primes = prime_states(*columns, ctx.vessel)
    level = dict(zip(("X", "Y", "N"), ctx.sigma))
    step = np.array([0.1 * level[t.dof] / max(float(np.sqrt(np.mean(t.feature(primes) ** 2))), 1e-12)
                     for t in terms])
    index = [names.index(t.name) for t in terms]
    pert = np.zeros((len(terms), len(names)))
    pert[np.arange(len(terms)), index] = step
    cols = []
    for i, w in enumerate(prob.windows):
        y = prob._window(w, np.vstack([beta, beta + pert]), theta, states[i], model)
        cols.append(((y[1:] - y[0]) / step[:, None]).T)
    g = np.vstack(cols + [np.zeros((prob.nb, len(terms)))])
    q, _ = np.linalg.qr(jac)
    g = g - q @ (q.T @ g)
    r = res - q @ (q.T @ res)
    gg = np.maximum(np.sum(g ** 2, axis=0), 1e-300)
    gr = g.T @ r
    s2, _ = _scale(ref)
    out = [(t, float(gr[j] ** 2 / gg[j] / s2), float(-gr[j] / gg[j])) for j, t in enumerate(terms)]
    return sorted(out, key=lambda x: -x[1])


def _autocorrelation_time(res: np.ndarray) -> float:
    """Largest integrated autocorrelation time over the channels of the data residual."""
    per = res.reshape(-1, len(CHANNELS))
    return max(integrated_time(per[:, k]) for k in range(per.shape[1]))


def refined_posterior(ctx: Context, fit: CauseFit, walkers: int = 6, steps: int = 40, burn: int = 15,
                      seed: int = 0) -> dict:
    """90 % intervals of a refined cause's parameters.

    The output-error residual is linearised in the nuisance unknowns (the
    coefficients and the windows' initial states) at the solution, so that
    for any trial of the cause's parameters they are profiled out by one
    projection; the likelihood is ``-cost(theta) / (2 s^2)`` with ``s^2`` the
    residual variance at the solution times the residuals' integrated
    autocorrelation time (they are not independent samples). emcee samples
    it (flat prior within the bounds). Added terms (``missing_term``) have no
    nonlinear parameter: their intervals are the Gaussian (Laplace) ones of
    the linearised fit.
    """
    ref = fit.refined
    prob = _Problem(ctx, fit, ref["windows"], ref["sigma"])
    x_star = np.concatenate([np.zeros(prob.nb + prob.nt), ref["states"]])
    jac = prob.jacobian(x_star)
    r_star = prob.residuals(x_star)
    n_data = len(r_star) - prob.nb
    tau = _autocorrelation_time(r_star[:n_data])
    s2 = float(np.sum(r_star ** 2)) / max(1, len(r_star) - jac.shape[1]) * tau
    nuisance = np.r_[0: prob.nb, prob.nb + prob.nt: jac.shape[1]]
    if prob.nt == 0:
        names = list(fit.cause.params)
        cov = s2 * np.linalg.pinv(jac.T @ jac)
        idx = [prob.names.index(n) for n in names]
        mid = np.array([prob.beta0[i] for i in idx])
        half = 1.645 * np.sqrt(np.maximum([cov[i, i] for i in idx], 0.0)) * prob.beta_scale[idx]
        return {"names": names, "q05": mid - half, "q50": mid, "q95": mid + half, "method": "linear",
                "tau": tau}
    q, _ = np.linalg.qr(jac[:, nuisance])
    low, high = prob.low, prob.high
    theta_index = slice(prob.nb, prob.nb + prob.nt)

    def log_prob(theta):
        if np.any(theta < low) or np.any(theta > high):
            return -np.inf
        x = x_star.copy()
        x[theta_index] = (theta - prob.theta0) / prob.theta_scale
        r = prob.residuals(x)
        r = r - q @ (q.T @ r)
        return -0.5 * float(r @ r) / s2

    k = prob.nt
    # start the walkers within the Laplace approximation's spread
    jt = jac[:, theta_index] - q @ (q.T @ jac[:, theta_index])
    sd = np.sqrt(np.diag(s2 * np.linalg.pinv(jt.T @ jt))) * prob.theta_scale
    walkers = max(walkers, 2 * k + 2)
    rng = np.random.default_rng(seed)
    start = prob.theta0 + 0.5 * sd * rng.standard_normal((walkers, k))
    start = np.clip(start, low + 1e-12, high - 1e-12)
    return {**sample_intervals(log_prob, start, burn, steps, seed), "tau": tau}
