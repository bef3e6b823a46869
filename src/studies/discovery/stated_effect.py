"""An effect stated beforehand, judged by the verdict's own criterion at its
stated parameters: can these records show it at all?

When an effect is injected into records (a rudder-sensor offset, a uniform
current added to a measured track) or hidden in a simulation, its truth is
exact. A discovery that misses it has one of two excuses: the method, or
records too short, too noisy or too gentle to show an effect that small.
This module tells them apart (``discover.injected``): the stated effect acts
at its stated parameters, the baseline's coefficients are re-identified
beside it on the tracks (least squares of the filter's standardised
innovations, under the verdict's filter and noises), and it is scored as
the verdict scores every model (:mod:`.track_inference`)::

    s = E - k ln(n) - 2 ln(m)

``E`` the fall in ``-2 ln L`` (the squared deviance residuals, :mod:`.innovations`) against the
verdict's ``none`` (a likelihood ratio: the verdict credits a cause with
this or the block-robust Wald statistic, whichever is smaller, so ``E`` is
the most the criterion could credit the truth with), ``k`` the effect's
parameters, ``n`` the measured innovations, ``m`` the cause's variants the
verdict compares. ``s < 0``: the stated effect, exactly as it acts, does not
beat ``none`` on these records; no verdict of this criterion names it, and a
criterion that did would name effects in records where none acts. For two
effects, each is also scored beside the other at its stated values, as the
verdict judges a second cause: under the filter whose process noise's scale
is the likeliest with the other acting, the two against the other alone.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from ..errors import ConfigError
from .causes import Combined, MissingTerm, NoCause, extended_library, manoeuvring_causes
from .causes.base import Cause
from .innovations import beside
from .track_inference import _innovations_of

__all__ = ["stated_causes", "score_stated"]

#: evaluations of the filter the coefficients' re-identification beside a stated effect may take
MAX_EVALUATIONS = 40


def stated_causes(ctx, stated: dict) -> list[tuple[Cause, np.ndarray, dict, int]]:
    """``[(cause, theta, added terms, parameters)]`` of the effects ``stated``
    (``{cause id: {parameter: value}}``, the catalogue's ids and units: prime
    coefficients, m/s, rad), in the catalogue's order; a cause the
    discovery does not judge, a parameter missing or unknown is refused in
    one line. A missing term is stated by its coefficients (``{"Nrrr":
    -0.002}``); a parameter the baseline's own coefficients hold (an
    earth-fixed yaw moment beside the model's ``N0``) is left to them."""
    library = {t.name: t for t in extended_library(ctx.model)}
    judged = {c.id: c for c in manoeuvring_causes(ctx, list(library.values()))}
    out = []
    for cid, values in stated.items():
        values = dict(values or {})
        if cid not in judged or cid == "none":
            raise ConfigError(f"discover.injected.{cid}: not a cause this discovery judges "
                              f"({', '.join(c for c in judged if c != 'none')})")
        cause = judged[cid]
        if cause.replaces_dynamics:
            raise ConfigError(f"discover.injected.{cid}: replaces the baseline's process model, so it has no "
                              "stated parameters to score")
        if isinstance(cause, MissingTerm):
            unknown = [n for n in values if n not in library]
            if unknown or not values:
                raise ConfigError(f"discover.injected.missing_term: {unknown[0] if unknown else 'no term'} is not "
                                  f"a term the baseline {ctx.model.name} lacks (its library: monomials of u', v', "
                                  "r', delta up to third order)")
            out.append((MissingTerm([library[n] for n in values]), np.zeros(0),
                        {n: float(v) for n, v in values.items()}, len(values)))
            continue
        missing = [p for p in cause.nl_params if p not in values]
        unknown = [p for p in values if p not in cause.params]
        if missing or unknown:
            raise ConfigError(f"discover.injected.{cid}: "
                              + (f"needs {', '.join(missing)}" if missing else f"has no parameter {unknown[0]}")
                              + f" (its parameters: {', '.join(cause.nl_params)})")
        theta = np.array([float(values[p]) for p in cause.nl_params])
        out.append((cause, theta, {}, len(theta)))
    order = list(judged)
    return sorted(out, key=lambda c: order.index(c[0].id))


def _relative(design, params: dict) -> np.ndarray:
    """Coefficients ``params`` as the design's relative changes (:meth:`InnovationDesign.coefficients_at`)."""
    base = design.fit.params
    return np.array([(float(params.get(n, base.get(n, 0.0))) - float(base.get(n, 0.0))) / float(s)
                     for n, s in zip(design.coefficient_names, design.coefficient_scale)])


