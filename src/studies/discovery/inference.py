"""Discovery by one inference over the whole cause catalogue.

What the baseline misses is estimated once along the smoothed records, and
every cause of the catalogue is judged by how well it predicts stretches of
the records it was not fitted to; one criterion names the verdict, and the
share of resampled records for which the same criterion names it is its
confidence.

1. **States.** Every record (training and held out) is smoothed by the
   kinematic EKF/RTS smoother (:func:`studies.identification.kalman.ekf_derivatives`,
   no sensor-bias states: they would take a model's or a cause's error for
   drifting sensors); its accelerations are used as they are.
   (:func:`smooth_with_baseline` can also smooth with the identified
   baseline as process model, ``iterations`` > 0; measured, that pulls the
   states towards the baseline and shrinks every effect, so it is off.)
2. **Signatures.** For a cause with parameters ``theta`` (no effect at 0),
   the prime residual ``r(theta) = y(theta) - Theta(theta) c`` of the
   inverse-dynamics regression along the smoothed states changes by ``J
   theta`` to first order, with the baseline's coefficients ``c`` held. ``J``
   comes from the cause's own hooks (:class:`~studies.discovery.causes.base.Cause`:
   the records as the hydrodynamics saw them, the external forces) by
   central differences, so it holds for any baseline whose regression the
   cause protocol reaches (the Abkowitz models, the MMG model). It is exact
   for a missing term (the library's feature column), an earth-fixed bias
   and a propeller side force; first-order for a rudder offset and a
   current (``(speed cos dir, speed sin dir)`` as its linear parameters);
   a wind the records do not carry acts as the square of its speed, so it
   enters as the secant column of a reference wind from each of
   :data:`WIND_DIRECTIONS` directions.
3. **One comparison, on unseen blocks.** The records are cut into blocks of
   four correlation times of the error (:func:`_residual_tau`: of the
   baseline's residual, or of what the best-fitting variant of a cause
   leaves of it where shorter, so that a larger effect does not leave fewer
   blocks); every cause, with
   the baseline's columns projected out (:class:`_Residualised`), is fitted
   with one block left out and predicts that block
   (:mod:`studies.discovery.selection`); a cause with variants (a missing
   term, a wind direction) picks its variant on the other blocks. A cause's
   held-out gain is the fall in the held-out blocks' weighted residual sum of
   squares (half of it, a log-likelihood ratio over ``none``). Noise that
   the smoother took for signal, coloured or quantised sensor noise, or one
   manoeuvre's quirk does not repeat in another block, so it earns nothing.
4. **One criterion.** A cause is named when its held-out gain exceeds
   the quantile ``1 - FALSE_NAMING / causes`` of Student's t with one
   degree of freedom less than the blocks of its standard error over the
   blocks (Bonferroni: at most :data:`FALSE_NAMING` of records where nothing
   acts get a cause); among those, the one of largest gain less the log of
   its number of variants. A second cause is judged the same way on the
   records as the first cause's refined model leaves them. The Bayesian
   bootstrap over the blocks (Dirichlet weights) applies the same criterion
   to each draw: the share of draws that name a verdict is its probability,
   the named verdict's share its confidence, a cause's share its inclusion.
5. **Parameters.** Every single cause is refined by profiled nonlinear
   least squares from its linear solution (its parameters are reported
   whether named or not); the named verdict's intervals come from the
   jackknife over the blocks of its linear coefficients
   (:func:`intervals`). The held-out records then measure the gain (the
   workflow refits the named model on the training records for it); the gain
   is reported, it does not name anything.

Conventions as in :mod:`studies.discovery.causes.base`: angles in radians,
current direction where it flows to, wind direction where it comes from,
prime forces (thesis eq. 3.6).

References
----------
Rubin, D. B. (1981). The Bayesian bootstrap. Ann. Statist. 9(1), 130-134.
Arlot, S., Celisse, A. (2010). A survey of cross-validation procedures for
model selection. Statistics Surveys 4, 40-79.
"""

