"""Epsilon-support vector regression with a linear kernel (thesis section 3.2.2).

Each DOF's inverse-dynamics regression ``y = Theta c`` of
:mod:`studies.identification.regression` (prime units, mass matrix and known
coefficients already on the ``y`` side) is solved as a linear
epsilon-insensitive support vector regression (Drucker et al. 1997; Wang et
al. 2021, eq. 7-11): with a linear kernel the SVR weight vector *is* the
coefficient vector,

    min_w  1/2 |w|^2 + C sum_k L_eps(y_k - x_k^T w),

with ``L_eps(e) = max(0, |e| - eps)`` (``loss="epsilon_insensitive"``, the
classical SVR of Wang et al. eq. 8) or ``max(0, |e| - eps)^2``
(``loss="squared_epsilon_insensitive"``, the L2-loss SVR of Ho & Lin 2012,
the default: solved in the primal by liblinear's trust-region Newton method,
which converges in a few iterations on 40 000 rows where the dual coordinate
descent of the L1 loss needs minutes).

Scaling
    The Abkowitz features span three orders of magnitude in RMS and the
    coefficients five; the penalty ``|w|^2`` is not scale invariant. Every
    column of ``Theta`` is divided by its RMS and ``y`` by its RMS, so that
    ``C`` and ``eps`` mean the same for every term and DOF (``eps`` is a
    fraction of the RMS generalised force of the DOF), and the weights are
    mapped back exactly: ``c_j = w_j rms(y) / rms(Theta_j)``.
Intercept
    liblinear penalises its intercept like any weight (it is a weight on a
    constant feature of value ``intercept_scaling``). So no separate
    intercept is fitted (``fit_intercept=False``): a model with a constant
    term (``Y0``, ``N0``) has a column of ones in ``Theta``, which after
    scaling is exactly liblinear's intercept feature, and its weight maps
    back to the constant coefficient like every other; a DOF without a
    constant term (surge of the Abkowitz model) gets no intercept, as the
    model says.
Hyper-parameters
    ``C`` and ``eps`` are chosen by grid search with cross-validation
    (Wang et al. 2021, section 3.2) on at most ``max_rows`` rows taken evenly
    in time, with *time-blocked* folds: each test fold is one contiguous
    stretch of the record(s), never rows interleaved with the training rows
    (neighbouring samples of a 10 Hz record are nearly identical, so
    shuffled folds would measure interpolation, not prediction). The best
    pair is then refitted on all rows.
Tolerance
    liblinear's default ``tol=1e-4`` stops the Newton iterations at a
    relative gradient of 1e-4, which on the unit-scaled Mariner problem
    leaves median deviations of 10-90 % without any warning (the solver
    believes it has converged); ``tol=1e-9`` reaches deviations below
    0.02 % on the clean 20/20 zig-zag and still converges on every point
    of the default grid (``1e-10`` is a little more accurate but the
    non-smooth ``eps > 0`` losses then stall at large ``C``; ``1e-8``
    leaves up to 0.2 %). Fits that stop at ``max_iter``
    raise sklearn's ``ConvergenceWarning``: it is caught, counted in the
    metrics and logged, never silent.

Metrics per DOF: ``svm/<dof>/C``, ``svm/<dof>/epsilon`` (fraction of
``rms(y)``), ``svm/<dof>/epsilon_prime`` (prime force units),
``svm/<dof>/cv_score`` (best mean CV score, by default the negative mean
squared error of the scaled target), ``svm/<dof>/cv_rmse`` (with that
default scorer: the CV RMS error in prime units),
``svm/<dof>/converged`` (1 when the final fit converged, else 0),
``svm/<dof>/search_nonconverged`` (grid-search fits that did not converge),
``svm/<dof>/n_iter``, ``svm/<dof>/search_rows``, plus
:func:`~studies.identification.ls.regression_diagnostics`.

References
----------
Drucker, H., Burges, C.J.C., Kaufman, L., Smola, A., Vapnik, V. (1997).
Support vector regression machines. Advances in Neural Information
Processing Systems 9, 155-161.

Smola, A.J., Schoelkopf, B. (2004). A tutorial on support vector regression.
Statistics and Computing 14, 199-222. doi:10.1023/B:STCO.0000035301.49549.88

Ho, C.-H., Lin, C.-J. (2012). Large-scale linear support vector regression.
Journal of Machine Learning Research 13, 3323-3348.

Wang, T., Li, G., Wu, B., Aesoy, V., Zhang, H. (2021). Parameter
identification of ship manoeuvring model under disturbance using support
vector machine method. Ships and Offshore Structures.
doi:10.1080/17445302.2021.1927600, sections 2.3 and 3.2.

Zhu, M. (2021). MSc thesis, NTNU, section 3.2.2 and appendix A.2.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np

from ..errors import ConfigError
from .base import Identification, known_coefficients
from .ls import regression_diagnostics
from .regression import RegressionProblem
from ..config import SVM_LOSSES

__all__ = ["SupportVectorRegression", "time_blocked_splits", "search_rows", "scale_problem"]

log = logging.getLogger(__name__)

LOSSES = SVM_LOSSES


def scale_problem(problem: RegressionProblem):
    """Unit-RMS columns and target of one regression problem.

    Returns
    -------
    x : ndarray (n, p)
        ``Theta`` with every column divided by its RMS (an all-zero column is
        left as it is).
    y : ndarray (n,)
        ``y / rms(y)``.
    col_scale : ndarray (p,)
        RMS of each column [prime].
    y_scale : float
        RMS of ``y`` [prime].

    A weight ``w_j`` on the scaled problem is the coefficient
    ``w_j * y_scale / col_scale[j]`` on the original one.
    """
    theta = np.asarray(problem.theta, float)
    col_scale = np.sqrt(np.mean(theta ** 2, axis=0)) if theta.size else np.ones(theta.shape[1])
    col_scale = np.where(col_scale > 0, col_scale, 1.0)
    y_scale = float(np.sqrt(np.mean(np.asarray(problem.y, float) ** 2))) or 1.0
    return theta / col_scale, problem.y / y_scale, col_scale, y_scale


def search_rows(problem: RegressionProblem, max_rows: int | None) -> np.ndarray:
    """Rows used for the hyper-parameter search: all, or ``max_rows`` evenly
    spaced ones, in record-then-time order."""
    n = problem.n_rows
    if problem.record is not None and problem.time is not None:
        order = np.lexsort((np.asarray(problem.time), np.asarray(problem.record)))
    else:
        order = np.arange(n)
    if max_rows is None or max_rows >= n:
        return order
    pick = np.unique(np.linspace(0, n - 1, int(max_rows)).round().astype(int))
    return order[pick]


def time_blocked_splits(n_rows: int, folds: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(train, test)`` positions of ``folds`` contiguous, unshuffled blocks.

    Positions refer to rows already in time order (see :func:`search_rows`);
    each test fold is one contiguous block and the training set is the rest
    (:class:`sklearn.model_selection.KFold` with ``shuffle=False``).
    """
    from sklearn.model_selection import KFold  # lazy: scikit-learn takes about 1 s to load

    if folds < 2 or folds > n_rows:
        raise ValueError(f"need 2 <= folds <= rows, got folds={folds}, rows={n_rows}")
    return list(KFold(n_splits=folds, shuffle=False).split(np.zeros((n_rows, 1))))


