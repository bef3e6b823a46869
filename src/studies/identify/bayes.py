"""Bayesian posteriors of the manoeuvring coefficients, sampled with emcee.

Two posteriors are provided by :class:`BayesianRegression` (``method=bayes``).

(a) Regression posterior, per DOF. The inverse-dynamics regression of
:mod:`studies.identify.regression`, ``y = Theta c + e`` (prime units), with
an unknown noise scale ``sigma`` (prime force of the DOF) and the Gaussian
likelihood ``e ~ N(0, sigma^2)``. Priors are flat in every coefficient and
in ``log sigma`` (Jeffreys). The posterior of ``(c, log sigma)`` is sampled
with :class:`emcee.EnsembleSampler`, started in a small ball around the
least-squares solution whose axes are the LS standard errors. Internally
the columns of ``Theta`` are scaled to unit RMS and the coordinates are
``(c - c_LS) / se`` and ``log(sigma / sigma_LS) / sd``, so every coordinate
is of order one; samples are mapped back to prime coefficients.

The log-likelihood is evaluated from precomputed moments, exactly::

    SSE(c) = |y - Theta c|^2
           = SSE_LS - 2 d^T Theta^T r_LS + d^T (Theta^T Theta) d,   d = c - c_LS,

with ``r_LS`` the LS residual. This is the same algebra as using
``Theta^T Theta``, ``Theta^T y`` and ``y^T y`` but centred on the LS
solution, which avoids the cancellation of ``y^T y - 2 c^T Theta^T y + ...``
when the fit is nearly exact (clean data: ``R^2 = 1 - 1e-12``). One
evaluation costs O(p^2) instead of O(n p), and the log-probability is
vectorised over walkers (``vectorize=True``).

Autocorrelated residuals. Regression rows of a time series are not
independent: differentiating a record with a stencil, or a
Savitzky-Golay filter, spreads each disturbance sample over several rows,
and process noise drives the states themselves. The i.i.d. likelihood then
counts every row as new information and its intervals are too narrow (by
a factor of about 4 with Savitzky-Golay derivatives). With
``autocorr_correction=True`` (default) the likelihood is raised to the
power ``n_eff / n`` (a tempered or "effective sample size" likelihood):
``n_eff = sum over records of n_k / tau_k`` with ``tau_k`` the integrated
autocorrelation time of the LS residuals of record ``k`` (Sokal's
window, as emcee estimates it for chains). This is the same as inflating
``sigma`` by ``sqrt(n / n_eff)`` in the coefficients' covariance and is the
first-order Newey-West correction for regressors that vary slowly compared
with the residual correlation (ship states vary over tens of seconds,
residual correlations last 0.1-4 s). The factor is reported as
``bayes/<dof>/n_eff_rows`` and ``bayes/<dof>/sigma_inflation``.

What the likelihood cannot represent. The Gaussian likelihood is on ``y``
only; the regressors (the prime states in ``Theta``) are taken as exact.
With measurement noise on ``u, v, r, delta`` the regressors are noisy and
smoothed, which biases the coefficients (errors-in-variables, attenuation)
by an amount that does not shrink with the record length, so the intervals
cover less than their nominal 90 % once the record is long enough. Process
noise (SVM paper eq. 12) has a milder form of the same effect: a central
difference at row ``i`` contains the disturbance of the steps just before
``t_i``, which already moved the states of row ``i`` (bias of order
``sqrt(n) dt`` standard errors, mostly in the yaw equation: about 1 standard
error for a 1200 s record at 0.1 s, 2-3 at 4000 s; a one-sided forward
stencil, whose residual holds only disturbances after ``t_i``, removes it,
but :mod:`studies.data.derivatives` does not offer one). The metric
``bayes/noisy_regressors`` is 1 when the records were differentiated with
the Savitzky-Golay filter (the derivative estimator found sensor noise),
that is when this caveat applies most.

(b) Trajectory posterior of a few named coefficients (``trajectory_terms``),
the others fixed at the regression medians: every coefficient set of the
walkers is simulated by replaying the training records' rudder
(:meth:`~studies.identify.objective.TrajectoryObjective.residuals_many`,
one compiled parallel call per emcee half-step), and the simulated minus
recorded ``u, v, r`` at evenly spaced samples have a Gaussian likelihood
with unknown noise scale per channel, integrated out under the Jeffreys
prior (``log L = -sum_ch kappa_ch m/2 log SSE_ch``). Simulation errors are
strongly autocorrelated, so ``kappa_ch = n_eff/m`` is estimated from the
residuals at the best walker after the first half of the burn-in (the
first half uses ``kappa = 1`` to find the mode). The prior is flat in a
box ``|c - c_reg| <= trajectory_prior_width * |c_reg|``.

References
----------
Foreman-Mackey, D., Hogg, D.W., Lang, D., Goodman, J. (2013). emcee: the
MCMC hammer. PASP 125(925), 306-312. doi:10.1086/670067

Goodman, J., Weare, J. (2010). Ensemble samplers with affine invariance.
Communications in Applied Mathematics and Computational Science 5(1),
65-80. doi:10.2140/camcos.2010.5.65

ter Braak, C.J.F. (2006). A Markov chain Monte Carlo version of the genetic
algorithm differential evolution. Statistics and Computing 16, 239-249
(the default ``moves="de"``; Nelson et al. 2014, ApJS 210, 11).

Sokal, A. (1997). Monte Carlo methods in statistical mechanics: foundations
and new algorithms. In: Functional Integration, Springer, 131-192
(integrated autocorrelation time, automatic window).

Newey, W.K., West, K.D. (1987). A simple, positive semi-definite,
heteroskedasticity and autocorrelation consistent covariance matrix.
Econometrica 55(3), 703-708.

Wang, T. et al. (2021). Parameter identification of ship manoeuvring model
under disturbance using support vector machine method. Ships and Offshore
Structures 16(S1), 13-21 (disturbance model, eq. 12-14).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from .. import interrupt
from ..errors import ConfigError
from .base import Identification
from .ls import regression_diagnostics
from .regression import RegressionProblem

__all__ = ["BayesianRegression", "RegressionPosterior", "ChainDiagnostics", "residual_autocorr_time",
           "effective_rows", "plot_corner", "least_certain"]

logger = logging.getLogger(__name__)

#: usual emcee rules: chain longer than this many autocorrelation times ...
MIN_TAU_MULTIPLE = 50.0
#: ... and a mean acceptance fraction in this range
ACCEPTANCE_RANGE = (0.15, 0.7)
#: at most this many coefficients per corner plot (the least certain ones)
CORNER_MAX = 8


@dataclass
class ChainDiagnostics:
    """Convergence checks of one emcee run.

    Attributes
    ----------
    acceptance_fraction : float
        Mean over walkers.
    autocorr_time_max : float
        Largest integrated autocorrelation time over the parameters [steps]
        (NaN when it could not be estimated).
    n_effective : float
        Walkers x kept steps / ``autocorr_time_max``.
    steps : int
        Steps after burn-in (before thinning).
    converged : bool
        ``steps > 50 autocorr_time_max`` and acceptance in 0.15-0.7.
    reasons : list of str
        Why it did not converge.
    """

    acceptance_fraction: float
    autocorr_time_max: float
    n_effective: float
    steps: int
    converged: bool
    reasons: list = field(default_factory=list)

    def metrics(self, prefix: str) -> dict:
        return {f"{prefix}/acceptance_fraction": self.acceptance_fraction,
                f"{prefix}/autocorr_time_max": self.autocorr_time_max,
                f"{prefix}/n_effective": self.n_effective,
                f"{prefix}/converged": float(self.converged)}



def run_with_progress(sampler, start, steps: int, label: str | None = None):
    """``sampler.run_mcmc`` that logs its progress five times when given a
    ``label``, and stops on SIGINT/SIGTERM between steps: inside emcee a
    signal would be caught and printed as a traceback."""
    every = max(1, steps // 5)
    state = None
    with interrupt.deferred():
        for i, state in enumerate(sampler.sample(start, iterations=steps), 1):
            interrupt.checkpoint()
            if label and (i % every == 0 or i == steps):
                logger.info("%s: emcee step %d/%d, mean acceptance %.2f", label, i, steps,
                            float(np.mean(sampler.acceptance_fraction)))
    return state


def residual_autocorr_time(residual: np.ndarray) -> float:
    """Integrated autocorrelation time of a residual series [rows].

    Sokal's estimate with the automatic window (``c = 5``) as emcee computes
    it for chains; 1 for white noise, about 1.4 for the residual of the
    4th-order central difference of a process-noise-driven record, 10-20
    for Savitzky-Golay derivatives. Never below 1 (negative correlations
    are not used to narrow the intervals).
    """
    from emcee.autocorr import integrated_time

    x = np.asarray(residual, float)
    if x.size < 8 or not np.all(np.isfinite(x)) or np.std(x) == 0:
        return 1.0
    tau = float(integrated_time(x, c=5, tol=0, quiet=True)[0])
    return max(tau, 1.0) if np.isfinite(tau) else float(x.size)


def effective_rows(problem: RegressionProblem, residual: np.ndarray) -> float:
    """``n_eff = sum_k n_k / tau_k`` over the records of a regression problem."""
    which = problem.record if problem.record is not None else np.zeros(len(residual), int)
    n_eff = 0.0
    for k in np.unique(which):
        part = residual[which == k]
        n_eff += part.size / residual_autocorr_time(part)
    return float(n_eff)


def _vectorised(move_class):
    """``move_class`` (an emcee red-blue move) with the accept step vectorised.

    emcee's :meth:`RedBlueMove.propose` accepts walker by walker in a Python
    loop; with a cheap vectorised log-probability that loop is a third of the
    run time. The proposal, the acceptance rule and the bookkeeping are
    emcee's own; only the loop is replaced by array operations.
    """
    from emcee.state import State

    class Vectorised(move_class):
        def propose(self, model, state):
            nwalkers, ndim = state.coords.shape
            if nwalkers < 2 * ndim and not self.live_dangerously:
                raise RuntimeError("It is unadvisable to use a red-blue move "
                                   "with fewer walkers than twice the number of dimensions.")
            self.setup(state.coords)
            accepted = np.zeros(nwalkers, dtype=bool)
            inds = np.arange(nwalkers) % self.nsplits
            if self.randomize_split:
                model.random.shuffle(inds)
            for split in range(self.nsplits):
                s1 = inds == split
                sets = [state.coords[inds == j] for j in range(self.nsplits)]
                q, factors = self.get_proposal(sets[split], sets[:split] + sets[split + 1:],
                                               model.random)
                new_log_probs, new_blobs = model.compute_log_prob_fn(q)
                lnpdiff = factors + new_log_probs - state.log_prob[s1]
                accepted[s1] = lnpdiff > np.log(model.random.rand(int(s1.sum())))
                new_state = State(q, log_prob=new_log_probs, blobs=new_blobs)
                state = self.update(state, new_state, accepted, s1)
            return state, accepted

    Vectorised.__name__ = f"Vectorised{move_class.__name__}"
    return Vectorised


def _moves(kind: str, n_walkers: int, ndim: int):
    """The move of ``kind``; fewer than ``2 ndim`` walkers are allowed (and
    diagnosed by :func:`_diagnose`) rather than refused."""
    import emcee

    live = n_walkers < 2 * ndim
    if kind == "de":
        return _vectorised(emcee.moves.DEMove)(live_dangerously=live)
    if kind == "stretch":
        return _vectorised(emcee.moves.StretchMove)(live_dangerously=live)
    raise ConfigError(f"method.moves must be 'de' or 'stretch', got {kind!r}")


def _diagnose(sampler, burn_in: int, steps: int, label: str) -> ChainDiagnostics:
    """Acceptance, autocorrelation time and the convergence verdict; warns when bad."""
    from emcee.autocorr import AutocorrError

    acc = float(np.mean(sampler.acceptance_fraction))
    reasons = []
    try:
        tau = sampler.get_autocorr_time(discard=burn_in, quiet=True)
        tau_max = float(np.max(tau))
    except AutocorrError as exc:  # only raised with quiet=False, kept for safety
        tau_max = float("nan")
        reasons.append(f"autocorrelation time not estimable ({exc})")
    if not np.isfinite(tau_max):
        if not reasons:
            reasons.append("autocorrelation time not estimable")
    elif steps <= MIN_TAU_MULTIPLE * tau_max:
        reasons.append(f"chain of {steps} steps is shorter than {MIN_TAU_MULTIPLE:g} x the "
                       f"autocorrelation time {tau_max:.1f}")
    lo, hi = ACCEPTANCE_RANGE
    if not (lo <= acc <= hi):
        reasons.append(f"mean acceptance fraction {acc:.3f} outside {lo}-{hi}")
    n_walkers = sampler.get_chain().shape[1]
    n_eff = n_walkers * steps / tau_max if np.isfinite(tau_max) and tau_max > 0 else float("nan")
    diag = ChainDiagnostics(acc, tau_max, n_eff, steps, not reasons, reasons)
    if reasons:
        logger.warning("bayes %s: the sampler has not converged: %s; the quantiles are not "
                       "reliable (run longer: burn_in, n_samples, thin, or more walkers)",
                       label, "; ".join(reasons))
    return diag


class RegressionPosterior:
    """Log-posterior of one DOF's regression, evaluated from precomputed moments.

    Parameters
    ----------
    problem : RegressionProblem
        ``y = theta @ c`` (prime).
    autocorr_correction : bool
        Temper the likelihood by ``n_eff / n`` (module docstring).

    Attributes
    ----------
    n, p, ndim : int
        Rows, coefficients, sampled dimensions (``p + 1``: the noise scale).
    scale : ndarray (p,)
        RMS of each column of ``theta`` (columns are scaled by it).
    coef_ls : ndarray (p,)
        Least-squares coefficients (prime).
    sse_ls : float
        Residual sum of squares of the LS fit.
    n_eff, kappa : float
        Effective number of rows and ``n_eff / n``.
    se : ndarray (p,)
        Posterior standard deviations (Gaussian approximation) of the
        scaled coefficients; the sampled coordinates are ``(z - z_LS) / se``.
    sd_eta : float
        Posterior sd of ``log sigma``; the last coordinate is
        ``log(sigma / sigma_LS) / sd_eta``.
    """

    def __init__(self, problem: RegressionProblem, autocorr_correction: bool = True):
        theta = np.asarray(problem.theta, float)
        y = np.asarray(problem.y, float)
        n, p = theta.shape
        if n <= p + 2:
            raise ValueError(f"bayes {problem.dof}: {n} rows for {p} coefficients")
        self.n, self.p, self.ndim = n, p, p + 1
        scale = np.sqrt(np.mean(theta ** 2, axis=0))
        scale[scale == 0] = 1.0
        self.scale = scale
        ts = theta / scale
        z_ls, *_ = np.linalg.lstsq(ts, y, rcond=None)
        resid = y - ts @ z_ls
        self.z_ls = z_ls
        self.coef_ls = z_ls / scale
        self.gram = ts.T @ ts                     # Theta^T Theta (scaled columns)
        self.cross = ts.T @ resid                 # Theta^T r_LS, ~0; kept: SSE stays exact
        floor = n * (1e-12 * max(float(np.sqrt(np.mean(y ** 2))), 1e-300)) ** 2
        self.sse_ls = max(float(resid @ resid), floor)
        self.n_eff = effective_rows(problem, resid) if autocorr_correction else float(n)
        self.kappa = min(1.0, self.n_eff / n)
        self.sigma_ls = float(np.sqrt(self.sse_ls / n))
        cov = np.linalg.pinv(self.gram) * self.sigma_ls ** 2 / self.kappa
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        se[se == 0] = 1e-300
        self.se = se
        self.sd_eta = 1.0 / np.sqrt(2.0 * self.kappa * n)
        # the quadratic form in the sampled coordinates
        self._a = self.gram * np.outer(se, se)
        self._b = self.cross * se

    def sse(self, coef: np.ndarray) -> np.ndarray:
        """``|y - theta c|^2`` of prime coefficient vectors (m, p), in O(p^2) each."""
        d = np.atleast_2d(coef) * self.scale - self.z_ls
        return self.sse_ls + np.sum((d @ self.gram) * d, axis=1) - 2.0 * (d @ self.cross)

    def log_prob(self, x: np.ndarray) -> np.ndarray:
        """Log-posterior (up to a constant) of walkers ``x`` (m, p + 1), vectorised.

        ``kappa [-n log sigma - SSE(c) / (2 sigma^2)]`` with flat priors in
        ``c`` and ``log sigma``.
        """
        x = np.atleast_2d(x)
        d = x[:, :self.p]
        eta = x[:, self.p] * self.sd_eta
        ratio = 1.0 + (np.sum((d @ self._a) * d, axis=1) - 2.0 * (d @ self._b)) / self.sse_ls
        ratio = np.maximum(ratio, 0.0)
        lp = -self.kappa * (self.n * eta + 0.5 * self.n * ratio * np.exp(-2.0 * eta))
        return np.where(np.isfinite(lp), lp, -np.inf)

    def to_coefficients(self, x: np.ndarray):
        """``(coef (m, p), sigma (m,))`` in prime units from sampled coordinates."""
        x = np.atleast_2d(x)
        coef = (self.z_ls + x[:, :self.p] * self.se) / self.scale
        sigma = self.sigma_ls * np.exp(x[:, self.p] * self.sd_eta)
        return coef, sigma


class BayesianRegression:
    """Posterior of the coefficients with emcee: ``fit(problems, objective) -> Identification``.

    Parameters
    ----------
    n_walkers : int, optional
        Walkers per DOF; default ``max(32, 2 (p + 1))`` (even) with ``p`` the
        coefficients of the DOF (the noise scale is one more dimension).
    n_samples : int
        Posterior samples kept per DOF after burn-in and thinning, all walkers
        together (default 10 000).
    burn_in : int
        Steps discarded at the start of each chain.
    thin : int
        Keep every ``thin``-th step; the chain after burn-in has
        ``thin * ceil(n_samples / n_walkers)`` steps.
    seed : int
        Seed of the samplers' random numbers (DOF ``k`` uses ``seed + k``).
    init_scale : float
        Radius of the initial ball in LS standard errors.
    moves : {"de", "stretch"}
        emcee moves: differential evolution (ter Braak 2006), whose
        autocorrelation time on these 11-16 dimensional posteriors is about
        40-60 steps against 140 for the stretch move of Goodman & Weare
        (both affine invariant); or the stretch move.
    autocorr_correction : bool
        Account for autocorrelated regression residuals with the effective
        number of rows (module docstring). ``False`` gives the i.i.d.
        likelihood (intervals far too narrow on time series).
    corner_max : int
        At most this many coefficients per corner plot (the least certain).
    trajectory_terms : list of str, "ga" or None
        Coefficients of the trajectory-likelihood posterior (b); ``"ga"``:
        the 5 least Sobol-sensitive per DOF
        (:func:`studies.identify.sensitivity.least_sensitive`); ``None``
        skips (b).
    trajectory_walkers : int, optional
        Walkers of (b); default ``max(8, 2 k + 2)`` for ``k`` terms.
    trajectory_steps, trajectory_burn_in, trajectory_thin : int
        Steps kept after burn-in, burn-in steps and thinning of (b).
    trajectory_max_samples : int
        Compared samples per record and channel (evenly spaced).
    trajectory_duration : float, optional
        Use only the first ``trajectory_duration`` seconds of each training
        record for (b) (simulation cost is linear in it); ``None``: whole.
    trajectory_prior_width : float
        Flat prior box ``|c - c_reg| <= width * |c_reg|`` of (b).
    trajectory_init_scale : float
        Radius of the initial ball of (b), relative to ``|c_reg|``.
    trajectory_autocorr_correction : bool
        Effective-sample-size correction of the trajectory likelihood.

    References
    ----------
    Foreman-Mackey et al. (2013), PASP 125, 306; Goodman & Weare (2010),
    CAMCoS 5, 65 (see the module docstring).
    """

    name = "bayes"

    def __init__(self, n_walkers: int | None = None, n_samples: int = 10_000, burn_in: int = 500,
                 thin: int = 12, seed: int = 0, init_scale: float = 0.1, moves: str = "de",
                 autocorr_correction: bool = True, corner_max: int = CORNER_MAX,
                 trajectory_terms=None, trajectory_walkers: int | None = None,
                 trajectory_steps: int = 300, trajectory_burn_in: int = 200,
                 trajectory_thin: int = 1, trajectory_max_samples: int = 300,
                 trajectory_duration: float | None = 600.0, trajectory_prior_width: float = 1.0,
                 trajectory_init_scale: float = 0.01, trajectory_autocorr_correction: bool = True):
        for key, value, low in (("n_samples", n_samples, 1), ("burn_in", burn_in, 0),
                                ("thin", thin, 1), ("trajectory_steps", trajectory_steps, 1),
                                ("trajectory_burn_in", trajectory_burn_in, 0),
                                ("trajectory_thin", trajectory_thin, 1),
                                ("trajectory_max_samples", trajectory_max_samples, 10)):
            if int(value) != value or value < low:
                raise ConfigError(f"method.{key} must be an integer >= {low}, got {value!r}")
        for key, value in (("n_walkers", n_walkers), ("trajectory_walkers", trajectory_walkers)):
            if value is not None and (int(value) != value or value < 4 or value % 2):
                raise ConfigError(f"method.{key} must be an even integer >= 4, got {value!r}")
        if moves not in ("de", "stretch"):
            raise ConfigError(f"method.moves must be 'de' or 'stretch', got {moves!r}")
        if not (init_scale > 0 and trajectory_init_scale > 0 and trajectory_prior_width > 0):
            raise ConfigError("method.init_scale, trajectory_init_scale and "
                              "trajectory_prior_width must be positive")
        if trajectory_terms is not None and trajectory_terms != "ga" and (
                isinstance(trajectory_terms, str) or not all(isinstance(t, str) for t in trajectory_terms)):
            raise ConfigError("method.trajectory_terms must be null, 'ga' or a list of "
                              f"coefficient names, got {trajectory_terms!r}")
        self.n_walkers = n_walkers
        self.n_samples = int(n_samples)
        self.burn_in = int(burn_in)
        self.thin = int(thin)
        self.seed = int(seed)
        self.init_scale = float(init_scale)
        self.moves = moves
        self.autocorr_correction = bool(autocorr_correction)
        self.corner_max = int(corner_max)
        self.trajectory_terms = (trajectory_terms if trajectory_terms in (None, "ga")
                                 else [str(t) for t in trajectory_terms])
        self.trajectory_walkers = trajectory_walkers
        self.trajectory_steps = int(trajectory_steps)
        self.trajectory_burn_in = int(trajectory_burn_in)
        self.trajectory_thin = int(trajectory_thin)
        self.trajectory_max_samples = int(trajectory_max_samples)
        self.trajectory_duration = None if trajectory_duration is None else float(trajectory_duration)
        self.trajectory_prior_width = float(trajectory_prior_width)
        self.trajectory_init_scale = float(trajectory_init_scale)
        self.trajectory_autocorr_correction = bool(trajectory_autocorr_correction)

    # ------------------------------------------------------------------ (a)
    def fit_one(self, problem: RegressionProblem, seed: int | None = None) -> Identification:
        """Posterior of one DOF's coefficients and noise scale.

        Returns an :class:`Identification` with medians as ``params``, 5 %
        and 95 % quantiles, ``samples[dof] = {"names", "values" (n_samples,
        p), "sigma" (n_samples,)}`` and the ``bayes/<dof>/...`` metrics.
        """
        import emcee

        started = time.perf_counter()
        dof = problem.dof
        post = RegressionPosterior(problem, self.autocorr_correction)
        n, p, ndim = post.n, post.p, post.ndim
        log_prob = post.log_prob
        walkers = self.n_walkers or max(32, 2 * ndim)
        seed = self.seed + "XYN".find(dof) + 1 if seed is None else seed
        rng = np.random.default_rng(seed)
        x0 = self.init_scale * rng.standard_normal((walkers, ndim))
        kept = int(np.ceil(self.n_samples / walkers))
        steps = self.thin * kept
        sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True,
                                        moves=_moves(self.moves, walkers, ndim))
        sampler.random_state = np.random.RandomState(seed).get_state()
        run_with_progress(sampler, x0, self.burn_in + steps, f"bayes {dof}")
        diag = _diagnose(sampler, self.burn_in, steps, dof)
        chain = sampler.get_chain(discard=self.burn_in, thin=self.thin, flat=True)[-self.n_samples:]
        coef, sigma = post.to_coefficients(chain)
        q05, q50, q95 = np.quantile(coef, [0.05, 0.5, 0.95], axis=0)
        names = list(problem.names)
        result = Identification()
        result.params = dict(zip(names, q50.tolist()))
        result.lower = dict(zip(names, q05.tolist()))
        result.upper = dict(zip(names, q95.tolist()))
        result.samples[dof] = {"names": names, "values": coef, "sigma": sigma}
        # posterior sd over the Gaussian (Laplace) one: 1 in these coordinates
        ratio = np.std(chain[:, :p], axis=0)
        prefix = f"bayes/{dof}"
        result.metrics.update(regression_diagnostics(problem, q50))
        result.metrics.update(diag.metrics(prefix))
        result.metrics.update({
            f"{prefix}/n_eff_rows": post.n_eff,
            f"{prefix}/rows": float(n),
            f"{prefix}/residual_autocorr_time": n / post.n_eff,
            f"{prefix}/sigma_inflation": float(np.sqrt(1.0 / post.kappa)),
            f"{prefix}/sigma": float(np.median(sigma)),
            f"{prefix}/walkers": float(walkers),
            f"{prefix}/steps": float(self.burn_in + steps),
            f"{prefix}/sd_ratio_min": float(np.min(ratio)),
            f"{prefix}/sd_ratio_max": float(np.max(ratio)),
            f"{prefix}/runtime_s": time.perf_counter() - started,
        })
        return result

    def fit(self, problems: dict, objective=None) -> Identification:
        """Regression posterior of every DOF, then (b) when ``trajectory_terms`` is set.

        Parameters
        ----------
        problems : dict
            ``{dof: RegressionProblem}`` (:func:`~studies.identify.regression.build_problems`).
        objective : TrajectoryObjective, optional
            Needed only for the trajectory posterior (b).
        """
        started = time.perf_counter()
        result = Identification()
        converged = []
        for dof, problem in problems.items():
            one = self.fit_one(problem)
            result.update(one)
            converged.append(one.metrics[f"bayes/{dof}/converged"])
        result.metrics["bayes/converged"] = float(all(c == 1.0 for c in converged))
        noisy = any(getattr(p, "meta", {}).get("derivative") == "savgol" for p in problems.values())
        result.metrics["bayes/noisy_regressors"] = float(noisy)
        if noisy:
            logger.info("bayes: the records were differentiated with Savitzky-Golay (sensor "
                        "noise): the regressors are noisy and the intervals do not include "
                        "the errors-in-variables bias of the coefficients")
        result.metrics["bayes/autocorr_correction"] = float(self.autocorr_correction)
        for dof in problems:
            entry = result.samples[dof]
            result.writers[f"corner_{dof}.png"] = _corner_writer(
                entry["names"], entry["values"], f"{dof}: regression posterior", self.corner_max)
        terms = self.trajectory_names(problems, result.params)
        if terms:
            if objective is None:
                raise ValueError("bayes: trajectory_terms needs the trajectory objective "
                                 "(fit(problems, objective=...))")
            traj = self.sample_trajectory(objective, result.params, terms)
            result.update(traj)
        result.metrics["bayes/runtime_s"] = time.perf_counter() - started
        return result

    # ------------------------------------------------------------------ (b)
    def trajectory_names(self, problems: dict, params: dict) -> list:
        """Coefficients of the trajectory posterior (b) from ``trajectory_terms``.

        ``"ga"``: the 5 least Sobol-sensitive coefficients per DOF at
        ``params`` (:func:`studies.identify.sensitivity.least_sensitive`);
        a list is checked against the identified names; ``None``: none.
        """
        if self.trajectory_terms is None:
            return []
        if self.trajectory_terms == "ga":
            try:
                from .sensitivity import least_sensitive
            except ImportError as exc:
                raise ConfigError("method.trajectory_terms=ga needs "
                                  "studies.identify.sensitivity.least_sensitive") from exc
            picked = least_sensitive(problems, params, per_dof=5, n_samples=5000, seed=self.seed)
            if isinstance(picked, tuple):  # (names, table)
                picked = picked[0]
            return list(picked)
        unknown = [t for t in self.trajectory_terms if t not in params]
        if unknown:
            raise ConfigError(f"method.trajectory_terms: {unknown} are not identified "
                              f"coefficients of the model")
        return list(self.trajectory_terms)

    def sample_trajectory(self, objective, params: dict, terms, start: dict | None = None,
                          seed: int | None = None) -> Identification:
        """Trajectory-likelihood posterior of ``terms``, the others fixed at ``params``.

        Parameters
        ----------
        objective : TrajectoryObjective
            Gives the model, the vessel and the training records.
        params : dict
            Values of every coefficient of the model (regression medians); the
            centre of the prior box of ``terms``.
        terms : list of str
            Coefficients to sample.
        start : dict, optional
            Centre of the initial ball for some of ``terms`` (default
            ``params``), e.g. a perturbed start.
        seed : int, optional
            Default: the identifier's seed + 10.

        Returns
        -------
        Identification
            Medians and 5/95 % quantiles of ``terms``, ``samples["trajectory"]``
            and the ``bayes/trajectory/...`` metrics; writer of
            ``corner_trajectory.png``.
        """
        import emcee

        from .objective import TrajectoryObjective

        started = time.perf_counter()
        model = objective.model
        names = model.names
        terms = list(terms)
        missing = [t for t in terms if t not in names]
        if missing:
            raise ConfigError(f"trajectory terms {missing} are not terms of model '{model.name}'")
        idx = np.array([names.index(t) for t in terms])
        base = model.vector(params)
        centre = base[idx]
        width = self.trajectory_prior_width * np.where(np.abs(centre) > 0, np.abs(centre), 1e-6)
        records = []
        for rec in objective.records:
            if self.trajectory_duration is not None:
                t = rec["t"].to_numpy(float)
                cut = rec.loc[t - t[0] <= self.trajectory_duration]
                cut.attrs = dict(rec.attrs)
                rec = cut
            records.append(rec)
        traj = TrajectoryObjective(model, objective.vessel, records)
        picks = []
        for rec in records:
            m = len(rec)
            k = min(self.trajectory_max_samples, m - 1)
            picks.append(np.unique(np.linspace(1, m - 1, k).astype(int)))
        m_total = float(sum(len(p) for p in picks))
        kappa = np.ones(3)

        def sse_of(vectors):
            total = np.zeros((vectors.shape[0], 3))
            for res, pick in zip(traj.residuals_many(vectors), picks):
                pick = pick[pick < res.shape[1]]
                total += np.sum(res[:, pick, :] ** 2, axis=1)
            return total

        def residual_series(vector):
            out = [res[0, pick[pick < res.shape[1]], :]
                   for res, pick in zip(traj.residuals_many(vector[None, :]), picks)]
            return out

        def log_prob(x):
            x = np.atleast_2d(x)
            lp = np.full(x.shape[0], -np.inf)
            inside = np.all(np.abs(x) <= 1.0, axis=1)
            if not np.any(inside):
                return lp
            vectors = np.repeat(base[None, :], int(inside.sum()), axis=0)
            vectors[:, idx] = centre + x[inside] * width
            sse = sse_of(vectors)
            with np.errstate(divide="ignore", invalid="ignore"):
                val = -0.5 * m_total * np.sum(kappa * np.log(np.maximum(sse, 1e-300)), axis=1)
            val[~np.all(np.isfinite(sse), axis=1)] = -np.inf
            lp[inside] = np.where(np.isfinite(val), val, -np.inf)
            return lp

        ndim = len(terms)
        walkers = self.trajectory_walkers or max(8, 2 * ndim + 2)
        walkers += walkers % 2
        seed = self.seed + 10 if seed is None else seed
        rng = np.random.default_rng(seed)
        start_vec = centre.copy()
        for j, t in enumerate(terms):
            if start and t in start:
                start_vec[j] = start[t]
        x_start = (start_vec - centre) / width
        ball = self.trajectory_init_scale / self.trajectory_prior_width
        x0 = x_start + ball * rng.standard_normal((walkers, ndim))
        x0 = np.clip(x0, -0.999, 0.999)
        moves = _moves(self.moves, walkers, ndim)
        first = self.trajectory_burn_in // 2
        sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True, moves=moves)
        sampler.random_state = np.random.RandomState(seed).get_state()
        state = run_with_progress(sampler, x0, first) if first else None
        coords = state.coords if state is not None else x0
        if self.trajectory_autocorr_correction:
            best = coords[np.argmax(state.log_prob)] if state is not None else x_start
            vector = base.copy()
            vector[idx] = centre + best * width
            series = residual_series(vector)
            n_eff = np.zeros(3)
            for part in series:
                for ch in range(3):
                    n_eff[ch] += part.shape[0] / residual_autocorr_time(part[:, ch])
            kappa[:] = np.minimum(1.0, n_eff / m_total)
        # second sampler: the target changed (kappa), so restart from the walkers
        sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True, moves=moves)
        sampler.random_state = np.random.RandomState(seed + 1).get_state()
        rest = self.trajectory_burn_in - first
        steps = self.trajectory_steps
        run_with_progress(sampler, coords, rest + steps, "bayes trajectory")
        diag = _diagnose(sampler, rest, steps, "trajectory")
        chain = sampler.get_chain(discard=rest, thin=self.trajectory_thin, flat=True)
        coef = centre + chain * width
        q05, q50, q95 = np.quantile(coef, [0.05, 0.5, 0.95], axis=0)
        result = Identification()
        result.params = dict(zip(terms, q50.tolist()))
        result.lower = dict(zip(terms, q05.tolist()))
        result.upper = dict(zip(terms, q95.tolist()))
        result.samples["trajectory"] = {"names": terms, "values": coef}
        at_edge = float(np.mean(np.abs(chain) > 0.98))
        result.metrics.update(diag.metrics("bayes/trajectory"))
        result.metrics.update({
            "bayes/trajectory/n_terms": float(ndim),
            "bayes/trajectory/walkers": float(walkers),
            "bayes/trajectory/steps": float(self.trajectory_burn_in + steps),
            "bayes/trajectory/compared_samples": m_total,
            "bayes/trajectory/n_eff_u": float(kappa[0] * m_total),
            "bayes/trajectory/n_eff_v": float(kappa[1] * m_total),
            "bayes/trajectory/n_eff_r": float(kappa[2] * m_total),
            "bayes/trajectory/prior_edge_fraction": at_edge,
            "bayes/trajectory/runtime_s": time.perf_counter() - started,
        })
        if at_edge > 0.01:
            logger.warning("bayes trajectory: %.1f %% of the samples are at the edge of the "
                           "prior box (+-%g x |regression value|): the posterior is cut by it",
                           100 * at_edge, self.trajectory_prior_width)
        result.writers["corner_trajectory.png"] = _corner_writer(
            terms, coef, "trajectory-likelihood posterior", self.corner_max)
        return result


# ---------------------------------------------------------------------- plots
def least_certain(names, samples: np.ndarray, k: int) -> list[int]:
    """Indices (model order) of the ``k`` coefficients with the widest 90 %
    interval relative to their median."""
    q05, q50, q95 = np.quantile(samples, [0.05, 0.5, 0.95], axis=0)
    rel = (q95 - q05) / np.maximum(np.abs(q50), 1e-300)
    order = np.argsort(-rel, kind="stable")[:k]
    return sorted(order.tolist())


def _corner_writer(names, samples, title, max_params):
    names = list(names)
    samples = np.asarray(samples)

    def write(path):
        plot_corner(names, samples, path, title, max_params=max_params)

    return write


def plot_corner(names, samples: np.ndarray, path, title: str, truths: dict | None = None,
                max_params: int = CORNER_MAX) -> list[str]:
    """Corner plot: 1-D histograms on the diagonal, 2-D histograms below.

    Draws at most ``max_params`` coefficients, the least certain ones
    (:func:`least_certain`), and says which in the title. Uses the Agg
    canvas directly (no pyplot state, no display needed).

    Parameters
    ----------
    names : list of str
    samples : ndarray (n_samples, len(names))
        Prime coefficient samples.
    path : str or Path
        PNG file to write.
    truths : dict, optional
        Known values to mark.

    Returns
    -------
    list of str
        The coefficients drawn.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    names = list(names)
    samples = np.asarray(samples, float)
    pick = list(range(len(names)))
    if len(names) > max_params:
        pick = least_certain(names, samples, max_params)
        title = f"{title}: the {max_params} least certain of {len(names)} coefficients"
    shown = [names[i] for i in pick]
    data = samples[:, pick]
    k = len(pick)
    fig = Figure(figsize=(1.7 * k + 1.5, 1.7 * k + 1.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(k, k, squeeze=False)
    qs = np.quantile(data, [0.05, 0.5, 0.95], axis=0)
    for i in range(k):
        for j in range(k):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                ax.hist(data[:, i], bins=40, color="tab:blue", histtype="stepfilled", alpha=0.6)
                for q, style in zip(qs[:, i], (":", "-", ":")):
                    ax.axvline(q, color="k", ls=style, lw=0.8)
                ax.set_yticks([])
            else:
                ax.hist2d(data[:, j], data[:, i], bins=30, cmap="Blues")
                if truths and shown[i] in truths and shown[j] in truths:
                    ax.plot(truths[shown[j]], truths[shown[i]], "r+", ms=8)
            if truths and shown[j] in truths:
                ax.axvline(truths[shown[j]], color="tab:red", lw=0.8)
            if i == k - 1:
                ax.set_xlabel(shown[j], fontsize=8)
            else:
                ax.set_xticklabels([])
            if j == 0 and i > 0:
                ax.set_ylabel(shown[i], fontsize=8)
            elif i != j:
                ax.set_yticklabels([])
            ax.tick_params(labelsize=6)
            for label in ax.get_xticklabels():
                label.set_rotation(45)
    fig.suptitle(f"{title}\n({', '.join(shown)}; lines: 5, 50, 95 %)", fontsize=9)
    fig.savefig(path, dpi=80)
    return shown
