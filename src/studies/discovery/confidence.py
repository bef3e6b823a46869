"""How sure a discovery is: the verdict's confidence, the rivals the records
cannot tell from it, and the manoeuvre that would separate them.

Scores of the ranking are on the ``2 ln`` Bayes-factor scale (BIC
differences, :mod:`studies.discovery.fitting`), so the posterior probability
of each candidate, with equal prior odds, is::

    P(cause) = exp(-score / 2) / sum_j exp(-score_j / 2)

The confidence of a verdict is that probability of the named cause (or of
``none``). A cause without a training score (``propulsion``, judged on the
held-out records) carries ``1 - p`` of its held-out test instead, which is
the confidence that its held-out windows are predicted better, not a model
probability; the report says which it is.

References
----------
Kass, R. E., Raftery, A. E. (1995). Bayes factors. Journal of the American
Statistical Association 90(430), 773-795.
"""

from __future__ import annotations

import numpy as np

__all__ = ["posterior_probabilities", "confidence", "separating_manoeuvre", "certainty", "SEPARATING"]

#: what separates two causes that the training records explain equally well
#: (keyed by the unordered pair of ids; :func:`separating_manoeuvre`)
SEPARATING = {
    frozenset({"rudder_offset", "propeller_asymmetry"}):
        "turning circles to both sides (a propeller's side force grows as the ship slows, a rudder "
        "offset does not)",
    frozenset({"rudder_offset", "missing_term"}):
        "a zig-zag started to the other side (an offset makes the two sides' overshoots differ, a "
        "symmetric hull term does not)",
    frozenset({"rudder_offset", "environmental_bias"}):
        "a turning circle (an earth-fixed force turns with the heading, an offset turns with the ship)",
    frozenset({"current", "wind_unmodelled"}):
        "a manoeuvre at another speed (wind loads scale with the relative wind, a current shifts the "
        "track at any speed)",
    frozenset({"current", "environmental_bias"}):
        "a turning circle at another speed (a current drifts the track at its own speed, a force "
        "pushes the ship by an amount that depends on its speed)",
    frozenset({"wind_unmodelled", "environmental_bias"}):
        "a turning circle (the wind load changes with the relative wind angle as the ship turns)",
    frozenset({"wind_speed_bias", "wind_unmodelled"}):
        "a manoeuvre on another heading to the wind",
    frozenset({"missing_term", "propeller_asymmetry"}):
        "turning circles to both sides",
    frozenset({"propulsion", "missing_term"}):
        "a turning circle at full rudder (the speed lost in a tight turn at constant rpm)",
    frozenset({"roll_quadratic_damping", "roll_cubic_damping"}):
        "a decay released from a larger angle (quadratic and cubic damping part most at large amplitudes)",
    frozenset({"roll_linear_damping", "roll_quadratic_damping"}):
        "decays released from a small and a large angle (linear damping does not change with the amplitude)",
}

#: when no entry of :data:`SEPARATING` applies
DEFAULT_SEPARATING = ("a manoeuvre unlike the training records: a turning circle to the other side, or a "
                      "zig-zag at another speed")


def posterior_probabilities(ranking: list) -> dict:
    """``{cause: probability}`` over the ranked candidates that have a training
    score (``[{"cause", "score"}, ...]``, scores on the 2 ln Bayes-factor scale)."""
    scored = {r["cause"]: float(r["score"]) for r in ranking if r.get("score") is not None}
    if not scored:
        return {}
    s = np.array(list(scored.values()))
    w = np.exp(-(s - s.min()) / 2.0)
    return dict(zip(scored, (w / w.sum()).tolist()))


def confidence(ranking: list, cause: str, held_out_p: float | None = None) -> float:
    """Confidence (0-1) of naming ``cause``: its posterior probability among the
    ranked candidates, or ``1 - held_out_p`` for a cause judged on held-out
    records (no training score)."""
    probs = posterior_probabilities(ranking)
    if cause in probs:
        return float(probs[cause])
    if held_out_p is not None:
        return float(1.0 - held_out_p)
    return float("nan")


def separating_manoeuvre(cause: str, rivals) -> str:
    """The manoeuvre that would separate ``cause`` from ``rivals`` (ids), in words."""
    found = [SEPARATING[frozenset({cause, r})] for r in rivals if frozenset({cause, r}) in SEPARATING]
    return "; ".join(dict.fromkeys(found)) if found else DEFAULT_SEPARATING


def certainty(discovery: dict, held_out_p: float | None = None, undecidable=()) -> None:
    """Add to ``discovery`` its ``confidence`` (:func:`confidence`) and, when
    the records cannot settle the verdict, ``undecided`` (the named cause, then
    its rivals) and ``next_manoeuvre`` (what would separate them).

    The rivals are, first, the causes that explain the training records better
    but that these records cannot decide for, ``undecidable`` as ``(cause id,
    manoeuvre)`` pairs (:meth:`studies.discovery.causes.base.Cause.undecidable`),
    then the ``indistinguishable_from`` causes (scores within the margin),
    with :func:`separating_manoeuvre`."""
    cause = discovery["cause"]
    discovery["confidence"] = confidence(discovery["ranking"], cause, held_out_p)
    discovery["confidence_basis"] = ("1 - p of the held-out test" if cause not in
                                     posterior_probabilities(discovery["ranking"]) else
                                     "posterior probability from the scores")
    rivals = [c for c, _ in undecidable]
    manoeuvres = [m for _, m in undecidable]
    close = [c for c in discovery.get("indistinguishable_from", []) if c not in rivals]
    if close:
        rivals += close
        manoeuvres.append(separating_manoeuvre(cause, close))
    if rivals:
        discovery["undecided"] = [cause] + rivals
        discovery["next_manoeuvre"] = "; ".join(manoeuvres)
