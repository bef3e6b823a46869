"""Naming the cause: all causes fitted (by regression, and on noisy records
refined by replaying them), ranked, the best checked on unseen data, and a
second cause tried on top. Missing terms come from sparse regression and
single-term screening, or on noisy records from score tests at the refined
baseline, chosen by forward selection."""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from ..data.resample import block_means
from ..identify.regression import prime_states
from .causes import (Combined, MissingTerm, NoCause, Setup, compact_parameters, extended_library,
                     manoeuvring_causes)
from .fitting import (CauseFit, Context, calibrate, fit_cause, kinematic_smoothing, posterior, regression_fit,
                      rescore, validate)
from .kinematics import coloured_velocity_noise, derived_velocities
from .prediction_error import FilterScores
from .output_error import (_nested_theta, needs_refinement, noise_levels, output_error_scores, refine, refine_cause,
                           refined_posterior, restart_from, score_terms, training_windows)

__all__ = ["select_missing_terms", "forward_select", "terms_by_output_error", "breaks_down", "not_named",
           "held_out_evidence", "named_on_held_out", "second_candidates", "second_cause",
           "second_on_held_out_note", "search"]

log = logging.getLogger(__name__)


def select_missing_terms(ctx: Context, residuals, problems, threshold: float = 0.1,
                         max_terms: int = 3) -> list:
    """Terms of the extended library that the baseline's residual needs (SINDy's STLSQ).

    Per DOF the candidate features are made orthogonal to the baseline's own
    columns (so a candidate only gets what the baseline cannot explain), then
    STLSQ runs on unit-variance columns against the unit-variance residual;
    ``threshold`` is in those units (a selected term explains at least about
    ``threshold^2`` of the residual variance). At most ``max_terms`` per DOF,
    the largest first.
    """
    import pysindy as ps  # lazy: pysindy loads scikit-learn (about 1 s), needed by this search only

    chosen = []
    library = extended_library(ctx.model, 3)
    for k, dof in enumerate(("X", "Y", "N")):
        p = problems[dof]
        primes = prime_states(p.states["u"], p.states["v"], p.states["r"], p.states["delta"], ctx.vessel)
        cands = [t for t in library if t.dof == dof]
        if not cands:
            continue
        feats = np.column_stack([t.feature(primes) for t in cands])
        if p.theta.shape[1]:
            coef, *_ = np.linalg.lstsq(p.theta, feats, rcond=None)
            feats = feats - p.theta @ coef
        scale = feats.std(axis=0)
        ok = scale > 1e-12 * max(1.0, np.abs(feats).max())
        if not ok.any():
            continue
        z = feats[:, ok] / scale[ok]
        r = residuals[k] / max(residuals[k].std(), 1e-300)
        opt = ps.STLSQ(threshold=threshold, alpha=1e-6, max_iter=50)
        opt.fit(z, r)
        w = np.ravel(opt.coef_)
        idx = np.flatnonzero(np.abs(w) > 0)
        idx = idx[np.argsort(-np.abs(w[idx]))][:max_terms]
        names = [cands[i] for i in np.flatnonzero(ok)[idx]]
        chosen += names
    return chosen


def screen_terms(ctx: Context, base: float, per_dof: int = 2) -> list:
    """The library terms that lower the score most when added alone, ``per_dof``
    per DOF (only those that lower it below the baseline's score ``base``).

    Sparse regression on the residual picks the terms with the largest
    coefficients; with noisy records those are often the ones that fit the
    noise-induced bias of the regression, while the missing term lowers the
    residual most. Screening every single term by the score catches it.
    """
    out = []
    for dof in ("X", "Y", "N"):
        trials = sorted((fit_cause(ctx, MissingTerm([t])).score, i, t)
                        for i, t in enumerate(extended_library(ctx.model, 3)) if t.dof == dof)
        out += [t for score, _, t in trials[:per_dof] if score < base]
    return out


def forward_select(ctx: Context, candidates: list, base: float) -> list:
    """The candidate terms worth adding, by forward selection on the score.

    Starting from the baseline's score ``base``, the term that lowers the
    score most is added while it lowers it at all (each term costs
    ``ln n_eff``); the candidates come from the sparse regression and the
    screening. At least the best single term is returned
    (so that the ranking shows what adding a term could do).
    """
    chosen, best_score = [], base
    remaining = list(candidates)
    while remaining:
        trials = [(fit_cause(ctx, MissingTerm(chosen + [t])).score, t) for t in remaining]
        score, term = min(trials, key=lambda x: x[0])
        if chosen and score >= best_score:
            break
        chosen.append(term)
        remaining.remove(term)
        if score >= best_score:
            break
        best_score = score
    return chosen


#: a cause must lower the score by this much to be preferred to a simpler
#: explanation ("very strong" evidence on the 2 ln Bayes-factor scale)
EVIDENCE = 10.0


def _with_terms(ctx: Context, parent: CauseFit, terms: list, start: dict, windows, sigma,
                max_nfev: int = 30) -> CauseFit:
    """``missing_term`` with ``terms`` refined by output error, started from the
    refined ``parent`` (its coefficients and initial states) and the terms'
    values ``start`` (prime)."""
    cause = MissingTerm(terms)
    fit = CauseFit(cause, np.zeros(0), {**parent.params, **start}, np.zeros(3),
                   setup=cause.setup(replace(ctx, train=[]), np.zeros(0)))
    return refine(ctx, fit, windows, sigma, states=parent.refined["states"], max_nfev=max_nfev)


