"""Discovery by one inference over the whole cause catalogue.

What the baseline misses is estimated once, and every cause of the
catalogue, alone or in pairs, is weighed against it in one Bayesian model
comparison; the named verdict is the model of highest posterior
probability, and that probability is its confidence.

1. **States.** Every record (training and held out) is smoothed by the
   kinematic EKF/RTS smoother (:func:`studies.identify.kalman.ekf_derivatives`,
   no sensor-bias states: they would take a model's or a cause's error for
   drifting sensors); its accelerations are used as they are.
   (:func:`smooth_with_baseline` can also smooth with the identified
   baseline as process model, ``iterations`` > 0; measured, that pulls the
   states towards the baseline and shrinks every effect, so it is off.)
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
3. **One comparison.** Every model ``M`` (``none``, each cause, each pair of
   causes; a missing term or a wind direction is one of the variants of its
   cause) is fitted with the baseline's columns projected out
   (:class:`_Residualised`). Its likelihood ratio over ``none``,
   ``LR_M = n sum_dof ln(RSS_dof(none) / RSS_dof(M))``, is divided by the
   dispersion ``phi`` that a parametric bootstrap under the baseline measures
   on the records' own noise (:func:`null_dispersion`)::

       score(M) = -LR_M / phi + k_M ln(n / phi) - 2 ln prior(M)

   with uniform prior odds over 0, 1 and 2 causes, over the causes of each
   size and over the variants of a cause. The posterior probability
   ``exp(-score / 2)`` normalised over all models is the model's; a cause's
   inclusion probability is the sum over the models that hold it. The
   contenders (``none``, every single cause, the most probable verdicts)
   are refined by profiled nonlinear least squares and scored on their exact
   residuals; a pair's second cause is judged with the dispersion of records
   made by its first cause's refined model.
4. **Parameters.** The named verdict is the one of highest posterior
   probability (summed over its variants), its probability the confidence;
   its parameters come from the refinement, their 90 % intervals from the
   regression's covariance times the dispersion (:func:`intervals`). The
   held-out records then measure the gain (the workflow refits the named
   model on the training records for it); the gain is reported, it does not
   name anything.

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

from ..identify.kalman import KalmanSettings, kalman_smooth, smoothed_record
from ..models.terms import DOFS
from .causes import Combined, Current, MissingTerm, WindUnmodelled, extended_library, manoeuvring_causes
from .causes.base import Cause, Setup
from .fitting import (CauseFit, Context, _score, integrated_time, kinematic_smoothing, regression_fit,
                      scored_fit, setup_problems)

__all__ = ["Variant", "Inference", "infer", "smooth_with_baseline", "WIND_DIRECTIONS", "WIND_REFERENCE"]

log = logging.getLogger(__name__)

#: directions (from which the wind comes) of the wind signatures [rad]
WIND_DIRECTIONS = np.deg2rad(np.arange(0.0, 360.0, 22.5))
#: passes of identification and model-based smoothing (:func:`smooth_with_baseline`)
SMOOTHING_ITERATIONS = 0
#: the smoother's settings: no sensor-bias states, which would take the baseline's errors (and
#: a cause's effect) for slowly drifting velocity sensors and keep the states on the baseline
SMOOTHER = KalmanSettings(bias=False, scale_grid=tuple(10.0 ** np.arange(-3.0, 1.01, 1.0)))
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
    dispersion : float
        The likelihood-ratio dispersion of the named model (:func:`null_dispersion`).
    n_rows : int
    seconds : dict
        Time spent per stage [s].
    dispersions : dict
        ``{cause id: dispersion}`` and ``"all"`` (set by :func:`infer`).
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
    dispersion: float
    n_rows: int
    seconds: dict = field(default_factory=dict)

    def verdict_of(self, model: tuple) -> str:
        """The verdict id of a model: its causes' ids joined by ``+`` in catalogue order, or ``none``."""
        return _verdict_id(self.variants, model)

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
    current = [kinematic_smoothing(r, settings, rates=True) for r in records]
    for _ in range(int(iterations)):
        thin = Context(ctx.vessel, ctx.model, current, [], "recorded", dynamics=ctx.dynamics)
        params, _, _ = regression_fit(thin, _baseline_setup(thin))
        out = []
        for rec, last in zip(records, current):
            try:
                out.append(_smooth_once(ctx, rec, params, settings))
            except (ValueError, np.linalg.LinAlgError) as exc:
                log.warning("record %s: the baseline's EKF/RTS smoother failed (%s); the previous "
                            "smoothing is kept", rec.attrs.get("name"), exc)
                out.append(last)
        current = out
    return current


