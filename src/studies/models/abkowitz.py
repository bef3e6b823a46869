"""3-DOF Abkowitz manoeuvring model as a set of named terms.

The hydrodynamic forces of thesis eq. 3.5/3.8 (Zhu 2021; Chislett &
Strom-Tejsen 1965 as revised in Fossen & Perez 2004):

    M [u'_dot, v'_dot, r'_dot]^T = [X', Y', N']^T + tau'_wind + tau'_ext

with ``M`` the prime mass matrix of the vessel (thesis eq. 3.7) and each of
``X'``, ``Y'``, ``N'`` a sum of coefficient x monomial of ``u', v', r',
delta`` (see :mod:`studies.models.terms`). The model's terms are its only
definition: the simulator, the regression and the report tables read them.

References
----------
Abkowitz, M.A. (1964). Lectures on ship hydrodynamics - steering and
manoeuvrability. Hydro- and Aerodynamic Laboratory, Lyngby, Report Hy-5.

Zhu, M. (2021). Genetic-algorithm-based parameter identification for ship
manoeuvring model under wind disturbance. MSc thesis, NTNU, eq. 3.4-3.13.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .terms import DOFS, Term

__all__ = ["ManoeuvringModel", "abkowitz", "ABKOWITZ_POWERS"]

# (name, powers of u', v', r', delta) per DOF, in the order of thesis eq. 3.11.
ABKOWITZ_POWERS = {
    "X": [("Xu", (1, 0, 0, 0)), ("Xuu", (2, 0, 0, 0)), ("Xuuu", (3, 0, 0, 0)),
          ("Xvv", (0, 2, 0, 0)), ("Xrr", (0, 0, 2, 0)), ("Xrv", (0, 1, 1, 0)),
          ("Xdd", (0, 0, 0, 2)), ("Xudd", (1, 0, 0, 2)), ("Xvd", (0, 1, 0, 1)),
          ("Xuvd", (1, 1, 0, 1))],
    "Y": [("Yv", (0, 1, 0, 0)), ("Yr", (0, 0, 1, 0)), ("Yvvv", (0, 3, 0, 0)),
          ("Yvvr", (0, 2, 1, 0)), ("Yvu", (1, 1, 0, 0)), ("Yru", (1, 0, 1, 0)),
          ("Yd", (0, 0, 0, 1)), ("Yddd", (0, 0, 0, 3)), ("Yud", (1, 0, 0, 1)),
          ("Yuud", (2, 0, 0, 1)), ("Yvdd", (0, 1, 0, 2)), ("Yvvd", (0, 2, 0, 1)),
          ("Y0", (0, 0, 0, 0)), ("Y0u", (1, 0, 0, 0)), ("Y0uu", (2, 0, 0, 0))],
}
ABKOWITZ_POWERS["N"] = [("N" + name[1:], p) for name, p in ABKOWITZ_POWERS["Y"]]


@dataclass(frozen=True)
class ManoeuvringModel:
    """A named set of terms per degree of freedom.

    Attributes
    ----------
    name : str
        Name of the model (the ``model=`` config option).
    terms : tuple of Term
        All terms, surge first, then sway, then yaw.
    """

    name: str
    terms: tuple[Term, ...]

    def __post_init__(self):
        names = [t.name for t in self.terms]
        if len(set(names)) != len(names):
            raise ValueError(f"model '{self.name}' has duplicated term names")
        keys = [t.key for t in self.terms]
        if len(set(keys)) != len(keys):
            raise ValueError(f"model '{self.name}' has two terms with the same monomial")

    @property
    def names(self) -> list[str]:
        return [t.name for t in self.terms]

    def terms_of(self, dof: str) -> list[Term]:
        """Terms of one DOF (``"X"``, ``"Y"`` or ``"N"``) in model order."""
        return [t for t in self.terms if t.dof == dof]

    def names_of(self, dof: str) -> list[str]:
        return [t.name for t in self.terms_of(dof)]

    def powers_array(self) -> np.ndarray:
        """Exponents as an int array (n_terms, 4) for the compiled simulator."""
        return np.array([t.powers for t in self.terms], dtype=np.int64)

    def dof_array(self) -> np.ndarray:
        """DOF index (0 surge, 1 sway, 2 yaw) of each term, int array."""
        return np.array([t.dof_index for t in self.terms], dtype=np.int64)

    def vector(self, values: dict, default: float | None = None) -> np.ndarray:
        """Coefficient values in term order from a ``{name: value}`` mapping.

        Terms missing from ``values`` take ``default``; with ``default=None``
        a missing term raises ``KeyError`` naming it.
        """
        out = np.empty(len(self.terms))
        for i, term in enumerate(self.terms):
            if term.name in values:
                out[i] = values[term.name]
            elif default is not None:
                out[i] = default
            else:
                raise KeyError(f"no value for coefficient '{term.name}' of model '{self.name}'")
        return out

    def as_dict(self, vector) -> dict:
        return {t.name: float(v) for t, v in zip(self.terms, vector)}

    def features(self, primes: np.ndarray, dof: str) -> np.ndarray:
        """Regression matrix of one DOF: columns are the terms' monomials."""
        terms = self.terms_of(dof)
        return np.column_stack([t.feature(primes) for t in terms]) if terms else np.empty((len(primes), 0))

    def forces(self, primes: np.ndarray, values: dict) -> np.ndarray:
        """Prime hydrodynamic forces (n, 3) = sum of coefficient x feature per DOF."""
        out = np.zeros((len(primes), 3))
        for k, dof in enumerate(DOFS):
            terms = self.terms_of(dof)
            if terms:
                coef = np.array([values[t.name] for t in terms])
                out[:, k] = self.features(primes, dof) @ coef
        return out

    def rudder_yaw_sign(self, values: dict) -> float:
        """Sign of the yaw moment per unit rudder angle at straight course.

        Manoeuvres use it to know which way a positive rudder turns the ship
        (Mariner: ``Nd < 0``, positive rudder gives negative heading).
        """
        for t in self.terms_of("N"):
            if t.powers == (0, 0, 0, 1) and not getattr(t, "thrust", 0):
                return float(np.sign(values[t.name])) or -1.0
        return -1.0

    def extended(self, extra: list[Term], name: str | None = None) -> "ManoeuvringModel":
        """A new model with ``extra`` terms appended (existing ones kept)."""
        have = {t.key for t in self.terms}
        add = [t for t in extra if t.key not in have]
        ordered = []
        for dof in DOFS:
            ordered += self.terms_of(dof) + [t for t in add if t.dof == dof]
        return ManoeuvringModel(name or f"{self.name}+", tuple(ordered))

    def subset(self, names, name: str) -> "ManoeuvringModel":
        """A new model keeping only the terms named in ``names``."""
        keep = set(names)
        unknown = keep - set(self.names)
        if unknown:
            raise KeyError(f"terms not in model '{self.name}': {sorted(unknown)}")
        return ManoeuvringModel(name, tuple(t for t in self.terms if t.name in keep))


def abkowitz() -> ManoeuvringModel:
    """The full 40-coefficient Abkowitz model of the Mariner (thesis eq. 3.8)."""
    terms = []
    for dof in DOFS:
        for name, powers in ABKOWITZ_POWERS[dof]:
            terms.append(Term(name, dof, powers))
    return ManoeuvringModel("abkowitz", tuple(terms))