#: candidate terms tried at each step of the forward selection by output error, and the
#: evaluations each trial gets: the score test is a first-order look, and terms that share
#: the missing effect's shape score alike there (at 5 % noise a hidden cubic yaw damping
#: Nrrr came seventh, behind Nuvd, Nurr and Nurd, yet its short refinement replays the
#: records far better than theirs)
TERM_TRIALS, TERM_TRIAL_EVALUATIONS = 10, 6


def _best_term(ctx: Context, parent: CauseFit, chosen: list, start: dict, ranked: list, windows,
               sigma) -> tuple:
    """Of the :data:`TERM_TRIALS` terms the score test ranks first, the one whose
    short refinement (:data:`TERM_TRIAL_EVALUATIONS`) of ``parent`` extended by it
    (with the terms ``chosen``, values ``start``) replays the training records
    best, refined to the end: ``(term, value, refined fit)``."""
    trials = []
    for term, _, value in ranked[:TERM_TRIALS]:
        fit = _with_terms(ctx, parent, chosen + [term], {**start, term.name: value}, windows, sigma,
                          TERM_TRIAL_EVALUATIONS)
        trials.append((fit.refined["cost"], term, fit))
    _, term, fit = min(trials, key=lambda x: x[0])
    fit = refine(ctx, fit, windows, sigma, states=fit.refined["states"])
    return term, fit.params[term.name], fit


def terms_by_output_error(ctx: Context, baseline: CauseFit, windows, sigma, max_terms: int = 3,
                          rivals: list = (), scoring=output_error_scores) -> tuple[list, CauseFit | None, list]:
    """The missing terms chosen by output error: forward selection on score tests.

    At the refined ``baseline`` every term of the extended library is scored
    (:func:`.output_error.score_terms`); the extensions by each of the best
    :data:`TERM_TRIALS` are refined and the one that replays the records best
    is kept (:func:`_best_term`). A further term is tried while its score-test evidence
    exceeds ``ln n_eff + EVIDENCE`` and kept when the refined extension lowers
    the output-error score by :data:`EVIDENCE`; at most ``max_terms`` terms,
    and only while the terms explain the records better than every refined
    fit of ``rivals`` (other causes).
    With noisy records this replaces the equation-error selection, which
    cannot see a cubic yaw damping through the noise-induced bias of the
    regression. Returns ``(terms, refined missing_term fit or None,
    candidate terms whose evidence exceeds ln n_eff)``.
    """
    library = extended_library(ctx.model, 3)
    ranked = score_terms(ctx, baseline, library)
    n_eff = baseline.refined["n"] / max(1.0, baseline.refined["tau"])
    candidates = [t for t, evidence, _ in ranked if evidence > np.log(n_eff)]
    if not ranked:
        return [], None, candidates
    log.info("output-error score test: %s", ", ".join(f"{t.name} {e:.1f}" for t, e, _ in ranked[:5]))
    term, value, best = _best_term(ctx, baseline, [], {}, ranked, windows, sigma)
    chosen, start = [term], {term.name: value}
    while len(chosen) < max_terms:
        if rivals:
            scoring(list(rivals) + [best])
            if best.score >= min(f.score for f in rivals):
                break
        ranked = score_terms(ctx, best, [t for t in library if t.name not in start])
        if not ranked:
            break
        n_eff = best.refined["n"] / max(1.0, best.refined["tau"])
        if ranked[0][1] < np.log(n_eff) + EVIDENCE:
            break
        term, value, trial = _best_term(ctx, best, chosen, start, ranked, windows, sigma)
        scoring([best, trial])
        if trial.score >= best.score - EVIDENCE:
            break
        chosen, start, best = chosen + [term], {**start, term.name: value}, trial
    return chosen, best, candidates


def _pair_order(best: CauseFit, other: CauseFit) -> tuple[CauseFit, CauseFit]:
    """``(first, second)`` of a pair as :class:`Combined` takes them: a missing
    term always second (it adds its terms to the first cause's model)."""
    return (other, best) if isinstance(best.cause, MissingTerm) else (best, other)


def _pair_start(best: CauseFit, other: CauseFit):
    """The pair of ``best`` and ``other`` with its starting point: ``best``'s
    solution with ``other`` at no effect (nonlinear parameters zero, its own
    coefficients zero), so the pair starts where ``best`` ends and cannot fit
    the training records worse. Returns ``(cause, theta, params)``."""
    first, second = _pair_order(best, other)
    parts = [f.theta if f is best else np.zeros(len(f.theta)) for f in (first, second)]
    theta = np.concatenate(parts)
    cause = Combined(first.cause, second.cause, starts=[theta])
    own = {name: 0.0 for name in other.cause.params if name not in best.params}
    return cause, theta, {**best.params, **own}


