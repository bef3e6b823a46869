"""Discovery on the tracks: every cause judged by how much it improves the
baseline's one-step-ahead predictions of the measured records.

1. **The filter.** The baseline's extended Kalman filter runs over every
   record, training and held out, as measured (:mod:`.innovations`); the
   baseline's coefficients and the filter's process and measurement noise
   are fitted to the tracks first (the filter-error method,
   :func:`.innovations.baseline_on_tracks`: the smoothed records'
   regression only starts it). The process noise is white or coloured
   (disturbances with a correlation time), whichever the tracks' likelihood
   prefers (:meth:`.prediction_error.FilterScores.estimate_shape`): a push
   that lasts tens of seconds, read as white, is credited to a constant
   force or a missing term. Every cause's columns (how it would change
   the standardised innovations at no effect) choose its variant and start
   its fit.
2. **Every model fitted to the tracks.** ``none``, every single cause and
   every pair judged are fitted by least squares of the filter's
   deviance residuals (standardised innovations and the log of their
   variances: ``-2 ln L``, :mod:`.innovations`), the cause's parameters and the model's
   coefficients together (:func:`refine_on_tracks`), so that every verdict
   is compared at its own optimum under one filter: a cause is credited
   only with what its parameters add to coefficients that are re-identified
   beside it. A nested model is also taken at the larger one's fit (the
   first cause alone at a pair's values): what the larger model's
   refinement found for the shared coefficients is not credited to its own
   parameters. A cause whose fit lies where it is no effect
   (:meth:`~studies.discovery.causes.base.Cause.acts`) is not credited.
3. **One criterion.** A verdict (``none``, one cause, or a second cause
   beside the first) is scored by the Bayesian information criterion of the
   tracks' likelihood, with a uniform prior over a cause's variants::

       s = E - k ln(n) - 2 ln(m)

   ``E`` the evidence of its model over the model without it (the fall in
   ``-2 ln L``, a likelihood ratio, or the Wald
   statistic of that change with a variance robust to innovations
   correlated within :data:`~.innovations.BLOCK_SECONDS` stretches where
   smaller: :func:`_evidence_at`), ``k`` its parameters, ``n`` the
   measured innovations, ``m`` the cause's variants (the library's terms
   for a missing term, the directions of a wind); ``none`` scores 0. The
   probability of a verdict is ``exp(s / 2)`` normalised over ``none``,
   every single cause and every second cause beside the most probable
   single one (the BIC's approximation of the posterior, Kass & Raftery
   1995); the most probable verdict is named and its probability is the
   confidence. A second cause is judged only beside a first that beats
   ``none`` (forward selection), under the filter whose process noise is
   the likeliest for the first's model, against the first refined again
   under that filter.
4. **Parameters.** The named single cause's parameters are those of its
   refit under its own filter (under the baseline's process noise, which
   follows part of a cause's effect, a current of 0.8 m/s came out at
   0.58 m/s); every other single cause's (``candidates``) those of its fit
   under the baseline's filter; intervals come from the robust covariance
   of the linear coefficients (:func:`studies.discovery.inference.intervals`).

The held-out records measure the named model's gain in the workflow
(:mod:`studies.workflows.discover_inference`); it is reported, it does not
name anything.

References
----------
Kass, R. E., Raftery, A. E. (1995). Bayes factors. J. Amer. Statist. Assoc.
90(430), 773-795.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares
from scipy.special import expit

from .alike import signature_alike
from .look_alike import Detectability, LikelihoodSeparation
from .causes import Combined, MissingTerm, NoCause, manoeuvring_causes
from .causes.base import Cause
from .fitting import CauseFit, Context, calibrate
from .inference import (Inference, Variant, _by_cause, _catalogue_order, _model_cause, _model_theta, _pair_id,
                        baseline_fit, fit_at)
from .innovations import (BLOCK_SECONDS, TERM_STEP, InnovationDesign, beside, cause_steps, cause_variants,
                          innovation_design, judge, own_columns, robust_wald)

__all__ = ["infer_on_tracks", "refine_on_tracks", "propulsion_on_tracks", "fit_at", "MAX_EVALUATIONS"]

log = logging.getLogger(__name__)

#: evaluations of the filter a cause's refinement on the innovations may take
MAX_EVALUATIONS = 40
#: a refinement stops when an iteration lowers -ln L by less than this (the criterion's
#: differences that decide, penalties of one parameter, are of order ln n, about 10)
REFINE_TOLERANCE = 0.01
#: a second cause is refined beside the first only when its first-order score is above minus this
PAIR_SCREEN = 20.0


#: what the evidence between two causes is on the tracks (:mod:`.look_alike`)
TRACK_SEPARATION = ("difference of the two fitted models' likelihood evidence over none (twice the log-likelihood "
                    "ratio of the tracks, no penalty on parameters)")


def _score_of(evidence: float, n_params: int, n: int, n_variants: int) -> float:
    return float(evidence - n_params * np.log(n) - 2.0 * np.log(max(n_variants, 1)))


def infer_on_tracks(ctx: Context, smoothed: list, measured: list, causes: list | None = None,
                    pairs: bool = True) -> Inference:
    """Name the verdict that best predicts the measured tracks (module docstring).

    Parameters
    ----------
    ctx : Context
        The baseline and its vessel (its training records decide which causes
        the records can decide); with ``ctx.dynamics``, the MMG model is the
        filter's process model (:mod:`studies.identification.mmg_filter`).
    smoothed : list of DataFrame
        Every record smoothed (states and accelerations): the coefficients of
        each refined model are identified on them.
    measured : list of DataFrame
        The same records as measured: the filter runs on them.
    causes : list of Cause, optional
        Default: the catalogue's applicable causes; undecidable ones are left out.
    pairs : bool
        Judge a second cause beside the most probable single one when it beats ``none``.
    """
    seconds = {}
    t0 = time.perf_counter()
    every = Context(ctx.vessel, ctx.model, list(smoothed), [], "recorded", dynamics=ctx.dynamics)
    calibrate(every)
    baseline = baseline_fit(every)
    design = innovation_design(every, measured, baseline)
    log.info("baseline on the tracks: cost %.2f", 0.5 * float(design.residual @ design.residual))
    seconds["filter"] = time.perf_counter() - t0
    causes = causes if causes is not None else list(manoeuvring_causes(ctx))
    causes = [c for c in causes if c.undecidable(ctx) is None]
    t1 = time.perf_counter()
    variants = cause_variants(design, causes)
    alike = signature_alike(variants, [design.project(np.nan_to_num(v.columns)) for v in variants])
    seconds["signatures"] = time.perf_counter() - t1

    # 1. every cause alone against none, judged at its fit refined on the tracks (its parameters
    # are reported whether named or not)
    t2 = time.perf_counter()
    singles = _by_cause(variants)
    # none refined as every cause is (its coefficients to convergence under this filter): a cause is
    # credited only with what it adds
    none = refine_on_tracks(design, every, NoCause(), np.zeros(0), {})
    against = _innovations_of(design, none)
    fits, best, scores = {(): none}, {}, {"none": 0.0}
    # each verdict's likelihood evidence (no penalty): what the records say between two causes
    raw, raw2 = {}, {}
    at_fits = []
    for cid, idx in singles.items():
        i, j = max(((i, judge(design, variants[i].columns)) for i in idx), key=lambda ij: ij[1].evidence)
        fit = refine_on_tracks(design, every, *_start(variants, (i,), j.coefficients))
        fits[(i,)] = fit
        best[cid] = i
        at_fits.append(_innovations_of(design, replace(none, params=_without(fit.params, fit))))
    # none at the best of its own refit and every cause's coefficients: a cause is credited only
    # with what its own parameters add
    nested = _nested(against, *at_fits)
    for cid, idx in singles.items():
        i = best[cid]
        fit = fits[(i,)]
        raw[cid] = (_evidence_at(design, nested, _innovations_of(design, fit))
                    if fit.cause.acts(fit.theta) else 0.0)
        scores[cid] = _score_of(raw[cid], variants[i].n_params, design.n, len(idx))
    evidence = {cid: scores[cid] for cid in singles}
    seconds["comparison"] = time.perf_counter() - t2
    propulsion = [c for c in causes if c.replaces_dynamics] if ctx.dynamics is None else []
    if propulsion:
        t4 = time.perf_counter()
        judged = propulsion_on_tracks(ctx, propulsion[0], smoothed, measured, design, none)
        if judged is not None:
            score, fit = judged
            variants = variants + [Variant(fit.cause, fit.cause.id, np.zeros((len(design.residual), 0)),
                                           lambda b: np.zeros(0), fit.cause.n_params())]
            i = len(variants) - 1
            singles[fit.cause.id] = [i]
            fits[(i,)], best[fit.cause.id] = fit, i
            scores[fit.cause.id] = evidence[fit.cause.id] = score
            raw[fit.cause.id] = score - _score_of(0.0, fit.cause.n_params(), design.n, 1)
        seconds["propulsion"] = time.perf_counter() - t4

    # 2. a second cause beside the most probable single one, the two refined together
    first = max(singles, key=lambda c: scores[c], default=None)
    named = (best[first],) if first is not None and scores[first] > 0.0 else ()
    pair_fits, pair_variants = {}, {}
    if named and variants[best[first]].cause.replaces_dynamics:
        # another process model: a second cause is judged on it as the baseline (model=mmg)
        pairs = False
    elif named:
        t3 = time.perf_counter()
        fit1 = fits[(best[first],)]
        terms1 = _terms_of(fit1)
        # the filter with the process noise's scale the first's model implies (the baseline's
        # followed part of the cause's effect as process noise, and its fit falls short: a current
        # of 0.8 m/s came out at 0.58 m/s), the first refined again under it: its parameters, and
        # the model the pairs are compared with, each at its optimum under one filter
        design2 = beside(design, fit1.cause, fit1.theta, terms1, fit1.params)
        plain2 = replace(design2, base=None)           # the same filter, nothing beneath
        fit1 = refine_on_tracks(plain2, every, fit1.cause, fit1.theta, terms1)
        fits[(best[first],)] = fit1
        terms1 = _terms_of(fit1)
        against = _innovations_of(plain2, fit1)
        seconds["first_cause"] = time.perf_counter() - t3
    if pairs and named:
        t3 = time.perf_counter()
        own = own_columns(design2, cause_steps(every, fit1.cause) if len(fit1.theta) else np.zeros(0))
        second = cause_variants(design2, [c for c in causes if c.id != first], library=first != "missing_term")
        tried = []
        for cid, idx in _by_cause(second).items():
            i, j = max(((i, judge(design2, np.hstack([own, second[i].columns]), tested=slice(own.shape[1], None)))
                        for i in idx), key=lambda ij: ij[1].evidence)
            linear = _score_of(j.evidence, second[i].n_params, design.n, len(idx))
            if linear < -PAIR_SCREEN:
                # its first-order evidence is far below what naming it would take: not refined
                scores[_pair_id(first, cid)] = scores[first] + linear
                evidence[_pair_id(first, cid)] = linear
                raw2[cid] = float(j.evidence)
                continue
            _, theta2, terms2 = _start(second, (i,), j.coefficients[own.shape[1]:])
            fit = refine_on_tracks(plain2, every, *_join(fit1.cause, fit1.theta, terms1, second[i].cause,
                                                         theta2, terms2))
            tried.append((cid, i, idx, fit, _innovations_of(plain2, _first_of(fit, fit1))))
        # the first alone at the best of its own refit and the pairs' values of its parameters and the
        # coefficients: a pair is credited only with what its second cause adds
        nested = _nested(against, *[at_pair for *_, at_pair in tried])
        for cid, i, idx, fit, _ in tried:
            pair = _pair_id(first, cid)
            after = _innovations_of(plain2, fit)
            log.debug("pair %s: first alone %.2f, pair %.2f", cid, 0.5 * float(nested @ nested),
                      0.5 * float(after @ after))
            raw2[cid] = _evidence_at(design2, nested, after) if fit.cause.acts(fit.theta) else 0.0
            s2 = _score_of(raw2[cid], second[i].n_params, design.n, len(idx))
            scores[pair] = scores[first] + s2
            evidence[pair] = s2
            pair_fits[cid], pair_variants[pair] = fit, second[i]
        seconds["second_cause"] = time.perf_counter() - t3
    top = max(scores, key=scores.get)
    if "+" in top:
        variants = variants + [pair_variants[top]]
        named = (best[first], len(variants) - 1)
        fits[named] = pair_fits[next(c for c in pair_fits if _pair_id(first, c) == top)]
    named_judgement = (judge(design, np.hstack([variants[i].columns for i in named]))
                       if named and not variants[named[0]].cause.replaces_dynamics else None)

    top_score = max(scores.values())
    weights = {k: float(np.exp(0.5 * (s - top_score))) for k, s in scores.items()}
    total = sum(weights.values())
    verdicts = {k: w / total for k, w in sorted(weights.items(), key=lambda kv: -kv[1])}
    inclusion = {}
    for k, p in verdicts.items():
        for cid in k.split("+"):
            if cid != "none":
                inclusion[cid] = inclusion.get(cid, 0.0) + p
    beats_none = {cid: float(expit(0.5 * scores[cid])) for cid in singles}
    out = Inference(variants, tuple(named), inclusion, verdicts,
                    named_judgement.coefficients if named_judgement is not None else np.zeros(0),
                    named_judgement.covariance if named_judgement is not None else np.zeros((0, 0)),
                    int(design.n), seconds,
                    gains={k: 0.5 * s for k, s in scores.items()}, beats_none=beats_none, threshold=0.0,
                    evidence=evidence, second_threshold=0.0 if pair_variants else float("nan"),
                    n_blocks=design.n_blocks, block_seconds=float(BLOCK_SECONDS), probability_floor=1e-300,
                    alike=alike)
    # two causes are told apart when one's likelihood evidence exceeds the other's by what one
    # parameter must earn to be named over none (the BIC's ln n)
    separate = float(np.log(design.n))
    out.separations = {"first": LikelihoodSeparation(list(raw), separate, TRACK_SEPARATION, values=raw)}
    if raw2:
        out.separations["second"] = LikelihoodSeparation(list(raw2), separate, TRACK_SEPARATION, values=raw2)
    out.detectability = {cid: Detectability(float(raw[cid]), float(raw[cid] - scores[cid]), 2) for cid in raw}
    out.fits = fits
    out.fit = fits.get(tuple(named))
    # the filter and the records every verdict was judged on (an effect stated beforehand is scored
    # on them: .stated_effect)
    out.design, out.context = design, every
    scorer = design.scorer
    out.filter_reading = {"step_s": float(scorer.step), "velocities_measured": bool(scorer.velocities),
                          "process_noise": "coloured" if scorer.tau > 0.0 else "white",
                          "correlation_time_s": float(scorer.tau)}
    # what every other cause would be beside a named single one (refined together)
    out.beside = dict(pair_fits) if len(named) == 1 else {}
    #: every second cause refined beside the first (a pair's class of look-alikes)
    out.pair_fits = dict(pair_fits)
    log.info("discovery on the tracks: %s (scores %s)", out.verdict_of(out.named),
             ", ".join(f"{k} {v:.1f}" for k, v in sorted(scores.items(), key=lambda kv: -kv[1])[:6]))
    return out


def propulsion_on_tracks(ctx: Context, cause: Cause, smoothed: list, measured: list, design: InnovationDesign,
                         none: CauseFit) -> tuple[float, CauseFit] | None:
    """``(score, fit)`` of a cause that replaces the baseline's dynamics
    (``propulsion``: the MMG model, with thrust from the measured rpm and the
    rudder in the slipstream), or None where it does not apply.

    The replacement is not a column beside the baseline's coefficients: it is
    another process model in the filter. Its coefficients and its filter's
    noises are fitted to the same tracks at the same filter step as the
    baseline's (:func:`.innovations.innovation_design`, then refined as every
    verdict is, :func:`refine_on_tracks`), the noises searched from the
    records' noise levels and from the baseline's estimate and the likelier
    kept (the likelihood over the noises has more than one maximum); it is
    judged by the same BIC
    (module docstring) on the two filters' whole log-likelihoods at their
    own noises (the standardised innovations alone would leave out the
    innovation variances, which differ between the two filters): ``E = 2
    (ln L_replacement - ln L_none)``, ``k`` its coefficients less the
    baseline's (negative when it has fewer), one variant."""
    if not cause.applicable(ctx):       # every record, training and held out, carries the rpm
        return None
    dynamics = cause.setup(ctx, np.zeros(0)).dynamics
    other = Context(ctx.vessel, dynamics.model, list(smoothed), [], "recorded", dynamics=dynamics)
    calibrate(other)
    start = baseline_fit(other)
    ll_none = design.scorer._likelihood(none).loglik(none.setup.model.vector(none.params, 0.0), design.log_q_scale)
    best = None
    # the noises' likelihood has more than one maximum: the replacement's filter is searched from
    # the records' noise levels and from the baseline's estimate, the likelier kept
    for noises in (None, design.scorer):
        origin = "the baseline's noises" if noises is not None else "the records' noise levels"
        try:
            # its process noise white or coloured by likelihood, as the polynomial baseline's
            replaced = innovation_design(other, measured, start, step=float(design.scorer.step),
                                         coloured=design.scorer.coloured, noises=noises)
            refined = refine_on_tracks(replaced, other, NoCause(), np.zeros(0), {})
        except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
            log.info("%s not judged on the tracks from %s: its filter failed (%s)", cause.id, origin, exc)
            continue
        ll = replaced.scorer._likelihood(refined).loglik(dynamics.model.vector(refined.params, 0.0),
                                                         replaced.log_q_scale)
        log.info("%s's filter from %s: ln L %.1f", cause.id, origin, ll)
        if np.isfinite(ll) and (best is None or ll > best[0]):
            best = (ll, refined)
    if best is None or not np.isfinite(ll_none):
        return None
    ll_other, refined = best
    score = _score_of(2.0 * (ll_other - ll_none), cause.n_params(), design.n, 1)
    log.info("%s on the tracks: ln L %.1f against the baseline's %.1f, %+d coefficients: score %.1f",
             cause.id, ll_other, ll_none, cause.n_params(), score)
    return score, replace(refined, cause=cause, theta=np.zeros(0))


