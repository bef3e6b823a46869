"""The baseline's one-step-ahead prediction errors along the measured tracks,
and how every cause of the catalogue would change them.

An extended Kalman filter whose process model is the baseline (the
simulator's own right-hand side, :mod:`studies.identification.filter_error`)
predicts every sample of every record from the samples before it; white
process noise on ``du, v, r`` (its shape and scale by maximum likelihood)
absorbs what no model holds. The baseline's coefficients, the process
noise and the measurement noise are fitted to the tracks
(:func:`baseline_on_tracks`, :meth:`FilterScores.estimate_shape`). The
standardised innovations (innovation ``e`` over its standard deviation
``sqrt(S)``, six channels ``x0, y0, psi, u, v, r`` per sample) are white
and of unit variance when the model is right. The residuals ``w`` every
model is fitted and judged by are those and, per channel, ``sqrt(ln(S /
R))`` (:meth:`~studies.identification.filter_error.PredictionError.deviance_residuals`):
``|w|^2`` is the whole ``-2 ln L`` less a constant of the filter. The
variances ``S`` depend on the model (its damping propagates the state's
covariance); without their ``ln S`` a model that predicts no better but
lets the filter expect larger errors lowers the squared standardised
innovations, and on records with a process noise correlated over seconds
a missing term that weakens the yaw damping in the turn (``Nuur``) was
named with nothing hidden, its likelihood ratio 29 on the standardised
innovations, 8 on the whole likelihood. A cause is judged on the tracks
themselves, where a 0.1 m position carries what a noisy acceleration does
not. A cause with
parameters ``theta`` changes them by ``J theta`` to first order; the
baseline's coefficients ``beta`` by ``J_beta d_beta``. The linear
regression of ``w`` on those columns, the coefficients' columns projected
out (:func:`judge`), chooses each cause's variant and starts its fit
(:mod:`.track_inference` fits every model to the tracks before judging it).

Columns (:func:`cause_variants`), each from the cause's own hooks
(:class:`~studies.discovery.causes.base.Cause`: the records as the cause reads
them, its wind, current and external forces), by central differences of the
filter's innovations at no effect: exact to first order for a missing term
(one library term's coefficient), an earth-fixed force, a propeller side
force, a rudder offset and a current (its north and east components); a wind
the records do not carry acts as the square of its speed, so it enters as the
secant of a :data:`~studies.discovery.inference.WIND_REFERENCE` wind from each
of :data:`~studies.discovery.inference.WIND_DIRECTIONS`.

Noise the filter does not model (sensor noise correlated over seconds,
velocities differenced from positions) leaves the innovations correlated,
and their likelihood ratio then overstates the evidence. Two things keep
the filter's reading of the records right (:func:`innovation_design`):

- velocities derived from the track (:func:`.kinematics.derived_velocities`:
  a satellite receiver's differenced positions) are not measured: their
  noise is a filtered copy of the track's, which the filter would weigh
  twice and follow with a large process noise; the filter infers them from
  the track and heading, and the track has no drift of its own then;
- records whose velocity noise is coloured
  (:func:`.kinematics.coloured_velocity_noise`) are filtered at a step long
  enough for the innovations to be nearly independent
  (:func:`filter_setting`).

Each comparison also gives a Wald statistic with the coefficients'
covariance robust to the correlation left within :data:`BLOCK_SECONDS`
blocks of each record (the sandwich of Liang & Zeger 1986, the blocks as
clusters); the evidence a cause is credited with is the smaller of the two
(:func:`judge`).

References
----------
Jategaonkar, R.V. (2015). Flight vehicle system identification, 2nd ed.
AIAA, ch. 5 (filter error method).

Liang, K.-Y., Zeger, S. L. (1986). Longitudinal data analysis using
generalized linear models. Biometrika 73(1), 13-22.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from ..identification.filter_error import filter_all
from .causes import Combined, Current, MissingTerm, WindUnmodelled, extended_library
from .causes.base import Cause
from .fitting import CauseFit, Context
from .kinematics import coloured_velocity_noise, derived_velocities
from .noise_levels import noise_levels
from .prediction_error import FilterScores

__all__ = ["BLOCK_SECONDS", "FILTER_STEP", "InnovationDesign", "Judgement", "innovation_design", "beside", "robust_wald",
           "own_columns", "cause_variants", "judge", "cause_steps"]

log = logging.getLogger(__name__)

#: sampling [s] the records are averaged to before filtering (block means)
FILTER_STEP = 1.0
#: longest filter step, as a share of the ship's time unit L / U0 (records with coloured noise)
MAX_STEP_PER_TIME_UNIT = 0.25
#: length [s] of the stretches of a record over which innovations may be correlated
#: (the clusters of the robust covariance)
BLOCK_SECONDS = 60.0
#: the filter's process noise on du, v, r coloured, its correlation time estimated (FilterScores)
COLOURED_PROCESS_NOISE = True
#: the same on the MMG baseline: off (on the MARIN KVLCC2 records its disturbance states took up
#: part of an injected rudder offset, whose fitted value then moved by 3.8 deg for 1 deg injected,
#: and no verdict on those records came right; docs/discovery.md)
MMG_COLOURED = False
#: relative step of the coefficients' finite differences
COEFFICIENT_STEP = 1e-3
#: step of a missing term's coefficient [-, prime]
TERM_STEP = 1e-4
#: rounds of the baseline's fit to the tracks (noises estimated, then the coefficients)
BASELINE_ROUNDS = 2
#: least-squares evaluations of the baseline's coefficients per round
BASELINE_EVALUATIONS = 6


@dataclass
class InnovationDesign:
    """The baseline's standardised innovations on every record and what re-identifying
    its coefficients can do to them.

    Attributes
    ----------
    residual : ndarray (N,)
        The baseline's deviance residuals (records one after the other, per
        sample six standardised innovations then six ``sqrt(ln(S / R))``;
        zero where a channel is not measured): ``|residual|^2`` is ``-2 ln
        L`` less a constant of the filter.
    basis : ndarray (N, p)
        Orthonormal basis of their Jacobian with respect to the baseline's coefficients.
    projected : ndarray (N,)
        ``residual`` with that basis projected out (the baseline re-identified on the tracks).
    coefficient_jacobian : ndarray (N, p)
        d innovations / d (relative change of each coefficient).
    blocks : ndarray (N,) of int
        Cluster of every innovation (:data:`BLOCK_SECONDS` stretches of one record).
    n : int
        Measured innovations (the ``n`` of the BIC).
    log_q_scale : float
        log10 of the process noise's scale, the likeliest for the baseline.
    fit : CauseFit
        The baseline (coefficients from the smoothed records' regression).
    scorer : FilterScores
        The filter on the records, its process noise's shape and measurement noise estimated.
    """

    residual: np.ndarray
    basis: np.ndarray
    projected: np.ndarray
    coefficient_jacobian: np.ndarray
    blocks: np.ndarray
    n: int
    log_q_scale: float
    fit: CauseFit
    scorer: FilterScores
    ctx: Context
    #: ``(cause, theta, terms)`` acting beneath every cause judged (a first cause
    #: when a second is judged beside it); None: the baseline alone
    base: tuple | None = None
    #: the coefficients' scales of ``coefficient_jacobian`` (its columns are relative changes)
    coefficient_scale: np.ndarray | None = None

    @property
    def coefficient_names(self) -> list:
        return [t.name for t in self.fit.setup.model.terms]

    def coefficients_at(self, relative: np.ndarray) -> dict:
        """The fit's coefficients changed by ``relative`` times :attr:`coefficient_scale`."""
        out = dict(self.fit.params)
        for name, x, s in zip(self.coefficient_names, relative, self.coefficient_scale):
            out[name] = out.get(name, 0.0) + float(x) * float(s)
        return out

    @property
    def n_blocks(self) -> int:
        return int(self.blocks.max()) + 1 if len(self.blocks) else 0

    def project(self, columns: np.ndarray) -> np.ndarray:
        """``columns`` with the coefficients' directions projected out."""
        return columns - self.basis @ (self.basis.T @ columns)

    def innovations(self, cause: Cause, theta, extra: dict | None = None,
                    coefficients: dict | None = None) -> np.ndarray:
        """Standardised innovations of the baseline's coefficients (and ``extra``
        ones, e.g. an added term's) with ``cause`` acting at ``theta`` (beside
        :attr:`base`, if any; ``cause`` None: the base alone); ``coefficients``
        replace the baseline's."""
        like, vector = self.likelihood_of(cause, theta, extra, coefficients)
        return like.deviance_residuals(vector, self.log_q_scale)

    def innovations_many(self, models: list) -> list:
        """:meth:`innovations` of every ``(cause, theta, extra)`` or ``(cause,
        theta, extra, coefficients)`` of ``models``, their filters run side by
        side (:func:`filter_all`)."""
        built = [self.likelihood_of(*model) for model in models]
        done = filter_all([(like, vector, self.log_q_scale) for like, vector in built])
        return [like.deviance_of(results) for (like, _), results in zip(built, done)]

    def likelihood_of(self, cause: Cause, theta, extra: dict | None = None,
                      coefficients: dict | None = None) -> tuple:
        """``(PredictionError, coefficient vector)`` of the model whose
        :meth:`innovations` these are (arguments as there); its filter runs at
        :attr:`log_q_scale`."""
        theta = np.asarray(theta, float)
        if self.base is not None:
            first, first_theta, first_terms = self.base
            extra = {**first_terms, **(extra or {})}
            if cause is None:
                cause, theta = first, np.asarray(first_theta, float)
            else:
                cause = Combined(first, cause)
                theta = np.concatenate([np.asarray(first_theta, float), theta])
        # the filter replays the thinned records itself (FilterScores._plans): the cause's model is
        # all it needs here, not the training records transformed
        setup = cause.setup(self.scorer.bare, theta)
        fit = replace(self.fit, cause=cause, theta=theta, setup=setup)
        params = dict(self.fit.params if coefficients is None else coefficients)
        params.update(extra or {})
        return self.scorer._likelihood(fit), setup.model.vector(params, 0.0)


def beside(design: InnovationDesign, cause: Cause, theta: np.ndarray, terms: dict,
           coefficients: dict | None = None) -> InnovationDesign:
    """The design with ``cause`` acting at ``theta`` (``terms``: its added terms'
    coefficients) beneath every cause judged, the model's ``coefficients``
    (default the baseline's) in place of the baseline's, the process noise's
    scale the likeliest for that model: its residual is the innovations of
    that model, the coefficients' directions (their Jacobian) taken again
    under that filter."""
    fit = design.fit if coefficients is None else replace(design.fit, params=dict(coefficients))
    out = replace(design, base=(cause, np.asarray(theta, float), dict(terms)), fit=fit)
    # the process noise's scale the likeliest with the cause acting: the baseline's took up the
    # cause's effect as drift and would let the filter follow a second cause's too
    theta = np.asarray(theta, float)
    setup = cause.setup(design.scorer.bare, theta)
    acting = replace(fit, cause=cause, theta=theta, setup=setup)
    like = design.scorer._likelihood(acting)
    beta = setup.model.vector({**fit.params, **terms}, 0.0)
    _, out.log_q_scale = like.fit(beta)
    r = like.deviance_residuals(beta, out.log_q_scale)
    # the coefficients' directions under this filter (its process noise is not the baseline's): the
    # baseline's coefficients' columns of the acting model's Jacobian
    idx = [setup.model.names.index(n) for n in design.coefficient_names]
    jac = coefficient_jacobian(like, beta, out.log_q_scale, r)[:, idx]
    out.coefficient_jacobian, out.coefficient_scale = jac, np.maximum(np.abs(beta[idx]), 1e-6)
    out.basis = _orthonormal(jac)
    out.residual = r
    out.projected = r - out.basis @ (out.basis.T @ r)
    return out


def own_columns(design: InnovationDesign, steps: np.ndarray) -> np.ndarray:
    """``-d w / d`` (the base cause's parameters, then its added terms'
    coefficients) at the base: the first cause re-fitted beside a second."""
    cause, theta, terms = design.base
    theta = np.asarray(theta, float)
    low, high = cause.bounds(design.ctx) if len(theta) else (theta, theta)
    cols = []
    for j, h in enumerate(steps):
        # central differences, one-sided at a bound (a current of nearly no speed)
        plus, minus = theta.copy(), theta.copy()
        plus[j] = min(theta[j] + h, high[j])
        minus[j] = max(theta[j] - h, low[j])
        span = plus[j] - minus[j]
        if span <= 0.0:
            cols.append(np.zeros(len(design.residual)))
            continue
        cols.append(-(_alone(design, cause, plus, terms) - _alone(design, cause, minus, terms)) / span)
    for name in terms:
        bumped = {**terms, name: terms[name] + TERM_STEP}
        cols.append(-(_alone(design, cause, theta, bumped) - design.residual) / TERM_STEP)
    return np.column_stack(cols) if cols else np.zeros((len(design.residual), 0))


def _alone(design: InnovationDesign, cause: Cause, theta: np.ndarray, terms: dict) -> np.ndarray:
    return replace(design, base=None).innovations(cause, theta, terms)


def innovation_design(ctx: Context, records: list, baseline: CauseFit, step: float | None = None,
                      block_seconds: float = BLOCK_SECONDS, coloured: bool | None = None,
                      noises: FilterScores | None = None) -> InnovationDesign:
    """The baseline's filter on ``records`` (measured, not smoothed).

    ``ctx`` gives the vessel and the baseline (the polynomial model, or the
    MMG model when ``ctx.dynamics`` holds it: the filter's process model is
    then the MMG model, :mod:`studies.identification.mmg_filter`); ``baseline`` its
    coefficients. The measurement noise per channel is the records' noise at
    the filter's step (:func:`studies.discovery.noise_levels.noise_levels`);
    the process noise's shape and both noises' levels are then estimated by
    maximum likelihood under the baseline (:meth:`FilterScores.estimate_shape`).

    The filter's likelihood counts its standardised innovations as
    independent; what the records' sensors are decides how it reads them
    (:func:`filter_setting`, unless ``step`` is given): velocities derived
    from the track are not measured (the filter infers them from the track),
    and records whose velocity noise is coloured are filtered at a step long
    enough for the innovations to be nearly independent.

    ``coloured``: whether the process noise may be coloured (white or
    coloured by likelihood); default :data:`COLOURED_PROCESS_NOISE` on a
    polynomial baseline, white on the MMG baseline (:data:`MMG_COLOURED`).

    ``noises``: another filter of the same records whose estimated noises
    (measurement variances, process-noise densities, correlation time) start
    this one's search instead of the records' noise levels (the likelihood
    over the noises has more than one maximum; two filters compared on the
    same records are each taken at their best from both starts,
    :func:`.track_inference.propulsion_on_tracks`).
    """
    if coloured is None:
        coloured = COLOURED_PROCESS_NOISE and (ctx.dynamics is None or MMG_COLOURED)
    rctx = Context(ctx.vessel, ctx.model, list(records), [], "recorded", dynamics=ctx.dynamics)
    velocities = not derived_velocities(records)
    if step is None:
        step = FILTER_STEP
        if coloured_velocity_noise(records):
            step = filter_setting(ctx, records, step, _plain_innovations(rctx, records, baseline, step, velocities))
    scorer, fit, like, log_q, r0 = _baseline_filtered(rctx, records, baseline, step, velocities, coloured, noises)
    log.info("innovations: filter step %.2f s, velocities %s", scorer.step,
             "measured" if velocities else "derived from the track, not measured")
    return _design_of(rctx, fit, scorer, like, log_q, r0, block_seconds)


def _plain_innovations(rctx: Context, records: list, baseline: CauseFit, step: float,
                       velocities: bool) -> np.ndarray:
    """The baseline's standardised innovations at ``step`` with the records'
    noise levels as measured and the process noise's default shape at its
    likeliest scale: how correlated the sensors' noise looks before the
    noises are fitted (fitted, a noise correlated over seconds is taken up
    as process noise and the track's drift, and the innovations look white)."""
    scorer = FilterScores(rctx, step, noise_levels(rctx, records, step), drift=velocities, velocities=velocities)
    beta = baseline.setup.model.vector(baseline.params, 0.0)
    like = scorer._likelihood(baseline)
    _, log_q = like.fit(beta)
    return like.residuals(beta, log_q)


def filter_setting(ctx: Context, records: list, step: float, residual: np.ndarray) -> float:
    """The filter's step [s] for records whose velocity noise is coloured
    (:func:`.kinematics.coloured_velocity_noise`; otherwise ``step``, the
    filter's at ``residual``): twice the e-folding time of the standardised
    innovations' lag-one autocorrelation ``rho`` at ``step`` (``-step / ln
    rho``, the median over the measured channels; a first-order
    autoregression's block means over twice its time are correlated by about
    0.2), at most :data:`MAX_STEP_PER_TIME_UNIT` of the ship's time unit
    ``L / U0``, where the filter's one integration step per sample stays
    accurate. ``residual``: the baseline's standardised innovations, six
    channels per sample, zero where not measured."""
    if not coloured_velocity_noise(records):
        return step
    w = residual.reshape(-1, 6)
    rhos = []
    for j in range(6):
        x = w[:, j]
        x = x[x != 0.0]
        if len(x) > 10:
            rhos.append(float(np.corrcoef(x[:-1], x[1:])[0, 1]))
    rho = float(np.median(rhos)) if rhos else 0.0
    if not 0.0 < rho < 1.0:
        return step
    cap = MAX_STEP_PER_TIME_UNIT * float(ctx.vessel.length) / float(ctx.vessel.speed)
    return float(min(max(step, 2.0 * step / -np.log(rho)), max(cap, step)))


def _baseline_filtered(rctx: Context, records: list, baseline: CauseFit, step: float,
                       velocities: bool, coloured: bool = COLOURED_PROCESS_NOISE,
                       noises: FilterScores | None = None) -> tuple:
    """The baseline's filter on the records at ``step``, its coefficients
    fitted to the tracks (:func:`baseline_on_tracks`): ``(scorer, fit,
    likelihood, log10 process-noise scale, standardised innovations)``;
    ``noises`` another filter whose estimated noises start the search
    (:func:`innovation_design`)."""
    # the track's drift from the integral of the velocities is a disagreement between two sensors:
    # with the velocities not measured there is none (it would take the place of the dynamics)
    scorer = FilterScores(rctx, step, noise_levels(rctx, records, step), drift=velocities, velocities=velocities,
                          coloured=coloured)
    if noises is not None and noises.q_shape is not None:
        scorer.R, scorer.q_shape = noises.R.copy(), noises.q_shape.copy()
        scorer.tau = noises.tau if coloured else 0.0
    fit = baseline_on_tracks(scorer, baseline)
    # white or coloured process noise decided again under the coefficients fitted to the tracks
    scorer.estimate_shape(fit, rounds=1, decide=True)
    beta0 = fit.setup.model.vector(fit.params, 0.0)
    like = scorer._likelihood(fit)
    _, log_q = like.fit(beta0)
    return scorer, fit, like, log_q, like.deviance_residuals(beta0, log_q)


def coefficient_jacobian(like, beta: np.ndarray, log_q: float, r0: np.ndarray | None = None) -> np.ndarray:
    """d (deviance residuals) / d (relative change of each coefficient)
    at ``beta`` (forward differences of :data:`COEFFICIENT_STEP`; ``r0`` the
    innovations at ``beta`` if known)."""
    r0 = like.deviance_residuals(beta, log_q) if r0 is None else r0
    scale = np.maximum(np.abs(beta), 1e-6)
    bumped = []
    for j in range(len(beta)):
        b = beta.copy()
        b[j] += COEFFICIENT_STEP * scale[j]
        bumped.append((like, b, log_q))
    # every column's filter runs side by side
    jac = np.empty((len(r0), len(beta)))
    for j, results in enumerate(filter_all(bumped)):
        jac[:, j] = (like.deviance_of(results) - r0) / COEFFICIENT_STEP
    return jac


def baseline_on_tracks(scorer: FilterScores, baseline: CauseFit, rounds: int = BASELINE_ROUNDS,
                       max_nfev: int = BASELINE_EVALUATIONS) -> CauseFit:
    """The baseline's coefficients fitted to the measured tracks: the
    filter-error method (Jategaonkar 2015, ch. 5), SciPy's trust-region least
    squares of the filter's deviance residuals (``-2 ln L``) with the process and
    measurement noise held, then both noises estimated again
    (:meth:`FilterScores.estimate_shape`), ``rounds`` times.

    The smoothed records' regression only starts it. Its coefficients are
    those of states smoothed from sensors whose errors the smoother does not
    know (velocities derived from the track, coloured noise): on a record
    whose velocities were differenced from satellite positions its sway and
    yaw derivatives came out with the wrong sign, and the filter then needed
    a process noise that hid every cause. The causes are judged against the
    coefficients that predict the tracks best."""
    model = baseline.setup.model
    names = [t.name for t in model.terms]
    fit = baseline
    for _ in range(rounds):
        scorer.estimate_shape(fit, rounds=1)
        like = scorer._likelihood(fit)
        beta0 = model.vector(fit.params, 0.0)
        _, log_q = like.fit(beta0)
        scale = np.maximum(np.abs(beta0), 1e-6)

        def residuals(x):
            return like.deviance_residuals(beta0 + x * scale, log_q)

        def jacobian(x):
            beta = beta0 + x * scale
            # d w / d x: the relative changes of the coefficients at beta0's scale
            return coefficient_jacobian(like, beta, log_q) * (scale / np.maximum(np.abs(beta), 1e-6))

        r0 = residuals(np.zeros(len(beta0)))
        res = least_squares(residuals, np.zeros(len(beta0)), jac=jacobian, method="trf", max_nfev=max_nfev)
        if not float(res.fun @ res.fun) < float(r0 @ r0):
            break
        beta = beta0 + res.x * scale
        fit = replace(fit, params={**fit.params, **dict(zip(names, beta.tolist()))})
    return fit


def _design_of(rctx: Context, baseline: CauseFit, scorer: FilterScores, like, log_q: float, r0: np.ndarray,
               block_seconds: float) -> InnovationDesign:
    """The design of the baseline's filtered innovations ``r0``: their Jacobian
    with respect to the coefficients and the blocks of the robust covariance."""
    beta0 = baseline.setup.model.vector(baseline.params, 0.0)
    jac = coefficient_jacobian(like, beta0, log_q, r0)
    basis = _orthonormal(jac)
    per = max(1, int(round(block_seconds / scorer.step)))
    blocks, first = [], 0
    for z in scorer.measured:
        # two residuals per channel and sample (.identify.filter_error.PredictionError.deviance_residuals)
        idx = np.repeat(np.arange(len(z)) // per, 2 * z.shape[1]) + first
        blocks.append(idx)
        first = int(idx.max()) + 1
    fit = replace(baseline, setup=baseline.setup)
    return InnovationDesign(r0, basis, r0 - basis @ (basis.T @ r0), jac, np.concatenate(blocks),
                            int(scorer.n), float(log_q), fit, scorer, rctx,
                            coefficient_scale=np.maximum(np.abs(beta0), 1e-6))


def _orthonormal(x: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """An orthonormal basis of the column space of ``x`` (rank-revealing SVD)."""
    x = np.nan_to_num(x)
    if x.shape[1] == 0:
        return x
    u, s, _ = np.linalg.svd(x, full_matrices=False)
    keep = s > rtol * (s[0] if len(s) else 0.0)
    return u[:, keep]


def cause_steps(ctx: Context, cause: Cause) -> np.ndarray:
    """Finite-difference steps of a cause's parameters (those of the block
    cross-validation's signatures, :func:`studies.discovery.inference._steps`)."""
    from .inference import _steps
    return _steps(ctx, cause)


def cause_variants(design: InnovationDesign, causes: list, library: bool = True) -> list:
    """Every variant of every cause of ``causes`` (:class:`studies.discovery.inference.Variant`)
    with its columns ``-d w / d theta`` in the innovations' rows, so that the
    regression coefficient of a column is the parameter's value; with
    ``library``, a missing term for every term of the extended library."""
    from .inference import WIND_DIRECTIONS, WIND_REFERENCE, Variant

    ctx = design.ctx
    r0 = design.residual
    # the models whose innovations give the columns, filtered together; each variant's columns
    # from them
    models, builders = [], []

    def need(cause, theta, extra=None) -> int:
        models.append((cause, np.asarray(theta, float), extra))
        return len(models) - 1

    for cause in causes:
        if cause.replaces_dynamics or cause.id == "none" or isinstance(cause, MissingTerm):
            continue
        if isinstance(cause, Current):
            # linear in its earth-fixed components (north, east) at no current
            s = 0.01 * max(float(ctx.vessel.speed), 0.1)
            at = [need(cause, [s, d]) for d in (0.0, np.pi, 0.5 * np.pi, -0.5 * np.pi)]

            def current(w, cause=cause, at=at, s=s):
                cols = -np.column_stack([w[at[0]] - w[at[1]], w[at[2]] - w[at[3]]]) / (2.0 * s)

                def to_theta(b):
                    return np.array([np.hypot(b[0], b[1]), np.arctan2(b[1], b[0])])
                return [Variant(cause, cause.id, cols, to_theta, 2)]
            builders.append(current)
            continue
        if isinstance(cause, WindUnmodelled):
            calm = need(cause, [0.0, 0.0])
            at = [need(cause, [WIND_REFERENCE, beta]) for beta in WIND_DIRECTIONS]

            def wind(w, cause=cause, calm=calm, at=at):
                out = []
                for beta, i in zip(WIND_DIRECTIONS, at):
                    def to_theta(b, beta=beta):
                        return np.array([WIND_REFERENCE * np.sqrt(max(float(b[0]), 1e-4)), beta])
                    out.append(Variant(cause, f"{cause.id}@{np.rad2deg(beta):.0f}deg", -(w[i] - w[calm])[:, None],
                                       to_theta, 2))
                return out
            builders.append(wind)
            continue
        steps = cause_steps(ctx, cause)
        at = []
        for j, h in enumerate(steps):
            th = np.zeros(len(steps))
            th[j] = h
            at.append((need(cause, th.copy()), need(cause, -th)))

        def central(w, cause=cause, steps=steps, at=at):
            cols = [-(w[p] - w[m]) / (2.0 * h) for h, (p, m) in zip(steps, at)]
            return [Variant(cause, cause.id, np.column_stack(cols), lambda b: np.asarray(b, float), len(steps))]
        builders.append(central)
    for term in (extended_library(ctx.model, 3) if library else []):
        if ctx.dynamics is not None and term.powers[0]:
            continue            # the MMG hull is a function of v', r' only: no surge-speed terms
        added = MissingTerm([term])
        i = need(added, np.zeros(0), {term.name: TERM_STEP})

        def missing(w, added=added, i=i, name=term.name):
            col = -(w[i] - r0) / TERM_STEP
            if not np.any(col):
                return []
            return [Variant(added, f"missing_term:{name}", col[:, None], lambda b: np.zeros(0), 1)]
        builders.append(missing)
    w = design.innovations_many(models)
    return [variant for build in builders for variant in build(w)]


@dataclass
class Judgement:
    """One regression of the innovations on some causes' columns.

    Attributes
    ----------
    coefficients : ndarray
        The columns' coefficients (the causes' linear parameters).
    covariance : ndarray
        Their covariance, robust to correlation within blocks.
    likelihood_ratio : float
        Fall in the sum of squared deviance residuals (``-2 ln L``) over the model judged against.
    wald : float
        Wald statistic of the tested columns with the robust covariance.
    """

    coefficients: np.ndarray
    covariance: np.ndarray
    likelihood_ratio: float
    wald: float

    @property
    def evidence(self) -> float:
        """``min(likelihood ratio, robust Wald)``: the likelihood ratio, unless
        correlated innovations make it overstate the evidence."""
        return float(min(self.likelihood_ratio, self.wald))


def robust_wald(design: InnovationDesign, y: np.ndarray, change: np.ndarray) -> float:
    """The Wald statistic of ``y``'s regression on one column ``change`` (no
    projection), its variance robust to correlation within the design's
    blocks (the sandwich over them)."""
    x = np.nan_to_num(np.asarray(change, float))
    xx = float(x @ x)
    if xx <= 0.0:
        return 0.0
    c = float(x @ y) / xx
    e = y - c * x
    scores = np.zeros(design.n_blocks)
    np.add.at(scores, design.blocks, x * e)
    var = float(scores @ scores) / xx ** 2
    return float(c * c / var) if var > 0.0 else 0.0


def judge(design: InnovationDesign, columns: np.ndarray, tested: slice | None = None) -> Judgement:
    """Regress the baseline's innovations on ``columns`` (coefficients' directions
    projected out) and test the coefficients ``tested`` (default all) against
    the same regression without them."""
    x = design.project(np.nan_to_num(np.asarray(columns, float)))
    y = design.projected
    k = x.shape[1]
    tested = slice(0, k) if tested is None else tested
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    e = y - x @ coef
    rest = np.ones(k, bool)
    rest[tested] = False
    if rest.any():
        c0, *_ = np.linalg.lstsq(x[:, rest], y, rcond=None)
        e0 = y - x[:, rest] @ c0
    else:
        e0 = y
    lr = float(e0 @ e0 - e @ e)
    scores = np.zeros((design.n_blocks, k))
    np.add.at(scores, design.blocks, x * e[:, None])
    bread = np.linalg.pinv(x.T @ x)
    cov = bread @ (scores.T @ scores) @ bread
    sub = cov[tested, tested]
    c = coef[tested]
    wald = float(c @ np.linalg.pinv(sub) @ c) if np.all(np.isfinite(sub)) else 0.0
    return Judgement(coef, cov, max(lr, 0.0), max(wald, 0.0))