def _pair(ctx: Context, best: CauseFit, other: CauseFit, windows, sigma) -> CauseFit:
    """``best`` and ``other`` at once, from :func:`_pair_start`: refined by output
    error when ``windows`` are given (from ``best``'s window states), else
    fitted by regression from that start. Refined also from ``best``'s
    solution with ``other``'s own parameters (and its added coefficients),
    the lower cost kept: from no effect the second effect may stay at none."""
    cause, theta, params = _pair_start(best, other)
    first, second = _pair_order(best, other)
    if windows is None:
        # by regression the coefficients are re-solved: the two causes' own solutions are a second start
        return fit_cause(ctx, Combined(first.cause, second.cause,
                                       starts=[theta, np.concatenate([first.theta, second.theta])]))
    combo = fit_cause(ctx, cause)
    start = replace(combo, theta=theta, params={**combo.params, **params}, setup=cause.setup(ctx, theta))
    out = refine(ctx, start, windows, sigma, states=best.refined["states"])
    if not len(other.theta) and all(other.params.get(n, 0.0) == 0.0 for n in params if n not in best.params):
        return out
    theta = np.concatenate([f.theta for f in (first, second)])
    own = {n: other.params.get(n, 0.0) for n in other.cause.params if n not in best.params}
    started = replace(start, theta=theta, params={**start.params, **own}, setup=cause.setup(ctx, theta))
    again = refine(ctx, started, windows, sigma, states=best.refined["states"])
    return again if again.refined["cost"] < out.refined["cost"] else out


def _filter_pair(ctx: Context, scorer: FilterScores, best: CauseFit, other: CauseFit) -> CauseFit:
    """``best`` and ``other`` at once, refined by the filter-error method
    (:meth:`.prediction_error.FilterScores.refine`) from ``best``'s solution
    with ``other``'s parameters at the start that the filter finds likeliest
    among no effect, ``other``'s own solution and its starting grid (a
    current or a wind at no effect has no direction to move along), and from
    ``other``'s own solution too, the better refined kept: the likeliest
    start is nearly always no effect (the first cause's coefficients and
    states suit it), and refined from there the second effect may stay at none."""
    first, second = _pair_order(best, other)
    cause = Combined(first.cause, second.cause)
    bare = replace(ctx, train=[])
    options = [np.zeros(len(other.theta)), np.asarray(other.theta, float)]
    if len(other.theta):
        options += [np.asarray(t, float) for t in other.cause.starts(ctx)]
    added = [name for name in other.cause.params if name not in best.params and name in other.params]
    values = [{name: 0.0 for name in added}, {name: other.params[name] for name in added}] if added else [{}]
    scale = (best.refined or {}).get("filter", {}).get("log_q_scale", 0.0)
    # a pair holding a cause the training records cannot decide is not decided either
    undecidable = cause.undecidable(ctx)
    trials, own = [], None
    for i, theta_other in enumerate(options):
        for extra in values:
            theta = np.concatenate([best.theta, theta_other] if first is best else [theta_other, best.theta])
            params = {**{n: 0.0 for n in other.cause.params if n not in best.params}, **best.params, **extra}
            fit = CauseFit(cause, theta, params, np.zeros(3), setup=cause.setup(bare, theta),
                           refined=dict(best.refined or {}), undecidable=undecidable)
            ll = scorer.initial_loglik(fit, scale)
            trials.append((ll if np.isfinite(ll) else -np.inf, len(trials), fit))
            if i == (1 if len(other.theta) else 0) and extra is values[-1]:
                own = fit
    _, _, start = max(trials, key=lambda x: (x[0], -x[1]))
    starts = [start] if own is None or own is start else [start, own]
    out = min((scorer.refine(f, max_nfev=FILTER_EVALUATIONS) for f in starts), key=lambda f: f.score)
    out.setup = cause.setup(ctx, out.theta)
    return out


def _filter_restart(ctx: Context, scorer: FilterScores, small: CauseFit, large: CauseFit) -> CauseFit:
    """``small`` refined by the filter-error method from the solution of
    ``large``, a richer model holding it (the baseline in a cause, a cause in
    a pair), its extra effect left out; the better scored of that and
    ``small``. A richer model's fit may find better values of the parameters
    the two share (the fits stop after a few evaluations); without this its
    gain would be credited to its extra effect."""
    theta = _nested_theta(small, large)
    if theta is None:
        return small
    params = {**small.params, **{k: v for k, v in large.params.items() if k in small.params}}
    trial = scorer.refine(replace(small, theta=theta, params=params, setup=small.cause.setup(ctx, theta)),
                          max_nfev=FILTER_EVALUATIONS)
    return trial if trial.score < small.score else small


def _filter_settled(ctx: Context, scorer: FilterScores, small: CauseFit, richer: list) -> CauseFit:
    """``small`` restarted (:func:`_filter_restart`) from the richer fits that
    score better than it by the evidence margin, best first, at most
    :data:`RESTARTS`."""
    better = sorted((f for f in richer if f.score < small.score - EVIDENCE), key=lambda f: f.score)[:RESTARTS]
    for f in better:
        small = _filter_restart(ctx, scorer, small, f)
    return small


def _filter_refined(ctx: Context, scorer: FilterScores, fits: list) -> list:
    """The baseline and the :data:`FILTER_REFINED` causes with the best
    prediction-error scores refined by the filter-error method (the others
    keep their output-error solutions, and their scores there, which the
    filter-error fit could only lower); the baseline then restarted from the
    causes that beat it (:func:`_filter_settled`)."""
    scorer.score(fits)
    ranked = sorted((f for f in fits[1:] if f.refined is not None and f.setup.dynamics is None),
                    key=lambda f: f.score)[:FILTER_REFINED]
    fits = [scorer.refine(f, max_nfev=FILTER_EVALUATIONS) if (f is fits[0] or f in ranked) else f
            for f in fits]
    base = _filter_settled(ctx, scorer, fits[0], [f for f in fits[1:] if f.setup.dynamics is None])
    return [base] + fits[1:]


#: causes refined by the filter-error method after the output-error fits (the baseline is always)
FILTER_REFINED = 3

