"""Scoring the refined causes by their prediction-error likelihood.

The output-error fit (:mod:`.output_error`) replays windows of the training
records and takes the model as exact between the windows' starts. Records
with process noise (waves, gusts, whatever the model does not hold) drift
off any replay; the replay's residual is then mostly that drift, correlated
over minutes, and its sum of squares favours an extension that bends the
replay towards one record's drift (a current, a wind) over the one that is
right. Here every refined fit is scored instead by the likelihood of its
one-sample-ahead predictions, from an extended Kalman filter whose process
model is the simulator with the cause's wind, current, external forces and
rudder, and whose process noise absorbs the drift
(:mod:`studies.identify.filter_error`): white, or coloured (disturbance
accelerations with a correlation time) where the records' likelihood
prefers it (:meth:`FilterScores.estimate_shape`). When the model is right its
innovations are white, so the score is a plain BIC::

    score = -2 ln L + k ln(n) + penalty

with ``k`` the cause's own parameters, ``n`` the measured samples (six
channels per sample of the thinned records) and, for terms chosen from the
library, the search penalty of the extended BIC
(:meth:`~studies.discover.causes.base.Cause.search_penalty`). The measurement-noise
variances are the channels' noise levels at the records' resolution
(:func:`.output_error.noise_levels`); the process noise's spectral densities
on ``du``, ``v``, ``r`` are estimated by maximum likelihood on the baseline
(their shape, three values) and every fit then gets its own overall scale by
maximum likelihood, so an extension that explains the drift needs less of
it. Differences are on the 2 ln Bayes-factor scale of the other scores.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize

from ..data.resample import block_means
from ..identify.filter_error import PredictionError
from ..simulate.simulator import ReplayPlan
from .fitting import CauseFit, Context, training_error
from .output_error import noise_floors

__all__ = ["FilterScores", "REPLAY_GUARD"]

log = logging.getLogger(__name__)

#: the noises' search stops when -ln L changes by less than this share of it (1e-5: about one
#: unit of log-likelihood on records of 10^5; the causes are compared under the noises held)
NOISE_FTOL = 1e-5
#: the coloured process noise's search starts at this many filter steps of correlation time
COLOURED_START = 10.0

#: a filter-error refinement is refused when its windowed replay of the training
#: records errs more than this many times its start's
REPLAY_GUARD = 2.0


def _measured(record, velocities: bool = True) -> np.ndarray:
    """``x0, y0, psi`` (unwrapped), ``u, v, r`` of a record as an (n, 6) array;
    without ``velocities``, ``u, v, r`` are NaN (not measured: the filter
    skips them)."""
    z = np.column_stack([record["x0"].to_numpy(float), record["y0"].to_numpy(float),
                         np.unwrap(record["psi"].to_numpy(float)), record["u"].to_numpy(float),
                         record["v"].to_numpy(float), record["r"].to_numpy(float)])
    if not velocities:
        z[:, 3:] = np.nan
    return z


class FilterScores:
    """Prediction-error scores of refined fits on the training records of ``ctx``.

    Parameters
    ----------
    ctx : Context
        The vessel, the baseline model and the training records.
    step : float
        Sampling [s] the records are thinned to (block means), the filter's step.
    sigma : ndarray (6,)
        Noise standard deviations of ``x0, y0, psi, u, v, r`` at that sampling.
    records : list of DataFrame, optional
        The records scored (default the training records; the validation
        records for :meth:`held_out`).
    drift : bool
        Let the track and heading drift from the integral of the velocities
        (process noise on ``x0, y0, psi`` as well, by maximum likelihood in
        :meth:`estimate_shape`): what measured records need, whose sensors
        disagree by small biases and scale factors (the discovery on the
        tracks). False: process noise on the velocities only (the earlier
        search, ``discover.method=search``).
    velocities : bool
        Measure ``u, v, r`` as well as the track and heading. False for
        velocities derived from the track (their noise is the track's, which
        the filter would otherwise weigh twice): the filter then infers them.
    coloured : bool
        Let the process noise on ``du, v, r`` be coloured: a disturbance
        acceleration whose correlation time :attr:`tau` is estimated with the
        noises (:meth:`estimate_shape`; white is its limit). Waves, gusts and
        a model's own errors push a ship for seconds to minutes; taken as
        white, such a push looks like a constant force or a missing term to
        the filter, and is credited to a cause. The polynomial baseline's
        filter only (:mod:`studies.identify.filter_error`).
    """

    def __init__(self, ctx: Context, step: float, sigma: np.ndarray, records: list | None = None,
                 drift: bool = False, velocities: bool = True, coloured: bool = False):
        self.ctx = ctx
        self.drift = bool(drift)
        self.velocities = bool(velocities)
        self.records = []
        for rec in (ctx.train if records is None else records):
            thin = block_means(rec, step)
            thin.attrs = dict(rec.attrs)
            self.records.append(thin)
        self.step = float(np.median(np.diff(self.records[0]["t"].to_numpy(float))))
        self.measured = [_measured(r, self.velocities) for r in self.records]
        self.R = np.asarray(sigma, float) ** 2
        self.n = int(sum(np.isfinite(z).sum() for z in self.measured))
        self.q_shape = None
        #: correlation time [s] of the process noise on du, v, r (0: white); estimated with the
        #: noises when ``coloured`` (estimate_shape)
        self.tau = 0.0
        self.coloured = bool(coloured)
        self._tau_tried = 0.0
        self._plain = {}
        self._bare = replace(ctx, train=[])

    def _plans(self, fit: CauseFit) -> list:
        """Each training record's replay as the fit's cause reads it."""
        setup = fit.cause.setup(self._bare, np.asarray(fit.theta, float))
        model = setup.model
        dynamics = self.ctx.dynamics
        if dynamics is not None:
            # the MMG model as the filter's process model (a baseline's dynamics)
            return [dynamics.filter_plan(model, setup.sim_record(rec), setup.environment(rec), setup.external())
                    for rec in self.records]
        out = []
        for i, rec in enumerate(self.records):
            key = (i, id(model))
            if key not in self._plain:
                # one integration step per sample of this record (records thinned to the same
                # step differ in its last digits: Froude-scaled sampling)
                own = float(np.median(np.diff(rec["t"].to_numpy(float))))
                self._plain[key] = (model, ReplayPlan(model, self.ctx.vessel, rec, max_step=own * (1.0 + 1e-6)))
            seen = setup.sim_record(rec)
            out.append(self._plain[key][1].variant(None if seen is rec else seen, setup.environment(rec),
                                                   setup.external()))
        return out

    def _default_shape(self) -> np.ndarray:
        """A starting shape of the process noise: per DOF, the square of a
        hundredth of the records' acceleration (finite differences of the
        thinned velocities), over a second; on the track and heading, a
        hundredth of their measurement noise's variance per second."""
        acc = [np.concatenate([np.diff(r[c].to_numpy(float)) / self.step for r in self.records])
               for c in ("u", "v", "r")]
        dynamic = [max(np.sqrt(np.mean(a ** 2)) * 1e-2, 1e-12) ** 2 for a in acc]
        if not self.drift:
            return np.array(dynamic)
        kinematic = [max(1e-2 * self.R[j], 1e-16) for j in range(3)]
        return np.array(dynamic + kinematic)

    def _expand(self, logs: np.ndarray) -> np.ndarray:
        """The process noise's log scales per density from those searched: with
        ``drift``, six (du, v, r, x0, y0, psi) from five, the track's two sharing one."""
        logs = np.asarray(logs, float)
        if not self.drift:
            return logs
        return np.array([logs[0], logs[1], logs[2], logs[3], logs[3], logs[4]])

    def _likelihood(self, fit: CauseFit) -> PredictionError:
        return PredictionError(self._plans(fit), self.measured, self.R,
                               self.q_shape if self.q_shape is not None else self._default_shape(), self.tau)

    def estimate_shape(self, fit: CauseFit, rounds: int = 2, decide: bool = False) -> np.ndarray:
        """The process noise's spectral densities (three, six with ``drift``)
        and the measurement-noise variances by maximum likelihood on ``fit``
        (the baseline), jointly (SciPy's Powell search over their log10
        scales: the track's two process densities and its two noise levels
        each share one, a channel not measured has none); the process noise
        is kept as the shape every fit is scaled from. The measurement noise
        starts from the levels given (:func:`.output_error.noise_levels`),
        which a smoothing of the records misjudges when the noise is coloured
        or the signal sharp, and a heading's when its rate is derived from
        it; the process noise and a white measurement noise are told apart by
        the innovations' correlation, which only the joint likelihood weighs.
        ``rounds``: the searches, each from the last one's end; the first
        from the last estimate, if any.

        With :attr:`coloured`, the process noise is white or coloured
        (:attr:`tau`), whichever is the likelier by more than the BIC's
        penalty of the correlation time (one more parameter): decided at the
        first estimate and again when ``decide``."""
        vector = fit.setup.model.vector(fit.params, 0.0)
        # from the last estimate, if any (the same records under a model refined since)
        q0 = self._default_shape() if self.q_shape is None else self.q_shape
        groups = self._noise_groups()
        like = PredictionError(self._plans(fit), self.measured, self.R, q0, self.tau)
        _, a = like.fit(vector)
        nq = 5 if self.drift else 3
        nr = len(groups)
        R0 = self.R.copy()

        def unpack(x):
            r = R0.copy()
            for g, cols in enumerate(groups):
                r[cols] = R0[cols] * 10.0 ** x[nq + g]
            tau = 10.0 ** x[nq + nr] if len(x) > nq + nr else 0.0
            return q0 * 10.0 ** self._expand(x[:nq]), r, tau

        def cost(x):
            like.q0, like.R, like.tau = unpack(x)
            ll = like.loglik(vector, 0.0)
            return -ll if np.isfinite(ll) else 1e300

        # no channel below the floor of a sensor's resolution (noise_floors)
        floor = noise_floors(self.ctx.vessel) ** 2
        lowest = [min(0.0, max(-2.0, float(np.log10(np.max(floor[g] / R0[g]))))) for g in groups]
        bounds = [(a - 6.0, a + 4.0)] * nq + [(low, 2.0) for low in lowest]

        def search(x, bounds, rounds):
            x = np.clip(x, [b[0] for b in bounds], [b[1] for b in bounds])
            for _ in range(rounds):
                res = minimize(cost, x, method="Powell", bounds=bounds,
                               options={"xtol": 0.05, "ftol": NOISE_FTOL, "maxfev": 150 * len(x)})
                x = res.x
                log.debug("noises: %d evaluations, -ln L %.2f", res.nfev, res.fun)
            return x, float(cost(x))

        x = np.concatenate([np.full(nq, a), np.zeros(nr)])
        # the correlation time in log10 seconds, from a tenth of the step to ten minutes
        tau_bounds = (float(np.log10(0.1 * self.step)), float(np.log10(600.0)))
        coloured = bounds + [tau_bounds]
        if self.tau > 0.0:
            x, best = search(np.append(x, np.log10(self.tau)), coloured, rounds)
        else:
            x, best = search(x, bounds, rounds)
        if self.coloured and (decide or self.q_shape is None):
            # white and coloured process noise are not nested (over a filter step a coloured push is
            # held, white noise accumulates): the other one, searched from this one's end (the
            # dynamic densities' common scale, and the correlation time), is kept when its
            # likelihood is the higher by more than the BIC's penalty of the correlation time
            was_coloured = self.tau > 0.0
            start = np.log10(self._tau_tried or COLOURED_START * self.step)
            other, value = self._other_noise(cost, x[:nq + nr], None if was_coloured else start, tau_bounds)
            white, col = (value, best) if was_coloured else (best, value)
            if not was_coloured:
                self._tau_tried = 10.0 ** other[-1]
            log.info("process noise: -ln L %.2f white, %.2f coloured (correlation time %.3g s)", white, col,
                     self.tau if was_coloured else self._tau_tried)
            if (col < white - 0.5 * np.log(max(self.n, 2))) != was_coloured:
                x, best = other, value
        self.q_shape, self.R, self.tau = unpack(x)
        log.info("process noise of the baseline: q = %s, correlation time %.3g s; measurement noise sd %s; "
                 "-ln L %.2f", np.array2string(self.q_shape, precision=3), self.tau,
                 np.array2string(np.sqrt(self.R), precision=3), best)
        return self.q_shape

    @staticmethod
    def _other_noise(cost, x: np.ndarray, log_tau: float | None, tau_bounds: tuple) -> tuple:
        """The other process noise's search from the noises ``x`` (log10 scales,
        white's layout): the three dynamic densities' common scale, and with
        ``log_tau`` (the coloured noise's start) the correlation time; the rest
        held. ``(x of the other's layout, -ln L)``."""
        def full(y):
            z = np.asarray(x, float).copy()
            z[:3] += y[0]
            return z if log_tau is None else np.append(z, y[1])

        y0 = [0.0] if log_tau is None else [0.0, float(np.clip(log_tau, *tau_bounds))]
        bounds = [(-3.0, 3.0)] + ([] if log_tau is None else [tau_bounds])
        res = minimize(lambda y: cost(full(y)), y0, method="Powell", bounds=bounds,
                       options={"xtol": 0.05, "ftol": 1e-6, "maxfev": 60 * len(y0)})
        return full(res.x), float(res.fun)

    def _noise_groups(self) -> list:
        """The measured channels' groups of one measurement-noise scale: the
        track (``x0, y0``), the heading, then each velocity measured."""
        measured = np.zeros(6, bool)
        for z in self.measured:
            measured |= np.isfinite(z).any(axis=0)
        groups = [[0, 1], [2]] + [[j] for j in (3, 4, 5)]
        return [g for g in groups if measured[g].all()]

    def held_out(self, fits: list, training: "FilterScores") -> None:
        """Keep in ``refined["filter"]["held_out_loglik"]`` the log-likelihood of
        this scorer's records (the held-out ones) under every fit scored by
        ``training``: how well each model predicts records it was not fitted
        to, one sample ahead, whatever drift the process noise gives them.
        The process noise has the shape estimated on the training records and
        its scale, for every fit, the likeliest on these records: a scale
        carried over from the training records would make a model that fits
        them closely overconfident on a manoeuvre it extrapolates to, and
        favour a poorer model that needed more process noise. -inf when a
        prediction leaves the physical range."""
        self.q_shape, self.tau = training.q_shape, training.tau
        for f in fits:
            info = (f.refined or {}).get("filter")
            if info is None:
                continue
            ll, a = self._likelihood(f).fit(f.setup.model.vector(f.params, 0.0))
            info["held_out_loglik"], info["held_out_log_q_scale"] = ll, a

    def score(self, fits: list) -> None:
        """Set ``score`` (``-2 ln L + k ln n``) of every refined fit, and keep
        ``refined["filter"]``: the log-likelihood and the process noise's log10 scale."""
        for f in fits:
            if f.refined is None or f.setup.dynamics is not None:
                continue
            if self.q_shape is None:
                self.estimate_shape(f)
            ll, a = self._likelihood(f).fit(f.setup.model.vector(f.params, 0.0))
            f.refined["filter"] = {"loglik": ll, "log_q_scale": a}
            f.score = -2.0 * ll + f.cause.n_params() * np.log(self.n) + f.cause.search_penalty(self.ctx)

    def refine(self, fit: CauseFit, max_nfev: int = 20, rounds: int = 2) -> CauseFit:
        """``fit`` refined by the filter-error method: its coefficients and the
        cause's parameters fitted to the training records' innovations (their
        sum of squares, each over its standard deviation; the weak prior of
        :mod:`.output_error` on the coefficients' relative changes), with the
        process noise's scale held at the likeliest for the fit as it stands
        and estimated again between ``rounds`` (``max_nfev`` evaluations in
        all), then scored (:meth:`score`). The coefficients change where the
        replay's drift had bent them."""
        start = fit
        for _ in range(rounds):
            fit = self._refine_once(fit, max(2, max_nfev // rounds))
        before, after = training_error(self.ctx, start), training_error(self.ctx, fit)
        if not after <= REPLAY_GUARD * before:
            # coloured sensor noise taken for process noise lets the filter follow a model
            # that no longer predicts: keep the start
            log.info("cause %-18s filter error refused: its replay of the training records errs %.4g m "
                     "against %.4g m", fit.cause.id, after, before)
            fit = start
        self.score([fit])
        return fit

    def _refine_once(self, fit: CauseFit, max_nfev: int) -> CauseFit:
        from scipy.optimize import least_squares

        if self.q_shape is None:
            self.estimate_shape(fit)
        cause, model = fit.cause, fit.setup.model
        names = [t.name for t in model.terms]
        beta0 = model.vector(fit.params, 0.0)
        beta_scale = np.maximum(np.abs(beta0), 1e-6)
        theta0 = np.asarray(fit.theta, float)
        nb, nt = len(beta0), len(theta0)
        low, high = cause.bounds(self.ctx) if nt else (np.zeros(0), np.zeros(0))
        theta_scale = np.maximum(np.abs(theta0), cause.scales(self.ctx)) if nt else np.zeros(0)
        _, a = self._likelihood(fit).fit(beta0)
        cache = {}

        def like(theta):
            key = tuple(np.round(theta, 15))
            if key not in cache:
                if len(cache) > 16:
                    cache.clear()
                cache[key] = self._likelihood(replace(fit, theta=np.asarray(theta, float)))
            return cache[key]

        def residuals(x):
            beta = beta0 + x[:nb] * beta_scale
            theta = theta0 + x[nb:] * theta_scale
            return np.concatenate([like(theta).residuals(beta, a), x[:nb]])

        lo = np.full(nb + nt, -np.inf)
        hi = np.full(nb + nt, np.inf)
        if nt:
            lo[nb:] = (low - theta0) / theta_scale
            hi[nb:] = (high - theta0) / theta_scale
        x0 = np.clip(np.zeros(nb + nt), lo, hi)
        res = least_squares(residuals, x0, bounds=(lo, hi), method="trf", x_scale=1.0, diff_step=1e-4,
                            max_nfev=max_nfev, ftol=1e-4, xtol=1e-6)
        beta = beta0 + res.x[:nb] * beta_scale
        theta = theta0 + res.x[nb:] * theta_scale
        out = replace(fit, theta=theta, params={**fit.params, **dict(zip(names, beta.tolist()))},
                      setup=cause.setup(self.ctx, theta), validation={}, refined=dict(fit.refined or {}))
        log.info("cause %-18s filter error: %d evaluations at process-noise scale 10^%.2f", cause.id, res.nfev, a)
        return out

    def initial_loglik(self, fit: CauseFit, log_scale: float) -> float:
        """Log-likelihood of ``fit`` as it stands at a given process-noise scale (one filter pass)."""
        return self._likelihood(fit).loglik(fit.setup.model.vector(fit.params, 0.0), log_scale)

    def posterior(self, fit: CauseFit, walkers: int = 6, steps: int = 40, burn: int = 15, seed: int = 0) -> dict:
        """90 % intervals of the cause's parameters from the prediction-error
        likelihood, the coefficients profiled out.

        The standardised innovations are linearised in the coefficients at
        the solution (a finite-difference Jacobian), so that for any trial of
        the cause's parameters the coefficients are profiled out by one
        projection; with the process noise at the fit's scale the innovations
        are of unit variance, and the log-likelihood is ``-1/2`` their
        projected sum of squares. emcee samples it (flat prior within the
        bounds). Added terms (``missing_term``) have no nonlinear parameter:
        their intervals are the Gaussian (Laplace) ones of the linearised fit.
        """
        from .fitting import sample_intervals

        cause, model = fit.cause, fit.setup.model
        beta = model.vector(fit.params, 0.0)
        theta = np.asarray(fit.theta, float)
        a = fit.refined["filter"]["log_q_scale"]
        like = self._likelihood(fit)
        r0 = like.residuals(beta, a)
        scale = np.maximum(np.abs(beta), 1e-6)
        columns = []
        for j in range(len(beta)):
            b = beta.copy()
            b[j] += 1e-4 * scale[j]
            columns.append((like.residuals(b, a) - r0) / 1e-4)
        jb = np.column_stack(columns)
        if not len(theta):
            names = list(cause.params)
            idx = [[t.name for t in model.terms].index(n) for n in names]
            cov = np.linalg.pinv(jb.T @ jb)
            half = 1.645 * np.sqrt(np.maximum(np.diag(cov)[idx], 0.0)) * scale[idx]
            mid = beta[idx]
            return {"names": names, "q05": mid - half, "q50": mid, "q95": mid + half, "method": "linear"}
        q, _ = np.linalg.qr(jb)
        low, high = cause.bounds(self.ctx)

        def log_prob(th):
            if np.any(th < low) or np.any(th > high):
                return -np.inf
            r = self._likelihood(replace(fit, theta=np.asarray(th, float))).residuals(beta, a)
            r = r - q @ (q.T @ r)
            return -0.5 * float(r @ r)

        # the walkers start within the Laplace approximation's spread of the parameters
        t_scale = np.maximum(np.abs(theta), 1e-6)
        cols = []
        for j in range(len(theta)):
            th = theta.copy()
            th[j] += 1e-4 * t_scale[j]
            cols.append((self._likelihood(replace(fit, theta=th)).residuals(beta, a) - r0) / (1e-4 * t_scale[j]))
        jt = np.column_stack(cols)
        jt = jt - q @ (q.T @ jt)
        sd = np.sqrt(np.maximum(np.diag(np.linalg.pinv(jt.T @ jt)), 1e-30))
        walkers = max(walkers, 2 * len(theta) + 2)
        rng = np.random.default_rng(seed)
        start = theta + 0.5 * sd * rng.standard_normal((walkers, len(theta)))
        start = np.clip(start, low + 1e-12, high - 1e-12)
        return sample_intervals(log_prob, start, burn, steps, seed)
