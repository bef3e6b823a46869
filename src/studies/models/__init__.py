"""Manoeuvring models as named term sets (see :mod:`studies.models.terms`)."""

from .abkowitz import ManoeuvringModel, abkowitz
from .terms import DOFS, Term, candidate_terms, monomial_name

__all__ = ["ManoeuvringModel", "abkowitz", "Term", "DOFS", "candidate_terms", "monomial_name"]