def _evidence_at(design: InnovationDesign, against: np.ndarray, innovations: np.ndarray) -> float:
    """Evidence of a refined model over the refined model whose innovations
    are ``against`` (both with their coefficients fitted to the tracks): the
    fall in their sum of squared deviance residuals (``-2 ln L``, a likelihood ratio), or, where smaller, the
    Wald statistic of the change it makes with the covariance robust to
    innovations correlated within the design's blocks."""
    after = np.nan_to_num(innovations)
    change = against - after
    lr = float(against @ against - after @ after)
    return float(min(max(lr, 0.0), robust_wald(design, against, change)))


def _nested(*innovations: np.ndarray) -> np.ndarray:
    """Of the nested model's innovations at its own fit and at the larger
    model's coefficients, those of the smaller sum of squares: a larger model
    is credited only with what its own parameters add, not with coefficients
    its refinement found and the nested one's did not."""
    return min(innovations, key=lambda w: float(np.nan_to_num(w) @ np.nan_to_num(w)))


def _first_of(pair: CauseFit, first: CauseFit) -> CauseFit:
    """The first cause alone at a refined pair's values (its parameters, its
    added terms', the coefficients): the nested model at the larger one's fit."""
    cause = pair.cause
    a, b = cause._split(np.asarray(pair.theta, float))
    theta = a if cause.first.id == first.cause.id else b
    own = set(first.cause.params) if _has_terms(first.cause) else set()
    other = (set(pair.cause.params) - own) if _has_terms(pair.cause) else set()
    params = {k: v for k, v in pair.params.items() if k not in other}
    return replace(first, theta=np.asarray(theta, float), params=params)


