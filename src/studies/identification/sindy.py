"""Sparse identification (SINDy) of the manoeuvring model's terms.

Sequentially thresholded least squares (STLSQ, Brunton et al. 2016) on each
DOF's inverse-dynamics regression ``y = Theta xi`` of
:mod:`studies.identification.regression`: least squares, drop the terms whose
coefficient is below a threshold, refit on the rest, repeat until the set of
terms stops changing, then an unpenalised least-squares refit on the kept
terms. pysindy's :class:`~pysindy.optimizers.STLSQ` is used directly on the
design matrix, so the columns keep the model's coefficient names.

Library
    ``library="model"``: the columns are exactly the model's terms (the
    problems the run built); SINDy then only prunes terms that contribute
    less than the threshold. ``library="extended"``: every monomial of
    ``u', v', r', delta`` up to ``max_order`` per DOF
    (:func:`~studies.models.terms.candidate_terms`, 35 per DOF for order 3),
    the model's own terms included; SINDy reports which terms it selects
    beyond the model (``missing_term`` of ``studies discover``). Candidates
    are matched to model terms by ``(dof, powers)``, not by name (the
    thesis' ``Yvu``, ``Xrv`` are the canonical ``Yuv``, ``Xvr``): a selected
    term is reported under the model's name when it is a model term, else
    under its canonical name. The extended regression matrix is rebuilt
    from the training records of the trajectory objective, with the same
    acceleration estimator and known coefficients as the run's problems.
    :func:`term_library` gives the same library as a pysindy
    ``CustomLibrary`` on the prime states, for use with ``ps.SINDy``.
Mass matrix
    SINDy usually regresses the state derivative, ``x_dot = Theta(x) Xi``.
    The manoeuvring equations are ``M nu_dot' = F(nu', delta)`` with a
    non-diagonal prime mass matrix (sway-yaw coupling ``m23``, ``m32``);
    regressing ``nu_dot'`` would identify ``M^-1 F``, in which every sway
    term also appears in the yaw equation, so the sparse structure of the
    force model would be lost (Wang et al. 2021, eq. 6, must undo the same
    mixing). The regression target ``y`` of every problem already *is*
    ``M nu_dot'`` (minus known loads), so ``Xi`` are the hydrodynamic
    coefficients and sparsity is that of the force model. The accelerations
    come from the run's estimator (:mod:`studies.data.derivatives`), not
    from pysindy's differentiation.
Scaling and threshold
    Columns are divided by their RMS and ``y`` by its RMS before STLSQ and
    the coefficients unscaled after, so a scaled coefficient is the RMS
    contribution of its term relative to the RMS force of the DOF and one
    ``threshold`` means the same for every term and DOF. By default
    (``threshold=None``) it is chosen per DOF by cross-validation over time
    blocks: fold ``k`` holds out the ``k``-th fifth of every record (so that
    each training set spans every record's manoeuvre; holding out a whole
    20/20 zig-zag from a 10/10 measures extrapolation, with held-out errors
    ten times the force), STLSQ is fitted on the others at every threshold of
    ``thresholds`` (0 is least squares) and the held-out equation error
    measured; the largest threshold whose mean held-out error is within one
    standard error of the smallest is kept (the one-standard-error rule:
    the sparsest model as good as the best within its uncertainty). A fixed
    number still works: on the clean RK4 zig-zag 20/20 of the Mariner the
    weakest terms are ``Yvdd`` (4.2e-4 of the RMS sway force) and ``Y0uu``
    (9.4e-4), the largest spurious candidates of the full 35-term least
    squares ``Nvrr`` (2.9e-4) and ``Yvrr`` (1.0e-4), so 1e-4 separates them.
Selection variants (options, defaults as above)
    ``rule="min"`` keeps the threshold of the smallest held-out error;
    ``rule="paired_se"`` applies the one-standard-error rule with the
    standard error of the fold-by-fold difference to the best threshold
    (the folds are shared, so their common difficulty drops out).
    ``selection="simulation"`` scores one threshold shared by all DOFs by
    the replayed position [m^2] of held-out time blocks (``folds="blocks"``)
    or whole records (``folds="records"``), each replayed from its own first
    measured state with its measured rudder: the track, not the one-step
    force, is what a prediction is judged by. ``coefficients="median"``
    gives the kept terms the median of the bootstrap draws' coefficients
    (E-SINDy "bragging", Fasel et al. 2022) instead of a least-squares refit.
    On the KVLCC2 records none of them predicts MARIN's ``tc_35`` better
    than least squares from both MARIN's and HSVA's zig-zags
    (``docs/cross_facility.md``): the held-out errors, equation or
    replayed, of the zig-zags hardly change with the threshold, and the
    terms the turn needs (``Xvvvv`` at drift v' 0.28-0.39, where the
    zig-zags reach 0.23) contribute a few per cent of the zig-zags' force.
Ensemble
    With ``ensemble = B > 0`` STLSQ is refitted at the chosen threshold on
    ``B`` block-bootstrap draws of the rows (each record cut into blocks of
    ``block_s`` seconds, drawn with replacement: the rows of a record are
    correlated in time, so single rows are not resampled), and each term's
    inclusion probability is the share of draws that keep it. The model
    keeps the terms included in at least ``inclusion`` of the draws and
    refits them by least squares on every row.
Ridge
    ``alpha`` is the ridge weight relative to the mean squared residual of
    the scaled problem (STLSQ is given ``alpha * n_rows``). The extended
    library's correlation matrix has eigenvalues down to ~1e-9, and a ridge
    weight comparable with them spreads weight over collinear candidates so
    that nothing falls below the threshold (at 1e-7 STLSQ keeps all 35
    terms); the default 1e-12 only guards against a singular matrix.

Metrics per DOF: ``sindy/<dof>/n_selected``, ``sindy/<dof>/n_extra`` (selected
terms not in the model), ``sindy/<dof>/n_candidates``,
``sindy/<dof>/n_dropped`` (model terms not selected),
``sindy/<dof>/converged``, ``sindy/<dof>/threshold`` (the one used),
``sindy/<dof>/cv_error`` (its mean held-out error relative to the
DOF's mean square force), ``sindy/<dof>/inclusion/<term>`` (with an
ensemble), plus :func:`~studies.identification.ls.regression_diagnostics` of the
selected terms. ``Identification.params`` holds every free model term (0.0
where not selected) and the selected extra terms; the writer
``sindy_terms.json`` lists ``{dof: {"selected": [...], "extra": [...],
"dropped": [...], "threshold": t, "inclusion": {term: p}, "cv": [[t, mean,
se], ...]}}``.

References
----------
Brunton, S.L., Proctor, J.L., Kutz, J.N. (2016). Discovering governing
equations from data by sparse identification of nonlinear dynamical systems.
PNAS 113(15), 3932-3937. doi:10.1073/pnas.1517384113

de Silva, B.M., Champion, K., Quade, M., Loiseau, J.-C., Kutz, J.N., Brunton,
S.L. (2020). PySINDy: a Python package for the sparse identification of
nonlinear dynamical systems from data. JOSS 5(49), 2104.

Wang, T., Li, G., Wu, B., Aesoy, V., Zhang, H. (2021). Ships and Offshore
Structures, doi:10.1080/17445302.2021.1927600, eq. 1-6.

Zhu, M. (2021). MSc thesis, NTNU, eq. 3.7-3.13 (the regression).
"""

