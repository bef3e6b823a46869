"""Likelihoods of the two posteriors of :mod:`studies.identification.bayes`.

* :class:`RegressionPosterior`: the Gaussian likelihood of one DOF's
  inverse-dynamics regression ``y = Theta c + e`` (with its flat priors),
  evaluated from precomputed moments and tempered by ``n_eff / n`` for
  autocorrelated residuals (:func:`effective_rows`,
  :func:`residual_autocorr_time`);
* :class:`TrajectoryLikelihood`: simulated minus recorded ``u, v, r`` of the
  training records at evenly spaced samples (:func:`compared_samples`),
  Gaussian with the noise scale per channel integrated out, inside the box
  prior of :class:`~studies.identification.bayes.priors.BoxPrior`.

The package docstring derives both.
"""

from __future__ import annotations

import numpy as np
from emcee.autocorr import integrated_time

from ..objective import TrajectoryObjective
from ..regression import RegressionProblem
from .priors import BoxPrior

__all__ = ["residual_autocorr_time", "effective_rows", "RegressionPosterior", "first_seconds",
           "compared_samples", "TrajectoryLikelihood"]


def residual_autocorr_time(residual: np.ndarray) -> float:
    """Integrated autocorrelation time of a residual series [rows].

    Sokal's estimate with the automatic window (``c = 5``) as emcee computes
    it for chains; 1 for white noise, about 1.4 for the residual of the
    4th-order central difference of a process-noise-driven record, 10-20
    for Savitzky-Golay derivatives. Never below 1 (negative correlations
    are not used to narrow the intervals).
    """
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


class RegressionPosterior:
    """Log-posterior of one DOF's regression, evaluated from precomputed moments.

    Parameters
    ----------
    problem : RegressionProblem
        ``y = theta @ c`` (prime).
    autocorr_correction : bool
        Temper the likelihood by ``n_eff / n`` (package docstring).

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


def first_seconds(records, duration: float | None) -> list:
    """The first ``duration`` seconds of each record (column ``t`` [s]), attributes
    kept; ``None``: the whole records."""
    out = []
    for rec in records:
        if duration is not None:
            t = rec["t"].to_numpy(float)
            cut = rec.loc[t - t[0] <= duration]
            cut.attrs = dict(rec.attrs)
            rec = cut
        out.append(rec)
    return out


def compared_samples(records, max_samples: int) -> list[np.ndarray]:
    """Rows compared per record: at most ``max_samples`` evenly spaced, the
    initial row (the simulation's initial condition) excluded."""
    picks = []
    for rec in records:
        m = len(rec)
        k = min(max_samples, m - 1)
        picks.append(np.unique(np.linspace(1, m - 1, k).astype(int)))
    return picks


class TrajectoryLikelihood:
    """Log-posterior of some coefficients from replayed training records.

    The coefficients ``idx`` of ``base`` are sampled in the coordinates of
    the box ``prior``; the others stay at ``base``. Every walker's
    coefficient set is simulated by replaying the records' rudder, and the
    simulated minus recorded ``u, v, r`` at the compared samples give::

        log L = -sum_ch kappa_ch m/2 log SSE_ch

    (Gaussian, noise scale per channel integrated out under the Jeffreys
    prior; ``m`` compared samples in all records).

    Parameters
    ----------
    objective : TrajectoryObjective
        Model, vessel and the records to replay.
    base : ndarray (n_coefficients,)
        Model vector of every coefficient (prime).
    idx : ndarray of int (k,)
        Positions of the sampled coefficients in ``base``.
    prior : BoxPrior
        Box of the sampled coefficients.
    max_samples : int
        Compared samples per record and channel (evenly spaced).

    Attributes
    ----------
    picks : list of ndarray
        Compared rows per record.
    m_total : float
        Compared samples in all records.
    kappa : ndarray (3,)
        ``n_eff / m`` per channel ``u, v, r``; 1 until
        :meth:`correct_for_autocorrelation`.
    """

    def __init__(self, objective: TrajectoryObjective, base: np.ndarray, idx: np.ndarray,
                 prior: BoxPrior, max_samples: int):
        self.objective = objective
        self.base = base
        self.idx = idx
        self.prior = prior
        self.picks = compared_samples(objective.records, max_samples)
        self.m_total = float(sum(len(p) for p in self.picks))
        self.kappa = np.ones(3)

    def vector(self, x: np.ndarray) -> np.ndarray:
        """Model vector of box coordinates ``x`` (k,)."""
        vector = self.base.copy()
        vector[self.idx] = self.prior.values(x)
        return vector

    def sse(self, vectors: np.ndarray) -> np.ndarray:
        """Sums of squared residuals per channel ``u, v, r`` (m, 3) of model vectors (m, n)."""
        total = np.zeros((vectors.shape[0], 3))
        for res, pick in zip(self.objective.residuals_many(vectors), self.picks):
            pick = pick[pick < res.shape[1]]
            total += np.sum(res[:, pick, :] ** 2, axis=1)
        return total

    def residual_series(self, vector: np.ndarray) -> list[np.ndarray]:
        """Residuals ``u, v, r`` at the compared samples of each record, (m_k, 3) each."""
        return [res[0, pick[pick < res.shape[1]], :]
                for res, pick in zip(self.objective.residuals_many(vector[None, :]), self.picks)]

    def log_prob(self, x: np.ndarray) -> np.ndarray:
        """Log-posterior (up to a constant) of walkers ``x`` (m, k) in box
        coordinates, vectorised; ``-inf`` outside the box or when a simulation
        diverges."""
        x = np.atleast_2d(x)
        lp = np.full(x.shape[0], -np.inf)
        inside = self.prior.inside(x)
        if not np.any(inside):
            return lp
        vectors = np.repeat(self.base[None, :], int(inside.sum()), axis=0)
        vectors[:, self.idx] = self.prior.values(x[inside])
        sse = self.sse(vectors)
        with np.errstate(divide="ignore", invalid="ignore"):
            val = -0.5 * self.m_total * np.sum(self.kappa * np.log(np.maximum(sse, 1e-300)), axis=1)
        val[~np.all(np.isfinite(sse), axis=1)] = -np.inf
        lp[inside] = np.where(np.isfinite(val), val, -np.inf)
        return lp

    def correct_for_autocorrelation(self, x: np.ndarray) -> None:
        """Set ``kappa = min(1, n_eff / m)`` per channel from the residuals at
        box coordinates ``x`` (k,): ``n_eff = sum_k m_k / tau_k`` over the
        records, ``tau_k`` of :func:`residual_autocorr_time`."""
        n_eff = np.zeros(3)
        for part in self.residual_series(self.vector(x)):
            for ch in range(3):
                n_eff[ch] += part.shape[0] / residual_autocorr_time(part[:, ch])
        self.kappa[:] = np.minimum(1.0, n_eff / self.m_total)

    @property
    def n_eff(self) -> np.ndarray:
        """Effective number of compared samples per channel ``u, v, r`` (3,)."""
        return self.kappa * self.m_total
