"""Sparse identification (SINDy) of the manoeuvring model's terms.

Sequentially thresholded least squares (STLSQ, Brunton et al. 2016) on each
DOF's inverse-dynamics regression ``y = Theta xi`` of
:mod:`studies.identify.regression`: least squares, drop the terms whose
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
    ``threshold`` means the same for every term and DOF. The threshold must
    lie below the weakest true term and above the spurious coefficients the
    data allow. On the clean RK4 zig-zag 20/20 of the Mariner the weakest
    terms are ``Yvdd`` (4.2e-4 of the RMS sway force) and ``Y0uu``
    (9.4e-4); the largest spurious candidates of the full 35-term least
    squares are ``Nvrr`` (2.9e-4) and ``Yvrr`` (1.0e-4), which fall below
    2e-5 once the first STLSQ pass has removed the other junk terms (what
    remains is the acceleration estimate's 1e-6 relative error amplified by
    collinearity). The default ``threshold=1e-4`` sits a factor ~4 below
    the weakest term and ~5 above that floor; measured data need a
    threshold above their noise floor instead.
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
``sindy/<dof>/converged``, plus
:func:`~studies.identify.ls.regression_diagnostics` of the selected terms.
``Identification.params`` holds every free model term (0.0 where not
selected) and the selected extra terms; the writer ``sindy_terms.json``
lists ``{dof: {"selected": [...], "extra": [...], "dropped": [...]}}``.

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
from ..models.terms import candidate_terms
from .base import Identification
from .ls import regression_diagnostics
from .regression import RegressionProblem, build_problems

__all__ = ["SparseRegression", "term_library", "LIBRARIES"]

log = logging.getLogger(__name__)

LIBRARIES = ("model", "extended")


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


class SparseRegression:
    """STLSQ on unit-scaled model terms or on the extended candidate library.

    Parameters
    ----------
    threshold : float
        Smallest kept scaled coefficient, i.e. RMS contribution of a term
        relative to the RMS force of its DOF [-] (see module notes).
    alpha : float
        Ridge weight of the STLSQ passes relative to the mean squared
        residual of the scaled problem [-]; the final refit is unpenalised.
    library : {"model", "extended"}
        The model's terms, or all monomials up to ``max_order`` per DOF.
    max_order : int
        Highest total order of the extended library's monomials.
    max_iter : int
        Most STLSQ passes.

    References
    ----------
    Brunton, Proctor & Kutz (2016), PNAS 113(15), 3932-3937.
    """

    name = "sindy"

    def __init__(self, threshold: float = 1e-4, alpha: float = 1e-12, library: str = "model",
                 max_order: int = 3, max_iter: int = 20):
        if library not in LIBRARIES:
            raise ConfigError(f"sindy: library must be one of {', '.join(LIBRARIES)}, got '{library}'")
        if threshold < 0 or alpha < 0:
            raise ConfigError("sindy: threshold and alpha must be >= 0")
        if int(max_order) < 1 or int(max_iter) < 1:
            raise ConfigError("sindy: max_order and max_iter must be >= 1")
        self.threshold = float(threshold)
        self.alpha = float(alpha)
        self.library = library
        self.max_order = int(max_order)
        self.max_iter = int(max_iter)

    def extended_problems(self, problems: dict, objective) -> dict:
        """Problems of the extended library, rebuilt from the objective's records.

        The model's terms keep their names; candidates with the same
        ``(dof, powers)`` as a model term are not added twice.
        """
        model = objective.model
        extra = [t for dof in problems for t in candidate_terms(dof, self.max_order)]
        extended = model.extended(extra, name=f"{model.name}+candidates{self.max_order}")
        first = next(iter(problems.values()))
        derivative = getattr(first, "meta", {}).get("derivative", "auto")
        fixed = {}
        for problem in problems.values():
            fixed.update(problem.fixed)
        rebuilt = build_problems(extended, objective.vessel, objective.records, derivative, fixed)
        out = {}
        for dof, problem in problems.items():
            missing = set(problem.names) - set(rebuilt[dof].names)
            if missing:
                raise ValueError(f"sindy: the objective's model '{model.name}' lacks the terms "
                                 f"{sorted(missing)} of the problems; pass the run's objective")
            out[dof] = rebuilt[dof]
        return out

    def fit_one(self, problem: RegressionProblem) -> tuple[np.ndarray, dict]:
        """Coefficients (prime, in ``problem.names`` order; 0 = not selected) and metrics."""
        import pysindy as ps  # lazy: pysindy loads scikit-learn (about 1 s)
        from sklearn.exceptions import ConvergenceWarning  # lazy, as pysindy

        dof = problem.dof
        x, y, col, ys = _unit_rms(problem)
        opt = ps.STLSQ(threshold=self.threshold, alpha=self.alpha * len(y), max_iter=self.max_iter,
                       normalize_columns=False, unbias=True)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            opt.fit(x, y)
        converged = True
        for w in caught:
            if issubclass(w.category, ConvergenceWarning):
                converged = False
                log.warning("sindy %s: STLSQ did not settle on a set of terms in max_iter=%d "
                            "passes: raise max_iter", dof, self.max_iter)
            elif "eliminated all" in str(w.message):
                log.warning("sindy %s: threshold %g removed every term", dof, self.threshold)
            else:
                log.debug("sindy %s: %s", dof, w.message)
        xi = np.asarray(opt.coef_, float).reshape(-1)
        coef = xi * ys / col
        return coef, {f"sindy/{dof}/converged": float(converged)}

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
        result = Identification()
        terms = {}
        for dof, problem in fitted.items():
            model_names = list(problems[dof].names)
            if problem.theta.shape[1] == 0:
                terms[dof] = {"selected": [], "extra": [], "dropped": []}
                continue
            coef, metrics = self.fit_one(problem)
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
            terms[dof] = {"selected": selected, "extra": extra, "dropped": dropped}
        text = json.dumps(terms, indent=2)
        result.writers["sindy_terms.json"] = lambda path: Path(path).write_text(text + "\n")
        return result