from __future__ import annotations

import json
import logging
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..models.mmg import MMGTerm
from ..models.terms import candidate_terms
from .base import Identification, known_coefficients
from .ls import regression_diagnostics
from .regression import RegressionProblem, build_problems
from ..config import SINDY_COEFFICIENTS, SINDY_FOLDS, SINDY_LIBRARIES, SINDY_RULES, SINDY_SELECTIONS

__all__ = ["SparseRegression", "term_library", "LIBRARIES"]

log = logging.getLogger(__name__)

LIBRARIES = SINDY_LIBRARIES


def term_library(terms):
    """A pysindy ``CustomLibrary`` whose features are ``terms``' monomials.

    Parameters
    ----------
    terms : sequence of Term
        Terms of one DOF.

    Returns
    -------
    pysindy.CustomLibrary
        Fitted on inputs ``(u', v', r', delta)`` it returns one column per
        term (``Term.feature``) and ``get_feature_names()`` gives the
        coefficient names, so equations printed by ``ps.SINDy`` read as the
        model.
    """
    import pysindy as ps  # lazy: pysindy loads scikit-learn (about 1 s)

    def monomial(powers):
        a, b, c, d = powers
        return lambda u, v, r, delta: u ** a * v ** b * r ** c * delta ** d

    def label(name):
        return lambda *inputs: name

    return ps.CustomLibrary(library_functions=[monomial(t.powers) for t in terms],
                            function_names=[label(t.name) for t in terms])


