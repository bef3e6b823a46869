"""Identification methods, selected by the ``method=`` config group.

Every method is an estimator: the constructor stores settings (the keys of
its ``conf/method/<name>.yaml`` besides ``name``), and
``fit(problems, objective=None)`` takes the regression problems of
:mod:`studies.identify.regression` (one per DOF) and, for methods that
simulate, a :class:`~studies.identify.objective.TrajectoryObjective` on the
training records, and returns an :class:`~studies.identify.base.Identification`.
"""

from __future__ import annotations

from ..errors import ConfigError
from .base import Identification
from .bayes import BayesianRegression
from .ga import GeneticRefinement
from .ls import LeastSquares
from .sindy import SparseRegression
from .svm import SupportVectorRegression
from .regression import RegressionProblem, build_problems

__all__ = ["Identification", "RegressionProblem", "build_problems", "LeastSquares",
           "GeneticRefinement", "BayesianRegression", "SupportVectorRegression",
           "SparseRegression", "MANOEUVRING_METHODS", "make_identifier"]

#: manoeuvring identifiers by config name
MANOEUVRING_METHODS = {"ls": LeastSquares, "svm": SupportVectorRegression,
                       "ls_ga": GeneticRefinement, "svm_ga": GeneticRefinement,
                       "bayes": BayesianRegression, "sindy": SparseRegression}


def make_identifier(name: str, options: dict | None = None):
    """Instantiate the identifier registered as ``name`` with ``options`` (the name is checked
    by :func:`studies.workflows.methods.check_method` when the run is prepared)."""
    if name not in MANOEUVRING_METHODS:
        raise ConfigError(f"method '{name}' is not a manoeuvring identifier; known: {', '.join(MANOEUVRING_METHODS)}")
    cls = MANOEUVRING_METHODS[name]
    try:
        return cls(**(options or {}))
    except TypeError as exc:
        raise ConfigError(f"method '{name}': {exc}") from None
