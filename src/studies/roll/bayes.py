"""Bayesian identification of the roll-decay model (``model=roll method=bayes``), sampled with emcee.

Likelihood. Output error: every training decay is replayed by the compiled
RK4 simulator (:func:`studies.roll.model.compiled_rk4`) from its own initial
state ``(phi0, phi0')``, sampled with the coefficients, and compared with the
measured angle at :data:`POINTS_PER_PERIOD` evenly spaced samples per roll
period. The residual ``r`` of each record is an AR(2) process,

    r_i = a1 r_{i-1} + a2 r_{i-2} + e_i,   e_i ~ N(0, sigma^2) independent,

with the AR coefficients and ``sigma`` estimated jointly with the
coefficients: ``sigma`` is integrated out under the Jeffreys prior and the
first two samples of each record are conditioned on, so that::

    log L = -(m - 2 R)/2 log sum_i e_i^2        (R records, m samples)

The AR(2) is sampled through its partial autocorrelations ``pacf1``,
``pacf2`` in (-1, 1) with flat priors (every stationary AR(2)), in the
coordinates ``atanh(pacf)`` (with the Jacobian of the change) so that
residuals near the unit circle mix as well as others; the coefficients and
initial states have flat priors (``omega0 > 0``).

Why output error. The coefficients keep the meaning of NLS (Chen et al.
2019): the constant-coefficient decay closest to the record. A
prediction-error (Kalman filter) likelihood with a model discrepancy in the
state weighs the one-step dynamics instead; on test 21338 the mean damping
then traded against the discrepancy and came out with the wrong amplitude
dependence (``b2 < 0``; :mod:`studies.roll.discrepancy`).

Why AR(2). A likelihood that takes the residuals as independent treats the
model as exact: on a measured decay the noise level it finds is what the
model cannot follow (0.1-0.3 deg on the SSPA KVLCC2 tests against the
sensor's 0.006 deg) and its intervals are far too narrow. That residual is
not white: it is a narrow-band oscillation at the roll frequency whose
envelope changes slowly (the period drift and the damping the ``b1 + b2``
model cannot follow). On a grid of :data:`POINTS_PER_PERIOD` = 20 samples
per period an AR(2) represents it as a resonance at the roll frequency
(complex roots of modulus 0.94-0.98 on the KVLCC2 tests); the Gauss-Newton
standard errors of ``b1`` and ``b2`` whitened by it are 3.7-6.2 times the
independent-residual ones there and unchanged on a simulated decay with
white noise (partial autocorrelations near zero). On finer grids the AR(2)
describes the residual's smoothness from one sample to the next instead of
its oscillation (one real root near 1, one small) and its standard errors
fall towards the independent ones as the grid gets finer (measured on the
first 70 % of test 21338: se of ``b2`` 0.027, 0.026, 0.017, 0.009, 0.005 at
15, 20, 30, 50, 80 samples per period; 0.046, 0.040, 0.025, 0.014, 0.009 on
21337); the coarse grid is where the estimate has settled. An AR(1) cannot
represent an oscillating residual, and the tempering of the manoeuvring
regression posterior by the residual's integrated autocorrelation time
does not fit either: positive and negative lags of an oscillation cancel
(4 samples on 21338), while that of the score (residual times sensitivity)
is dominated by slow drifts (110-390 samples for ``omega0``), which
flattened the posterior into nonsense (``b2`` up to 12). A narrow-band
continuous-time residual (quasi-periodic Ornstein-Uhlenbeck, independent
of the grid) was tried as well: with its correlation time free it became a
persistent sinusoid that shifted ``omega0`` (to 2.479 rad/s on 21338,
against 2.468 for NLS) and spread ``b2`` over 0.02-0.15.

What it cannot represent. The AR(2) widens the intervals of a wrong model's
coefficients; it does not make the model right: replays with posterior
coefficients alone still lose a measured decay within cycles. That is the
model discrepancy of the predictive bands (``method.discrepancy=process_noise``:
:mod:`studies.roll.discrepancy`, estimated after the coefficients, on the
training decays only).

Sampling. emcee (:func:`studies.identification.bayes.sampler.sample_regression_chain`,
the manoeuvring regression's run: differential-evolution moves by default,
walkers started in a ball of ``init_scale`` standard errors) in the
coordinates ``(x - x_0) / se``: ``x_0`` the NLS solution
(:class:`studies.roll.estimators.NLSEstimator`, coefficients and initial
states) with the AR(2) of its residual, ``se`` the Gauss-Newton standard
errors of the whitened residual from finite-difference sensitivities.
Convergence as for the manoeuvring posterior
(:func:`studies.identification.bayes.diagnostics.diagnose`).

References
----------
Chen, C. et al. (2019). Ocean Engineering 191, 106479 (the model; NLS).

Foreman-Mackey, D., Hogg, D.W., Lang, D., Goodman, J. (2013). emcee: the
MCMC hammer. PASP 125(925), 306-312.

Box, G.E.P., Jenkins, G.M., Reinsel, G.C. (2008). Time series analysis,
4th ed. Wiley (AR(2) with complex roots, conditional likelihood, ch. 3 and 7).

Barndorff-Nielsen, O., Schou, G. (1973). On the parametrization of
autoregressive models by partial autocorrelations. J. Multivariate
Analysis 3, 408-419.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Sequence

import numpy as np
import pandas as pd

from studies.errors import ConfigError
from studies.identification.bayes.sampler import sample_regression_chain
from studies.roll.discrepancy import DISCREPANCIES, estimate_wander
from studies.roll.estimators import NLSEstimator, _Estimator, _period
from studies.roll.model import NO_WANDER, RollModel, compiled_decays_sse, compiled_rk4

__all__ = ["BayesRollEstimator", "DecayPosterior", "POINTS_PER_PERIOD", "pacf_to_ar", "ar2_fit"]

logger = logging.getLogger(__name__)

#: compared samples per roll period of the output-error likelihood
POINTS_PER_PERIOD = 20
#: RK4 steps per natural period (as :meth:`RollModel.simulate`)
STEPS_PER_PERIOD = 60


def pacf_to_ar(pacf1, pacf2):
    """AR(2) coefficients ``(a1, a2)`` of partial autocorrelations in (-1, 1)
    (Barndorff-Nielsen & Schou 1973): ``a2 = pacf2``, ``a1 = pacf1 (1 - pacf2)``."""
    return pacf1 * (1.0 - pacf2), pacf2


def ar2_fit(residuals: Sequence[np.ndarray]) -> tuple[float, float]:
    """Partial autocorrelations ``(pacf1, pacf2)`` of the least-squares AR(2) of
    residual series (pooled), clipped inside (-0.99, 0.99)."""
    rows = [np.column_stack((r[1:-1], r[:-2])) for r in residuals if r.size > 4]
    rhs = [r[2:] for r in residuals if r.size > 4]
    if not rows:
        return 0.0, 0.0
    a1, a2 = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    pacf2 = float(np.clip(a2, -0.99, 0.99))
    pacf1 = float(np.clip(a1 / (1.0 - pacf2), -0.99, 0.99))
    return pacf1, pacf2


class DecayPosterior:
    """Output-error log-posterior of the roll coefficients, initial states and AR(2) residual.

    Parameters
    ----------
    model : RollModel
        Which terms are identified.
    records : sequence of DataFrame
        Prepared training decays.
    start : dict
        The NLS coefficients (the centre of the sampled coordinates).
    initial_states : sequence of (phi0, dphi0)
        The NLS initial state of each record [rad, rad/s].
    points_per_period : int
        Compared samples per roll period.
    max_steps : int, optional
        A chain shorter than 50 autocorrelation times runs on by itself up to
        this many steps after burn-in (``method.max_steps``); None: never.
    autoregressive : bool
        AR(2) residuals (module docstring); ``False`` takes them as
        independent (``pacf1 = pacf2 = 0``, not sampled).

    Attributes
    ----------
    names : list of str
        Sampled parameters: ``omega0``, the terms, ``phi0_<k>``,
        ``dphi0_<k>`` per record, then ``atanh_pacf1``, ``atanh_pacf2``
        (with ``autoregressive``).
    ndim : int
    x_ls, se : ndarray (ndim,)
        The starting point (NLS and the AR(2) of its residual) and the
        Gauss-Newton standard errors of the whitened residual.
    m : int
        Compared samples (all records).
    pacf_ls : (float, float)
        Partial autocorrelations of the NLS residual.
    sse_ls : float
        Sum of squared residuals at the NLS solution [rad^2].
    """

    def __init__(self, model: RollModel, records: Sequence[pd.DataFrame], start: dict, initial_states,
                 points_per_period: int = POINTS_PER_PERIOD, autoregressive: bool = True):
        self.model = model
        self.k = len(model.param_names)
        self.names = list(model.param_names)
        self.autoregressive = bool(autoregressive)
        period = 2.0 * math.pi / float(start["omega0"])
        self.data = []
        for j, rec in enumerate(records):
            t = rec["t"].to_numpy(float)
            step = max(1, int(round(period / points_per_period / float(t[1] - t[0]))))
            self.data.append((np.ascontiguousarray(t[::step]), rec["phi"].to_numpy(float)[::step].copy()))
            self.names += [f"phi0_{j}", f"dphi0_{j}"]
        self.n_states = len(self.names)
        if self.autoregressive:
            self.names += ["atanh_pacf1", "atanh_pacf2"]
        self.ndim = len(self.names)
        self.m = int(sum(t.size for t, _ in self.data))
        self.dof = self.m - 2 * len(self.data) if self.autoregressive else self.m
        x = [float(start[n]) for n in model.param_names]
        for s0 in initial_states:
            x += [float(s0[0]), float(s0[1])]
        self._kernel = compiled_rk4()
        self._batch = compiled_decays_sse()
        self._t_all = np.concatenate([t for t, _ in self.data])
        self._y_all = np.concatenate([y for _, y in self.data])
        self._offsets = np.cumsum([0] + [t.size for t, _ in self.data]).astype(np.int64)
        x = np.asarray(x, float)
        parts = self.residual_parts(x)
        self.sse_ls = float(sum(r @ r for r in parts))
        self.pacf_ls = ar2_fit(parts) if self.autoregressive else (0.0, 0.0)
        if self.autoregressive:
            x = np.concatenate((x, np.arctanh(self.pacf_ls)))
        self.x_ls = x
        a1, a2 = pacf_to_ar(*self.pacf_ls)
        sens = self._whiten(self.sensitivities(x[:self.n_states]), a1, a2)
        white = self._whiten(np.concatenate(parts)[:, None], a1, a2)[:, 0]
        cov = np.linalg.pinv(sens.T @ sens) * float(white @ white) / max(1, self.dof - self.n_states)
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        se = np.where(se > 0, se, np.abs(x[:self.n_states]) * 1e-9 + 1e-15)
        if self.autoregressive:
            # atanh of the partial autocorrelations: about 1 / sqrt(m) each
            se = np.concatenate((se, np.full(2, 1.0 / math.sqrt(self.m))))
        self.se = se

    # ------------------------------------------------------------ replays
    def _replay(self, x: np.ndarray, j: int) -> np.ndarray:
        b1, b2, b3, w2, c3 = self.model.coefficients(dict(zip(self.model.param_names, x[:self.k])))
        t, _ = self.data[j]
        w0 = math.sqrt(abs(w2)) if w2 != 0 else 1.0
        nsub = max(1, int(math.ceil(float(t[1] - t[0]) * w0 * STEPS_PER_PERIOD / (2 * math.pi) - 1e-9)))
        out = self._kernel(float(x[self.k + 2 * j]), float(x[self.k + 2 * j + 1]), t, b1, b2, b3, w2, c3,
                           nsub, NO_WANDER, NO_WANDER)
        return out[:, 0]

    def residual_parts(self, x: np.ndarray) -> list[np.ndarray]:
        """Measured minus replayed angle at the compared samples, per record [rad]."""
        return [y - self._replay(x, j) for j, (_, y) in enumerate(self.data)]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """:meth:`residual_parts` of every record, one after the other."""
        return np.concatenate(self.residual_parts(x))

    def _whiten(self, columns: np.ndarray, a1: float, a2: float) -> np.ndarray:
        """``c_i - a1 c_{i-1} - a2 c_{i-2}`` per record (the first two samples dropped),
        or ``columns`` unchanged without the AR(2)."""
        if not self.autoregressive:
            return columns
        out, offset = [], 0
        for t, _ in self.data:
            c = columns[offset:offset + t.size]
            out.append(c[2:] - a1 * c[1:-1] - a2 * c[:-2])
            offset += t.size
        return np.concatenate(out)

    def sensitivities(self, x: np.ndarray) -> np.ndarray:
        """``d phi / d x`` (m, coefficients + initial states) at the compared samples,
        central differences."""
        ref = np.maximum(np.abs(x), np.abs(x) * 1e-3 + 1e-8)
        out = np.empty((self.m, x.size))
        for c in range(x.size):
            h = 1e-6 * ref[c]
            up, down = x.copy(), x.copy()
            up[c] += h
            down[c] -= h
            out[:, c] = (self.residuals(down) - self.residuals(up)) / (2.0 * h)
        return out

    # ------------------------------------------------------------ posterior
    def values(self, z: np.ndarray) -> np.ndarray:
        """Parameters ``x_ls + z se`` of sampled coordinates (m, ndim)."""
        return self.x_ls + np.atleast_2d(z) * self.se

    def whitened_sse(self, x: np.ndarray) -> float:
        """Sum of the squared innovations ``e`` (with the AR(2)) or residuals [rad^2]."""
        parts = self.residual_parts(x)
        if not self.autoregressive:
            return float(sum(r @ r for r in parts))
        a1, a2 = pacf_to_ar(math.tanh(x[self.n_states]), math.tanh(x[self.n_states + 1]))
        return float(sum(np.sum((r[2:] - a1 * r[1:-1] - a2 * r[:-2]) ** 2) for r in parts))

    def log_prob(self, z: np.ndarray) -> np.ndarray:
        """Log-posterior (up to a constant) of walkers ``z`` (m, ndim): every walker's replay of
        every record in one compiled call (:func:`studies.roll.model.compiled_decays_sse`)."""
        xs = self.values(z)
        out = np.full(xs.shape[0], -np.inf)
        valid = (xs[:, 0] > 0) & np.all(np.isfinite(xs), axis=1)
        if not valid.any():
            return out
        x = xs[valid]
        coef = np.array([self.model.coefficients(dict(zip(self.model.param_names, row[:self.k]))) for row in x])
        starts = np.ascontiguousarray(x[:, self.k:self.n_states])
        if self.autoregressive:
            u = x[:, self.n_states:self.n_states + 2]
            a = np.column_stack(pacf_to_ar(np.tanh(u[:, 0]), np.tanh(u[:, 1])))
        else:
            a = np.zeros((x.shape[0], 2))
        sse = self._batch(coef, starts, self._t_all, self._y_all, self._offsets, np.ascontiguousarray(a),
                          self.autoregressive, float(STEPS_PER_PERIOD), NO_WANDER)
        with np.errstate(divide="ignore", invalid="ignore"):
            lp = np.where(np.isfinite(sse) & (sse > 0), -0.5 * self.dof * np.log(sse), -np.inf)
        if self.autoregressive:  # flat in pacf: the Jacobian of tanh
            lp = lp + np.sum(np.log1p(-np.tanh(u) ** 2), axis=1)
        out[valid] = lp
        return out


class BayesRollEstimator(_Estimator):
    """Posterior of the roll coefficients with emcee (``method=bayes``): see the module docstring.

    Parameters
    ----------
    terms : sequence of str
        Model terms.
    n_walkers : int, optional
        Walkers; default ``max(32, 2 ndim)`` (even), ``ndim`` = coefficients
        + 2 initial-state values per record.
    n_samples, burn_in, thin : int
        Posterior samples kept (all walkers), steps discarded, thinning: the
        chain after burn-in has ``thin * ceil(n_samples / n_walkers)`` steps.
    seed : int
        Seed of the sampler (the run's ``seed``).
    init_scale : float
        Radius of the initial ball [Gauss-Newton standard errors].
    moves : {"de", "stretch"}
        emcee moves.
    autocorr_correction : bool
        AR(2) residuals (module docstring); ``False`` takes them as
        independent (the model as exact).
    discrepancy : {"none", "process_noise"}
        ``process_noise``: estimate the coefficient wander of
        :mod:`studies.roll.discrepancy` on the training decays at the
        posterior medians, for the predictive bands.
    discrepancy_evaluations : int
        Most likelihood evaluations of each of its Powell searches.
    points_per_period : int
        Compared samples per roll period.

    Notes
    -----
    ``fit`` returns a :class:`~studies.roll.estimators.RollFit` whose
    ``params`` are the posterior medians; ``meta`` adds ``lower``/``upper``
    (5 and 95 % quantiles), ``samples`` (``names``, ``values`` of the
    coefficients, ``initial_states``), ``metrics`` (``bayes/roll/...``
    diagnostics), ``history`` (acceptance and autocorrelation time at
    checkpoints), ``discrepancy`` (a :class:`RollDiscrepancy` or None) and
    ``nls`` (the starting point).
    """

    name = "bayes"
    initial_state_source = "posterior median of the initial state, sampled with the coefficients"

    def __init__(self, terms: Sequence[str] = ("b1", "b2"), n_walkers: int | None = None,
                 n_samples: int = 10_000, burn_in: int = 500, thin: int = 12, seed: int = 0,
                 init_scale: float = 0.1, moves: str = "de", autocorr_correction: bool = True,
                 discrepancy: str = "none", discrepancy_evaluations: int = 300,
                 points_per_period: int = POINTS_PER_PERIOD, max_steps: int | None = None):
        super().__init__(terms, seed)
        if discrepancy not in DISCREPANCIES:
            raise ConfigError(f"method.discrepancy must be one of {', '.join(DISCREPANCIES)}, got {discrepancy!r}")
        if n_walkers is not None and (int(n_walkers) != n_walkers or n_walkers < 4 or n_walkers % 2):
            raise ConfigError(f"method.n_walkers must be an even integer >= 4, got {n_walkers!r}")
        for key, value, low in (("n_samples", n_samples, 1), ("burn_in", burn_in, 0), ("thin", thin, 1),
                                ("discrepancy_evaluations", discrepancy_evaluations, 1),
                                ("points_per_period", points_per_period, 4)):
            if int(value) != value or value < low:
                raise ConfigError(f"method.{key} must be an integer >= {low}, got {value!r}")
        if not init_scale > 0:
            raise ConfigError(f"method.init_scale must be positive, got {init_scale!r}")
        self.n_walkers = None if n_walkers is None else int(n_walkers)
        self.n_samples, self.burn_in, self.thin = int(n_samples), int(burn_in), int(thin)
        self.init_scale = float(init_scale)
        self.moves = str(moves)
        self.autocorr_correction = bool(autocorr_correction)
        self.discrepancy = str(discrepancy)
        self.discrepancy_evaluations = int(discrepancy_evaluations)
        self.points_per_period = int(points_per_period)
        if max_steps is not None and (int(max_steps) != max_steps or max_steps < 1):
            raise ConfigError(f"method.max_steps must be null or an integer >= 1, got {max_steps!r}")
        self.max_steps = None if max_steps is None else int(max_steps)

    def _prepare(self) -> None:
        compiled_rk4()

    def _fit(self, records):
        started = time.perf_counter()
        nls = NLSEstimator(self.terms)._fit(records)
        start, nls_meta = nls
        post = DecayPosterior(self.model, records, start, nls_meta["initial_states"], self.points_per_period,
                              self.autocorr_correction)
        walkers = self.n_walkers or max(32, 2 * post.ndim)
        chain, diag = sample_regression_chain(post, walkers, self.n_samples, self.burn_in, self.thin,
                                              self.init_scale, self.moves, self.seed, "roll", self.max_steps)
        values = post.values(chain)
        k = post.k
        names = list(self.model.param_names)
        q05, q50, q95 = np.quantile(values, [0.05, 0.5, 0.95], axis=0)
        params = dict(zip(names, q50[:k].tolist()))
        states = [(float(q50[k + 2 * j]), float(q50[k + 2 * j + 1])) for j in range(len(records))]
        resid = post.residuals(q50)
        metrics = diag.metrics("bayes/roll")
        metrics.update({
            "bayes/converged": float(diag.converged),
            "bayes/roll/compared_samples": float(post.m),
            "bayes/roll/residual_rms_deg": math.degrees(math.sqrt(float(resid @ resid) / post.m)),
            "bayes/roll/innovation_sd_deg": math.degrees(math.sqrt(post.whitened_sse(q50) / post.dof)),
            "bayes/roll/walkers": float(walkers),
            "bayes/roll/steps": float(self.burn_in + diag.steps),
            "bayes/roll/autocorr_correction": float(self.autocorr_correction),
        })
        if post.autoregressive:
            j = post.n_states
            pacf = np.tanh(values[:, j:j + 2])
            a1, a2 = pacf_to_ar(pacf[:, 0], pacf[:, 1])
            roots = np.abs(np.roots([1.0, -float(np.median(a1)), -float(np.median(a2))]))
            metrics.update({"bayes/roll/pacf1": float(np.median(pacf[:, 0])),
                            "bayes/roll/pacf2": float(np.median(pacf[:, 1])),
                            "bayes/roll/ar_root_modulus": float(np.max(roots))})
        metrics["bayes/runtime_s"] = time.perf_counter() - started
        disc = None
        if self.discrepancy == "auto":
            raise ValueError("bayes roll: method.discrepancy=auto must be settled by the run before fitting "
                             "(studies.config.settled_discrepancy: process_noise on measured records)")
        if self.discrepancy != "none":
            disc = estimate_wander(params, self.terms, records, self.discrepancy_evaluations)
            logger.info("bayes roll: coefficient wander sigma(omega0^2) = %.3g 1/s^2, sigma(b1) = %.3g 1/s, "
                        "tau = %.3g s", disc.sigma_w2, disc.sigma_b1, disc.tau)
            metrics.update(disc.metrics(params))
        meta = {
            "lower": dict(zip(names, q05[:k].tolist())),
            "upper": dict(zip(names, q95[:k].tolist())),
            "samples": {"names": names, "values": values[:, :k].copy(),
                        "initial_states": values[:, k:post.n_states].copy()},
            "metrics": metrics,
            "history": diag.history_metrics("bayes/roll"),
            "discrepancy": disc,
            "initial_states": states,
            "nls": dict(start),
            "period_s": float(np.median([_period(r) for r in records])),
        }
        return params, meta