def _without(params: dict, fit: CauseFit) -> dict:
    """A refined fit's coefficients without its added terms."""
    own = set(fit.cause.params) if _has_terms(fit.cause) else set()
    return {k: v for k, v in params.items() if k not in own}


def _innovations_of(design: InnovationDesign, fit: CauseFit) -> np.ndarray:
    """The innovations of a refined fit (its own coefficients)."""
    return design.innovations(fit.cause, fit.theta, coefficients=fit.params)


def _start(variants: list, model: tuple, coefficients: np.ndarray) -> tuple:
    """``(cause, theta, terms)`` of a model from its columns' linear coefficients."""
    coefficients = np.asarray(coefficients, float)
    cause = _model_cause(variants, model)
    theta = _model_theta(variants, model, coefficients)
    terms, col = {}, 0
    for i in model:
        v = variants[i]
        if isinstance(v.cause, MissingTerm):
            terms[v.cause.params[0]] = float(coefficients[col])
        col += v.columns.shape[1]
    return cause, theta, terms


def _terms_of(fit: CauseFit) -> dict:
    """The added terms' coefficients of a refined fit."""
    names = [n for n in (fit.cause.params if _has_terms(fit.cause) else ())]
    return {n: float(fit.params[n]) for n in names if n in fit.params}


