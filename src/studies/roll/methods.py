"""The roll-decay identification methods by name (``method=`` with ``model=roll``).

:data:`ROLL_METHODS` holds the estimators of :mod:`studies.roll.estimators`
(``nls``, ``fls``, ``nls_svm``: point estimates) and the Bayesian one of
:mod:`studies.roll.bayes` (``bayes``: a posterior, its quantiles and, with a
discrepancy, predictive bands); :func:`make_method` builds one.
"""

from __future__ import annotations

from typing import Sequence

from studies.lazy import LazyClasses

__all__ = ["ROLL_METHODS", "make_method"]

#: every roll identification method by its ``method=`` name
#: (imported when looked up: the Bayesian one loads emcee)
ROLL_METHODS = LazyClasses({"nls": "studies.roll.estimators:NLSEstimator",
                            "fls": "studies.roll.estimators:FLSEstimator",
                            "nls_svm": "studies.roll.estimators:NLSSVMEstimator",
                            "bayes": "studies.roll.bayes:BayesRollEstimator"})


def make_method(method: str, terms: Sequence[str] = ("b1", "b2"), seed: int = 0, **settings):
    """The estimator of ``method`` (:data:`ROLL_METHODS`) with its settings.

    Raises
    ------
    ValueError
        Unknown method.
    """
    try:
        cls = ROLL_METHODS[method]
    except KeyError:
        raise ValueError(f"unknown roll identification method '{method}'; choose from "
                         f"{sorted(ROLL_METHODS)}") from None
    return cls(terms=terms, seed=seed, **settings)
