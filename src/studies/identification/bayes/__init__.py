"""Bayesian posteriors of the manoeuvring coefficients, sampled with emcee.

Two posteriors are provided by :class:`BayesianRegression` (``method=bayes``).

(a) Regression posterior, per DOF. The inverse-dynamics regression of
:mod:`studies.identification.regression`, ``y = Theta c + e`` (prime units), with
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
(:meth:`~studies.identification.objective.TrajectoryObjective.residuals_many`,
one compiled parallel call per emcee half-step), and the simulated minus
recorded ``u, v, r`` at evenly spaced samples have a Gaussian likelihood
with unknown noise scale per channel, integrated out under the Jeffreys
prior (``log L = -sum_ch kappa_ch m/2 log SSE_ch``). Simulation errors are
strongly autocorrelated, so ``kappa_ch = n_eff/m`` is estimated from the
residuals at the best walker after the first half of the burn-in (the
first half uses ``kappa = 1`` to find the mode). The prior is flat in a
box ``|c - c_reg| <= trajectory_prior_width * |c_reg|``.

Modules
-------
:mod:`~studies.identification.bayes.estimator`
    :class:`BayesianRegression`, the ``method=bayes`` identifier.
:mod:`~studies.identification.bayes.likelihood`
    :class:`RegressionPosterior` (a), the residual autocorrelation time and
    effective rows, the trajectory likelihood (b).
:mod:`~studies.identification.bayes.priors`
    The flat box prior of (b).
:mod:`~studies.identification.bayes.sampler`
    emcee moves, :func:`run_with_progress` and the sampling runs of (a)
    and (b).
:mod:`~studies.identification.bayes.diagnostics`
    Convergence checks (:class:`ChainDiagnostics`) and
    :func:`least_certain`.
:mod:`~studies.identification.bayes.figures`
    :func:`plot_corner`, drawn with the ``corner`` package.

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

Foreman-Mackey, D. (2016). corner.py: scatterplot matrices in Python. The
Journal of Open Source Software 1(2), 24. doi:10.21105/joss.00024

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

from .diagnostics import ChainDiagnostics, least_certain
from .estimator import BayesianRegression
from .figures import plot_corner
from .likelihood import RegressionPosterior, effective_rows, residual_autocorr_time
from .sampler import run_with_progress

__all__ = ["BayesianRegression", "RegressionPosterior", "ChainDiagnostics", "residual_autocorr_time",
           "effective_rows", "plot_corner", "least_certain", "run_with_progress"]
