"""Named model terms: the one description that every part of `studies` uses.

A manoeuvring model is a set of :class:`Term` per degree of freedom. Each term
is a monomial of the prime states ``u' = (u - U0) / U``, ``v' = v / U``,
``r' = r L / U`` and the rudder angle ``delta`` [rad], multiplied by one
hydrodynamic coefficient named as in the thesis tables (``Yvvr`` multiplies
``v'^2 r'`` in the sway equation). The simulator evaluates forces from the
terms' exponents, the regression matrix of LS/SVM/emcee is the stack of the
terms' features, SINDy's library and the GA's genes are the same list.

Names of extra terms follow the same pattern: letters ``u``, ``v``, ``r``,
``d`` repeated by their exponent, in that order; a term of ``u'`` alone in
sway/yaw is written ``Y0u``, ``Y0uu`` as in the Abkowitz tables, the constant
is ``Y0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np

__all__ = ["DOFS", "STATE_SYMBOLS", "Term", "monomial_name", "candidate_terms"]

DOFS = ("X", "Y", "N")
STATE_SYMBOLS = ("u", "v", "r", "d")


@dataclass(frozen=True)
class Term:
    """One coefficient of a manoeuvring model.

    Attributes
    ----------
    name : str
        Coefficient name, e.g. ``"Yvvr"``.
    dof : str
        ``"X"`` (surge force), ``"Y"`` (sway force) or ``"N"`` (yaw moment).
    powers : tuple of 4 int
        Exponents of ``(u', v', r', delta)``.
    """

    name: str
    dof: str
    powers: tuple[int, int, int, int]

    @property
    def key(self) -> tuple:
        """What makes two terms the same feature: DOF, exponents, the exponent of
        the thrust loading and whether it is a cross-flow integral (0 and False
        but for :class:`~studies.models.mmg.MMGTerm`)."""
        return self.dof, self.powers, int(getattr(self, "thrust", 0)), bool(getattr(self, "crossflow", False))

    @property
    def dof_index(self) -> int:
        return DOFS.index(self.dof)

    @property
    def order(self) -> int:
        return int(sum(self.powers))

    def feature(self, primes: np.ndarray) -> np.ndarray:
        """Evaluate the monomial on prime states.

        Parameters
        ----------
        primes : ndarray, shape (n, 4)
            Columns ``u', v', r', delta``.
        """
        primes = np.asarray(primes, dtype=float)
        out = np.ones(primes.shape[0])
        for j, p in enumerate(self.powers):
            if p:
                out = out * primes[:, j] ** p
        return out


def monomial_name(dof: str, powers) -> str:
    """Canonical coefficient name of a monomial (see module docstring)."""
    a, b, c, d = (int(p) for p in powers)
    body = "u" * a + "v" * b + "r" * c + "d" * d
    if dof in ("Y", "N") and (b + c + d) == 0:
        return f"{dof}0{body}"
    if not body:
        return f"{dof}0"
    return dof + body


def candidate_terms(dof: str, max_order: int = 3, include_constant: bool = True) -> list[Term]:
    """All monomials of ``u', v', r', delta`` up to ``max_order`` for one DOF.

    This is the extended candidate library of sparse regression (SINDy) and
    of the ``missing_term`` cause.
    """
    terms = []
    for powers in product(range(max_order + 1), repeat=4):
        order = sum(powers)
        if order > max_order or (order == 0 and not include_constant):
            continue
        terms.append(Term(monomial_name(dof, powers), dof, tuple(powers)))
    terms.sort(key=lambda t: (t.order, t.powers[::-1]))
    return terms
