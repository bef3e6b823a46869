"""Discovery by one inference over the whole cause catalogue.

What the baseline misses is estimated once, and every cause of the
catalogue, alone or in pairs, is weighed against it in one Bayesian model
comparison; the named verdict is the model of highest posterior
probability, and that probability is its confidence.

1. **States.** Every training record is smoothed by the EKF/RTS smoother
   with the identified baseline as process model and a random-walk force
   discrepancy (:func:`studies.identify.kalman.kalman_smooth`): the smoother
   follows the measured motions where the baseline is wrong, and handles the
   measurement noise of every family (white, coloured, quantised, velocities
   derived from the track) in one place. The baseline is first identified
   on the kinematic smoother's states.
2. **Signatures.** For a cause with parameters ``theta`` (no effect at 0),
   the prime residual ``r(theta) = y(theta) - Theta(theta) c`` of the
   inverse-dynamics regression along the smoothed states changes by ``J
   theta`` to first order, with the baseline's coefficients ``c`` held. ``J``
   comes from the cause's own hooks (:class:`~studies.discover.causes.base.Cause`:
   the records as the hydrodynamics saw them, the external forces) by
   central differences, so it holds for any baseline whose regression the
   cause protocol reaches (the Abkowitz models, the MMG model). It is exact
   for a missing term (the library's feature column), an earth-fixed bias
   and a propeller side force; first-order for a rudder offset and a
   current (``(speed cos dir, speed sin dir)`` as its linear parameters);
   a wind the records do not carry acts as the square of its speed, so it
   enters as the secant column of a reference wind from each of
   :data:`WIND_DIRECTIONS` directions.
3. **One comparison.** With the regression ``y = Theta c - J theta + e``
   over the stacked degrees of freedom, every model ``M`` (``none``, each
   cause, each pair of causes; a missing term or a wind direction is one of
   the variants of its cause) is scored by the BIC with the effective number
   of independent rows ``n_eff = n / tau`` (``tau`` the integrated
   autocorrelation time of the baseline's residual)::

       score(M) = n_eff sum_dof ln(RSS_dof(M) / n) + k_M ln(n_eff) - 2 ln prior(M)

   with uniform prior odds over 0, 1 and 2 causes, over the causes of each
   size and over the variants of a cause. The posterior probability
   ``exp(-score / 2)`` normalised over all models is the model's; a cause's
   inclusion probability is the sum over the models that hold it. All models
   share one Gram matrix, so the whole comparison takes a fraction of a
   second.
4. **Parameters.** Only the named model is refined: its parameters by the
   profiled nonlinear least squares of :func:`studies.discover.fitting.fit_cause`
   started at the linear solution, their 90 % intervals from the regression's
   covariance (inflated by ``tau``). The held-out records then measure the
   gain; the gain is reported, it does not name anything.

Conventions as in :mod:`studies.discover.causes.base`: angles in radians,
current direction where it flows to, wind direction where it comes from,
prime forces (thesis eq. 3.6).

References
----------
Schwarz, G. (1978). Estimating the dimension of a model. Ann. Statist. 6(2).
Kass, R. E., Raftery, A. E. (1995). Bayes factors. JASA 90(430), 773-795.
Hoeting, J. A. et al. (1999). Bayesian model averaging: a tutorial.
Statistical Science 14(4), 382-417.
"""

from __future__ import annotations

import itertools
import logging
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ..identify.kalman import KalmanSettings, ekf_derivatives, kalman_smooth
from ..models.terms import DOFS
from .causes import Combined, Current, MissingTerm, WindUnmodelled, extended_library, manoeuvring_causes
from .causes.base import Cause, Setup
from .fitting import (CauseFit, Context, _score, integrated_time, regression_fit,
                      scored_fit, setup_problems)

__all__ = ["Variant", "Inference", "infer", "smooth_with_baseline", "WIND_DIRECTIONS", "WIND_REFERENCE"]

log = logging.getLogger(__name__)

#: directions (from which the wind comes) of the wind signatures [rad]
WIND_DIRECTIONS = np.deg2rad(np.arange(0.0, 360.0, 22.5))
#: passes of identification and model-based smoothing (:func:`smooth_with_baseline`)
SMOOTHING_ITERATIONS = 3
#: the smoother's settings: no sensor-bias states, which would take the baseline's errors (and
#: a cause's effect) for slowly drifting velocity sensors and keep the states on the baseline
SMOOTHER = KalmanSettings(bias=False)
#: reference wind speed of the wind signatures [m/s]
WIND_REFERENCE = 10.0