def _count_convergence(caught) -> int:
    from sklearn.exceptions import ConvergenceWarning  # lazy: scikit-learn takes about 1 s to load

    return sum(issubclass(w.category, ConvergenceWarning) for w in caught)


class SupportVectorRegression:
    """Linear epsilon-SVR per DOF with time-blocked grid search of ``C`` and ``eps``.

    Parameters
    ----------
    c_grid : sequence of float
        Candidate penalty factors ``C`` (``gamma`` of Wang et al. eq. 8) on the
        unit-scaled problem; ``C`` weights the *sum* of the row losses, so the
        regularisation relative to the data weakens as rows are added.
    epsilon_grid : sequence of float
        Candidate tube half-widths ``eps`` as fractions of ``rms(y)`` of the DOF.
    folds : int
        Number of contiguous time blocks of the cross-validation (>= 2).
    max_rows : int or None
        At most this many rows, evenly spaced in time, for the search
        (``None``: all rows); the final fit uses all rows.
    loss : {"squared_epsilon_insensitive", "epsilon_insensitive"}
        L2-loss SVR (primal Newton solver, fast) or the classical L1-loss
        SVR (dual coordinate descent, slow on long records).
    dual : {"auto", True, False}
        liblinear formulation; ``"auto"`` takes the primal when the loss
        allows it (``n_rows >> n_terms``).
    max_iter : int
        Iteration limit of every liblinear fit.
    tol : float
        Relative stopping tolerance of liblinear (see module notes: 1e-4,
        sklearn's default, is far too loose here).
    scoring : str
        sklearn scorer of the search (default negative mean squared error
        of the scaled target).
    seed : int
        Random state of the dual coordinate descent (unused by the primal).

    References
    ----------
    Drucker et al. (1997); Smola & Schoelkopf (2004); Wang et al. (2021).
    """

    name = "svm"

    def __init__(self, c_grid=(1.0, 1e2, 1e4, 1e6, 1e8), epsilon_grid=(0.0, 1e-3, 1e-2),
                 folds: int = 5, max_rows: int | None = 5000,
                 loss: str = "squared_epsilon_insensitive", dual="auto", max_iter: int = 10000,
                 tol: float = 1e-9, scoring: str = "neg_mean_squared_error", seed: int = 0):
        if loss not in LOSSES:
            raise ConfigError(f"svm: loss must be one of {', '.join(LOSSES)}, got '{loss}'")
        if int(folds) < 2:
            raise ConfigError(f"svm: folds must be at least 2, got {folds}")
        if not len(c_grid) or not len(epsilon_grid):
            raise ConfigError("svm: c_grid and epsilon_grid need at least one value each")
        if min(c_grid) <= 0 or min(epsilon_grid) < 0:
            raise ConfigError("svm: C must be > 0 and epsilon >= 0")
        self.c_grid = tuple(float(c) for c in c_grid)
        self.epsilon_grid = tuple(float(e) for e in epsilon_grid)
        self.folds = int(folds)
        self.max_rows = None if max_rows is None else int(max_rows)
        self.loss = loss
        self.dual = dual
        self.max_iter = int(max_iter)
        self.tol = float(tol)
        self.scoring = scoring
        self.seed = int(seed)

    def estimator(self, C: float = 1.0, epsilon: float = 0.0):
        """The unfitted :class:`sklearn.svm.LinearSVR` with these settings."""
        from sklearn.svm import LinearSVR  # lazy: scikit-learn takes about 1 s to load

        return LinearSVR(C=C, epsilon=epsilon, loss=self.loss, dual=self.dual,
                         fit_intercept=False, tol=self.tol, max_iter=self.max_iter,
                         random_state=self.seed)

    def search(self, x: np.ndarray, y: np.ndarray, problem: RegressionProblem) -> dict:
        """Grid search of ``C`` and ``eps`` on time-blocked folds of the scaled rows."""
        from sklearn.model_selection import GridSearchCV  # lazy: scikit-learn takes about 1 s to load

        rows = search_rows(problem, self.max_rows)
        folds = min(self.folds, len(rows))
        grid = GridSearchCV(self.estimator(), {"C": list(self.c_grid), "epsilon": list(self.epsilon_grid)},
                            scoring=self.scoring, cv=time_blocked_splits(len(rows), folds),
                            refit=False, error_score="raise")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            grid.fit(x[rows], y[rows])
        for w in caught:
            if _count_convergence([w]) == 0:
                log.debug("svm %s search: %s", problem.dof, w.message)
        return {"C": float(grid.best_params_["C"]), "epsilon": float(grid.best_params_["epsilon"]),
                "score": float(grid.best_score_), "nonconverged": _count_convergence(caught),
                "fits": len(self.c_grid) * len(self.epsilon_grid) * folds, "rows": len(rows)}

    def fit_one(self, problem: RegressionProblem) -> tuple[np.ndarray, dict]:
        """Coefficients (prime, in ``problem.names`` order) and metrics of one DOF."""
        dof = problem.dof
        x, y, col_scale, y_scale = scale_problem(problem)
        best = self.search(x, y, problem)
        if best["nonconverged"]:
            log.warning("svm %s: %d of %d grid-search fits did not converge in max_iter=%d "
                        "(tol=%g); the chosen C=%g, epsilon=%g may be wrong: raise max_iter",
                        dof, best["nonconverged"], best["fits"], self.max_iter, self.tol,
                        best["C"], best["epsilon"])
        svr = self.estimator(best["C"], best["epsilon"])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            svr.fit(x, y)
        converged = _count_convergence(caught) == 0
        for w in caught:
            if _count_convergence([w]) == 0:
                log.debug("svm %s fit: %s", dof, w.message)
        if not converged:
            log.warning("svm %s: the final fit (C=%g, epsilon=%g) did not converge in "
                        "max_iter=%d iterations (tol=%g); the coefficients are not the SVR "
                        "optimum: raise max_iter", dof, best["C"], best["epsilon"],
                        self.max_iter, self.tol)
        coef = np.asarray(svr.coef_, float) * y_scale / col_scale
        metrics = {
            f"svm/{dof}/C": best["C"],
            f"svm/{dof}/epsilon": best["epsilon"],
            f"svm/{dof}/epsilon_prime": best["epsilon"] * y_scale,
            f"svm/{dof}/cv_score": best["score"],
            f"svm/{dof}/converged": float(converged),
            f"svm/{dof}/search_nonconverged": float(best["nonconverged"]),
            f"svm/{dof}/n_iter": float(svr.n_iter_),
            f"svm/{dof}/search_rows": float(best["rows"]),
        }
        if self.scoring == "neg_mean_squared_error":
            metrics[f"svm/{dof}/cv_rmse"] = float(np.sqrt(max(-best["score"], 0.0))) * y_scale
        return coef, metrics

    def fit(self, problems: dict, objective=None) -> Identification:
        """Fit every DOF's problem; ``objective`` (trajectory fitness) is unused.
        ``params`` hold the problems' known coefficients too (:func:`known_coefficients`)."""
        result = Identification(params=known_coefficients(problems))
        for dof, problem in problems.items():
            if problem.theta.shape[1] == 0:
                continue
            coef, metrics = self.fit_one(problem)
            result.params.update(dict(zip(problem.names, coef.tolist())))
            result.metrics.update(metrics)
            result.metrics.update(regression_diagnostics(problem, coef))
        return result
