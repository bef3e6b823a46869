"""The prediction-error filter on the measured records, with its noises
estimated: how every model of a discovery on the tracks is scored
(:mod:`.innovations`, :mod:`.track_inference`).

Each record is thinned to the filter's step and run through an extended
Kalman filter whose process model is the simulator with the cause's wind,
current, external forces and rudder, or the MMG model
(:mod:`studies.identification.filter_error`, :mod:`studies.identification.mmg_filter`).
Its process noise absorbs what the model does not hold (waves, gusts, the
model's own errors): white, or coloured (disturbance accelerations with a
correlation time) where the records' likelihood prefers it
(:meth:`FilterScores.estimate_shape`). The measurement-noise variances
start from the channels' noise levels at the filter's step
(:func:`.noise_levels.noise_levels`); the process noise's spectral
densities on ``du``, ``v``, ``r`` (their shape) and both noises' levels
are then estimated by maximum likelihood under the baseline, and every
model is compared at the noises so held, its own overall process-noise
scale the likeliest for it.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize

from ..data.resample import block_means
from ..identification.filter_error import PredictionError, filter_all
from ..simulate.simulator import ReplayPlan
from .fitting import CauseFit, Context
from .noise_levels import noise_floors

__all__ = ["FilterScores"]

log = logging.getLogger(__name__)

#: the noises' search stops when -ln L changes by less than this share of it in an iteration
#: (1e-7: about 0.005 unit of log-likelihood on three records of 600 s at 1 s steps, -ln L near
#: 5 10^4; the causes are compared under the noises held. At 1e-6 the search took 11-36 % fewer
#: filters but stopped 1.1 units short of the maximum, which a cause could then be credited with:
#: tests/test_discover_baseline_on_tracks.py)
NOISE_FTOL = 1e-7
#: step [log10 units] of the finite differences that give the noises' search its gradient
NOISE_STEP = 1e-3
#: trials of one line search (SciPy's default 20). Near the maximum the forward differences'
#: error leaves no descent along the gradient they give: every trial of the failing line searches
#: is a filter run of every record per noise (plus one), and the search ends when two have failed
#: (L-BFGS-B's abnormal termination). Measured on the timing seeds: the searches ended at the same
#: -ln L to its last printed digit with a third to a half fewer evaluations where they ended so
NOISE_LINE_SEARCH = 5
_SEARCH = {"eps": NOISE_STEP, "ftol": NOISE_FTOL, "gtol": 1e-2, "maxls": NOISE_LINE_SEARCH}
#: the coloured process noise's search starts at this many filter steps of correlation time
COLOURED_START = 10.0


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


def _difference_points(x: np.ndarray, bounds: list) -> list:
    """The points of a forward-difference gradient at ``x``: each coordinate
    moved by :data:`NOISE_STEP`, backward where that leaves its bounds (as
    SciPy's L-BFGS-B differences by itself)."""
    x = np.asarray(x, float)
    out = []
    for j, (low, high) in enumerate(bounds):
        p = x.copy()
        h = NOISE_STEP if x[j] + NOISE_STEP <= high or x[j] - NOISE_STEP < low else -NOISE_STEP
        p[j] = x[j] + h
        out.append(p)
    return out


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
    drift : bool
        Let the track and heading drift from the integral of the velocities
        (process noise on ``x0, y0, psi`` as well, by maximum likelihood in
        :meth:`estimate_shape`): what measured records need, whose sensors
        disagree by small biases and scale factors (the discovery on the
        tracks). False: process noise on the velocities only.
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
        the filter, and is credited to a cause (the polynomial models' filter,
        :mod:`studies.identification.filter_error`, and the MMG model's,
        :mod:`studies.identification.mmg_filter`).
    """

    def __init__(self, ctx: Context, step: float, sigma: np.ndarray,
                 drift: bool = False, velocities: bool = True, coloured: bool = False):
        self.ctx = ctx
        self.drift = bool(drift)
        self.velocities = bool(velocities)
        self.records = []
        for rec in ctx.train:
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
        #: the context without its records: what a cause's model and forces need (a replay takes the thinned records)
        self.bare = replace(ctx, train=[])

    def _plans(self, fit: CauseFit) -> list:
        """Each training record's replay as the fit's cause reads it."""
        setup = fit.cause.setup(self.bare, np.asarray(fit.theta, float))
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
        (the baseline), jointly (SciPy's L-BFGS-B search over their log10
        scales: the track's two process densities and its two noise levels
        each share one, a channel not measured has none); the process noise
        is kept as the shape every fit is scaled from. The measurement noise
        starts from the levels given (:func:`.noise_levels.noise_levels`),
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

        def cost_and_gradient(x, bounds):
            # -ln L and its forward differences (steps of NOISE_STEP, backward at an upper bound),
            # every filter of them run side by side
            points = [np.asarray(x, float)] + _difference_points(x, bounds)
            done = filter_all([(like.with_noises(*unpack(p)), vector, 0.0) for p in points])
            values = np.array([-ll if np.isfinite(ll) else 1e300 for ll in map(PredictionError.total, done)])
            steps = np.array([p[j] - x[j] for j, p in enumerate(points[1:])])
            return values[0], (values[1:] - values[0]) / steps

        def search(x, bounds, rounds):
            x = np.clip(x, [b[0] for b in bounds], [b[1] for b in bounds])
            for _ in range(rounds):
                # the same budget of filter evaluations as a search that differences by itself
                res = minimize(cost_and_gradient, x, args=(bounds,), jac=True, method="L-BFGS-B", bounds=bounds,
                               options=_SEARCH | {"maxfun": 150 * len(x) // (len(x) + 1)})
                x = res.x
                log.debug("noises: %d evaluations, -ln L %.2f", res.nfev * (len(x) + 1), res.fun)
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
        res = minimize(lambda y: cost(full(y)), y0, method="L-BFGS-B", bounds=bounds,
                       options=_SEARCH | {"maxfun": 60 * len(y0)})
        return full(res.x), float(res.fun)

    def _noise_groups(self) -> list:
        """The measured channels' groups of one measurement-noise scale: the
        track (``x0, y0``), the heading, then each velocity measured."""
        measured = np.zeros(6, bool)
        for z in self.measured:
            measured |= np.isfinite(z).any(axis=0)
        groups = [[0, 1], [2]] + [[j] for j in (3, 4, 5)]
        return [g for g in groups if measured[g].all()]