@dataclass
class Variant:
    """One way a cause may act: its signature columns and how to read them.

    Attributes
    ----------
    cause : Cause
        The catalogue cause (for a missing term, the cause with this one term).
    label : str
        ``rudder_offset``, ``missing_term:Nrrr``, ``wind_unmodelled@45deg``.
    columns : ndarray (N, k)
        ``-J`` on the stacked, weighted rows (a parameter's coefficient is its value).
    to_theta : callable
        The cause's ``theta`` (:attr:`Cause.nl_params`) from the linear coefficients.
    n_params : int
        Parameters the variant adds (for the BIC).
    """

    cause: Cause
    label: str
    columns: np.ndarray
    to_theta: object
    n_params: int


@dataclass
class Inference:
    """The outcome of :func:`infer`.

    Attributes
    ----------
    models : list of tuple
        Every model compared: tuples of variant indices (``()`` is ``none``).
    scores : ndarray
        Their scores (lower is better, ``2 ln`` Bayes-factor scale, best 0).
    probabilities : ndarray
        Their posterior probabilities.
    variants : list of Variant
    named : tuple
        The model of highest posterior probability.
    inclusion : dict
        ``{cause id: probability that it acts}``.
    verdicts : dict
        ``{verdict id ("none", "current", "current+rudder_offset"): probability}``.
    linear : dict
        ``{model: coefficients of its variants' columns}`` for the named model.
    covariance : ndarray
        Covariance of the named model's cause coefficients (tau-inflated).
    tau, n_rows : float, int
    seconds : dict
        Time spent per stage [s].
    """

    models: list
    scores: np.ndarray
    probabilities: np.ndarray
    variants: list
    named: tuple
    inclusion: dict
    verdicts: dict
    coefficients: np.ndarray
    covariance: np.ndarray
    tau: float
    n_rows: int
    seconds: dict = field(default_factory=dict)

    def verdict_of(self, model: tuple) -> str:
        """The verdict id of a model: its causes' ids joined by ``+`` in catalogue order, or ``none``."""
        if not model:
            return "none"
        return "+".join(self.variants[i].cause.id for i in model)

    @property
    def confidence(self) -> float:
        """Posterior probability of the named verdict (every variant of its causes)."""
        return float(self.verdicts.get(self.verdict_of(self.named), 0.0))

    def ranking(self) -> list:
        """``[{"cause": verdict, "probability", "score"}]`` by verdict, most probable first
        (score: ``-2 ln`` of its probability relative to the best verdict)."""
        items = sorted(self.verdicts.items(), key=lambda kv: -kv[1])
        top = items[0][1] if items else 1.0
        return [{"cause": k, "probability": float(p),
                 "score": float(-2.0 * np.log(max(p, 1e-300) / top))} for k, p in items]


# --------------------------------------------------------------- smoothing

def smooth_with_baseline(ctx: Context, records: list, settings: KalmanSettings | None = None,
                         iterations: int = SMOOTHING_ITERATIONS) -> list:
    """Each record's states re-estimated by the EKF/RTS smoother with the
    baseline as its process model (its force discrepancy a random walk):
    ``x0, y0, psi, u, v, r`` replaced by the smoothed states, other columns
    kept, ``attrs["smoothed"] = "ekf_model"``.

    The baseline is identified on the kinematic smoother's states first, then
    on each pass's smoothed states, ``iterations`` times (Alexandersson et
    al. 2022): a process model identified on distorted states would pull the
    smoothed states towards itself. With an MMG baseline (``ctx.dynamics``)
    the process model is the MMG model.
    """
    settings = settings or SMOOTHER
    current = [_kinematic(r, settings) for r in records]
    vessel = ctx.dynamics.vessel if ctx.dynamics is not None else ctx.vessel
    modules = ctx.dynamics.modules if ctx.dynamics is not None else None
    for _ in range(max(int(iterations), 1)):
        thin = Context(ctx.vessel, ctx.model, current, [], "central", dynamics=ctx.dynamics)
        params, _, _ = regression_fit(thin, _baseline_setup(thin))
        values = {n: params.get(n, 0.0) for n in ctx.model.names}
        out = []
        for rec, last in zip(records, current):
            try:
                res = kalman_smooth(rec, settings, ctx.model, values, vessel, modules)
            except (ValueError, np.linalg.LinAlgError) as exc:
                log.warning("record %s: the baseline's EKF/RTS smoother failed (%s); the previous "
                            "smoothing is kept", rec.attrs.get("name"), exc)
                out.append(last)
                continue
            sm = rec.copy()
            for name, idx in (("x0", 0), ("y0", 1), ("psi", 2), ("u", 3), ("v", 4), ("r", 5)):
                sm[name] = res.states[:, idx]
            sm.attrs = dict(rec.attrs)
            sm.attrs["smoothed"] = "ekf_model"
            out.append(sm)
        current = out
    return current


