"""The ``method=bayes`` identifier: :class:`BayesianRegression`.

Settings, the regression posterior (a) of every DOF, the choice of the
coefficients of the trajectory posterior (b) and its run, and the results
(medians, 5/95 % quantiles, samples, ``bayes/...`` metrics, corner-plot
writers). The package docstring of :mod:`studies.identification.bayes` describes
both posteriors.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from ...errors import ConfigError
from ..base import Identification, known_coefficients
from ..discrepancy import DISCREPANCIES, estimate_process_noise, out_of_sample_values
from ..ls import regression_diagnostics
from ..objective import TrajectoryObjective
from ..regression import RegressionProblem
from ..sensitivity import least_sensitive
from .figures import CORNER_MAX, corner_writer
from .likelihood import RegressionPosterior, TrajectoryLikelihood, first_seconds
from .priors import BoxPrior
from .sampler import sample_regression_chain, sample_trajectory_chain

__all__ = ["BayesianRegression"]

#: one logger for the whole package: ``studies.identification.bayes``
logger = logging.getLogger(__package__)


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
        number of rows (package docstring). ``False`` gives the i.i.d.
        likelihood (intervals far too narrow on time series).
    corner_max : int
        At most this many coefficients per corner plot (the least certain).
    trajectory_terms : list of str, "ga" or None
        Coefficients of the trajectory-likelihood posterior (b); ``"ga"``:
        the 5 least Sobol-sensitive per DOF
        (:func:`studies.identification.sensitivity.least_sensitive`); ``None``
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
    discrepancy : {"none", "process_noise"}
        Model discrepancy for the predictive bands
        (:mod:`studies.identification.discrepancy`): ``process_noise`` estimates an
        Ornstein-Uhlenbeck acceleration per DOF by the prediction-error
        method on the training records, at the posterior medians; kept in
        ``samples["discrepancy"]``, its figures in ``discrepancy/...``.
        ``none``: the model is taken as exact (bands from the coefficients
        alone).
    discrepancy_step : float or None
        The training records are thinned to about this step [s] for the
        discrepancy's Kalman filter; None: as sampled.
    discrepancy_evaluations : int
        Most likelihood evaluations of its search (Powell's method).
    discrepancy_out_of_sample : bool
        Filter each training record with the coefficients identified
        without it (:func:`~studies.identification.discrepancy.out_of_sample_values`),
        so that the discrepancy is what the model misses on records it was
        not fitted to (default); False: every record at the posterior medians.
    discrepancy_mean : bool
        Fit a mean of the discrepancy that depends on the state
        (:func:`~studies.identification.discrepancy.fit_mean`) to the training
        records' smoothed discrepancy, which the bands add; False (default):
        the discrepancy is centred on the model. Learnt on the training
        records, the mean is extrapolated to whatever the new record does:
        on the KVLCC2 records it helps the largest zig-zags and misleads the
        turning circle (``docs/calibration.md``).

    References
    ----------
    Foreman-Mackey et al. (2013), PASP 125, 306; Goodman & Weare (2010),
    CAMCoS 5, 65 (see the package docstring).
    """

    name = "bayes"

    def __init__(self, n_walkers: int | None = None, n_samples: int = 10_000, burn_in: int = 500,
                 thin: int = 12, seed: int = 0, init_scale: float = 0.1, moves: str = "de",
                 autocorr_correction: bool = True, corner_max: int = CORNER_MAX,
                 trajectory_terms=None, trajectory_walkers: int | None = None,
                 trajectory_steps: int = 300, trajectory_burn_in: int = 200,
                 trajectory_thin: int = 1, trajectory_max_samples: int = 300,
                 trajectory_duration: float | None = 600.0, trajectory_prior_width: float = 1.0,
                 trajectory_init_scale: float = 0.01, trajectory_autocorr_correction: bool = True,
                 discrepancy: str = "none", discrepancy_step: float | None = 0.5,
                 discrepancy_evaluations: int = 600, max_steps: int | None = None,
                 discrepancy_out_of_sample: bool = True, discrepancy_mean: bool = False):
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
        if discrepancy not in DISCREPANCIES:
            raise ConfigError(f"method.discrepancy must be one of {', '.join(DISCREPANCIES)}, "
                              f"got {discrepancy!r}")
        if discrepancy_step is not None and not discrepancy_step > 0:
            raise ConfigError("method.discrepancy_step must be positive [s] or null, "
                              f"got {discrepancy_step!r}")
        if int(discrepancy_evaluations) != discrepancy_evaluations or discrepancy_evaluations < 1:
            raise ConfigError("method.discrepancy_evaluations must be an integer >= 1, "
                              f"got {discrepancy_evaluations!r}")
        self.discrepancy = str(discrepancy)
        self.discrepancy_step = None if discrepancy_step is None else float(discrepancy_step)
        self.discrepancy_evaluations = int(discrepancy_evaluations)
        self.discrepancy_out_of_sample = bool(discrepancy_out_of_sample)
        self.discrepancy_mean = bool(discrepancy_mean)
        if max_steps is not None and (int(max_steps) != max_steps or max_steps < 1):
            raise ConfigError(f"method.max_steps must be null or an integer >= 1, got {max_steps!r}")
        self.max_steps = None if max_steps is None else int(max_steps)

    # ------------------------------------------------------------------ (a)
    def fit_one(self, problem: RegressionProblem, seed: int | None = None) -> Identification:
        """Posterior of one DOF's coefficients and noise scale.

        Returns an :class:`Identification` with medians as ``params``, 5 %
        and 95 % quantiles, ``samples[dof] = {"names", "values" (n_samples,
        p), "sigma" (n_samples,)}`` and the ``bayes/<dof>/...`` metrics.
        """
        started = time.perf_counter()
        dof = problem.dof
        post = RegressionPosterior(problem, self.autocorr_correction)
        n, p, ndim = post.n, post.p, post.ndim
        walkers = self.n_walkers or max(32, 2 * ndim)
        seed = self.seed + "XYN".find(dof) + 1 if seed is None else seed
        chain, diag = sample_regression_chain(post, walkers, self.n_samples, self.burn_in,
                                              self.thin, self.init_scale, self.moves, seed, dof,
                                              self.max_steps)
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
        result.history.update(diag.history_metrics(prefix))
        result.metrics.update({
            f"{prefix}/n_eff_rows": post.n_eff,
            f"{prefix}/rows": float(n),
            f"{prefix}/residual_autocorr_time": n / post.n_eff,
            f"{prefix}/sigma_inflation": float(np.sqrt(1.0 / post.kappa)),
            f"{prefix}/sigma": float(np.median(sigma)),
            f"{prefix}/walkers": float(walkers),
            f"{prefix}/steps": float(self.burn_in + diag.steps),
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
            ``{dof: RegressionProblem}`` (:func:`~studies.identification.regression.build_problems`).
        objective : TrajectoryObjective, optional
            Needed only for the trajectory posterior (b).
        """
        started = time.perf_counter()
        # the problems' known coefficients (fixed terms, tied rudder pairs) are part of the model
        # the discrepancy and the trajectory posterior replay
        result = Identification(params=known_coefficients(problems))
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
            result.writers[f"corner_{dof}.png"] = corner_writer(
                entry["names"], entry["values"], f"{dof}: regression posterior", self.corner_max)
        terms = self.trajectory_names(problems, result.params)
        if terms:
            if objective is None:
                raise ValueError("bayes: trajectory_terms needs the trajectory objective "
                                 "(fit(problems, objective=...))")
            traj = self.sample_trajectory(objective, result.params, terms)
            result.update(traj)
        result.metrics["bayes/runtime_s"] = time.perf_counter() - started
        if self.discrepancy == "auto":
            raise ValueError("bayes: method.discrepancy=auto must be settled by the run before fitting "
                             "(studies.config.settled_discrepancy: process_noise on measured records)")
        if self.discrepancy != "none":
            result.update(self.estimate_discrepancy(objective, result.params, problems))
        return result

    def estimate_discrepancy(self, objective, params: dict, problems: dict | None = None) -> Identification:
        """The model discrepancy of ``discrepancy`` on the objective's training
        records at ``params`` (:mod:`studies.identification.discrepancy`); with
        ``discrepancy_out_of_sample`` and the regression ``problems``, each
        record filtered by the coefficients identified without it."""
        if objective is None:
            raise ValueError("bayes: method.discrepancy needs the training records "
                             "(fit(problems, objective=...))")
        model = objective.model
        values = {name: params.get(name, 0.0) for name in model.names}
        per_record = None
        if self.discrepancy_out_of_sample and problems is not None:
            per_record = out_of_sample_values(problems, values, len(objective.records))
            if per_record is None:
                logger.info("bayes: the discrepancy is estimated in sample (fewer than three training "
                            "records, or a record's removal leaves a regression underdetermined)")
        found = estimate_process_noise(model, per_record or values, objective.vessel, objective.records,
                                       step=self.discrepancy_step,
                                       max_evaluations=self.discrepancy_evaluations,
                                       modules=getattr(objective, "modules", None),
                                       mean=self.discrepancy_mean)
        logger.info("bayes: model discrepancy (%s%s) sigma = %.3g m/s^2, %.3g m/s^2, %.3g rad/s^2, "
                    "tau = %.1f s, %.1f s, %.1f s; constant per record: sd %.3g m/s^2, %.3g m/s^2, "
                    "%.3g rad/s^2", found.kind,
                    ", each record filtered by the model of the others" if per_record else "",
                    *found.sigma, *found.taus, *found.offset_sd)
        out = Identification()
        out.samples["discrepancy"] = found.as_sample()
        out.metrics.update(found.metrics(objective.vessel))
        return out

    # ------------------------------------------------------------------ (b)
    def trajectory_names(self, problems: dict, params: dict) -> list:
        """Coefficients of the trajectory posterior (b) from ``trajectory_terms``.

        ``"ga"``: the 5 least Sobol-sensitive coefficients per DOF at
        ``params`` (:func:`studies.identification.sensitivity.least_sensitive`);
        a list is checked against the identified names; ``None``: none.
        """
        if self.trajectory_terms is None:
            return []
        if self.trajectory_terms == "ga":
            picked, _table = least_sensitive(problems, params, per_dof=5, n_samples=5000,
                                             seed=self.seed)
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
        started = time.perf_counter()
        model = objective.model
        names = model.names
        terms = list(terms)
        missing = [t for t in terms if t not in names]
        if missing:
            raise ConfigError(f"trajectory terms {missing} are not terms of model '{model.name}'")
        idx = np.array([names.index(t) for t in terms])
        base = model.vector(params)
        prior = BoxPrior.around(base[idx], self.trajectory_prior_width)
        records = first_seconds(objective.records, self.trajectory_duration)
        likelihood = TrajectoryLikelihood(TrajectoryObjective(model, objective.vessel, records),
                                          base, idx, prior, self.trajectory_max_samples)
        ndim = len(terms)
        walkers = self.trajectory_walkers or max(8, 2 * ndim + 2)
        walkers += walkers % 2
        seed = self.seed + 10 if seed is None else seed
        x0, x_start = self._trajectory_start(prior, terms, start, walkers, seed)
        chain, diag = sample_trajectory_chain(likelihood, x0, x_start, self.trajectory_burn_in,
                                              self.trajectory_steps, self.trajectory_thin,
                                              self.moves, seed, self.trajectory_autocorr_correction)
        m_total = likelihood.m_total
        n_eff = likelihood.n_eff
        coef = prior.values(chain)
        q05, q50, q95 = np.quantile(coef, [0.05, 0.5, 0.95], axis=0)
        result = Identification()
        result.params = dict(zip(terms, q50.tolist()))
        result.lower = dict(zip(terms, q05.tolist()))
        result.upper = dict(zip(terms, q95.tolist()))
        result.samples["trajectory"] = {"names": terms, "values": coef}
        at_edge = prior.edge_fraction(chain)
        result.metrics.update(diag.metrics("bayes/trajectory"))
        result.history.update(diag.history_metrics("bayes/trajectory"))
        result.metrics.update({
            "bayes/trajectory/n_terms": float(ndim),
            "bayes/trajectory/walkers": float(walkers),
            "bayes/trajectory/steps": float(self.trajectory_burn_in + diag.steps),
            "bayes/trajectory/compared_samples": m_total,
            "bayes/trajectory/n_eff_u": float(n_eff[0]),
            "bayes/trajectory/n_eff_v": float(n_eff[1]),
            "bayes/trajectory/n_eff_r": float(n_eff[2]),
            "bayes/trajectory/prior_edge_fraction": at_edge,
            "bayes/trajectory/runtime_s": time.perf_counter() - started,
        })
        if at_edge > 0.01:
            logger.warning("bayes trajectory: %.1f %% of the samples are at the edge of the "
                           "prior box (+-%g x |regression value|): the posterior is cut by it",
                           100 * at_edge, self.trajectory_prior_width)
        result.writers["corner_trajectory.png"] = corner_writer(
            terms, coef, "trajectory-likelihood posterior", self.corner_max)
        return result

    def _trajectory_start(self, prior: BoxPrior, terms: list, start: dict | None, walkers: int,
                          seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Initial walkers of (b) in box coordinates.

        A ball of radius ``trajectory_init_scale / trajectory_prior_width``
        (``trajectory_init_scale`` relative to ``|c_reg|``) around ``start``
        (default: the box centre), kept inside the box.

        Returns
        -------
        x0 : ndarray (walkers, len(terms))
        x_start : ndarray (len(terms),)
            Centre of the ball.
        """
        rng = np.random.default_rng(seed)
        start_vec = prior.centre.copy()
        for j, t in enumerate(terms):
            if start and t in start:
                start_vec[j] = start[t]
        x_start = prior.coordinates(start_vec)
        ball = self.trajectory_init_scale / self.trajectory_prior_width
        x0 = x_start + ball * rng.standard_normal((walkers, len(terms)))
        x0 = np.clip(x0, -0.999, 0.999)
        return x0, x_start