def _refit(design, cause: Cause, theta: np.ndarray, terms: dict, starts: list) -> tuple[float, dict]:
    """``(-2 ln L less a constant, coefficients)`` with ``cause`` held
    at ``theta`` (and its added ``terms``), the baseline's coefficients
    re-identified beside it (the design's coefficient Jacobian, SciPy's
    trust-region least squares) from the baseline's and from each of
    ``starts`` (coefficients of the verdict's own fits of these causes: a
    large effect moves them far), the best kept."""
    nb = design.coefficient_jacobian.shape[1]

    def residual(x):
        return np.nan_to_num(design.innovations(cause, theta, terms, coefficients=design.coefficients_at(x)))

    best = None
    tried = [np.zeros(nb)]
    for p in starts:
        x0 = _relative(design, p)
        if not any(np.allclose(x0, t) for t in tried):
            tried.append(x0)
    for x0 in tried:
        res = least_squares(residual, x0, jac=lambda x: design.coefficient_jacobian, method="trf",
                            x_scale="jac", max_nfev=MAX_EVALUATIONS)
        if best is None or res.cost < best.cost:
            best = res
    w = residual(best.x)
    return float(w @ w), design.coefficients_at(best.x)


def _ssq(w: np.ndarray) -> float:
    w = np.nan_to_num(w)
    return float(w @ w)


def _starts(inference, ids: set) -> list:
    """The coefficients of the verdict's fits whose causes are among ``ids``."""
    out = []
    for fit in inference.fits.values():
        cid = fit.cause.id
        if cid != "none" and set(cid.split("+")) <= ids:
            out.append(dict(fit.params))
    for fit in getattr(inference, "beside", {}).values():
        if set(fit.cause.id.split("+")) <= ids:
            out.append(dict(fit.params))
    return out


def _variants(inference, cid: str) -> int:
    return max(sum(1 for v in inference.variants if v.cause.id == cid), 1)


def score_stated(inference, stated: dict) -> dict:
    """The stated effects' score on the records (module docstring), from a
    discovery on the tracks (:func:`.track_inference.infer_on_tracks`, which
    keeps its filter as ``design``).

    Returns
    -------
    dict
        ``causes`` (ids joined by ``+``), ``parameters`` (as stated),
        ``evidence``, ``penalty``, ``score`` of the stated effects together
        against ``none``, ``shown`` (every score of the stated model above 0:
        together, and each beside the other), and for two effects
        ``members``: ``{cause id: {evidence, penalty, score}}`` of each beside
        the other at its stated values.
    """
    design, ctx = inference.design, inference.context
    parts = stated_causes(ctx, stated)
    if not 1 <= len(parts) <= 2:
        raise ConfigError(f"discover.injected: one or two causes, got {len(parts)}")
    n = float(inference.n_rows)
    ssq_none = _ssq(_innovations_of(design, inference.fits[()]))

    def penalty(part):
        cause, _, _, k = part
        return float(k * np.log(n) + 2.0 * np.log(_variants(inference, cause.id)))

    def model(items):
        if len(items) == 1:
            return items[0][0], items[0][1], dict(items[0][2])
        (c1, t1, a1, _), (c2, t2, a2, _) = items
        return Combined(c1, c2), np.concatenate([t1, t2]), {**a1, **a2}

    ids = {p[0].id for p in parts}
    ssq_all, coefficients = _refit(design, *model(parts), _starts(inference, ids))
    # the baseline alone at those coefficients, the nested model at the larger one's fit (the verdict's
    # nesting: only what the stated parameters add is credited)
    bare = _ssq(design.innovations(NoCause(), np.zeros(0), coefficients=coefficients))
    pen = sum(penalty(p) for p in parts)
    evidence = min(ssq_none, bare) - ssq_all
    out = {"causes": "+".join(p[0].id for p in parts),
           "parameters": {cid: dict(v) for cid, v in stated.items()},
           "evidence": float(evidence), "penalty": pen, "score": float(evidence - pen),
           "measure": ("likelihood ratio of the tracks against none under the verdict's filter, the baseline's "
                       "coefficients re-identified beside the stated effect; less k ln n + 2 ln m")}
    scores = [out["score"]]
    if len(parts) == 2:
        out["members"] = {}
        for i, part in enumerate(parts):
            other = parts[1 - i]
            # as the verdict judges a second cause: under the filter whose process noise's scale is the
            # likeliest with the other acting (at its stated values, the coefficients re-identified
            # beside it), the other alone against the two, each with the coefficients re-identified
            _, coefficients = _refit(design, *model([other]), _starts(inference, {other[0].id}))
            under = replace(beside(design, other[0], other[1], other[2], coefficients), base=None)
            ssq_other, _ = _refit(under, *model([other]), [coefficients])
            ssq_pair, _ = _refit(under, *model(parts), [coefficients] + _starts(inference, ids))
            e = ssq_other - ssq_pair
            out["members"][part[0].id] = {"evidence": float(e), "penalty": penalty(part),
                                          "score": float(e - penalty(part))}
            scores.append(e - penalty(part))
    out["shown"] = bool(min(scores) > 0.0)
    return out