def _kinematic(record: pd.DataFrame, settings: KalmanSettings) -> pd.DataFrame:
    """The record's velocities and heading from the kinematic EKF/RTS smoother."""
    est = ekf_derivatives(record, settings)
    out = record.iloc[est.index].copy()
    for c in ("u", "v", "r", "psi"):
        out[c] = est.states[c]
    out.attrs = dict(record.attrs)
    out.attrs["smoothed"] = "ekf"
    return out.reset_index(drop=True)


def _baseline_setup(ctx: Context) -> Setup:
    return Setup(ctx.model, list(ctx.train), dynamics=ctx.dynamics)


def _with_dynamics(ctx: Context, setup: Setup) -> Setup:
    setup.dynamics = ctx.dynamics
    return setup


# --------------------------------------------------------------- design

@dataclass
class _Design:
    """A regression on the stacked, weighted rows of all DOFs and records.

    Data rows are prime forces at the nominal speed in Abkowitz prime units,
    each DOF's divided by the baseline's residual RMS ``sigma``; prior rows
    (the MMG regression's) come last, with ``dof`` 3 and ``fold`` -1.
    """

    x: np.ndarray             # (N, p) the model's columns, block diagonal over the DOFs
    y: np.ndarray             # (N,)
    dof: np.ndarray           # (N,) DOF of each row (3: prior rows)
    fold: np.ndarray          # (N,) fold of each row (-1: prior rows, in every fold's training)
    sigma: np.ndarray         # (3,) the row weights' inverse per DOF
    coef: dict                # the model's coefficients, fitted on all rows
    names: list               # the coefficient of each column
    states: list              # per DOF: u, v, r, delta of the data rows
    nominal: list             # per DOF: the nominal-speed factor of the data rows
    n_data: list              # data rows per DOF
    residual: np.ndarray      # weighted data-row residual of the fit on all rows