#: evaluations of a filter-error refinement (each costs one filter pass per training record
#: and parameter for its Jacobian)
FILTER_EVALUATIONS = 12

#: single causes tried as a second cause on top of the first, at most
SECOND_CANDIDATES = 6

#: a second cause judged on held-out records must lower the first's windowed
#: validation error by this fraction at least
SECOND_HELD_OUT_GAIN = 0.25


def second_candidates(fits: list, baseline: CauseFit, best: CauseFit) -> list:
    """The causes tried on top of ``best``, best score first, at most
    :data:`SECOND_CANDIDATES`: those that alone explain the training records
    clearly better than the baseline come first, and the others too. A second
    effect may show only beside the first: the baseline's own asymmetric
    terms absorb a rudder offset on the training manoeuvres, so the offset
    alone does not beat it. Never ``best`` itself, a pair, or a cause with
    its own dynamics."""
    if isinstance(best.cause, Combined) or best.cause.replaces_dynamics:
        return []
    others = [f for f in fits if f is not baseline and f.cause.id != best.cause.id
              and not f.cause.replaces_dynamics]
    return sorted(others, key=lambda f: f.score)[:SECOND_CANDIDATES]


def second_held_out(pair: CauseFit, best: CauseFit) -> bool:
    """The pair predicts the held-out records much better than ``best`` alone:
    its windowed validation error lower by :data:`SECOND_HELD_OUT_GAIN`, in a
    significant majority of windows (:func:`held_out_evidence`), losing none.
    A second effect the training records alone cannot show (the baseline's
    own asymmetric terms absorb a rudder offset on the training manoeuvres,
    not on others) is named this way. Never a missing term added to ``best``:
    its terms are chosen from a library by the training records, and terms
    they do not show are noise fitted there, whose coefficients may still
    bend the replay of another manoeuvre by a quarter."""
    if pair.undecidable or breaks_down(pair, best):
        return False
    parts = (getattr(pair.cause, "first", None), getattr(pair.cause, "second", None))
    if any(isinstance(c, MissingTerm) and c.id != best.cause.id for c in parts):
        return False
    return _plainly_better_held_out(pair, best)


def _plainly_better_held_out(fit: CauseFit, reference: CauseFit) -> bool:
    """``fit``'s windowed validation error lower than ``reference``'s by
    :data:`SECOND_HELD_OUT_GAIN`, in a significant majority of the windows
    (:func:`held_out_evidence`, :data:`HELD_OUT_P`)."""
    _, _, p = held_out_evidence(fit, reference)
    return p < HELD_OUT_P and fit.validation_rmse < (1.0 - SECOND_HELD_OUT_GAIN) * reference.validation_rmse


def second_cause(pairs: list, best: CauseFit) -> CauseFit | None:
    """The pair named as first plus second cause: among the pairs preferred
    to ``best`` on the training score (:func:`_gains`) the lowest score;
    failing those, among the pairs preferred on the held-out records
    (:func:`second_held_out`) the lowest validation error; else None."""
    by_score = [f for f in pairs if _gains(f, best)]
    if by_score:
        return min(by_score, key=lambda f: f.score)
    held_out = [f for f in pairs if second_held_out(f, best)]
    return min(held_out, key=lambda f: f.validation_rmse) if held_out else None


def _score_change(reference: CauseFit, fit: CauseFit, only: str = "") -> str:
    """How ``fit``'s score compares with ``reference``'s, in words
    (``only`` = ``"only "`` for a drop that falls short)."""
    d = reference.score - fit.score
    return f"score lower by {only}{d:.1f}" if d > 0 else f"score higher by {-d:.1f}"


def second_on_held_out_note(pair: CauseFit | None, best: CauseFit) -> str | None:
    """The note that says a pair was named on the held-out records (None when
    there is no pair or the training score alone names it)."""
    if pair is None or _gains(pair, best):
        return None
    better, n, p = held_out_evidence(pair, best)
    train = _score_change(best, pair, "only ")
    return (f"second cause of {pair.cause.id} named on the held-out records: the pair predicts {better} of {n} "
            f"validation windows better than {best.cause.id} alone ({pair.validation_rmse:.4g} against "
            f"{best.validation_rmse:.4g} m, Wilcoxon signed-rank p = {p:.2g}); the training records alone "
            f"do not show it ({train}; {EVIDENCE:g} needed)")


def _validated(ctx: Context, fit: CauseFit) -> CauseFit:
    """Prediction error on the validation records: whole records (``fit.whole``,
    with their replays under ``"predictions"`` for the figures) and windows
    (``fit.validation``)."""
    fit.whole = dict(validate(ctx, fit, keep=True, whole=True))
    validate(ctx, fit)
    return fit


def breaks_down(fit: CauseFit, reference: CauseFit) -> list:
    """Validation records whose whole replay diverges with ``fit`` but not with
    ``reference``: such an extension predicts a few minutes well and then
    loses the ship, and is not named whatever its windowed error."""
    return sorted(set(fit.whole.get("diverged", [])) - set(reference.whole.get("diverged", [])))


