"""Convergence checks of emcee runs and the ranking of coefficients by certainty.

:func:`diagnose` applies the usual emcee rules to a finished run (chain
longer than :data:`MIN_TAU_MULTIPLE` integrated autocorrelation times, mean
acceptance fraction in :data:`ACCEPTANCE_RANGE`) and returns a
:class:`ChainDiagnostics`; :func:`least_certain` picks the coefficients with
the widest 90 % interval relative to their median.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from emcee.autocorr import AutocorrError

__all__ = ["MIN_TAU_MULTIPLE", "ACCEPTANCE_RANGE", "ChainDiagnostics", "diagnose", "least_certain"]

#: one logger for the whole package: ``studies.identify.bayes``
logger = logging.getLogger(__package__)

#: usual emcee rules: chain longer than this many autocorrelation times ...
MIN_TAU_MULTIPLE = 50.0
#: ... and a mean acceptance fraction in this range
ACCEPTANCE_RANGE = (0.15, 0.7)


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
        """``{prefix}/acceptance_fraction``, ``autocorr_time_max``, ``n_effective``
        and ``converged`` (1.0 or 0.0)."""
        return {f"{prefix}/acceptance_fraction": self.acceptance_fraction,
                f"{prefix}/autocorr_time_max": self.autocorr_time_max,
                f"{prefix}/n_effective": self.n_effective,
                f"{prefix}/converged": float(self.converged)}


def diagnose(sampler, burn_in: int, steps: int, label: str) -> ChainDiagnostics:
    """Acceptance, autocorrelation time and the convergence verdict; warns when bad.

    Parameters
    ----------
    sampler : emcee.EnsembleSampler
        After its run of ``burn_in + steps`` steps.
    burn_in : int
        Steps discarded before the autocorrelation time is estimated.
    steps : int
        Steps after burn-in (before thinning).
    label : str
        Names the run in the warning (a DOF or ``"trajectory"``).
    """
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


def least_certain(names, samples: np.ndarray, k: int) -> list[int]:
    """Indices (model order) of the ``k`` coefficients with the widest 90 %
    interval relative to their median.

    Parameters
    ----------
    names : list of str
        Coefficient names, one per column of ``samples``.
    samples : ndarray (n_samples, len(names))
        Posterior samples (prime).
    k : int
        How many to pick.
    """
    q05, q50, q95 = np.quantile(samples, [0.05, 0.5, 0.95], axis=0)
    rel = (q95 - q05) / np.maximum(np.abs(q50), 1e-300)
    order = np.argsort(-rel, kind="stable")[:k]
    return sorted(order.tolist())