def _folds(record: np.ndarray, block: int) -> np.ndarray:
    """Fold of each row: every record is cut into contiguous blocks of
    ``block`` rows (several of the residual's correlation times), and block
    ``j`` goes to fold ``j mod FOLDS``, so that every fold holds short stretches
    of every manoeuvre and its training rows surround them. (Holding out whole
    records or long stretches would judge how a polynomial model extrapolates
    to motions it has not seen, which swamps what a cause explains.)"""
    fold = np.empty_like(record)
    for r in np.unique(record):
        rows = np.flatnonzero(record == r)
        fold[rows] = (np.arange(len(rows)) // max(int(block), 1) + int(r)) % FOLDS
    return fold


def _design(ctx: Context, setup: Setup, sigma: np.ndarray | None = None) -> _Design:
    """The setup's regression (its records as the cause reads them, its external
    forces removed) as a :class:`_Design`; ``sigma`` defaults to the residual
    RMS per DOF of this fit."""
    problems, ratio = setup_problems(ctx, setup)
    speed0 = ctx.vessel.speed
    rows = []
    for dof in DOFS:
        p = problems[dof]
        n = int(getattr(p, "n_data", p.n_rows))
        s = p.states
        factor = (np.asarray(s["u"][:n]) ** 2 + np.asarray(s["v"][:n]) ** 2) / speed0 ** 2 * ratio
        y, theta = p.y.copy(), p.theta.copy()
        y[:n] *= factor
        theta[:n] *= factor[:, None]
        y[n:] *= ratio
        theta[n:] *= ratio
        record = np.asarray(p.record[:n] if p.record is not None else np.zeros(n), int)
        states = {c: np.asarray(s[c][:n], float) for c in ("u", "v", "r", "delta")}
        rows.append((y, theta, list(p.names), n, factor, record, states))
    coef, resid = {}, []
    fitted_sigma = np.ones(3)
    for k, (y, theta, names, n, _, _, _) in enumerate(rows):
        c = np.linalg.lstsq(theta, y, rcond=None)[0] if theta.shape[1] else np.zeros(0)
        coef.update(zip(names, c.tolist()))
        r = y[:n] - theta[:n] @ c
        fitted_sigma[k] = max(float(np.sqrt(np.mean(r ** 2))), 1e-300)
        resid.append(r)
    sigma = fitted_sigma if sigma is None else sigma
    n_cols = sum(r[1].shape[1] for r in rows)
    starts = np.cumsum([0] + [r[1].shape[1] for r in rows])
    xs, ys, dofs, folds, prior_x, prior_y = [], [], [], [], [], []
    for k, (y, theta, names, n, _, record, _) in enumerate(rows):
        x = np.zeros((len(y), n_cols))
        x[:, starts[k]:starts[k + 1]] = theta
        xs.append(x[:n] / sigma[k])
        ys.append(y[:n] / sigma[k])
        dofs.append(np.full(n, k))
        folds.append(record)
        if len(y) > n:
            prior_x.append(x[n:] / sigma[k])
            prior_y.append(y[n:] / sigma[k])
    xs += prior_x
    ys += prior_y
    n_prior = sum(len(v) for v in prior_y)
    dofs.append(np.full(n_prior, 3))
    folds.append(np.full(n_prior, -1))
    names = [name for r in rows for name in r[2]]
    block = BLOCK_TAUS * max(integrated_time(r) for r in resid)
    folds = [_folds(f, block) if k < 3 else f for k, f in enumerate(folds)]
    return _Design(np.vstack(xs), np.concatenate(ys), np.concatenate(dofs), np.concatenate(folds), sigma,
                   coef, names, [r[6] for r in rows], [r[4] for r in rows], [r[3] for r in rows],
                   np.concatenate([r / sigma[k] for k, r in enumerate(resid)]))


def _residual(ctx: Context, setup: Setup, coef: dict, sigma: np.ndarray) -> np.ndarray:
    """The setup's weighted data-row residual with the coefficients ``coef`` held."""
    problems, ratio = setup_problems(ctx, setup)
    speed0 = ctx.vessel.speed
    parts = []
    for k, dof in enumerate(DOFS):
        p = problems[dof]
        n = int(getattr(p, "n_data", p.n_rows))
        s = p.states
        factor = (np.asarray(s["u"][:n]) ** 2 + np.asarray(s["v"][:n]) ** 2) / speed0 ** 2 * ratio
        c = np.array([coef.get(name, 0.0) for name in p.names])
        r = p.y[:n] - (p.theta[:n] @ c if p.theta.shape[1] else 0.0)
        parts.append(r * factor / sigma[k])
    return np.concatenate(parts)


def _pad(column: np.ndarray, n_rows: int) -> np.ndarray:
    out = np.zeros((n_rows,) + column.shape[1:])
    out[:len(column)] = column
    return out


def _signature(ctx: Context, design: _Design, cause: Cause, theta: np.ndarray) -> np.ndarray:
    """``-J`` (N, k) of a cause's parameters at ``theta`` by central differences
    of the residual, the design's coefficients held (zero on prior rows)."""
    theta = np.asarray(theta, float)
    steps = _steps(ctx, cause)
    cols = []
    for j in range(len(theta)):
        plus, minus = theta.copy(), theta.copy()
        plus[j] += steps[j]
        minus[j] -= steps[j]
        rp = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, plus)), design.coef, design.sigma)
        rm = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, minus)), design.coef, design.sigma)
        cols.append(-(rp - rm) / (2.0 * steps[j]))
    return _pad(np.column_stack(cols), len(design.y)) if cols else np.zeros((len(design.y), 0))


def _steps(ctx: Context, cause: Cause) -> np.ndarray:
    """Finite-difference steps of a cause's parameters (a hundredth of a small effect)."""
    steps = np.asarray(cause.scales(ctx), float) * 10.0
    low, high = cause.bounds(ctx)
    finite = np.isfinite(high - low)
    steps[finite] = np.minimum(steps[finite], 0.005 * (high - low)[finite])
    return np.maximum(steps, 1e-9)


