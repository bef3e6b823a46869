"""``missing_term``: hydrodynamic terms the baseline's polynomial lacks, and
the library they are chosen from (:func:`extended_library`)."""

from __future__ import annotations

import numpy as np

from ...models.abkowitz import ManoeuvringModel
from ...models.terms import candidate_terms
from .base import Cause

__all__ = ["MissingTerm", "extended_library"]


class MissingTerm(Cause):
    """Terms of the extended candidate library that the baseline lacks.

    One term of the extended library is a variant of the cause: the
    inference compares every variant (:func:`studies.discovery.innovations.cause_variants`,
    :func:`studies.discovery.inference.infer`) and charges the number of
    variants in its score; the extended model is then identified by LS, so
    the terms' coefficients come out of the regression (no outer search).

    Parameters
    ----------
    terms : sequence of Term
        The added terms; their prime coefficients [-] are written under
        ``terms`` by name. No effect without terms (the cause is then not
        applicable); changes only :meth:`model`.
    """

    id = "missing_term"
    no_effect = {"terms": {}}
    units = {"terms": "-, prime coefficients of the added terms (thesis eq. 3.6 units)"}
    explanation = ("A hydrodynamic effect the model's polynomial does not contain (e.g. a cubic yaw "
                   "damping Nrrr in tight turns): the monomials of u', v', r', delta up to third order "
                   "are compared one by one for the term the records need (its gain in the filter's "
                   "predictions of the tracks, or in held-out blocks of the force residual).")

    def __init__(self, terms=()):
        self.terms = list(terms)
        self.params = tuple(t.name for t in self.terms)

    @property
    def nl_params(self):
        return ()

    def applicable(self, ctx):
        return bool(self.terms)

    def model(self, ctx, theta):
        return ctx.model.extended(self.terms, f"{ctx.model.name}+" + "+".join(self.params))

    def parameters(self, theta, fitted=None):
        fitted = fitted or {}
        return {"terms": {name: float(fitted.get(name, np.nan)) for name in self.params}}


def extended_library(model: ManoeuvringModel, max_order: int = 3) -> list:
    """Candidate terms (monomials up to ``max_order``) the model does not have."""
    have = {t.key for t in model.terms}
    return [t for dof in ("X", "Y", "N") for t in candidate_terms(dof, max_order)
            if t.key not in have]
