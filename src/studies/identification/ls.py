"""Ordinary least squares on the inverse-dynamics regression (thesis eq. 3.28).

Columns are scaled to unit norm before the SVD-based solve (the Abkowitz
features span six orders of magnitude), then unscaled. The condition number
and the largest variance inflation factor of each DOF are reported so that an
ill-conditioned identification (weak excitation, collinear terms) is visible.

References
----------
Zhu, M. (2021). MSc thesis, NTNU, section 3.2.2.
"""

from __future__ import annotations

import numpy as np

from .base import Identification, condition_number, known_coefficients, variance_inflation
from .regression import RegressionProblem

__all__ = ["LeastSquares", "ILL_CONDITIONED"]

#: condition number above which an identification is flagged as ill-conditioned
ILL_CONDITIONED = 1e4


class LeastSquares:
    """Least-squares identifier: ``fit(problems) -> Identification``."""

    name = "ls"

    def __init__(self, rcond: float | None = None):
        self.rcond = rcond

    def fit_one(self, problem: RegressionProblem) -> np.ndarray:
        theta = problem.theta
        norms = np.linalg.norm(theta, axis=0)
        norms[norms == 0] = 1.0
        coef, *_ = np.linalg.lstsq(theta / norms, problem.y, rcond=self.rcond)
        return coef / norms

    def fit(self, problems: dict, objective=None) -> Identification:
        """Fit every DOF's problem; ``objective`` (trajectory fitness) is unused.
        ``params`` hold the problems' known coefficients too (:func:`known_coefficients`)."""
        result = Identification(params=known_coefficients(problems))
        for dof, problem in problems.items():
            coef = self.fit_one(problem)
            result.params.update(dict(zip(problem.names, coef.tolist())))
            result.metrics.update(regression_diagnostics(problem, coef))
        return result


def regression_diagnostics(problem: RegressionProblem, coef: np.ndarray) -> dict:
    """Residual RMS, R^2, condition number and worst VIF of one DOF."""
    dof = problem.dof
    resid = problem.y - problem.theta @ coef
    ss = float(np.sum((problem.y - problem.y.mean()) ** 2)) or 1.0
    cond = condition_number(problem.theta)
    vif = variance_inflation(problem.theta)
    return {
        f"regression/{dof}/residual_rms": float(np.sqrt(np.mean(resid ** 2))),
        f"regression/{dof}/r2": 1.0 - float(np.sum(resid ** 2)) / ss,
        f"regression/{dof}/condition_number": cond,
        f"regression/{dof}/max_vif": float(np.max(vif)) if len(vif) else 1.0,
        f"regression/{dof}/ill_conditioned": float(cond > ILL_CONDITIONED),
    }