def _has_terms(cause: Cause) -> bool:
    if isinstance(cause, MissingTerm):
        return True
    return isinstance(cause, Combined) and (isinstance(cause.first, MissingTerm)
                                            or isinstance(cause.second, MissingTerm))


def _join(first: Cause, theta1, terms1: dict, second: Cause, theta2, terms2: dict) -> tuple:
    """Two causes as one :class:`Combined` in catalogue order, with their parameters."""
    parts = sorted([(first, np.atleast_1d(theta1)), (second, np.atleast_1d(theta2))],
                   key=lambda ct: _catalogue_order(ct[0].id))
    cause = Combined(parts[0][0], parts[1][0])
    return cause, np.concatenate([parts[0][1], parts[1][1]]), {**terms1, **terms2}


def refine_on_tracks(design: InnovationDesign, ctx: Context, cause: Cause, theta: np.ndarray, terms: dict,
                     max_nfev: int = MAX_EVALUATIONS) -> CauseFit:
    """``cause``'s parameters ``theta``, its added terms' coefficients
    ``terms`` and the model's coefficients fitted together to the tracks from
    the values given and the design's coefficients (the filter-error method:
    SciPy's trust-region least squares of the deviance residuals (``-2 ln L``) at the
    design's process and measurement noise). The Jacobian's columns of the
    coefficients are the design's, taken once at its coefficients; the
    cause's by central differences of :func:`cause_steps`. Returned as a
    :class:`CauseFit` whose coefficients are those fitted (its scores those
    of the smoothed records' regression, :func:`fit_at`)."""
    theta = np.asarray(theta, float).copy()
    names = list(terms)
    n_theta, n_own = len(theta), len(theta) + len(names)
    nb = design.coefficient_jacobian.shape[1]
    low, high = (cause.bounds(ctx) if n_theta else (np.zeros(0), np.zeros(0)))
    theta = np.clip(theta, low + 1e-9, high - 1e-9)
    steps = np.concatenate([cause_steps(ctx, cause) if n_theta else np.zeros(0), np.full(len(names), TERM_STEP)])
    x0 = np.concatenate([theta, [terms[n] for n in names], np.zeros(nb)])
    lo = np.concatenate([low, np.full(len(names) + nb, -np.inf)])
    hi = np.concatenate([high, np.full(len(names) + nb, np.inf)])

    def model_at(x):
        return (cause, x[:n_theta], dict(zip(names, x[n_theta:n_own].tolist())), design.coefficients_at(x[n_own:]))

    def residual(x):
        if np.array_equal(x, x0):
            return r0               # least squares starts where the tolerance was taken
        return np.nan_to_num(design.innovations(*model_at(x)))

    def jacobian(x):
        points, spans = [], []
        for j, h in enumerate(steps):
            # central differences, one-sided at a bound (a current of nearly no speed)
            plus, minus = x.copy(), x.copy()
            plus[j], minus[j] = min(x[j] + h, hi[j]), max(x[j] - h, lo[j])
            points += [plus, minus]
            spans.append(max(plus[j] - minus[j], 1e-300))
        # every column's filters run side by side
        w = [np.nan_to_num(r) for r in design.innovations_many([model_at(p) for p in points])]
        cols = [(w[2 * j] - w[2 * j + 1]) / spans[j] for j in range(len(steps))]
        return np.column_stack(cols + [design.coefficient_jacobian])

    try:
        r0 = np.nan_to_num(design.innovations(*model_at(x0)))
        cost0 = 0.5 * float(r0 @ r0)
        res = least_squares(residual, x0, jac=jacobian, bounds=(lo, hi), max_nfev=max_nfev, method="trf",
                            x_scale="jac", ftol=max(REFINE_TOLERANCE / max(cost0, 1.0), 1e-12))
        x = res.x
        log.debug("refine %s: nfev %d njev %d status %d cost %.2f -> %.2f theta %s", cause.id, res.nfev, res.njev,
                  res.status, cost0, res.cost, np.array2string(x[:n_own], precision=5))
    except (ValueError, np.linalg.LinAlgError) as exc:
        log.info("refining %s on the tracks stopped (%s); its linear solution is kept", cause.id, exc)
        x = x0
    added = dict(zip(names, x[n_theta:n_own].tolist()))
    fit = fit_at(ctx, cause, x[:n_theta], added)
    return replace(fit, params={**design.coefficients_at(x[n_own:]), **added})