def _variants(ctx: Context, design: _Design, causes: list) -> list:
    """Every cause's signature columns on the design's rows."""
    n_rows = len(design.y)
    out = []
    for cause in causes:
        if cause.replaces_dynamics or cause.id == "none" or isinstance(cause, MissingTerm):
            continue
        if isinstance(cause, Current):
            # linear in the earth-fixed components (speed cos dir, speed sin dir) at no current
            step = 0.01 * max(ctx.vessel.speed, 0.1)
            rp = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, [step, 0.0])), design.coef, design.sigma)
            rm = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, [step, np.pi])), design.coef, design.sigma)
            rq = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, [step, 0.5 * np.pi])), design.coef,
                           design.sigma)
            rs = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, [step, -0.5 * np.pi])), design.coef,
                           design.sigma)
            cols = np.column_stack([-(rp - rm) / (2 * step), -(rq - rs) / (2 * step)])

            def to_theta(b):
                return np.array([np.hypot(b[0], b[1]), np.arctan2(b[1], b[0])])
            out.append(Variant(cause, cause.id, _pad(cols, n_rows), to_theta, 2))
            continue
        if isinstance(cause, WindUnmodelled):
            # a wind's load grows as the square of its speed: the secant from no wind
            base = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, [0.0, 0.0])), design.coef, design.sigma)
            for beta in WIND_DIRECTIONS:
                r = _residual(ctx, _with_dynamics(ctx, cause.setup(ctx, [WIND_REFERENCE, beta])),
                              design.coef, design.sigma)

                def to_theta(b, beta=beta):
                    return np.array([WIND_REFERENCE * np.sqrt(max(float(b[0]), 0.01)), beta])
                out.append(Variant(cause, f"{cause.id}@{np.rad2deg(beta):.0f}deg",
                                   _pad(-(r - base)[:, None], n_rows), to_theta, 2))
            continue
        cols = _signature(ctx, design, cause, np.zeros(len(cause.nl_params)))
        out.append(Variant(cause, cause.id, cols, lambda b: np.asarray(b, float), len(cause.nl_params)))
    for term in extended_library(ctx.model, 3):
        if ctx.dynamics is not None and term.powers[0]:
            continue            # the MMG hull is a function of v', r' only: no surge-speed terms
        col = _library_column(ctx, design, term)
        if col is None:
            continue
        out.append(Variant(MissingTerm([term]), f"missing_term:{term.name}", _pad(col[:, None], n_rows),
                           lambda b: np.zeros(0), 1))
    return out


def _library_column(ctx: Context, design: _Design, term) -> np.ndarray | None:
    """A candidate term's feature on its DOF's data rows (weighted, nominal speed), zero elsewhere."""
    from ..identify.regression import prime_states

    k = DOFS.index(term.dof)
    s = design.states[k]
    if ctx.dynamics is not None:
        speed = np.sqrt(s["u"] ** 2 + s["v"] ** 2)
        primes = np.column_stack([np.zeros_like(speed), s["v"] / speed,
                                  s["r"] * ctx.dynamics.vessel.length / speed, s["delta"]])
    else:
        primes = prime_states(s["u"], s["v"], s["r"], s["delta"], ctx.vessel)
    feature = term.feature(primes) * design.nominal[k] / design.sigma[k]
    if not np.all(np.isfinite(feature)) or np.sqrt(np.mean(feature ** 2)) < 1e-12:
        return None
    col = np.zeros(sum(design.n_data))
    start = sum(design.n_data[:k])
    col[start:start + len(feature)] = feature
    return col


# --------------------------------------------------------------- comparison

def _models(variants: list, pairs: bool) -> list:
    """``()``, every variant, and (``pairs``) every pair of variants of two different causes."""
    models = [()] + [(i,) for i in range(len(variants))]
    if pairs:
        for i, j in itertools.combinations(range(len(variants)), 2):
            if variants[i].cause.id != variants[j].cause.id:
                models.append((i, j))
    return models