def _unit_rms(problem: RegressionProblem):
    theta = np.asarray(problem.theta, float)
    col = np.sqrt(np.mean(theta ** 2, axis=0)) if theta.shape[0] else np.ones(theta.shape[1])
    col = np.where(col > 0, col, 1.0)
    ys = float(np.sqrt(np.mean(np.asarray(problem.y, float) ** 2))) or 1.0
    return theta / col, problem.y / ys, col, ys


#: thresholds tried by the cross-validation (scaled coefficients; 0 is least squares)
THRESHOLDS = (0.0, 1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3)
#: ridge weights tried by the cross-validation (relative to the mean squared scaled force)
ALPHAS = (1e-12, 1e-4, 1e-2)
#: contiguous time blocks of every record, one held out per fold
CV_BLOCKS = 5
#: what the cross-validation scores: the one-step equation error or the replayed track
SELECTIONS = SINDY_SELECTIONS
#: how the cross-validation picks among thresholds (see :func:`choose`)
RULES = SINDY_RULES
#: what ``selection="simulation"`` holds out: time blocks of every record, or whole records
FOLDS = SINDY_FOLDS
#: the kept terms' coefficients: least squares on every row, or the ensemble's median (bragging)
COEFFICIENTS = SINDY_COEFFICIENTS


def choose(errors: np.ndarray, terms, thresholds, rule: str) -> int:
    """Index of the chosen row of a cross-validation table.

    Parameters
    ----------
    errors : ndarray (n_rows, n_folds)
        Held-out error of each candidate (row) in each fold (column); an
        infinite error (a diverged replay) never qualifies.
    terms : sequence of int
        Terms each candidate keeps when fitted on every row.
    thresholds : sequence of float
        Each candidate's threshold (larger wins a tie in ``terms``).
    rule : {"one_se", "paired_se", "min"}
        ``min``: the smallest mean error. ``one_se``: the sparsest candidate
        whose mean is within one standard error (of the best candidate's
        fold errors) of the best. ``paired_se``: the same with the standard
        error of the fold-by-fold *difference* to the best candidate. The
        folds are the same for every candidate, and most of the spread of
        the fold errors is how hard each fold is (a turn against a steady
        stretch), which is common to all candidates; the paired standard
        error leaves it out and measures only the uncertainty of the
        difference, the quantity the rule compares.
    """
    errors = np.asarray(errors, float)
    finite = np.all(np.isfinite(errors), axis=1)
    mean = np.where(finite, errors.mean(axis=1) if errors.shape[1] else 0.0, np.inf)
    best = int(np.argmin(mean))
    if rule == "min" or not np.isfinite(mean[best]):
        return best
    k = errors.shape[1]
    if rule == "one_se":
        se = errors[best].std(ddof=1) / np.sqrt(k) if k > 1 else 0.0
        bound = np.full(len(mean), mean[best] + se)
    else:
        diff = errors - errors[best]
        se = diff.std(axis=1, ddof=1) / np.sqrt(k) if k > 1 else np.zeros(len(mean))
        bound = mean[best] + np.where(finite, se, 0.0)
    within = [i for i in range(len(mean)) if finite[i] and mean[i] <= bound[i] and terms[i] > 0]
    if not within:
        return best
    return min(within, key=lambda i: (terms[i], -thresholds[i], mean[i]))