def not_named(fit: CauseFit, reference: CauseFit, near_gain: float = 0.10) -> str | None:
    """Why ``fit``, which predicts the validation records better than the
    baseline ``reference``, is not preferred to it (None when it is, or when
    it predicts no better): its whole replay diverges (:func:`breaks_down`),
    or, for a windowed gain of at least ``near_gain``, the training records
    give too little evidence for it (score not lower by :data:`EVIDENCE`).
    A near miss is worth reading: the cause may be real and the training
    records too poor to show it."""
    b, v = reference.validation_rmse, fit.validation_rmse
    if fit is reference or not v < b:
        return None
    if fit.undecidable and fit.score < reference.score - EVIDENCE:
        values = compact_parameters(fit.cause.parameters(fit.theta, fit.params))
        why, manoeuvre = fit.undecidable
        return (f"{fit.cause.id} ({values}) not named although it explains the records better: "
                f"{why}; {manoeuvre} would decide it")
    lost = breaks_down(fit, reference)
    if lost and fit.score < reference.score:
        return (f"{fit.cause.id} not named: its prediction of {', '.join(lost)} diverges "
                "(the baseline's does not), although its windowed error is lower")
    if fit.cause.replaces_dynamics:
        better, n, p = held_out_evidence(fit, reference)
        if lost or p < HELD_OUT_P:
            return None
        return (f"{fit.cause.id} not named: it predicts {better} of {n} held-out windows better than the "
                f"baseline ({v:.4g} against {b:.4g} m), not significantly (Wilcoxon signed-rank p = {p:.2g})")
    if not lost and v < (1.0 - near_gain) * b and fit.score >= reference.score - EVIDENCE:
        evidence = _score_change(reference, fit, "only ")
        values = compact_parameters(fit.cause.parameters(fit.theta, fit.params))
        return (f"{fit.cause.id} ({values}) not named: it predicts the held-out records better ({v:.4g} against "
                f"{b:.4g} m, {100 * (1 - v / b):.0f} % less) but the training records give too little "
                f"evidence for it ({evidence}; {EVIDENCE:g} needed)")
    return None


#: one-sided p-value below which held-out windows support a cause that replaces
#: the baseline's dynamics (about the evidence of :data:`EVIDENCE`)
HELD_OUT_P = 0.01


def held_out_evidence(fit: CauseFit, reference: CauseFit) -> tuple[int, int, float]:
    """Windows of the validation records that ``fit`` predicts better than
    ``reference``: ``(better, windows, p)``, ``p`` the one-sided Wilcoxon
    signed-rank test (``scipy.stats.wilcoxon``) that the paired log errors of
    ``fit`` are lower (a sign test that also weighs by how much)."""
    from scipy.stats import wilcoxon

    a = np.asarray(fit.validation.get("windows", []), float)
    b = np.asarray(reference.validation.get("windows", []), float)
    if len(a) == 0 or len(a) != len(b) or not (np.all(a > 0) and np.all(b > 0)):
        return 0, 0, 1.0
    d = np.log(a) - np.log(b)
    d = d[d != 0]
    if len(d) == 0:
        return 0, 0, 1.0
    return int(np.sum(d < 0)), len(d), float(wilcoxon(d, alternative="less").pvalue)


def _gains(fit: CauseFit, reference: CauseFit) -> bool:
    """``fit`` is preferred to ``reference``: score lower by :data:`EVIDENCE`,
    windowed validation error lower, and no validation record lost; never
    when the training records cannot decide for it (``fit.undecidable``).
    Scored by the prediction-error likelihood, the held-out records judge by
    theirs: preferred when it is higher, or when it is lower but undecided
    (2 ln of the likelihood ratio above -:data:`EVIDENCE`) and the windowed
    validation error is lower.

    A cause that replaces the baseline's dynamics by a physical model
    (``propulsion``: the MMG model) is judged on the held-out records instead
    of the training score: its effect (thrust rising as the ship slows at
    constant rpm) lies outside the states the training records cover, which
    a flexible polynomial baseline fits at least as closely. It is preferred
    when it predicts the held-out records better in a significant majority of
    their windows (:func:`held_out_evidence`, :data:`HELD_OUT_P`) and loses none of them.
    """
    if fit.undecidable:
        return False
    if fit.cause.replaces_dynamics:
        better, n, p = held_out_evidence(fit, reference)
        return (p < HELD_OUT_P and fit.validation_rmse < reference.validation_rmse
                and not breaks_down(fit, reference))
    held = _held_out_likelihoods(fit, reference)
    if held is not None:
        # prediction-error scores: the held-out records' likelihood judges; an effect that barely
        # acts on the held-out manoeuvres leaves it undecided (2 ln of its ratio above -EVIDENCE),
        # and the replayed held-out windows decide
        return fit.score < reference.score - EVIDENCE and (held[0] > held[1] or (
            2.0 * (held[0] - held[1]) > -EVIDENCE and fit.validation_rmse < reference.validation_rmse))
    return (fit.score < reference.score - EVIDENCE and fit.validation_rmse < reference.validation_rmse
            and not breaks_down(fit, reference))


#: training evidence (lower score, 2 ln of the likelihood ratio) on which a cause is named
#: although the held-out records do not show it: five times :data:`EVIDENCE`
STRONG_EVIDENCE = 5.0 * EVIDENCE


def training_decides(fit: CauseFit, reference: CauseFit) -> bool:
    """The training records alone name ``fit`` over ``reference``: score lower
    by :data:`STRONG_EVIDENCE`, decidable on them, no validation record's
    whole replay diverging where the reference's does not (:func:`breaks_down`),
    and not a cause that replaces the dynamics (judged on held-out records,
    see :func:`_gains`). The held-out manoeuvre may barely excite a real effect
    (a side force on a zig-zag, a current on a short record), or excite it
    where the refined baseline's other coefficients have absorbed it: then it
    predicts them no better, and without this an effect the training records
    show beyond doubt would be refused. Used for the first cause only; a
    second cause still needs :func:`_gains` or :func:`second_held_out`."""
    return (not fit.undecidable and not fit.cause.replaces_dynamics
            and fit.score < reference.score - STRONG_EVIDENCE and not breaks_down(fit, reference))


