"""Convergence checks of emcee runs and the ranking of coefficients by certainty.

:func:`diagnose` applies the usual emcee rules to a finished run (chain
longer than :data:`MIN_TAU_MULTIPLE` integrated autocorrelation times, mean
acceptance fraction in :data:`ACCEPTANCE_RANGE`) and returns a
:class:`ChainDiagnostics`; :func:`least_certain` picks the coefficients with
the widest 90 % interval relative to their median. :class:`ChainHistory`
records the mean acceptance fraction and the autocorrelation time while a
run goes on, for the run's step metrics.
"""

from __future__ import annotations

import warnings

import logging
from dataclasses import dataclass, field

import numpy as np
from emcee.autocorr import AutocorrError, integrated_time

__all__ = ["MIN_TAU_MULTIPLE", "ACCEPTANCE_RANGE", "ChainDiagnostics", "ChainHistory", "diagnose",
           "least_certain"]

#: one logger for the whole package: ``studies.identification.bayes``
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
    history : ChainHistory or None
        The acceptance and autocorrelation time at checkpoints of the run.
    """

    acceptance_fraction: float
    autocorr_time_max: float
    n_effective: float
    steps: int
    converged: bool
    reasons: list = field(default_factory=list)
    history: "ChainHistory | None" = None

    def metrics(self, prefix: str) -> dict:
        """``{prefix}/acceptance_fraction``, ``autocorr_time_max``, ``n_effective``
        and ``converged`` (1.0 or 0.0)."""
        return {f"{prefix}/acceptance_fraction": self.acceptance_fraction,
                f"{prefix}/autocorr_time_max": self.autocorr_time_max,
                f"{prefix}/n_effective": self.n_effective,
                f"{prefix}/converged": float(self.converged)}

    def history_metrics(self, prefix: str) -> dict:
        """``{prefix}/acceptance_fraction`` and ``{prefix}/autocorr_time_max`` as
        ``[(emcee step, value), ...]`` (empty without a history); their last
        values are those of :meth:`metrics`."""
        return self.history.metrics(prefix) if self.history is not None else {}


#: checkpoints of a run at which the mean acceptance fraction is recorded
ACCEPTANCE_CHECKPOINTS = 50
#: shares of the steps after burn-in at which the autocorrelation time is estimated
#: while the run goes on; the last estimate is the diagnostics' own. Each costs
#: emcee's estimator on the chain so far (0.1-0.2 s for a whole default chain of
#: 3756 steps x 32 walkers x 16 parameters): the checkpoints took 7 % of a
#: default three-DOF fit (measured; ten evenly spaced ones doubled its time)
AUTOCORR_SHARES = (0.25, 0.5)
#: fewest steps after burn-in for an autocorrelation time at a checkpoint
MIN_AUTOCORR_STEPS = 20


def _every(steps: int, checkpoints: int) -> int:
    """Steps between checkpoints: at most ``checkpoints`` of them in ``steps``."""
    return max(1, -(-steps // checkpoints))


@dataclass
class ChainHistory:
    """Diagnostics of an emcee run at checkpoints, as it goes on.

    Attributes
    ----------
    steps : int
        Steps of the run (burn-in included).
    burn_in : int
        Steps discarded before the autocorrelation time is estimated.
    offset : int
        Added to the sampler's step count (a second stage that continues a
        first one).
    acceptance : list of (int, float)
        ``(step, mean acceptance fraction over the walkers since the start)``.
    autocorr : list of (int, float)
        ``(step, largest integrated autocorrelation time of the chain after
        burn_in so far [steps])``.
    with_autocorr : bool
        Estimate the autocorrelation time at the checkpoints (not in a run
        that continues a chain: its time is taken at the end).
    """

    steps: int
    burn_in: int = 0
    offset: int = 0
    acceptance: list = field(default_factory=list)
    autocorr: list = field(default_factory=list)
    with_autocorr: bool = True

    def record(self, sampler, step: int) -> None:
        """Record the run of ``sampler`` after ``step`` steps (1-based) when
        ``step`` is a checkpoint."""
        if step == self.steps or step % _every(self.steps, ACCEPTANCE_CHECKPOINTS) == 0:
            self.acceptance.append((self.offset + step, float(np.mean(sampler.acceptance_fraction))))
        kept = step - self.burn_in
        marks = {round(share * (self.steps - self.burn_in)) for share in AUTOCORR_SHARES}
        if self.with_autocorr and kept >= MIN_AUTOCORR_STEPS and kept in marks:
            # tol=0: the estimate without emcee's warning about a short chain
            chain = sampler.get_chain(discard=self.burn_in)
            tau = float(np.max(integrated_time(chain, tol=0, quiet=True)))
            self.autocorr.append((self.offset + step, tau))

    def extend(self, other: "ChainHistory") -> None:
        """Append the checkpoints of a later stage."""
        self.acceptance += other.acceptance
        self.autocorr += other.autocorr

    def metrics(self, prefix: str) -> dict:
        """``{prefix}/acceptance_fraction`` and ``{prefix}/autocorr_time_max``
        as ``[(step, value), ...]`` (a name without checkpoints left out)."""
        out = {f"{prefix}/acceptance_fraction": list(self.acceptance),
               f"{prefix}/autocorr_time_max": list(self.autocorr)}
        return {k: v for k, v in out.items() if v}


def autocorr_time(sampler, burn_in: int) -> float:
    """Largest integrated autocorrelation time [steps] of the chain after
    ``burn_in``, without emcee's warning about a short chain (nan when it
    cannot be estimated)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)       # a chain of one or two steps
            return float(np.max(sampler.get_autocorr_time(discard=burn_in, tol=0)))
    except (AutocorrError, ValueError, FloatingPointError):
        return float("nan")


def diagnose(sampler, burn_in: int, steps: int, label: str,
             history: ChainHistory | None = None, budget: int | None = None) -> ChainDiagnostics:
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
    history : ChainHistory, optional
        The run's checkpoints; the final autocorrelation time is added to it.
    budget : int, optional
        The chain was extended up to this many steps (``method.max_steps``):
        the warning names that setting.
    """
    acc = float(np.mean(sampler.acceptance_fraction))
    reasons = []
    tau_max = autocorr_time(sampler, burn_in)
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
    if history is not None and np.isfinite(tau_max):
        history.autocorr.append((history.offset + burn_in + steps, tau_max))
    diag = ChainDiagnostics(acc, tau_max, n_eff, steps, not reasons, reasons, history)
    if reasons and budget is not None:
        logger.warning("bayes %s: the sampler has not converged within method.max_steps=%d: %s; the "
                       "quantiles are not reliable (raise method.max_steps)", label, budget, "; ".join(reasons))
    elif reasons:
        logger.warning("bayes %s: the sampler has not converged: %s; the quantiles are not "
                       "reliable (run longer: method.max_steps, burn_in, n_samples, thin, or more walkers)",
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