def _replay_square_error(objective, params: dict, record, t0: float, t1: float) -> float:
    """Mean squared position error [m^2] of ``record``'s stretch ``t0 <= t <= t1`` [s] replayed.

    The stretch is replayed from its first sample's measured state with its
    measured rudder (and propeller rate) by the objective's simulator
    (:meth:`~studies.identification.objective.TrajectoryObjective.replay`), and the replayed ``(x0, y0)`` interpolated onto the measured
    times; ``inf`` if the replay diverges or the record has no positions.
    """
    t = record["t"].to_numpy(float)
    part = record[(t >= t0) & (t <= t1)]
    if len(part) < 2 or not {"x0", "y0"} <= set(part.columns):
        return np.inf if len(part) >= 2 else 0.0
    pred = objective.replay({n: params.get(n, 0.0) for n in objective.model.names}, part)
    if "diverged_at" in pred.attrs or len(pred) < 2:
        return np.inf
    tm = part["t"].to_numpy(float)
    tp = pred["t"].to_numpy(float)
    if tp[-1] < tm[-1] - 1e-6 * max(1.0, abs(tm[-1])):
        return np.inf
    dx = np.interp(tm, tp, pred["x0"].to_numpy(float)) - part["x0"].to_numpy(float)
    dy = np.interp(tm, tp, pred["y0"].to_numpy(float)) - part["y0"].to_numpy(float)
    error = float(np.mean(dx ** 2 + dy ** 2))
    return error if np.isfinite(error) else np.inf