def held_out_decides(fit: CauseFit, reference: CauseFit) -> bool:
    """The held-out records name ``fit`` over ``reference`` when the training
    records lower its score, but by less than the evidence needed: its
    windowed validation error lower by :data:`SECOND_HELD_OUT_GAIN` in a
    significant majority of the windows (:func:`held_out_evidence`,
    :data:`HELD_OUT_P`), decidable on the training records, no held-out
    replay diverging (:func:`breaks_down`); the rule that names a second
    cause (:func:`second_held_out`). Records whose noise is coloured are
    scored on few effective samples, and an effect they show plainly on the
    held-out manoeuvre may lower the training score by only a few units."""
    if fit.undecidable or fit.cause.replaces_dynamics or not fit.score < reference.score:
        return False
    return not breaks_down(fit, reference) and _plainly_better_held_out(fit, reference)


def named_on_held_out_windows(fit: CauseFit, reference: CauseFit) -> str | None:
    """The note that says a cause was named on the held-out windows
    (:func:`held_out_decides`) although its training evidence falls short;
    None otherwise."""
    if (fit is reference or fit.cause.replaces_dynamics or _gains(fit, reference)
            or training_decides(fit, reference) or not held_out_decides(fit, reference)):
        return None
    better, n, p = held_out_evidence(fit, reference)
    return (f"{fit.cause.id} is named on the held-out records: it predicts {better} of {n} validation windows "
            f"better than the baseline ({fit.validation_rmse:.4g} against {reference.validation_rmse:.4g} m, "
            f"Wilcoxon signed-rank p = {p:.2g}); the training records alone do not show it "
            f"({_score_change(reference, fit, 'only ')}; {EVIDENCE:g} needed)")


def named_on_training(fit: CauseFit, reference: CauseFit) -> str | None:
    """The note that says a cause was named on the training records' evidence
    alone (:func:`training_decides`, not :func:`_gains`), and why the held-out
    records do not confirm it; None otherwise."""
    if fit is reference or _gains(fit, reference) or not training_decides(fit, reference):
        return None
    b, v = reference.validation_rmse, fit.validation_rmse
    held = _held_out_likelihoods(fit, reference)
    if held is not None and v < b:
        why = (f"their prediction-error likelihood does not favour it (2 ln of its ratio "
               f"{2.0 * (held[0] - held[1]):.1f}), although its replay of them is closer "
               f"({v:.4g} against the baseline's {b:.4g} m)")
    else:
        why = f"it predicts them no better ({v:.4g} against the baseline's {b:.4g} m)"
    return (f"{fit.cause.id} is named on the training records' evidence ({_score_change(reference, fit)}; "
            f"{STRONG_EVIDENCE:g} needed without the held-out records' support); the held-out records do "
            f"not confirm it: {why}. A manoeuvre that excites it more would.")


def _held_out_likelihoods(fit: CauseFit, reference: CauseFit) -> tuple | None:
    """The held-out records' prediction-error log-likelihoods of ``fit`` and
    ``reference`` (:meth:`.prediction_error.FilterScores.held_out`), or None
    when either was not scored that way."""
    a = ((fit.refined or {}).get("filter") or {}).get("held_out_loglik")
    b = ((reference.refined or {}).get("filter") or {}).get("held_out_loglik")
    return None if a is None or b is None else (a, b)


def named_on_held_out(fit: CauseFit, reference: CauseFit) -> str | None:
    """The note that says why a cause replacing the dynamics was named on
    held-out evidence (None for other causes)."""
    if not fit.cause.replaces_dynamics or fit is reference:
        return None
    better, n, p = held_out_evidence(fit, reference)
    train = _score_change(reference, fit)
    return (f"{fit.cause.id} is judged on the held-out records: it predicts {better} of {n} validation "
            f"windows better than the baseline (Wilcoxon signed-rank p = {p:.2g}); the training records alone "
            f"do not show it ({train}), their states lie where the baseline's polynomial fits well")


#: nested restarts tried when richer models replay the records better than the model they hold
RESTARTS = 3


def _settled_baseline(ctx: Context, fits: list, windows, sigma) -> list:
    """The refined fits with the baseline (first) restarted from the solutions
    of the (at most :data:`RESTARTS`) causes that replay the training records
    best, when they do so better than it (:func:`.output_error.restart_from`);
    if the baseline moves, the causes that now replay worse than it are
    refined again from it. Without this a cause at no effect could beat a
    baseline caught in a worse local minimum, and be named."""
    base = fits[0]
    better = sorted((f for f in fits[1:] if f.refined is not None and f.refined["rss"] < base.refined["rss"]),
                    key=lambda f: f.refined["rss"])[:RESTARTS]
    for f in better:
        base = restart_from(ctx, base, f, windows, sigma)
    if base is fits[0]:
        return fits
    log.info("baseline restarted from a cause's solution: data residual %.1f -> %.1f", fits[0].refined["rss"],
             base.refined["rss"])
    out = [base]
    for f in fits[1:]:
        if f.refined is not None and f.refined["rss"] > base.refined["rss"]:
            again = refine_cause(ctx, replace(f, refined=None), base, windows, sigma, own=False)
            f = again if again.refined["rss"] < f.refined["rss"] else f
        out.append(f)
    return out


