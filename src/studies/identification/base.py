"""What every identification method returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Identification", "condition_number", "variance_inflation", "known_coefficients"]


@dataclass
class Identification:
    """Result of fitting one or more regression problems.

    Attributes
    ----------
    params : dict
        Point estimates ``{name: value}`` (prime).
    lower, upper : dict
        5 % and 95 % quantiles where the method gives uncertainty.
    samples : dict
        Posterior samples per DOF where the method gives them.
    metrics : dict
        Flat numeric diagnostics (condition numbers, residual RMS, ...).
    writers : dict
        ``{file name: callable(path)}`` for figures or tables the method
        produces (e.g. corner plots); the run writes them into its directory
        and logs them as artifacts.
    history : dict
        ``{metric name: [(step, value), ...]}``: diagnostics recorded while
        the method ran (GA best fitness per generation, emcee acceptance per
        iteration); the run logs them as step metrics. The last value of a
        name that is also in ``metrics`` equals it.
    """

    params: dict = field(default_factory=dict)
    lower: dict = field(default_factory=dict)
    upper: dict = field(default_factory=dict)
    samples: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)
    writers: dict = field(default_factory=dict)
    history: dict = field(default_factory=dict)

    def update(self, other: "Identification") -> None:
        self.params.update(other.params)
        self.lower.update(other.lower)
        self.upper.update(other.upper)
        self.samples.update(other.samples)
        self.metrics.update(other.metrics)
        self.writers.update(other.writers)
        self.history.update(other.history)


def _unit_columns(theta: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(theta, axis=0)
    norms[norms == 0] = 1.0
    return theta / norms


def known_coefficients(problems: dict) -> dict:
    """``{name: value}`` of the coefficients the problems hold as known
    (``problem.fixed``, moved into ``y``: a model's fixed terms, an MMG
    family's tied rudder pairs). Every identification returns them with the
    ones it fits, so that its ``params`` are the whole model."""
    return {name: float(value) for problem in problems.values()
            for name, value in (getattr(problem, "fixed", None) or {}).items()}


def condition_number(theta: np.ndarray) -> float:
    """2-norm condition number of the column-normalised regression matrix."""
    if theta.shape[1] == 0:
        return 1.0
    s = np.linalg.svd(_unit_columns(theta), compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def variance_inflation(theta: np.ndarray) -> np.ndarray:
    """Variance inflation factor of each column (diagonal of the inverse
    correlation matrix of the columns; a constant column gets VIF from the
    uncentred moment matrix)."""
    if theta.shape[1] < 2:
        return np.ones(theta.shape[1])
    x = _unit_columns(theta)
    gram = x.T @ x
    try:
        return np.diag(np.linalg.inv(gram)) * np.diag(gram)
    except np.linalg.LinAlgError:
        return np.full(theta.shape[1], np.inf)
