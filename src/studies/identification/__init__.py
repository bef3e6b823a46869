"""Identification methods, selected by the ``method=`` config group.

Every method is an estimator: the constructor stores settings (the keys of
its ``conf/method/<name>.yaml`` besides ``name``), and
``fit(problems, objective=None)`` takes the regression problems of
:mod:`studies.identification.regression` (one per DOF) and, for methods that
simulate, a :class:`~studies.identification.objective.TrajectoryObjective` on the
training records, and returns an :class:`~studies.identification.base.Identification`.
"""

from __future__ import annotations

from ..errors import ConfigError
from ..lazy import LazyClasses, load

__all__ = ["Identification", "RegressionProblem", "build_problems", "LeastSquares",
           "GeneticRefinement", "BayesianRegression", "SupportVectorRegression",
           "SparseRegression", "MANOEUVRING_METHODS", "make_identifier"]

#: where each public name lives: imported on first use (``import studies.identification`` is
#: cheap; a least-squares run never loads emcee, pygad or pysindy)
_EXPORTS = {"Identification": "studies.identification.base:Identification",
            "RegressionProblem": "studies.identification.regression:RegressionProblem",
            "build_problems": "studies.identification.regression:build_problems",
            "LeastSquares": "studies.identification.ls:LeastSquares",
            "GeneticRefinement": "studies.identification.ga:GeneticRefinement",
            "BayesianRegression": "studies.identification.bayes.estimator:BayesianRegression",
            "SupportVectorRegression": "studies.identification.svm:SupportVectorRegression",
            "SparseRegression": "studies.identification.sindy:SparseRegression"}

#: manoeuvring identifiers by config name (classes imported when looked up)
MANOEUVRING_METHODS = LazyClasses({name: _EXPORTS[cls] for name, cls in (
    ("ls", "LeastSquares"), ("svm", "SupportVectorRegression"), ("ls_ga", "GeneticRefinement"),
    ("svm_ga", "GeneticRefinement"), ("bayes", "BayesianRegression"), ("sindy", "SparseRegression"))})


def __getattr__(name: str):
    if name in _EXPORTS:
        value = load(_EXPORTS[name])
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

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