class SparseRegression:
    """STLSQ on unit-scaled model terms or on the extended candidate library.

    Parameters
    ----------
    threshold : float or None
        Smallest kept scaled coefficient, i.e. RMS contribution of a term
        relative to the RMS force of its DOF [-]; None: chosen per DOF by
        cross-validation among ``thresholds`` (see module notes).
    thresholds : sequence of float
        The thresholds the cross-validation tries.
    alpha : float
        Ridge weight of the STLSQ passes relative to the mean squared
        residual of the scaled problem [-] with a fixed ``threshold``; the
        final refit is unpenalised.
    alphas : sequence of float
        The ridge weights the cross-validation tries with the thresholds
        (a ridge keeps the extended library's collinear candidates from
        cancelling each other with large coefficients that no threshold
        removes).
    library : {"model", "extended"}
        The model's terms, or all monomials up to ``max_order`` per DOF.
    max_order : int
        Highest total order of the extended library's monomials.
    max_iter : int
        Most STLSQ passes.
    ensemble : int
        Block-bootstrap draws of the ensemble (0: none).
    inclusion : float
        Smallest inclusion probability of a kept term, in (0, 1].
    block_s : float
        Length of the bootstrap's time blocks [s].
    seed : int
        Seed of the bootstrap.

    References
    ----------
    Brunton, Proctor & Kutz (2016), PNAS 113(15), 3932-3937.
    Fasel, Kutz, Brunton & Brunton (2022), Ensemble-SINDy, Proc. R. Soc. A 478, 20210904.
    """

    name = "sindy"

    def __init__(self, threshold: float | None = None, thresholds=THRESHOLDS, alpha: float = 1e-12,
                 alphas=ALPHAS,
                 library: str = "model", max_order: int = 3, max_iter: int = 20, ensemble: int = 20,
                 inclusion: float = 0.5, block_s: float = 30.0, seed: int = 0,
                 selection: str = "equation", rule: str = "one_se", coefficients: str = "refit",
                 folds: str = "blocks"):
        if library not in LIBRARIES:
            raise ConfigError(f"sindy: library must be one of {', '.join(LIBRARIES)}, got '{library}'")
        thresholds = [float(t) for t in thresholds]
        if (threshold is not None and threshold < 0) or alpha < 0 or not thresholds or min(thresholds) < 0:
            raise ConfigError("sindy: threshold, thresholds and alpha must be >= 0")
        if int(max_order) < 1 or int(max_iter) < 1:
            raise ConfigError("sindy: max_order and max_iter must be >= 1")
        if int(ensemble) < 0 or not 0.0 < float(inclusion) <= 1.0 or not float(block_s) > 0:
            raise ConfigError("sindy: ensemble must be >= 0, inclusion in (0, 1] and block_s > 0")
        self.threshold = None if threshold is None else float(threshold)
        self.thresholds = sorted(set(thresholds))
        self.alphas = sorted({float(a) for a in alphas})
        if not self.alphas or min(self.alphas) < 0:
            raise ConfigError("sindy: alphas must be >= 0")
        self.alpha = float(alpha)
        self.library = library
        self.max_order = int(max_order)
        self.max_iter = int(max_iter)
        self.ensemble = int(ensemble)
        self.inclusion = float(inclusion)
        self.block_s = float(block_s)
        self.seed = int(seed)
        if selection not in SELECTIONS or rule not in RULES or coefficients not in COEFFICIENTS:
            raise ConfigError(f"sindy: selection must be one of {', '.join(SELECTIONS)}, rule one of "
                              f"{', '.join(RULES)}, coefficients one of {', '.join(COEFFICIENTS)}")
        if selection == "simulation" and library != "model":
            raise ConfigError("sindy: selection=simulation replays the model's own terms; use library=model")
        self.selection = selection
        self.rule = rule
        self.coefficients = coefficients
        if folds not in FOLDS:
            raise ConfigError(f"sindy: folds must be one of {', '.join(FOLDS)}")
        self.folds = folds

    def extended_problems(self, problems: dict, objective) -> dict:
        """Problems of the extended library, rebuilt from the objective's records.

        The model's terms keep their names; candidates with the same
        ``(dof, powers)`` as a model term are not added twice.
        """
        model = objective.model
        extra = [t for dof in problems for t in candidate_terms(dof, self.max_order)]
        if any(isinstance(t, MMGTerm) for t in model.terms):
            # the MMG hull's candidates are functions of v', r', delta: u' = u / U (cos(beta))
            # is a family's own term, not a free candidate (it is 1 - v'^2 / 2 to second order)
            extra = [t for t in extra if not t.powers[0]]
        extended = model.extended(extra, name=f"{model.name}+candidates{self.max_order}")
        first = next(iter(problems.values()))
        derivative = getattr(first, "meta", {}).get("derivative", "auto")
        fixed = {}
        for problem in problems.values():
            fixed.update(problem.fixed)
        builder = getattr(objective, "problems_for", None)
        if builder is not None:        # measured records: the run's own state and acceleration estimates
            rebuilt = builder(extended, fixed)
        else:
            rebuilt = build_problems(extended, objective.vessel, objective.records, derivative, fixed)
        out = {}
        for dof, problem in problems.items():
            missing = set(problem.names) - set(rebuilt[dof].names)
            if missing:
                raise ValueError(f"sindy: the objective's model '{model.name}' lacks the terms "
                                 f"{sorted(missing)} of the problems; pass the run's objective")
            out[dof] = rebuilt[dof]
        return out

    def _stlsq(self, x: np.ndarray, y: np.ndarray, threshold: float,
               alpha: float | None = None) -> tuple[np.ndarray, bool]:
        """Scaled STLSQ coefficients and whether the passes settled."""
        import pysindy as ps  # lazy: pysindy loads scikit-learn (about 1 s)
        from sklearn.exceptions import ConvergenceWarning  # lazy, as pysindy

        alpha = self.alpha if alpha is None else alpha
        opt = ps.STLSQ(threshold=threshold, alpha=alpha * len(y), max_iter=self.max_iter,
                       normalize_columns=False, unbias=True)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            opt.fit(x, y)
        converged = not any(issubclass(w.category, ConvergenceWarning) for w in caught)
        return np.asarray(opt.coef_, float).reshape(-1), converged

    @staticmethod
    def _record_folds(problem: RegressionProblem, n: int) -> list:
        """Held-out row sets, one whole record each (rows of a negative record index, a
        prior's pseudo-observations, never held out); a single record gives the time blocks
        of :meth:`_folds` instead."""
        record = np.zeros(n, int) if problem.record is None else np.asarray(problem.record, int)
        ids = [i for i in np.unique(record) if i >= 0]
        if len(ids) < 2:
            return SparseRegression._folds(problem, n)
        return [np.flatnonzero(record == i) for i in ids]

    @staticmethod
    def _folds(problem: RegressionProblem, n: int) -> list:
        """Held-out row sets: fold ``k`` holds out the ``k``-th of :data:`CV_BLOCKS` contiguous
        time blocks of every record, so that each training set still spans every record's
        manoeuvre (holding out a whole 20/20 zig-zag from a 10/10 would measure
        extrapolation, not noise). Rows of a negative record index (a prior's
        pseudo-observations) are never held out."""
        record = np.zeros(n, int) if problem.record is None else np.asarray(problem.record, int)
        folds = [[] for _ in range(CV_BLOCKS)]
        for i in np.unique(record):
            if i < 0:
                continue
            for k, part in enumerate(np.array_split(np.flatnonzero(record == i), CV_BLOCKS)):
                folds[k].append(part)
        return [np.concatenate(f) for f in folds if f and sum(len(p) for p in f)]

    def _cross_validate(self, problem, x, y) -> tuple[float, float, list]:
        """The chosen ``(threshold, alpha)`` and ``[(threshold, alpha, mean, se, n_terms), ...]``.

        Every pair of :attr:`thresholds` and :attr:`alphas` is scored by its
        held-out equation error in each fold (mean square scaled force), and
        :func:`choose` picks among them by :attr:`rule` (``one_se``: among the
        pairs within one standard error of the best, the one keeping the
        fewest terms, fitted on every row, the larger threshold on a tie).
        """
        folds = self._folds(problem, len(y))
        table, fold_errors = [], []
        for alpha in self.alphas:
            for threshold in self.thresholds:
                errors = []
                for held in folds:
                    train = np.ones(len(y), bool)
                    train[held] = False
                    xi, _ = self._stlsq(x[train], y[train], threshold, alpha)
                    errors.append(float(np.mean((y[held] - x[held] @ xi) ** 2)))
                errors = np.asarray(errors)
                se = float(errors.std(ddof=1) / np.sqrt(len(errors))) if len(errors) > 1 else 0.0
                terms = int(np.count_nonzero(self._stlsq(x, y, threshold, alpha)[0]))
                table.append((threshold, alpha, float(errors.mean()), se, terms))
                fold_errors.append(errors)
        i = choose(np.asarray(fold_errors), [row[4] for row in table], [row[0] for row in table], self.rule)
        return table[i][0], table[i][1], table

    def _simulated_threshold(self, problems: dict, objective) -> tuple[float, list]:
        """One threshold for every DOF, chosen by the replayed track of held-out time blocks.

        The folds are those of :meth:`_folds` (fold ``k`` holds out the
        ``k``-th fifth of every record). For each threshold of
        :attr:`thresholds`, every DOF is fitted by STLSQ (ridge
        :attr:`alpha`) on the other folds' rows, and each record's held-out
        stretch (from its first to its last held-out sample) is replayed
        from its own first measured state with its measured rudder (and
        propeller rate) by the objective's simulator; the fold's error is
        the mean over records of the mean squared distance between the
        replayed and the measured position ``(x0, y0)`` [m^2]. A replay that
        diverges makes the threshold's error infinite. :func:`choose` then
        picks by :attr:`rule`. One threshold serves all DOFs because a
        track depends on all three at once, and a scaled coefficient (RMS
        contribution over the DOF's RMS force) means the same in each.

        Returns ``(threshold, [(threshold, mean, se, n_terms), ...])``.
        """
        scaled = {dof: _unit_rms(p) for dof, p in problems.items() if p.theta.shape[1]}
        first = next(iter(problems.values()))
        record = (np.zeros(len(first.y), int) if first.record is None
                  else np.asarray(first.record, int))
        time = np.asarray(first.time, float)
        folds = (self._record_folds if self.folds == "records" else self._folds)(first, len(first.y))
        fixed = {}
        for p in problems.values():
            fixed.update(p.fixed)

        def values(held, threshold):
            """Every DOF fitted at ``threshold`` without the rows ``held`` (the data rows come
            first in each DOF's problem and are the same rows; a prior's rows stay in)."""
            out = {}
            for dof, (x, y, col, ys) in scaled.items():
                train = np.ones(len(y), bool)
                train[held] = False
                xi, _ = self._stlsq(x[train], y[train], threshold, self.alpha)
                out.update(zip(problems[dof].names, (xi * ys / col).tolist()))
            return out

        table, fold_errors, terms = [], [], []
        for threshold in self.thresholds:
            errors = []
            for held in folds:
                params = {**fixed, **values(held, threshold)}
                squares = []
                for i in np.unique(record[held]):
                    rows = held[record[held] == i]
                    squares.append(_replay_square_error(objective, params, objective.records[i],
                                                        float(time[rows].min()), float(time[rows].max())))
                errors.append(float(np.mean(squares)) if squares else 0.0)
            errors = np.asarray(errors)
            kept = int(sum(v != 0.0 for v in values(np.zeros(0, int), threshold).values()))
            finite = np.all(np.isfinite(errors))
            se = float(errors.std(ddof=1) / np.sqrt(len(errors))) if finite and len(errors) > 1 else np.inf
            table.append((threshold, float(errors.mean()), se, kept))
            fold_errors.append(errors)
            terms.append(kept)
        i = choose(np.asarray(fold_errors), terms, list(self.thresholds), self.rule)
        return self.thresholds[i], table

    def _blocks(self, problem, n: int) -> list:
        """Row indices of the bootstrap's time blocks (``block_s`` seconds of one record)."""
        record = np.zeros(n, int) if problem.record is None else np.asarray(problem.record, int)
        time = np.arange(n, dtype=float) if problem.time is None else np.asarray(problem.time, float)
        blocks = []
        for i in np.unique(record):
            rows = np.flatnonzero(record == i)
            if i < 0:
                continue
            t = time[rows] - time[rows].min()
            index = np.floor(t / self.block_s).astype(int)
            blocks += [rows[index == k] for k in np.unique(index)]
        return blocks

    def _inclusion(self, problem, x, y, threshold: float, alpha: float) -> tuple[np.ndarray, np.ndarray]:
        """Share of block-bootstrap draws in which STLSQ keeps each column, and the median of
        the draws' scaled coefficients (0 in a draw that drops the term)."""
        blocks = self._blocks(problem, len(y))
        record = np.zeros(len(y), int) if problem.record is None else np.asarray(problem.record, int)
        always = np.flatnonzero(record < 0)                 # the prior's rows stay in every draw
        rng = np.random.default_rng(self.seed)
        draws = np.zeros((self.ensemble, x.shape[1]))
        for b in range(self.ensemble):
            pick = rng.integers(0, len(blocks), len(blocks))
            rows = np.concatenate([blocks[i] for i in pick] + [always])
            draws[b], _ = self._stlsq(x[rows], y[rows], threshold, alpha)
        return np.mean(draws != 0.0, axis=0), np.median(draws, axis=0)

    def fit_one(self, problem: RegressionProblem, threshold: float | None = None,
                alpha: float | None = None) -> tuple[np.ndarray, dict, dict]:
        """Coefficients (prime, in ``problem.names`` order; 0 = not selected), metrics, and what
        ``sindy_terms.json`` lists of the DOF (threshold, ridge, cross-validation, inclusion).

        ``threshold`` (with ``alpha``, default :attr:`alpha`) given: used as it is (the
        shared threshold of ``selection="simulation"``); else :attr:`threshold` or, when
        that is None, the equation-error cross-validation's.

        With an ensemble, the kept terms (inclusion >= :attr:`inclusion`) get
        ``coefficients="refit"``: least squares on every row (the prior's
        included); ``"median"``: the median of the draws' coefficients
        (E-SINDy's bragging, Fasel et al. 2022), which is less swayed by the
        draws in which a collinear partner was dropped.
        """
        dof = problem.dof
        x, y, col, ys = _unit_rms(problem)
        metrics, info = {}, {}
        if threshold is not None:
            alpha = self.alpha if alpha is None else alpha
        elif self.threshold is None:
            threshold, alpha, table = self._cross_validate(problem, x, y)
            info["cv"] = [list(row) for row in table]
            metrics[f"sindy/{dof}/cv_error"] = next(row[2] for row in table
                                                   if row[0] == threshold and row[1] == alpha)
        else:
            threshold, alpha = self.threshold, self.alpha
        metrics[f"sindy/{dof}/threshold"] = threshold
        metrics[f"sindy/{dof}/alpha"] = alpha
        info["threshold"], info["alpha"] = threshold, alpha
        xi, converged = self._stlsq(x, y, threshold, alpha)
        if not converged:
            log.warning("sindy %s: STLSQ did not settle on a set of terms in max_iter=%d passes: raise "
                        "max_iter", dof, self.max_iter)
        if self.ensemble > 0:
            share, median = self._inclusion(problem, x, y, threshold, alpha)
            info["inclusion"] = {n: float(p) for n, p in zip(problem.names, share)}
            metrics.update({f"sindy/{dof}/inclusion/{n}": float(p) for n, p in zip(problem.names, share)})
            keep = np.flatnonzero(share >= self.inclusion)
            xi = np.zeros(x.shape[1])
            if len(keep) and self.coefficients == "median":
                xi[keep] = median[keep]
            elif len(keep):
                xi[keep] = np.linalg.lstsq(x[:, keep], y, rcond=None)[0]
        if not np.any(xi):
            log.warning("sindy %s: threshold %g removed every term", dof, threshold)
        metrics[f"sindy/{dof}/converged"] = float(converged)
        return xi * ys / col, metrics, info

    def fit(self, problems: dict, objective=None) -> Identification:
        """Select and fit terms per DOF.

        Parameters
        ----------
        problems : dict
            ``{dof: RegressionProblem}`` of the run's model.
        objective : TrajectoryObjective, optional
            Needed for ``library="extended"`` (its ``model``, ``vessel`` and
            ``records`` rebuild the regression with the candidate terms).

        Raises
        ------
        ValueError
            ``library="extended"`` without an objective.
        """
        if not problems:
            return Identification()
        if self.library == "extended":
            if objective is None:
                raise ValueError("sindy with library: extended needs the trajectory objective "
                                 "(model, vessel, records) to build the candidate library; "
                                 "call fit(problems, objective=...)")
            fitted = self.extended_problems(problems, objective)
        else:
            fitted = problems
        result = Identification(params=known_coefficients(problems))
        terms = {}
        shared, simulated = None, None
        if self.selection == "simulation" and self.threshold is None:
            if objective is None or not getattr(objective, "records", None):
                raise ValueError("sindy with selection: simulation needs the trajectory objective "
                                 "(model, vessel, records) to replay held-out blocks")
            shared, simulated = self._simulated_threshold(fitted, objective)
            result.metrics["sindy/simulated_threshold"] = shared
        for dof, problem in fitted.items():
            model_names = list(problems[dof].names)
            if problem.theta.shape[1] == 0:
                terms[dof] = {"selected": [], "extra": [], "dropped": []}
                continue
            coef, metrics, info = self.fit_one(problem, shared)
            if simulated is not None:
                info["cv_simulated"] = [list(row) for row in simulated]
            selected = [n for n, c in zip(problem.names, coef) if c != 0.0]
            extra = [n for n in selected if n not in model_names]
            dropped = [n for n in model_names if n not in selected]
            values = dict(zip(problem.names, coef.tolist()))
            result.params.update({n: values[n] for n in model_names})
            result.params.update({n: values[n] for n in extra})
            keep = np.flatnonzero(coef != 0.0)
            sub = replace(problem, theta=problem.theta[:, keep],
                          names=[problem.names[i] for i in keep])
            result.metrics.update(metrics)
            result.metrics.update(regression_diagnostics(sub, coef[keep]))
            result.metrics.update({f"sindy/{dof}/n_selected": float(len(selected)),
                                   f"sindy/{dof}/n_extra": float(len(extra)),
                                   f"sindy/{dof}/n_dropped": float(len(dropped)),
                                   f"sindy/{dof}/n_candidates": float(len(problem.names))})
            if extra:
                log.info("sindy %s: selected terms beyond the model: %s", dof, ", ".join(extra))
            terms[dof] = {"selected": selected, "extra": extra, "dropped": dropped, **info}
        text = json.dumps(terms, indent=2)
        result.writers["sindy_terms.json"] = lambda path: Path(path).write_text(text + "\n")
        return result