def _smooth_once(ctx: Context, record: pd.DataFrame, params: dict,
                 settings: KalmanSettings | None = None) -> pd.DataFrame:
    """One pass of the smoother with the baseline's coefficients ``params`` as
    process model: the record with the smoothed states and accelerations
    (:func:`studies.identify.kalman.smoothed_record`), ``attrs["smoothed"] = "ekf_model"``."""
    vessel = ctx.dynamics.vessel if ctx.dynamics is not None else ctx.vessel
    modules = ctx.dynamics.modules if ctx.dynamics is not None else None
    values = {n: params.get(n, 0.0) for n in ctx.model.names}
    out = smoothed_record(kalman_smooth(record, settings or SMOOTHER, ctx.model, values, vessel, modules), record)
    out.attrs["smoothed"] = "ekf_model"
    return out


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
    (the MMG regression's) come last, with ``dof`` 3.
    """

    x: np.ndarray             # (N, p) the model's columns, block diagonal over the DOFs
    y: np.ndarray             # (N,)
    dof: np.ndarray           # (N,) DOF of each row (3: prior rows)
    block: np.ndarray         # (N,) the DOF whose coefficients each row bears on (prior rows too)
    starts: np.ndarray        # (4,) first column of each DOF's block of columns, then the end
    sigma: np.ndarray         # (3,) the row weights' inverse per DOF
    coef: dict                # the model's coefficients, fitted on all rows
    names: list               # the coefficient of each column
    states: list              # per DOF: u, v, r, delta of the data rows
    nominal: list             # per DOF: the nominal-speed factor of the data rows
    n_data: list              # data rows per DOF
    residual: np.ndarray      # weighted data-row residual of the fit on all rows


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
        states = {c: np.asarray(s[c][:n], float) for c in ("u", "v", "r", "delta", "psi") if c in s}
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
    xs, ys, dofs, blocks, prior_x, prior_y, prior_b = [], [], [], [], [], [], []
    for k, (y, theta, names, n, _, record, _) in enumerate(rows):
        x = np.zeros((len(y), n_cols))
        x[:, starts[k]:starts[k + 1]] = theta
        xs.append(x[:n] / sigma[k])
        ys.append(y[:n] / sigma[k])
        dofs.append(np.full(n, k))
        blocks.append(np.full(n, k))
        if len(y) > n:
            prior_x.append(x[n:] / sigma[k])
            prior_y.append(y[n:] / sigma[k])
            prior_b.append(np.full(len(y) - n, k))
    xs += prior_x
    ys += prior_y
    blocks += prior_b
    n_prior = sum(len(v) for v in prior_y)
    dofs.append(np.full(n_prior, 3))
    names = [name for r in rows for name in r[2]]
    return _Design(np.vstack(xs), np.concatenate(ys), np.concatenate(dofs), np.concatenate(blocks), starts,
                   sigma,
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


class _Residualised:
    """The cause columns and the target with the baseline's columns projected
    out, DOF by DOF (QR; Frisch-Waugh-Lovell), so that every model is a small,
    well-conditioned least-squares problem in its cause columns alone: the
    normal equations of the whole design (40 ill-conditioned polynomial
    columns) would lose the digits that the models differ by.

    :meth:`rss` gives the per-DOF residual sums of squares of the data rows
    for any subset of the cause columns, :meth:`fit` their coefficients.
    """

    def __init__(self, design: "_Design", extra: np.ndarray | None = None):
        extra = np.zeros((len(design.y), 0)) if extra is None else extra
        y, x = design.y.copy(), extra.copy()
        for k in range(3):
            rows = design.block == k
            base = design.x[rows][:, design.starts[k]:design.starts[k + 1]]
            if base.shape[1]:
                q, _ = np.linalg.qr(base)
                y[rows] -= q @ (q.T @ y[rows])
                x[rows] -= q @ (q.T @ x[rows])
        self.g, self.b = x.T @ x, x.T @ y
        self.pieces = []
        for k in range(3):
            rows = design.dof == k
            xk, yk = x[rows], y[rows]
            self.pieces.append((xk.T @ xk, xk.T @ yk, float(yk @ yk)))
        self.n = float(np.mean([int((design.dof == k).sum()) for k in range(3)]))

    def fit(self, idx: np.ndarray) -> np.ndarray:
        """Coefficients of the cause columns ``idx``."""
        if not len(idx):
            return np.zeros(0)
        g = self.g[np.ix_(idx, idx)]
        try:
            return np.linalg.solve(g, self.b[idx])
        except np.linalg.LinAlgError:
            return np.linalg.lstsq(g, self.b[idx], rcond=None)[0]

    def rss(self, idx: np.ndarray) -> np.ndarray:
        """Per-DOF residual sums of squares (3,) of the data rows for the cause columns ``idx``."""
        beta = self.fit(idx)
        sub = np.ix_(idx, idx)
        return np.array([max(yy - 2.0 * beta @ b[idx] + beta @ g[sub] @ beta, 1e-300)
                         for g, b, yy in self.pieces])


def scores_of(rss: np.ndarray, n_params: np.ndarray, log_prior: np.ndarray, n_rows: float,
              dispersion) -> tuple[np.ndarray, np.ndarray]:
    """``(scores, probabilities)`` of models with per-DOF ``rss`` (m, 3), the
    parameters they add and their log prior (module docstring, step 3); the
    first model is ``none``. Each model's likelihood ratio over ``none`` is
    divided by its dispersion (one value, or one per model) and its BIC
    penalty taken at ``n_rows / dispersion`` rows; scores relative to the best."""
    phi = np.maximum(np.broadcast_to(np.asarray(dispersion, float), (len(rss),)), 1.0)
    n_eff = np.maximum(n_rows / phi, 10.0)
    ratio = n_rows * np.sum(np.log(rss[0] / rss), axis=1)
    scores = -ratio / phi + n_params * np.log(n_eff) - 2.0 * log_prior
    scores = scores - scores.min()
    w = np.exp(-0.5 * scores)
    return scores, w / w.sum()


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


def _refined_rss(ctx: Context, cause: Cause, theta: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Per-DOF weighted RSS of a cause's model at its refined ``theta`` (the
    baseline's coefficients re-identified there) on every record of ``ctx``."""
    design = _design(ctx, _with_dynamics(ctx, cause.setup(ctx, theta)), sigma)
    return _Residualised(design).rss(np.zeros(0, int))


# --------------------------------------------------------------- dispersion

#: replicates of the parametric bootstrap of :func:`null_dispersion`
NULL_REPLICATES = 3
#: weight (in ratios) of the mean over every cause in a cause's dispersion (:func:`null_dispersion`)
SHRINK = 5.0


def _block_resample(noise: np.ndarray, block: int, rng) -> np.ndarray:
    """A circular block bootstrap of a residual series (n, c): blocks of ``block`` rows."""
    n = len(noise)
    block = int(min(max(block, 1), n))
    starts = rng.integers(0, n, size=int(np.ceil(n / block)))
    idx = (starts[:, None] + np.arange(block)[None, :]).ravel()[:n] % n
    return noise[idx]


def null_records(ctx: Context, raw: list, smoothed: list, params: dict, block: int, rng,
                 setup: Setup | None = None) -> list:
    """Records as the baseline with ``params`` (or the extended model of
    ``setup``) would have made them, with the measured records' own noise:
    each record's rudder (and propeller rate, wind) replayed from its smoothed
    initial state, plus a block bootstrap of the record's measurement residual
    (measured minus smoothed, every channel together, so that coloured,
    quantised and track-derived noise keep their structure). The recorded
    rudder is kept as recorded."""
    out = []
    setup = setup or _baseline_setup(ctx)
    for rec, sm in zip(raw, smoothed):
        channels = [c for c in ("x0", "y0", "psi", "u", "v", "r") if c in rec and c in sm]
        n = min(len(rec), len(sm))
        seg = sm.iloc[:n].copy()
        seg.attrs = dict(rec.attrs)
        try:
            sim = setup.replay(params, ctx.vessel, seg)
        except (ValueError, FloatingPointError):
            continue
        if "diverged_at" in sim.attrs:
            continue
        t = seg["t"].to_numpy(float)
        clean = rec.iloc[:n].copy()
        for c in channels:
            clean[c] = np.interp(t, sim["t"].to_numpy(float), sim[c].to_numpy(float))
        noise = np.column_stack([rec[c].to_numpy(float)[:n] - sm[c].to_numpy(float)[:n] for c in channels])
        noise = _block_resample(noise, block, rng)
        for j, c in enumerate(channels):
            clean[c] = clean[c].to_numpy(float) + noise[:, j]
        clean.attrs = dict(rec.attrs)
        out.append(clean.reset_index(drop=True))
    return out


def null_dispersion(ctx: Context, raw: list, smoothed: list, causes: list, params: dict, block: int,
                    replicates: int = NULL_REPLICATES, seed: int = 0, under: CauseFit | None = None) -> dict:
    """How much the comparison's likelihood ratios are inflated on these records
    (>= 1), by a parametric bootstrap under the baseline.

    Records made by the identified baseline itself, with the measured
    records' noise (:func:`null_records`), go through the same smoother and
    signatures; there every cause is spurious, so each variant's likelihood
    ratio over ``none``, ``n sum_dof ln(RSS_none / RSS_v)``, would average its
    number of parameters (a chi-square law) if the rows were independent and
    the states exact. A cause's dispersion is the mean over its variants and
    the replicates of the ratio over the number of parameters (the
    quasi-likelihood estimate), shrunk towards the mean over every cause with
    the weight of :data:`SHRINK` ratios (a cause with one variant has only
    ``replicates`` ratios): causes differ in how much of the smoother's and
    the regressors' errors they can take up (a third-order rudder term far
    more than an earth-fixed force). It
    holds the residual's serial correlation, the smoother's errors and the
    errors in the regressors together (McCullagh & Nelder 1989, quasi-
    likelihood; Efron & Tibshirani 1993, parametric bootstrap).

    ``block``: rows of the residual's bootstrap blocks (several of its
    correlation times). ``under``: a single cause's refined fit; the records are then made by its
    extended model, and the ratios are those of each other cause's variants
    added to it (the dispersion that judges a second cause).

    Returns ``{cause id: dispersion}`` and ``"all"``: the mean over every cause.
    """
    rng = np.random.default_rng(seed)
    ratios = {}
    setup = None
    if under is not None:
        setup = _with_dynamics(ctx, under.cause.setup(ctx, under.theta))
        params = under.params
    for _ in range(int(replicates)):
        fake = null_records(ctx, raw, smoothed, params, block, rng, setup)
        if not fake:
            continue
        sm = [_smooth_once(ctx, r, params) if s.attrs.get("smoothed") == "ekf_model"
              else kinematic_smoothing(r, SMOOTHER, rates=True) for r, s in zip(fake, smoothed)]
        every = Context(ctx.vessel, ctx.model, sm, [], "recorded", dynamics=ctx.dynamics)
        design = _design(every, _baseline_setup(every))
        variants = _variants(every, design, causes)
        res = _Residualised(design, np.hstack([v.columns for v in variants]))
        spans, col = [], 0
        for v in variants:
            spans.append(np.arange(col, col + v.columns.shape[1]))
            col += v.columns.shape[1]
        own = np.zeros(0, int)
        if under is not None:
            label = _label_of(under)
            mine = [i for i, v in enumerate(variants) if v.cause.id == under.cause.id
                    and (label is None or v.label == label)]
            if mine:
                best = max(mine, key=lambda i: -float(np.sum(np.log(res.rss(spans[i])))))
                own = spans[best]
        base = res.rss(own)
        for i, v in enumerate(variants):
            if under is not None and v.cause.id == under.cause.id:
                continue
            rss = res.rss(np.concatenate([own, spans[i]]))
            ratios.setdefault(v.cause.id, []).append(res.n * float(np.sum(np.log(base / rss)))
                                                      / max(v.n_params, 1))
    every = [r for values in ratios.values() for r in values]
    if not every:
        return {"all": 1.0}
    overall = float(max(np.mean(every), 1.0))
    out = {"all": overall}
    for cid, values in ratios.items():
        out[cid] = float(max((np.sum(values) + SHRINK * overall) / (len(values) + SHRINK), 1.0))
    return out


def _label_of(fit: CauseFit) -> str | None:
    """The variant label of a missing term's fit (its one term), else None (any variant of the cause)."""
    if isinstance(fit.cause, MissingTerm) and fit.cause.params:
        return f"missing_term:{fit.cause.params[0]}"
    return None


def _tau(residual: np.ndarray, design: _Design) -> float:
    parts = np.split(residual, np.cumsum(design.n_data)[:-1])
    return max(integrated_time(r) for r in parts)


def infer(ctx: Context, records: list | None = None, causes: list | None = None, pairs: bool = True,
          contenders: int = CONTENDERS, raw: list | None = None, dispersion: float | None = None,
          seed: int = 0) -> Inference:
    """Compare every model of the catalogue (module docstring).

    Parameters
    ----------
    ctx : Context
        The baseline, its vessel and the smoothed training records.
    records : list of DataFrame, optional
        The smoothed records the models are compared, refined and fitted on
        (default ``ctx.train``; discovery passes the training and the held-out
        records, and measures the held-out gain with the named model refitted
        on the training records alone).
    causes : list of Cause, optional
        Default: the catalogue's applicable causes; undecidable ones are left out.
    pairs : bool
        Compare pairs of causes too.
    contenders : int
        Verdicts refined besides ``none`` and every single cause.
    raw : list of DataFrame, optional
        The measured records before smoothing, in the order of ``records``:
        the dispersion of the likelihood ratios is then estimated by
        :func:`null_dispersion`; without them (or with ``dispersion``
        given) the residual's autocorrelation time stands for it.
    """
    seconds = {}
    t0 = time.perf_counter()
    records = list(records or ctx.train)
    every = Context(ctx.vessel, ctx.model, records, [], "recorded", dynamics=ctx.dynamics)
    design = _design(every, _baseline_setup(every))
    every.sigma = design.sigma
    every.n_rows = int(np.mean(design.n_data))
    every.n_eff = float(every.n_rows)
    causes = causes if causes is not None else list(manoeuvring_causes(ctx))
    causes = [c for c in causes if c.undecidable(ctx) is None]
    variants = _variants(every, design, causes)
    seconds["signatures"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    #: bootstrap blocks of several residual correlation times
    block = max(20, int(4 * _tau(design.residual, design)))
    if dispersion is None:
        if raw is not None:
            dispersion = null_dispersion(ctx, raw, records, causes, design.coef, block, seed=seed)
        else:
            dispersion = {"all": _tau(design.residual, design)}
    elif not isinstance(dispersion, dict):
        dispersion = {"all": float(dispersion)}
    seconds["dispersion"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    gram = _Residualised(design, np.hstack([v.columns for v in variants]))
    spans, col = [], 0
    for v in variants:
        spans.append(np.arange(col, col + v.columns.shape[1]))
        col += v.columns.shape[1]
    models = _models(variants, pairs)
    index = [np.concatenate([spans[i] for i in m]) if m else np.zeros(0, int) for m in models]
    rss = np.array([gram.rss(idx) for idx in index])
    n_params = np.array([sum(variants[i].n_params for i in m) for m in models], float)
    log_prior = _log_prior(models, variants)

    # one dispersion for every model: a cause's own (dispersions[cause id]) favours the causes
    # of many variants, whose mean ratio is pulled down by the variants that explain nothing
    phis = np.full(len(models), dispersion["all"])
    scores, probs = scores_of(rss, n_params, log_prior, gram.n, phis)
    seconds["comparison"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    fits = {}
    for m_i in _contenders(models, variants, probs, contenders):
        m = models[m_i]
        if not m:
            fits[m_i] = baseline_fit(every)
            continue
        cause = _model_cause(variants, m)
        start = _model_theta(variants, m, gram.fit(index[m_i]))
        fit = refine(every, cause, start)
        fits[m_i] = fit
        rss[m_i] = _refined_rss(every, cause, fit.theta, design.sigma)
    scores, probs = scores_of(rss, n_params, log_prior, gram.n, phis)
    best = int(np.argmax(probs))
    seconds["refinement"] = time.perf_counter() - t2
    if pairs and raw is not None and len(models[best]) == 2:
        # a second cause is judged against the records its first cause would make
        t3 = time.perf_counter()
        singles = [m_i for m_i in fits if len(models[m_i]) == 1 and models[m_i][0] in models[best]]
        first = max(singles, key=lambda m_i: probs[m_i]) if singles else None
        if first is not None:
            a = models[first][0]
            second = null_dispersion(ctx, raw, records, causes, design.coef, block, seed=seed + 1,
                                     under=fits[first])
            own = {i for i, v in enumerate(variants) if v.cause.id == variants[a].cause.id}
            for m_i, m in enumerate(models):
                if len(m) == 2 and own & set(m):
                    others = [i for i in m if i not in own]
                    phis[m_i] = max(phis[m_i], second["all"])
            scores, probs = scores_of(rss, n_params, log_prior, gram.n, phis)
            best = int(np.argmax(probs))
        seconds["second_dispersion"] = time.perf_counter() - t3
    inclusion, verdicts, keys = {}, {}, []
    for m, p in zip(models, probs):
        key = _verdict_id(variants, m)
        keys.append(key)
        verdicts[key] = verdicts.get(key, 0.0) + float(p)
        for cid in {variants[i].cause.id for i in m}:
            inclusion[cid] = inclusion.get(cid, 0.0) + float(p)
    # the verdict of highest posterior probability (summed over its variants), then its most probable model
    verdict = max(verdicts, key=verdicts.get)
    best = max((m_i for m_i, k in enumerate(keys) if k == verdict), key=lambda m_i: probs[m_i])
    if best not in fits and models[best]:
        cause = _model_cause(variants, models[best])
        fits[best] = refine(every, cause, _model_theta(variants, models[best], gram.fit(index[best])))
    named = models[best]
    cov = np.zeros((0, 0))
    if named:
        idx = index[best]
        try:
            # rows weighted by the baseline's residual RMS: unit variance, inflated by the dispersion
            cov = phis[best] * np.linalg.inv(gram.g[np.ix_(idx, idx)])
        except np.linalg.LinAlgError:
            cov = np.full((len(idx),) * 2, np.nan)
    out = Inference(models, scores, probs, variants, named, inclusion, verdicts,
                    gram.fit(index[best]), cov, float(phis[best]) if named else dispersion["all"],
                    int(gram.n), seconds)
    out.dispersions = dispersion
    out.fits = {models[i]: f for i, f in fits.items()}
    out.fit = fits.get(best)
    if out.fit is None:
        cause = _model_cause(variants, named)
        out.fit = refine(every, cause, _model_theta(variants, named, out.coefficients))
    return out


def _catalogue_order(cause_id: str) -> int:
    from .causes import CATALOGUE

    ids = list(CATALOGUE)
    return ids.index(cause_id) if cause_id in ids else len(ids)


# --------------------------------------------------------------- refinement

def _verdict_id(variants: list, model: tuple) -> str:
    """A model's verdict: its causes' ids joined by ``+`` in catalogue order, or ``none``."""
    if not model:
        return "none"
    return "+".join(sorted((variants[i].cause.id for i in model), key=_catalogue_order))


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
            res = least_squares(vector, theta, bounds=(low, high), x_scale="jac",
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


# --------------------------------------------------------------- intervals

def _leaves(params: dict, prefix=()) -> dict:
    out = {}
    for k, v in params.items():
        if isinstance(v, dict):
            out.update(_leaves(v, prefix + (k,)))
        elif v is not None:
            out[prefix + (k,)] = float(v)
    return out


def _nest(flat: dict) -> dict:
    out = {}
    for path, value in flat.items():
        node = out
        for key in path[:-1]:
            node = node.setdefault(key, {})
        node[path[-1]] = value
    return out


def _draw_parameters(inference: Inference, coefficients: np.ndarray) -> dict:
    """The named model's parameters (:meth:`Cause.parameters`) at linear coefficients."""
    cause = named_cause(inference)
    theta = _model_theta(inference.variants, inference.named, coefficients)
    fitted, col = dict(inference.fit.params), 0
    for i in inference.named:
        v = inference.variants[i]
        if isinstance(v.cause, MissingTerm):
            fitted[v.cause.params[0]] = float(coefficients[col])
        col += v.columns.shape[1]
    return _leaves(cause.parameters(theta, fitted))


def intervals(inference: Inference, level: float = 0.9, draws: int = 2000, seed: int = 0) -> dict:
    """Intervals (``level``, default 90 %) of the named model's parameters,
    shaped as :meth:`Cause.parameters` gives them (``[low, high]`` per value).

    The linear coefficients' covariance (the regression's, inflated by the
    dispersion) is sampled and mapped through the causes' parameters; the
    draws are centred on the refined estimate (the nonlinear refinement moves
    the value, not the spread). Directions are taken about the estimate, on
    the circle."""
    if not inference.named or inference.fit is None:
        return {}
    cov = np.asarray(inference.covariance, float)
    coef = np.asarray(inference.coefficients, float)
    if cov.shape != (len(coef), len(coef)) or not np.all(np.isfinite(cov)):
        return {}
    rng = np.random.default_rng(seed)
    cov = 0.5 * (cov + cov.T)
    w, vecs = np.linalg.eigh(cov)
    samples = coef + (rng.standard_normal((draws, len(coef))) * np.sqrt(np.maximum(w, 0.0))) @ vecs.T
    centre = _draw_parameters(inference, coef)
    refined = _leaves(inference.fit.cause.parameters(inference.fit.theta, inference.fit.params))
    values = {k: [] for k in centre}
    for s in samples:
        for k, v in _draw_parameters(inference, s).items():
            if k in values:
                values[k].append(v)
    tail = 50.0 * (1.0 - level)
    out = {}
    for k, vals in values.items():
        vals = np.asarray(vals, float)
        ref = refined.get(k, centre[k])
        if k[-1] == "direction":
            dev = np.angle(np.exp(1j * (vals - centre[k])))
            lo, hi = np.percentile(dev, [tail, 100.0 - tail])
            out[k] = [float((ref + lo) % (2 * np.pi)), float((ref + hi) % (2 * np.pi))]
        else:
            lo, hi = np.percentile(vals - centre[k], [tail, 100.0 - tail])
            out[k] = [float(ref + lo), float(ref + hi)]
    return _nest(out)