def _settled_first(ctx: Context, best: CauseFit, pairs: list, windows, sigma) -> CauseFit:
    """``best`` restarted from the solutions of the (at most :data:`RESTARTS`)
    pairs holding it that replay the training records better than it
    (:func:`.output_error.restart_from`): a pair must not be credited with
    what its start let the first cause's coefficients find."""
    better = sorted((f for f in pairs if f.refined is not None and f.refined["rss"] < best.refined["rss"]),
                    key=lambda f: f.refined["rss"])[:RESTARTS]
    for f in better:
        best = restart_from(ctx, best, f, windows, sigma)
    return best


def _baseline_by_output_error(ctx: Context, thin: Context, regression: CauseFit, windows, sigma) -> CauseFit:
    """The baseline refined by output error from two regression solutions, the
    one that replays the training records better kept: on the thinned records
    (``regression``) and on the same records with their velocities and heading
    smoothed by the kinematic Kalman filter (:func:`.fitting.kinematic_smoothing`).
    The output-error fit has local minima, and which a start falls into
    depends on how the regression's noisy coefficients are bent (on 3 %
    noise two such starts ended 30 apart in the sum of squares, the better
    with a third of the other's coefficient error)."""
    smooth = replace(thin, train=[kinematic_smoothing(r) for r in thin.train], derivative="central")
    calibrate(smooth)
    bests = []
    for start in (regression, fit_cause(smooth, NoCause())):
        base = refine(ctx, start, windows, sigma)
        # once more from its own solution: the prior then centres where the
        # extensions by terms start (see terms_by_output_error), a fair comparison
        bests.append(refine(ctx, base, windows, sigma, states=base.refined["states"]))
    return min(bests, key=lambda f: f.refined["rss"])


def _candidate_fits(ctx: Context, threshold: float, max_terms: int, refined: bool, windows, sigma,
                    scoring=output_error_scores):
    """Every applicable cause fitted (and refined, when ``refined``); returns
    ``(fits, selected terms, candidate terms)``, the baseline first."""
    if refined:
        # the regression fits are only starts of the output-error fits: on the records thinned
        # as the windows are (block means), a tenth of the rows
        thin = replace(ctx, train=[block_means(r, windows[0].step) for r in ctx.train])
        calibrate(thin)
        ctx.sigma, ctx.n_rows, ctx.tau, ctx.n_eff = thin.sigma, thin.n_rows, thin.tau, thin.n_eff
        fits = [fit_cause(thin, cause) for cause in manoeuvring_causes(ctx)]
        rescore(thin, fits)
        base = _baseline_by_output_error(ctx, thin, fits[0], windows, sigma)
        # a cause with its own dynamics (propulsion) is not refined by the baseline's replays
        fits = [base] + [f if f.setup.dynamics is not None else
                         refine_cause(ctx, f, base, windows, sigma) for f in fits[1:]]
        fits = _settled_baseline(ctx, fits, windows, sigma)
        base = fits[0]
        terms, missing, candidates = terms_by_output_error(ctx, base, windows, sigma, max_terms, scoring=scoring,
                                                           rivals=
                                                           [f for f in fits if f.refined is not None])
        if missing is not None:
            fits.append(missing)
        return fits, terms, candidates
    _, residuals = calibrate(ctx)
    _, _, problems = regression_fit(ctx, Setup(ctx.model, ctx.train))
    candidates = select_missing_terms(ctx, residuals, problems, threshold, max_terms)
    base = fit_cause(ctx, MissingTerm([])).score
    have = {t.name for t in candidates}
    candidates += [t for t in screen_terms(ctx, base) if t.name not in have]
    terms = forward_select(ctx, candidates, base) if candidates else []
    fits = [fit_cause(ctx, cause) for cause in manoeuvring_causes(ctx, terms)]
    rescore(ctx, fits)
    return fits, terms, candidates


def _velocities_misread(records) -> str | None:
    """Why the prediction-error likelihood would misread the records'
    velocities, as the note that says so (None when it would not): coloured
    noise (:func:`.kinematics.coloured_velocity_noise`), which the filter
    takes for process noise and follows with any model; or velocities derived
    from the track (:func:`.kinematics.derived_velocities`), which it takes
    for independent sensors, weighing the track's noise twice."""
    if coloured_velocity_noise(records):
        return ("velocity noise correlated over seconds (coloured): causes scored by output error, "
                "not by the prediction-error likelihood, which would take that noise for process noise")
    if derived_velocities(records):
        return ("velocities derived from the track (their noise is a filtered copy of the position and "
                "heading noise): causes scored by output error, not by the prediction-error likelihood, "
                "which takes them for independent sensors")
    return None