from __future__ import annotations

import copy
import logging
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from ..identification.filter_error import side_by_side
from ..identification.kalman import KalmanSettings, kalman_smooth, smoothed_record
from ..models.terms import DOFS
from .alike import signature_alike
from .look_alike import BlockSeparation, Detectability
from .causes import (Combined, Current, MissingTerm, WindUnmodelled, catalogue_order, extended_library,
                     manoeuvring_causes, pair_id)
from .causes.base import Cause, Setup
from .fitting import (CauseFit, Context, _score, integrated_time, kinematic_smoothing, regression_fit,
                      scored_fit, setup_problems)
from .selection import DRAWS, BlockGains, BlockGrams, bayesian_bootstrap, name_per_draw, row_blocks, t_values

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
    variants : list of Variant
    named : tuple
        The named model: indices of its variants (``()`` is ``none``).
    inclusion : dict
        ``{cause id: share of the bootstrap reweightings of the blocks whose verdict holds it}``.
    verdicts : dict
        ``{verdict id ("none", "current", "current+rudder_offset"): share of the bootstrap
        reweightings of the blocks that name it}``, most probable first.
    coefficients : ndarray
        The named model's linear coefficients of its variants' columns (every block).
    covariance : ndarray
        Their covariance (jackknife over the blocks).
    n_rows : int
    seconds : dict
        Time spent per stage [s].
    gains : dict
        ``{verdict: held-out gain}`` summed over the blocks (half the fall in the
        weighted residual sum of squares, a log-likelihood ratio over ``none``).
    beats_none : dict
        ``{cause: probability that it predicts unseen blocks better than none}``.
    threshold : float
        Standard errors of its held-out gain a cause needs to be named (:func:`_threshold`).
    evidence : dict
        ``{cause or pair: held-out gain over its standard error}`` on the records as
        measured (a pair's: its second cause's gain beside the first).
    second_threshold : float
        The same threshold for a second cause (NaN when none was judged).
    n_blocks : int
    block_seconds : float
        Duration of a block [s].

    Set by :func:`infer` besides: ``fits`` (``{model: CauseFit}``: the baseline,
    every single cause refined, the named model), ``fit`` (the named model's)
    and ``beside`` (``{cause id: CauseFit}``: each other cause refined beside
    a named single cause).
    """

    variants: list
    named: tuple
    inclusion: dict
    verdicts: dict
    coefficients: np.ndarray
    covariance: np.ndarray
    n_rows: int
    seconds: dict = field(default_factory=dict)
    gains: dict = field(default_factory=dict)
    beats_none: dict = field(default_factory=dict)
    threshold: float = float("nan")
    evidence: dict = field(default_factory=dict)
    second_threshold: float = float("nan")
    n_blocks: int = 0
    block_seconds: float = float("nan")
    #: the smallest probability a verdict's ranking score is taken from (one more than the
    #: bootstrap's draws for the block cross-validation)
    probability_floor: float = 1.0 / (DRAWS + 1)
    #: how alike every pair of causes' signatures is on these records (:func:`.alike.signature_alike`)
    alike: dict = field(default_factory=dict)
    #: the records' evidence between candidates (:mod:`.look_alike`): ``"first"`` between the
    #: single causes, ``"second"`` between the second causes beside the first
    separations: dict = field(default_factory=dict)
    #: ``{cause id: Detectability}``: each single cause's evidence over none and what naming needs
    detectability: dict = field(default_factory=dict)

    def verdict_of(self, model: tuple) -> str:
        """The verdict id of a model: its causes' ids joined by ``+`` in catalogue order, or ``none``."""
        return _verdict_id(self.variants, model)

    @property
    def confidence(self) -> float:
        """Share of the bootstrap reweightings of the blocks that name the named verdict."""
        return float(self.verdicts.get(self.verdict_of(self.named), 0.0))

    def ranking(self) -> list:
        """``[{"cause": verdict, "probability", "gain", "score"}]``, most probable first
        (probability: share of the bootstrap reweightings of the blocks that
        name it; gain: summed held-out log-likelihood gain over none; score:
        ``-2 ln`` of its probability relative to the most probable verdict,
        lower is better, a verdict no reweighting names taken as named by
        one more than there were)."""
        items = sorted(set(self.verdicts) | set(self.gains), key=lambda k: (-self.verdicts.get(k, 0.0),
                                                                            -self.gains.get(k, 0.0)))
        top = max(self.verdicts.values(), default=1.0)
        floor = self.probability_floor
        return [{"cause": k, "probability": float(self.verdicts.get(k, 0.0)),
                 "gain": float(self.gains.get(k, float("nan"))),
                 "score": float(-2.0 * np.log(max(self.verdicts.get(k, 0.0), floor) / top))} for k in items]


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
    # the records side by side: each record's smoother is compiled code that releases Python's lock
    current = side_by_side(lambda r: kinematic_smoothing(r, settings, rates=True), records)
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
    (:func:`studies.identification.kalman.smoothed_record`), ``attrs["smoothed"] = "ekf_model"``."""
    vessel = ctx.dynamics.vessel if ctx.dynamics is not None else ctx.vessel
    modules = ctx.dynamics.modules if ctx.dynamics is not None else None
    values = {n: params.get(n, 0.0) for n in ctx.model.names}
    out = smoothed_record(kalman_smooth(record, settings or SMOOTHER, ctx.model, values, vessel, modules), record)
    out.attrs["smoothed"] = "ekf_model"
    return out


def _baseline_setup(ctx: Context) -> Setup:
    return Setup(ctx.model, list(ctx.train), dynamics=ctx.dynamics)


def _with_dynamics(ctx: Context, setup: Setup) -> Setup:
    """The setup on the baseline's process model (the MMG model of an MMG
    baseline), unless its cause replaces it (``propulsion``: its own)."""
    if not (setup.cause is not None and setup.cause.replaces_dynamics):
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
    record: np.ndarray = None  # (N,) the record of each row (-1: prior rows)


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
    records = []
    for k, (y, theta, names, n, _, record, _) in enumerate(rows):
        x = np.zeros((len(y), n_cols))
        x[:, starts[k]:starts[k + 1]] = theta
        xs.append(x[:n] / sigma[k])
        ys.append(y[:n] / sigma[k])
        dofs.append(np.full(n, k))
        blocks.append(np.full(n, k))
        records.append(record)
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
                   np.concatenate([r / sigma[k] for k, r in enumerate(resid)]),
                   np.concatenate(records + [np.full(n_prior, -1)]))


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
    from ..identification.regression import prime_states

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
        self.x, self.y = x, y
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


def _tau(residual: np.ndarray, design: _Design) -> float:
    parts = np.split(residual, np.cumsum(design.n_data)[:-1])
    return max(integrated_time(r) for r in parts)


def _residual_tau(design: _Design, res: "_Residualised", models: list) -> float:
    """Correlation time [rows] of the error the blocks must hold apart: of the
    baseline's residual, or of what the best-fitting variant of a cause
    leaves of it where shorter. An effect that acts along the records
    lengthens the baseline's residual's correlation; blocks cut from it
    would shrink in number as the effect grows, and the standard error of
    the effect's gain would rest on fewer blocks the larger the effect. The
    residual a cause's fit leaves holds the noise and what no cause
    explains, not the effect (the error variance of a regression is taken
    from the larger model for the same reason)."""
    n = int(np.sum(design.n_data))
    taus = [_tau(design.residual, design)]
    for idx in models:
        left = res.y - res.x[:, idx] @ res.fit(idx)
        taus.append(_tau(left[:n], design))
    return min(taus)


#: family-wise probability of naming a cause (or a second one) that does not act: a cause is
#: named only when its held-out gain exceeds the one-sided ``1 - FALSE_NAMING / (causes
#: compared)`` quantile of Student's t of its standard error (Bonferroni over the causes)
FALSE_NAMING = 0.05


def _threshold(n_causes: int, n_blocks: int) -> float:
    """Standard errors a cause's held-out gain must exceed to be named: the
    one-sided quantile of ``1 - FALSE_NAMING / n_causes`` of Student's t
    with ``n_blocks - 1`` degrees of freedom (the standard error is the
    spread of that many blocks' gains)."""
    from scipy.stats import t

    return float(t.ppf(1.0 - FALSE_NAMING / max(n_causes, 1), max(int(n_blocks) - 1, 1)))


def _spans(variants: list) -> list:
    spans, col = [], 0
    for v in variants:
        spans.append(np.arange(col, col + v.columns.shape[1]))
        col += v.columns.shape[1]
    return spans


def _by_cause(variants: list, skip: str | None = None) -> dict:
    """``{cause id: [variant indices]}`` in catalogue order (``skip``: a cause id left out)."""
    out = {}
    for i, v in enumerate(variants):
        if v.cause.id != skip:
            out.setdefault(v.cause.id, []).append(i)
    return dict(sorted(out.items(), key=lambda kv: _catalogue_order(kv[0])))


def _best_variant(res: _Residualised, spans: list, indices: list) -> int:
    """The variant (of ``indices``) that fits every row best."""
    return min(indices, key=lambda i: float(np.sum(np.log(res.rss(spans[i])))))


def _jackknife(beta: np.ndarray) -> np.ndarray:
    """Covariance of coefficients from their leave-one-block-out fits ``beta`` (K, s)."""
    k = len(beta)
    dev = beta - beta.mean(axis=0)
    return (k - 1) / k * dev.T @ dev if k > 1 else np.full((beta.shape[1],) * 2, np.nan)


#: what the evidence between two causes is with block cross-validation (:mod:`.look_alike`)
BLOCK_SEPARATION = ("paired held-out gain of the named cause over the rival, block by block, over its standard "
                    "error (the naming statistic)")


def infer(ctx: Context, records: list | None = None, causes: list | None = None, pairs: bool = True,
          seed: int = 0) -> Inference:
    """Name the verdict that predicts unseen stretches of the records (module docstring).

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
        Judge a second cause beside the first.
    seed : int
        Seed of the Bayesian bootstrap.
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

    # 1. every cause alone against none, each judged on blocks it was not fitted to
    t1 = time.perf_counter()
    spans = _spans(variants)
    columns = np.hstack([v.columns for v in variants]) if variants else np.zeros((len(design.y), 0))
    res = _Residualised(design, columns)
    n_data = int(np.sum(design.n_data))
    alike = signature_alike(variants, [res.x[:n_data, s] for s in spans])
    singles = _by_cause(variants)
    chosen = {cid: _best_variant(res, spans, idx) for cid, idx in singles.items()}
    block_rows = max(20, int(4 * _residual_tau(design, res, [spans[i] for i in chosen.values()])))
    blocks = row_blocks(design.record, design.dof, block_rows)
    grams = BlockGrams(res.x, res.y, blocks)
    gains = BlockGains.of(grams, {cid: [spans[i] for i in idx] for cid, idx in singles.items()})
    seconds["comparison"] = time.perf_counter() - t1

    # every single cause refined (its parameters are reported as candidates, named or not); a
    # cause that is not linear in its parameters is judged at its refined fit
    t2 = time.perf_counter()
    fits = {(): baseline_fit(every)}
    for j, (cid, idx) in enumerate(singles.items()):
        i = chosen[cid]
        fits[(i,)] = refine(every, variants[i].cause, _model_theta(variants, (i,), res.fit(spans[i])))
        if not isinstance(variants[i].cause, MissingTerm):
            refined = _refined_gains(every, fits[(i,)], design, variants[i].columns, blocks, grams.yyk)
            if refined is not None:
                gains.held[j] = refined
    seconds["refinement"] = time.perf_counter() - t2

    weights = np.vstack([np.ones(grams.n_blocks), bayesian_bootstrap(grams.n_blocks, seed=seed)])
    threshold = _threshold(len(gains.ids), grams.n_blocks)
    ids = np.array(["none"] + list(gains.ids), dtype=object)
    draw_verdict = ids[name_per_draw(gains.held, weights, threshold,
                                     np.log([len(singles[cid]) for cid in gains.ids])) + 1]
    first = None if draw_verdict[0] == "none" else str(draw_verdict[0])
    beats_none = dict(zip(gains.ids, np.mean(weights[1:] @ gains.held.T > 0.0, axis=0).tolist()))
    evidence = dict(zip(gains.ids, t_values(gains.held).tolist()))
    separations = {"first": BlockSeparation(list(gains.ids), threshold, BLOCK_SEPARATION, held=gains.held.copy())}
    t5 = time.perf_counter()
    detectability = {cid: Detectability(float(evidence[cid]), threshold, 1,
                                        factor=_limit_factor(res, blocks, spans[chosen[cid]], threshold))
                     for cid in gains.ids}
    seconds["detection_limits"] = time.perf_counter() - t5

    # 2. a second cause beside the first, judged the same way on the first's refined model
    named, held2, threshold2 = (), None, float("nan")
    if first is not None:
        i_first = chosen[first]
        named = (i_first,)
        others = _by_cause(variants, skip=first)
        if pairs and others:
            t3 = time.perf_counter()
            fit1 = fits[named]
            design2 = _design(every, _with_dynamics(every, fit1.cause.setup(every, fit1.theta)), design.sigma)
            if len(design2.y) == len(design.y):
                # the same blocks as the first cause's (shorter ones, from the residual the first
                # cause leaves, take the MMG model's slow errors on real records for a second cause)
                res2 = _Residualised(design2, columns)
                grams2 = BlockGrams(res2.x, res2.y, blocks)
                # the first cause's columns are fitted again beside each second cause's, so that what
                # the first took of the second's effect when fitted alone is given back
                own = spans[i_first]
                held2 = BlockGains.of(grams2, {cid: [np.concatenate([own, spans[i]]) for i in idx]
                                               for cid, idx in others.items()})
                held2.held = held2.held - grams2.folds(own[None]).held[:, 0][None, :]
                evidence.update({_pair_id(first, cid): t for cid, t in zip(held2.ids, t_values(held2.held))})
                threshold2 = _threshold(len(held2.ids), grams.n_blocks)
                separations["second"] = BlockSeparation(list(held2.ids), threshold2, BLOCK_SEPARATION,
                                                        held=held2.held.copy())
                extended = np.array([first] + [_pair_id(first, cid) for cid in held2.ids], dtype=object)
                pick2 = extended[name_per_draw(held2.held, weights, threshold2,
                                               np.log([len(others[cid]) for cid in held2.ids])) + 1]
                draw_verdict = np.where(draw_verdict == first, pick2, draw_verdict)
                if pick2[0] != first:
                    second = next(cid for cid in held2.ids if _pair_id(first, cid) == pick2[0])
                    i_second = _best_variant(res2, spans, others[second])
                    named = (i_first, i_second)
                    start = _joined_theta(variants, named, {
                        i_first: fit1.theta, i_second: variants[i_second].to_theta(res2.fit(spans[i_second]))})
                    fits[named] = refine(every, _model_cause(variants, named), start)
            seconds["second_cause"] = time.perf_counter() - t3

    draw_verdict = draw_verdict[1:]
    verdicts = {}
    for v in draw_verdict:
        verdicts[v] = verdicts.get(v, 0) + 1
    verdicts = {k: n / len(draw_verdict) for k, n in sorted(verdicts.items(), key=lambda kv: -kv[1])}
    inclusion = {}
    for k, p in verdicts.items():
        for cid in k.split("+"):
            if cid != "none":
                inclusion[cid] = inclusion.get(cid, 0.0) + p
    named = _most_probable(variants, named, verdicts, chosen, fits)
    index = np.concatenate([spans[i] for i in named]) if named else np.zeros(0, int)
    coefficients = res.fit(index)
    covariance = _jackknife(grams.folds(index[None]).beta[:, 0, :]) if named else np.zeros((0, 0))
    mean_gain = {"none": 0.0, **{cid: float(np.sum(gains.held[j])) for j, cid in enumerate(gains.ids)}}
    if held2 is not None:
        for j, cid in enumerate(held2.ids):
            mean_gain[_pair_id(first, cid)] = mean_gain[first] + float(np.sum(held2.held[j]))
    out = Inference(variants, named, inclusion, verdicts, coefficients, covariance, int(res.n), seconds,
                    gains=mean_gain, beats_none=beats_none, threshold=threshold,
                    evidence=evidence, second_threshold=threshold2,
                    n_blocks=grams.n_blocks, block_seconds=_block_seconds(records, design, block_rows),
                    alike=alike, separations=separations, detectability=detectability)
    out.fits = fits
    out.fit = fits.get(named)
    out.beside = {}
    if len(named) == 1:
        # what every other cause would be beside the named one (refined together)
        t4 = time.perf_counter()
        for cid, i in chosen.items():
            if i == named[0]:
                continue
            pair = (named[0], i)
            start = _joined_theta(variants, pair, {named[0]: fits[named].theta, i: fits[(i,)].theta})
            out.beside[cid] = refine(every, _model_cause(variants, pair), start)
        seconds["beside"] = time.perf_counter() - t4
    return out


def _limit_factor(res: "_Residualised", blocks: np.ndarray, index: np.ndarray, threshold: float) -> float | None:
    """The size, as a multiple of the cause's linear fit on the records, at which the
    cause added to the records without it would just be named: its fitted effect
    ``e = X b`` taken out of the residualised target and put back ``s`` times,
    ``s`` raised until the held-out gain of its columns (leave-one-block-out) is
    ``threshold`` standard errors (:func:`.selection.t_values`). Defined whatever
    the records' own evidence for the cause (which may be none); None when the fit
    is exactly zero or no size up to a thousand times it is named."""
    x = res.x[:, index]
    beta = res.fit(index)
    effect = x @ beta
    if not np.any(effect):
        return None
    columns = np.arange(len(index))[None]
    # the blocks' Gram matrices once: their right-hand sides are linear in the size
    base = BlockGrams(x, res.y - effect, blocks)
    added = BlockGrams(x, effect, blocks)
    grams = copy.copy(base)

    def t_at(size: float) -> float:
        grams.b = base.b + size * added.b
        grams.bk = base.bk + size * added.bk
        held = grams.folds(columns).held[:, 0]
        return float(t_values(held[None])[0])

    low, high = 0.0, 1.0
    while t_at(high) < threshold:
        low, high = high, 2.0 * high
        if high > 1e3:
            return None
    for _ in range(30):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if t_at(mid) < threshold else (low, mid)
    return float(high)


def _most_probable(variants: list, named: tuple, verdicts: dict, chosen: dict, fits: dict) -> tuple:
    """The verdict the reweightings name most often, as a model: the headline is the
    most probable verdict, not the one the records as measured happen to name. A
    pair whose fit was not refined (its first cause is not the measured verdict's) is
    left to the measured verdict."""
    if not verdicts:
        return named
    top = max(verdicts, key=verdicts.get)
    if top == _verdict_id(variants, named) or verdicts[top] <= verdicts.get(_verdict_id(variants, named), 0.0):
        return named
    if top == "none":
        return ()
    if "+" not in top and top in chosen and (chosen[top],) in fits:
        return (chosen[top],)
    return named


def _refined_gains(ctx: Context, fit: CauseFit, design: _Design, columns: np.ndarray, blocks: np.ndarray,
                   none_held: np.ndarray) -> np.ndarray | None:
    """A cause's held-out gain per block at its refined (nonlinear) fit: the
    fall from ``none``'s held-out sum of squares (``none_held``, per block) to
    the refined model's, whose parameters are moved, to first order along the
    cause's signature ``columns``, to their fit without the block; None when
    the refined model's rows differ from the design's."""
    refined = _design(ctx, _with_dynamics(ctx, fit.cause.setup(ctx, fit.theta)), design.sigma)
    if len(refined.y) != len(design.y) or not columns.shape[1]:
        return None
    res = _Residualised(refined, columns)
    grams = BlockGrams(res.x, res.y, blocks)
    return 0.5 * (none_held - grams.yyk) + grams.folds(np.arange(columns.shape[1])[None]).held[:, 0]


_pair_id = pair_id


def _block_seconds(records: list, design: _Design, block_rows: int) -> float:
    """Duration of a block [s] (rows of the first DOF over the records' time span)."""
    rows = design.n_data[0]
    span = sum(float(r["t"].iloc[-1] - r["t"].iloc[0]) for r in records if "t" in r and len(r) > 1)
    return float(block_rows * span / rows) if rows else float("nan")


_catalogue_order = catalogue_order


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
    cols = _spans([variants[i] for i in model])
    return _joined_theta(variants, model, {i: variants[i].to_theta(coefficients[c]) for i, c in zip(model, cols)})


def _joined_theta(variants: list, model: tuple, thetas: dict) -> np.ndarray:
    """A model's ``theta`` from each of its variants' own (``{variant index: theta}``), in catalogue order."""
    parts = [np.atleast_1d(thetas[model[j]]) for j in _ordered(variants, model)]
    return np.concatenate(parts) if parts else np.zeros(0)


def named_cause(inference: Inference) -> Cause | None:
    """The named model as one cause (a :class:`Combined` for a pair), in catalogue order."""
    return _model_cause(inference.variants, inference.named)


def refine(ctx: Context, cause: Cause, start: np.ndarray, max_nfev: int = 40) -> CauseFit:
    """Profiled nonlinear least squares of ``cause``'s parameters from ``start``
    (the linear solution), the baseline's coefficients re-identified at every
    trial (the profile least squares of the cause's parameters, the regression inside)."""
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
    fit = fit_at(ctx, cause, theta)
    fit.seconds = time.perf_counter() - t0
    return fit


def fit_at(ctx: Context, cause: Cause, theta: np.ndarray, terms: dict | None = None) -> CauseFit:
    """``cause`` at ``theta`` with the coefficients of the smoothed records'
    regression (``terms``: values of added terms estimated elsewhere, which
    replace the regression's), scored on its residuals."""
    setup = _with_dynamics(ctx, cause.setup(ctx, np.asarray(theta, float)))
    params, residuals, _ = scored_fit(ctx, setup)
    params = {**params, **(terms or {})}
    rss = np.array([float(np.sum(r ** 2)) for r in residuals])
    fit = CauseFit(cause, np.asarray(theta, float), params, rss, setup=setup,
                   tau=max(integrated_time(r) for r in residuals))
    fit.score = _score(ctx, rss, cause.n_params())
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

    The linear coefficients' covariance (the
    jackknife over the blocks) is sampled and mapped through the causes' parameters; the
    draws are centred on the refined estimate (the nonlinear refinement moves
    the value, not the spread). Directions are taken about the estimate, on
    the circle."""
    if not inference.named or inference.fit is None or inference.fit.cause.replaces_dynamics:
        return {}          # a replaced process model: its coefficients come from its own regression
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