def _log_prior(models: list, variants: list) -> np.ndarray:
    """``ln prior``: uniform over 0, 1, 2 causes, over the causes (or pairs of
    causes) of each size, and over the variants of each cause."""
    by_cause = {}
    for v in variants:
        by_cause[v.cause.id] = by_cause.get(v.cause.id, 0) + 1
    ids = list(by_cause)
    sizes = {0: 1, 1: len(ids), 2: len(ids) * (len(ids) - 1) // 2}
    levels = 3 if any(len(m) == 2 for m in models) else 2
    out = np.empty(len(models))
    for m_i, m in enumerate(models):
        lp = -np.log(levels) - np.log(max(sizes[len(m)], 1))
        for i in m:
            lp -= np.log(by_cause[variants[i].cause.id])
        out[m_i] = lp
    return out


class _Folds:
    """Gram pieces per fold and DOF, for the cross-validated likelihood of any
    subset of the columns (:meth:`loglik`)."""

    def __init__(self, x: np.ndarray, y: np.ndarray, dof: np.ndarray, fold: np.ndarray):
        self.ids = [int(f) for f in np.unique(fold[fold >= 0])]
        prior = fold < 0
        self.g0, self.b0 = x[prior].T @ x[prior], x[prior].T @ y[prior]
        self.pieces = {}
        for f in self.ids:
            for k in range(3):
                rows = (fold == f) & (dof == k)
                xf = x[rows]
                self.pieces[f, k] = (xf.T @ xf, xf.T @ y[rows], float(y[rows] @ y[rows]), int(rows.sum()))
        self.gk = {k: sum(self.pieces[f, k][0] for f in self.ids) for k in range(3)}
        self.bk = {k: sum(self.pieces[f, k][1] for f in self.ids) for k in range(3)}
        self.yk = {k: sum(self.pieces[f, k][2] for f in self.ids) for k in range(3)}
        self.nk = {k: sum(self.pieces[f, k][3] for f in self.ids) for k in range(3)}
        self.g = self.g0 + sum(self.gk.values())
        self.b = self.b0 + sum(self.bk.values())
        self.ridge = 1e-10 * np.trace(self.g) / max(len(self.g), 1)

    def _solve(self, g, b):
        try:
            return np.linalg.solve(g + self.ridge * np.eye(len(g)), b)
        except np.linalg.LinAlgError:
            return np.linalg.lstsq(g, b, rcond=None)[0]

    def fit(self, idx: np.ndarray) -> np.ndarray:
        """Coefficients of the columns ``idx`` fitted on every fold."""
        return self._solve(self.g[np.ix_(idx, idx)], self.b[idx])

    def loglik(self, idx: np.ndarray) -> float:
        """Held-out Gaussian log-likelihood of the columns ``idx``, summed over
        the folds: each fold predicted by the fit on the others, with each DOF's
        variance from that fit's residual."""
        total = 0.0
        sub = np.ix_(idx, idx)
        for f in self.ids:
            g = self.g[sub] - sum(self.pieces[f, k][0][sub] for k in range(3))
            b = self.b[idx] - sum(self.pieces[f, k][1][idx] for k in range(3))
            beta = self._solve(g, b)
            for k in range(3):
                gf, bf, yf, nf = self.pieces[f, k]
                if nf == 0:
                    continue
                gt, bt = self.gk[k][sub] - gf[sub], self.bk[k][idx] - bf[idx]
                nt = self.nk[k] - nf
                rss_t = max(self.yk[k] - yf - 2.0 * beta @ bt + beta @ gt @ beta, 1e-300)
                rss_f = max(yf - 2.0 * beta @ bf[idx] + beta @ gf[sub] @ beta, 0.0)
                var = rss_t / max(nt, 1)
                total += -0.5 * (nf * np.log(var) + rss_f / var)
        return float(total)


def scores_of(loglik: np.ndarray, log_prior: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """``(scores, probabilities)`` from the models' cross-validated log-likelihoods
    (rows ``tau``-correlated: divided by ``tau``) and log priors (module
    docstring, step 3); scores relative to the best."""
    scores = -2.0 * loglik / max(tau, 1.0) - 2.0 * log_prior
    scores = scores - scores.min()
    w = np.exp(-0.5 * scores)
    return scores, w / w.sum()


#: folds of the cross-validation (interleaved time blocks of every record, :func:`_folds`)
FOLDS = 5
#: length of the cross-validation's blocks in correlation times of the residual
BLOCK_TAUS = 4
#: models refined by nonlinear least squares before the final comparison (the most probable)
CONTENDERS = 6


def _contenders(models: list, variants: list, probs: np.ndarray, top: int) -> list:
    """Models to refine: ``none``, the most probable variant of every single
    cause (a cause's first-order signature may miss part of its effect, which
    only its nonlinear fit recovers), and the most probable model of each of
    the ``top`` most probable verdicts."""
    best_of = {}
    for m_i in np.argsort(-probs):
        key = tuple(sorted(variants[i].cause.id for i in models[m_i]))
        best_of.setdefault(key, int(m_i))
    singles = [m_i for key, m_i in best_of.items() if len(key) == 1]
    ranked = sorted(best_of.values(), key=lambda m_i: -probs[m_i])[:top]
    return list(dict.fromkeys([0] + singles + ranked))


def _relinearised(ctx: Context, cause: Cause, theta: np.ndarray, sigma: np.ndarray) -> tuple[float, float]:
    """Cross-validated log-likelihood of a cause's model linearised at its
    refined ``theta`` (the baseline's columns with the cause's at ``theta``,
    plus its signature there), and the autocorrelation time of its residual."""
    design = _design(ctx, _with_dynamics(ctx, cause.setup(ctx, theta)), sigma)
    cols = _signature(ctx, design, cause, theta) if len(theta) else np.zeros((len(design.y), 0))
    x = np.hstack([design.x, cols])
    folds = _Folds(x, design.y, design.dof, design.fold)
    return folds.loglik(np.arange(x.shape[1])), _tau(design.residual, design)


def _tau(residual: np.ndarray, design: _Design) -> float:
    parts = np.split(residual, np.cumsum(design.n_data)[:-1])
    return max(integrated_time(r) for r in parts)


def infer(ctx: Context, records: list | None = None, causes: list | None = None, pairs: bool = True,
          contenders: int = CONTENDERS) -> Inference:
    """Compare every model of the catalogue (module docstring).

    Parameters
    ----------
    ctx : Context
        The baseline, its vessel and the smoothed training records (the
        named model's parameters are refined on them).
    records : list of DataFrame, optional
        The smoothed records the models are compared on by cross-validation
        (default ``ctx.train``; discovery passes the training and the
        held-out records).
    causes : list of Cause, optional
        Default: the catalogue's applicable causes; undecidable ones are left out.
    pairs : bool
        Compare pairs of causes too.
    contenders : int
        Verdicts refined besides ``none`` and every single cause.
    """
    seconds = {}
    t0 = time.perf_counter()
    every = Context(ctx.vessel, ctx.model, list(records or ctx.train), [], ctx.derivative,
                    dynamics=ctx.dynamics)
    design = _design(every, _baseline_setup(every))
    causes = causes if causes is not None else list(manoeuvring_causes(ctx))
    causes = [c for c in causes if c.undecidable(ctx) is None]
    variants = _variants(every, design, causes)
    seconds["signatures"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    x = np.hstack([design.x] + [v.columns for v in variants])
    folds = _Folds(x, design.y, design.dof, design.fold)
    p_base = design.x.shape[1]
    spans, col = [], p_base
    for v in variants:
        spans.append(np.arange(col, col + v.columns.shape[1]))
        col += v.columns.shape[1]
    models = _models(variants, pairs)
    base_idx = np.arange(p_base)
    index = [np.concatenate([base_idx] + [spans[i] for i in m]) if m else base_idx for m in models]
    loglik = np.array([folds.loglik(idx) for idx in index])
    log_prior = _log_prior(models, variants)
    tau = _tau(design.residual, design)
    scores, probs = scores_of(loglik, log_prior, tau)
    seconds["comparison"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    fits, taus = {}, {0: tau}
    for m_i in _contenders(models, variants, probs, contenders):
        m = models[m_i]
        if not m:
            fits[m_i] = baseline_fit(ctx)
            continue
        cause = _model_cause(variants, m)
        start = _model_theta(variants, m, folds.fit(index[m_i])[p_base:])
        fit = refine(ctx, cause, start)
        fits[m_i] = fit
        loglik[m_i], taus[m_i] = _relinearised(every, cause, fit.theta, design.sigma)
    scores, probs = scores_of(loglik, log_prior, tau)
    best = int(np.argmax(probs))
    # the residual's correlation time without the effect the named model explains
    tau = min(taus.get(best, tau), tau)
    scores, probs = scores_of(loglik, log_prior, tau)
    best = int(np.argmax(probs))
    seconds["refinement"] = time.perf_counter() - t2
    named = models[best]
    inclusion, verdicts = {}, {}
    for m, p in zip(models, probs):
        key = "+".join(sorted((variants[i].cause.id for i in m), key=_catalogue_order)) if m else "none"
        verdicts[key] = verdicts.get(key, 0.0) + float(p)
        for cid in {variants[i].cause.id for i in m}:
            inclusion[cid] = inclusion.get(cid, 0.0) + float(p)
    cov = np.zeros((0, 0))
    if named:
        idx = index[best]
        try:
            # rows are weighted by the baseline's residual RMS: unit variance, tau-correlated
            cov = tau * np.linalg.inv(folds.g[np.ix_(idx, idx)])[p_base:, p_base:]
        except np.linalg.LinAlgError:
            cov = np.full((len(idx) - p_base,) * 2, np.nan)
    out = Inference(models, scores, probs, variants, named, inclusion, verdicts,
                    folds.fit(index[best])[p_base:], cov, tau, int(np.mean(design.n_data)), seconds)
    out.fits = {models[i]: f for i, f in fits.items()}
    out.fit = fits.get(best)
    if out.fit is None:       # a model the refinement did not reach cannot be the best; kept for safety
        cause = _model_cause(variants, named)
        out.fit = refine(ctx, cause, _model_theta(variants, named, out.coefficients))
    return out


def _catalogue_order(cause_id: str) -> int:
    from .causes import CATALOGUE

    ids = list(CATALOGUE)
    return ids.index(cause_id) if cause_id in ids else len(ids)


# --------------------------------------------------------------- refinement

def _ordered(variants: list, model: tuple) -> list:
    return sorted(range(len(model)), key=lambda j: _catalogue_order(variants[model[j]].cause.id))


def _model_cause(variants: list, model: tuple) -> Cause | None:
    """A model as one cause (a :class:`Combined` for a pair), in catalogue order."""
    causes = [variants[model[j]].cause for j in _ordered(variants, model)]
    if not causes:
        return None
    return causes[0] if len(causes) == 1 else Combined(causes[0], causes[1])


def _model_theta(variants: list, model: tuple, coefficients: np.ndarray) -> np.ndarray:
    """A model's ``theta`` (its cause's :attr:`Cause.nl_params`, catalogue order)
    from its linear coefficients."""
    spans, col = [], 0
    for i in model:
        w = variants[i].columns.shape[1]
        spans.append(coefficients[col:col + w])
        col += w
    parts = [np.atleast_1d(variants[model[j]].to_theta(spans[j])) for j in _ordered(variants, model)]
    return np.concatenate(parts) if parts else np.zeros(0)


def named_cause(inference: Inference) -> Cause | None:
    """The named model as one cause (a :class:`Combined` for a pair), in catalogue order."""
    return _model_cause(inference.variants, inference.named)


def linear_theta(inference: Inference) -> np.ndarray:
    """The named model's ``theta`` from its linear coefficients (catalogue order)."""
    return _model_theta(inference.variants, inference.named, inference.coefficients)


def refine(ctx: Context, cause: Cause, start: np.ndarray, max_nfev: int = 40) -> CauseFit:
    """Profiled nonlinear least squares of ``cause``'s parameters from ``start``
    (the linear solution), the baseline's coefficients re-identified at every
    trial (:func:`studies.discover.fitting.fit_cause`'s objective)."""
    t0 = time.perf_counter()
    theta = np.asarray(start, float)
    if len(cause.nl_params):
        low, high = cause.bounds(ctx)
        theta = np.clip(theta, low + 1e-9, high - 1e-9)

        def vector(th):
            _, residuals, _ = scored_fit(ctx, _with_dynamics(ctx, cause.setup(ctx, th)))
            return np.concatenate([r / s for r, s in zip(residuals, ctx.sigma)])
        try:
            res = least_squares(vector, theta, bounds=(low, high), x_scale=np.maximum(cause.scales(ctx) * 100, 1e-9),
                                max_nfev=max_nfev, diff_step=1e-3)
            theta = res.x
        except (ValueError, np.linalg.LinAlgError) as exc:
            log.info("refining %s from the linear solution failed (%s); the linear solution is kept",
                     cause.id, exc)
    setup = _with_dynamics(ctx, cause.setup(ctx, theta))
    params, residuals, _ = scored_fit(ctx, setup)
    rss = np.array([float(np.sum(r ** 2)) for r in residuals])
    fit = CauseFit(cause, np.asarray(theta, float), params, rss, setup=setup,
                   tau=max(integrated_time(r) for r in residuals))
    fit.score = _score(ctx, rss, cause.n_params())
    fit.seconds = time.perf_counter() - t0
    return fit


def baseline_fit(ctx: Context) -> CauseFit:
    """The baseline as a :class:`CauseFit` (coefficients by LS on ``ctx.train``)."""
    from .causes import NoCause

    setup = _baseline_setup(ctx)
    setup.cause = None
    params, residuals, _ = scored_fit(ctx, setup)
    rss = np.array([float(np.sum(r ** 2)) for r in residuals])
    fit = CauseFit(NoCause(), np.zeros(0), params, rss, setup=setup,
                   tau=max(integrated_time(r) for r in residuals))
    fit.score = _score(ctx, rss, 0)
    return fit
