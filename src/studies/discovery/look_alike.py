"""What the records at hand can tell apart: classes of look-alike causes, and
the smallest effect of each cause the records would show.

Two causes whose signatures are nearly alike on the records (a rudder
offset and a propeller's side force in zig-zags: both a nearly constant yaw
moment, :mod:`studies.discovery.alike`) explain the records nearly equally
well. Which of them scores a little higher is then decided by the noise, or
by the criterion's penalty on their numbers of parameters, not by the data;
naming it alone would state more than the records know. So the verdict
names a **class**: the named cause with every rival whose evidence falls
short of it by less than the records need to name a cause at all.

- **Evidence between two causes** is measured on the judge's own scale
  (:class:`Separation`): with block cross-validation, the paired held-out
  gain of one over the other, block by block, over its standard error (the
  statistic that names a cause over ``none``, :mod:`.selection`); on the
  tracks, the difference of their likelihood evidence over ``none`` (twice
  the log-likelihood ratio of the two fitted models, without the BIC's
  penalty on parameters: a penalty is not evidence).
- **A rival joins the class** when the named cause's evidence over it is
  below the threshold the judge names a cause with (with blocks, the same
  Bonferroni quantile; on the tracks, ``ln n``, what one parameter must earn
  to be named over ``none``). A rival that explains the records better than
  the named cause, but costs more parameters, always joins.
- **The class's probability** is the sum of its members' probabilities: the
  probability that the records' cause is one of them.
- **Detection limit** of a cause: its effect, in the direction it was fitted,
  scaled to where its evidence over ``none`` would just reach the naming
  threshold. With block cross-validation it is computed directly: the
  cause's fitted effect is taken out of the records and put back at the size
  that is just named (:func:`studies.discovery.inference._limit_factor`), so
  it exists whatever the records' own evidence for the cause. On the tracks
  (a filter run per trial would be needed) the evidence is scaled: it grows
  as the square of the effect (a log-likelihood ratio), so the limit is the
  fit times ``sqrt(needed / evidence)``, and none is given when the fit has no
  evidence. Below the limit an effect of that cause may act without these
  records showing it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from .causes import pair_id

__all__ = ["Separation", "BlockSeparation", "LikelihoodSeparation", "look_alike_class", "class_probability",
           "detection_limits", "Detectability", "verdict_class"]


@dataclass
class Separation(ABC):
    """How far the records tell one candidate from another, on a judge's scale.

    ``ids``: the candidates (cause ids; for a second cause, the second's id),
    ``threshold``: the evidence that separates, ``measure``: what the evidence is.
    """

    ids: list
    threshold: float
    measure: str

    @abstractmethod
    def evidence(self, a: str, b: str) -> float:
        """The records' evidence for ``a`` over ``b`` (negative: for ``b``)."""

    def table(self, named: str) -> dict:
        """``{rival: evidence of named over it}`` for every other candidate."""
        return {b: float(self.evidence(named, b)) for b in self.ids if b != named}


@dataclass
class BlockSeparation(Separation):
    """Held-out gains per block (``held`` (c, K), rows in the order of ``ids``):
    the evidence for ``a`` over ``b`` is the mean of their blocks' gain
    differences over its standard error (a paired t over the blocks)."""

    held: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def evidence(self, a: str, b: str) -> float:
        d = np.asarray(self.held[self.ids.index(a)], float) - np.asarray(self.held[self.ids.index(b)], float)
        k = len(d)
        if k < 2:
            return float("nan")
        sd = float(np.std(d))
        mean = float(np.mean(d))
        if sd <= 1e-300:
            return float(np.sign(mean) * np.inf) if mean else 0.0
        return mean / (sd / np.sqrt(k))


@dataclass
class LikelihoodSeparation(Separation):
    """Each candidate's evidence over ``none`` (``values``: twice its log-likelihood
    ratio, no penalty): the evidence for ``a`` over ``b`` is the difference."""

    values: dict = field(default_factory=dict)

    def evidence(self, a: str, b: str) -> float:
        return float(self.values[a]) - float(self.values[b])


def look_alike_class(named: str, separation: Separation | None) -> list[str]:
    """The named candidate, then every rival the records cannot tell from it
    (its evidence over the rival below the threshold), the closest first."""
    if separation is None or named not in separation.ids:
        return [named]
    gaps = separation.table(named)
    rivals = sorted((b for b, e in gaps.items() if not e >= separation.threshold), key=lambda b: gaps[b])
    return [named] + rivals


def class_probability(members: list, verdicts: dict, first: str | None = None) -> float:
    """Probability that the records' verdict is one of ``members``: the sum of
    their probabilities in ``verdicts`` (``{verdict id: probability}``), a pair
    of two members counted; with
    ``first``, the members are second causes and their pairs with ``first``
    (ids joined by ``+`` in either order) are summed."""
    total = 0.0
    for vid, p in verdicts.items():
        parts = set(vid.split("+"))
        if first is None:
            # a single member, or a pair of two members (both of the class act)
            hit = parts <= set(members)
        else:
            hit = len(parts) == 2 and first in parts and bool((parts - {first}) & set(members))
        total += float(p) if hit else 0.0
    return float(min(total, 1.0))


@dataclass
class Detectability:
    """A cause's evidence over ``none`` on these records and what naming it needs.

    ``evidence`` and ``needed`` on the judge's scale; ``order``: the power of
    the effect's size that the evidence grows as (1: a t-like statistic, 2: a
    log-likelihood ratio)."""

    evidence: float
    needed: float
    order: int
    #: the limit as a multiple of the fitted effect, where the judge computes it directly
    #: (it then overrides ``(needed / evidence) ** (1 / order)``)
    factor: float | None = None


def detection_limits(causes: dict, candidates: dict, detectability: dict) -> dict:
    """The smallest effect of each cause these records would show.

    Parameters
    ----------
    causes : dict
        ``{cause id: Cause}`` (the catalogue's objects, for their scaling).
    candidates : dict
        ``{cause id: parameters}``: each cause's fit on these records.
    detectability : dict
        ``{cause id: Detectability}``.

    Returns
    -------
    dict
        ``{cause id: parameters at the limit}`` (:meth:`Cause.at_effect`), or
        ``None`` for a cause whose fit explains nothing (no direction to
        scale along) or whose size is not one number.
    """
    out = {}
    for cid, d in detectability.items():
        cause, params = causes.get(cid), candidates.get(cid)
        if d.factor is not None:
            factor = float(d.factor)
        elif np.isfinite(d.evidence) and d.evidence > 0 and d.needed > 0:
            factor = float((d.needed / d.evidence) ** (1.0 / max(d.order, 1)))
        else:
            factor = None
        if cause is None or not params or factor is None:
            out[cid] = None
            continue
        out[cid] = cause.at_effect(params, factor)
    return out


def verdict_class(inference, candidates: dict, beside: dict | None = None) -> dict | None:
    """The named verdict's class of look-alikes (module docstring), or None for
    ``none`` and for a verdict the judge kept no evidence between candidates for.

    Parameters
    ----------
    inference : Inference
        The judge's outcome (:mod:`.inference`, :mod:`.track_inference`): its
        ``named`` model, ``verdicts`` and ``separations``.
    candidates : dict
        ``{cause id: parameters}`` of every single cause fitted on the records.
    beside : dict, optional
        ``{cause id: parameters}`` of the second causes fitted beside the first
        (a pair's class).

    Returns
    -------
    dict
        ``class`` (verdict ids, the named first, then the look-alikes closest
        first), ``parameters`` (``{member: parameters}`` where fitted),
        ``probability`` (that the records' verdict is one of them),
        ``evidence`` (``{rival: the records' evidence for the named over it}``
        for every rival compared, members or not), ``threshold`` and
        ``measure``.
    """
    named = tuple(inference.named)
    if not named:
        return None
    ids = [inference.variants[i].cause.id for i in named]
    if len(ids) == 1:
        separation = inference.separations.get("first")
        members = look_alike_class(ids[0], separation)
        verdicts = members
        probability = class_probability(members, inference.verdicts)
        parameters = {m: candidates[m] for m in members if m in candidates}
    else:
        first, second = ids
        separation = inference.separations.get("second")
        members = look_alike_class(second, separation)
        verdicts = [pair_id(first, m) for m in members]
        probability = class_probability(members, inference.verdicts, first=first)
        found = beside or {}
        parameters = {v: {first: candidates.get(first), m: found[m]} for v, m in zip(verdicts, members)
                      if m in found}
    if separation is None:
        return None
    return {"class": verdicts, "parameters": parameters, "probability": probability,
            "evidence": {b: round(e, 3) for b, e in separation.table(members[0]).items()},
            "threshold": float(separation.threshold), "measure": separation.measure}