def search(ctx: Context, threshold: float = 0.1, max_terms: int = 3, second: bool = True,
           posterior_steps: int = 40, seed: int = 0, output_error="auto", intervals: bool = True,
           score: str = "prediction_error") -> dict:
    """Fit every applicable cause, rank them, pick one, try a second, get intervals.

    Two ways of fitting and scoring, chosen by ``output_error``
    (:func:`.output_error.needs_refinement`: ``"auto"`` takes the second on
    noisy records):

    - equation error (:mod:`.fitting`): causes are fitted by regression and
      scored by BIC on the force residual; missing terms come from sparse
      regression and single-term screening;
    - output error (:mod:`.output_error`): every cause is then refined by
      replaying the training records and scored by BIC on the replay's
      residual; missing terms come from score tests at the refined baseline.
      With ``score="prediction_error"`` (the default) the refined causes are
      then scored, the best refined again, by the extended Kalman filter's
      innovation likelihood (:mod:`.prediction_error`), and the held-out
      records' one-step-ahead likelihood judges them; not when the
      velocities carry coloured noise (:func:`.kinematics.coloured_velocity_noise`),
      which the filter would take for process noise, or are derived from the
      track (:func:`.kinematics.derived_velocities`), which the filter would
      take for independent sensors (``result["notes"]`` says so).

    Every fit is replayed on the validation records, in windows and whole. A
    cause is chosen over ``none`` only when its score is lower by
    :data:`EVIDENCE`, its windowed prediction error on the validation
    records is lower than the baseline's, and its whole replay of no
    validation record diverges where the baseline's does not
    (:func:`breaks_down`), or when its score is lower by
    :data:`STRONG_EVIDENCE` and no validation record diverges
    (:func:`training_decides`), or when its score is lower and the held-out
    windows show it plainly (:func:`held_out_decides`); among those, the
    lowest score wins. The winner's
    90 % intervals come from emcee unless ``intervals`` is false.
    """
    output_error = needs_refinement(ctx, output_error, noise_levels(ctx, ctx.train))
    windows = training_windows(ctx, ctx.train) if output_error else None
    sigma = noise_levels(ctx, ctx.train, windows[0].step) if windows else None
    scale, scorer, notes = None, None, []
    misread = _velocities_misread(ctx.train) if output_error and score == "prediction_error" else None
    if misread is not None:
        score = "output_error"
        notes.append(misread)
        log.info("%s", misread)
    if output_error and score == "prediction_error":
        scorer = FilterScores(ctx, windows[0].step, sigma)
        scoring = scorer.score
    else:
        def scoring(fits):
            return output_error_scores(fits, scale, ctx)
    fits, terms, candidates = _candidate_fits(ctx, threshold, max_terms, output_error, windows, sigma,
                                              scoring)
    if output_error:
        scale = output_error_scores(fits, ctx=ctx)
        scoring(fits)
    if scorer is not None:
        fits = _filter_refined(ctx, scorer, fits)
        held_out = FilterScores(ctx, windows[0].step, sigma, ctx.validation)
        held_out.held_out(fits, scorer)
    for fit in fits:
        _validated(ctx, fit)
        log.info("cause %-18s score %.1f validation %.4g, whole records %.4g%s (%.1f s)", fit.cause.id,
                 fit.score, fit.validation_rmse, fit.whole["position_rmse"],
                 f" (diverges on {', '.join(fit.whole['diverged'])})" if fit.whole["diverged"] else "",
                 fit.seconds)
    baseline = fits[0]
    gaining = [f for f in fits if f is not baseline and (_gains(f, baseline) or training_decides(f, baseline)
                                                          or held_out_decides(f, baseline))]
    if any(f.cause.replaces_dynamics for f in gaining):
        # scores on different models' residuals do not compare: the held-out error decides
        best = min(gaining, key=lambda f: f.validation_rmse)
    else:
        best = min(gaining, key=lambda f: f.score) if gaining else baseline
    out = {"baseline": baseline, "fits": fits, "best": best, "terms": terms, "candidates": candidates,
           "second": None, "output_error": output_error, "notes": notes,
           "score": "prediction error" if scorer is not None else
           ("output error" if output_error else "equation error")}
    if second and best is not baseline and scorer is not None:
        out["pairs"] = [_filter_pair(ctx, scorer, best, other) for other in second_candidates(fits, baseline, best)]
        settled = _filter_settled(ctx, scorer, best, out["pairs"])
        if settled is not best:
            held_out.held_out([settled], scorer)
            fits[fits.index(best)] = best = out["best"] = _validated(ctx, settled)
        out["pairs"] = [_validated(ctx, f) for f in out["pairs"]]
        held_out.held_out(out["pairs"], scorer)
        for fit in out["pairs"]:
            log.info("pair  %-30s score %.1f validation %.4g", fit.cause.id, fit.score, fit.validation_rmse)
        out["second"] = second_cause(out["pairs"], best)
    elif second and best is not baseline:
        out["pairs"] = [_validated(ctx, _pair(ctx, best, other, windows, sigma))
                        for other in second_candidates(fits, baseline, best)]
        if output_error:
            settled = _settled_first(ctx, best, out["pairs"], windows, sigma)
            if settled is not best:
                fits[fits.index(best)] = best = out["best"] = _validated(ctx, settled)
                scoring(fits)
            scoring(out["pairs"])
        for fit in out["pairs"]:
            log.info("pair  %-30s score %.1f validation %.4g (%.1f s)", fit.cause.id, fit.score,
                     fit.validation_rmse, fit.seconds)
        out["second"] = second_cause(out["pairs"], best)
    if not intervals:
        out["posterior"] = {}
    elif scorer is not None and best is not baseline and (best.refined or {}).get("filter"):
        out["posterior"] = scorer.posterior(best, steps=posterior_steps, seed=seed)
    elif best.refined is not None and best is not baseline:
        out["posterior"] = refined_posterior(ctx, best, steps=posterior_steps, seed=seed)
    else:
        out["posterior"] = posterior(ctx, best, steps=posterior_steps, seed=seed) if len(best.theta) else {}
    return out
