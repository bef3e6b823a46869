"""The inverse-dynamics regression that LS, SVM, emcee, SINDy and the GA share.

For each DOF the model's terms give the columns of ``Theta`` and the measured
accelerations times the (known) prime mass matrix give ``y`` (thesis eq.
3.10/3.21, with the thesis' forward difference replaced by an estimator of
:mod:`studies.data.derivatives` or the Kalman smoother of
:mod:`studies.identification.kalman`)::

    X:  m11 u'_dot                 - tau'_X = Theta_X  a
    Y:  m22 v'_dot + m23 r'_dot    - tau'_Y = Theta_Y  b
    N:  m32 v'_dot + m33 r'_dot    - tau'_N = Theta_N  c

``u'_dot = u_dot L / U^2``, ``v'_dot = v_dot L / U^2``, ``r'_dot = r_dot
L^2 / U^2`` with ``U = sqrt(u^2 + v^2)``; ``tau'`` is the wind load computed
from the *recorded* wind (so a wind-speed measurement error stays in the
data, as in thesis section 4.2.2). Coefficients given as known are moved to
the left-hand side.

References
----------
Zhu, M. (2021). MSc thesis, NTNU, eq. 3.7-3.13 and 3.21.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..environment.wind import wind_loads_prime
from ..models.abkowitz import ManoeuvringModel
from ..models.terms import DOFS
from ..vessels.base import Vessel
from .kalman import estimate_derivatives

__all__ = ["RegressionProblem", "prime_states", "assemble_problems", "build_problems"]


@dataclass
class RegressionProblem:
    """``y = theta @ coefficients`` for one DOF.

    Attributes
    ----------
    dof : str
    theta : ndarray (n, p)
        Features of the free terms, prime.
    y : ndarray (n,)
        Prime generalised force to explain.
    names : list of str
        Coefficient names of the columns of ``theta``.
    fixed : dict
        Known coefficients already moved into ``y``.
    record : ndarray of int
        Index of the record each row comes from (for time-blocked folds).
    time : ndarray
        Time stamp of each row [s].
    states : dict of ndarray, optional
        The (possibly smoothed) ``u, v, r, delta, psi`` of each row, for
        diagnostics of the residuals.
    """

    dof: str
    theta: np.ndarray
    y: np.ndarray
    names: list
    fixed: dict = field(default_factory=dict)
    record: np.ndarray | None = None
    time: np.ndarray | None = None
    states: dict | None = None

    @property
    def n_rows(self) -> int:
        return self.theta.shape[0]


def prime_states(u, v, r, delta, vessel: Vessel) -> np.ndarray:
    """Prime states ``(u', v', r', delta)`` (n, 4) from total SI velocities."""
    u = np.asarray(u, float)
    v = np.asarray(v, float)
    speed = np.sqrt(u * u + v * v)
    return np.column_stack([(u - vessel.speed) / speed, v / speed,
                            np.asarray(r, float) * vessel.length / speed, np.asarray(delta, float)])


def _one_record(record: pd.DataFrame, vessel: Vessel, derivative: str):
    est = estimate_derivatives(record, derivative)
    s, a = est.states, est.rates
    primes = prime_states(s["u"], s["v"], s["r"], s["delta"], vessel)
    speed2 = s["u"] ** 2 + s["v"] ** 2
    L = vessel.length
    acc = np.column_stack([a["u_dot"] * L / speed2, a["v_dot"] * L / speed2,
                           a["r_dot"] * L * L / speed2])
    lhs = acc @ vessel.mass_matrix().T
    if "wind_speed" in record and "wind_direction" in record:
        rows = est.index
        lhs = lhs - wind_loads_prime(s["u"], s["v"], s["psi"],
                                     record["wind_speed"].to_numpy(float)[rows],
                                     record["wind_direction"].to_numpy(float)[rows], vessel)
        s = {**s, "wind_direction": record["wind_direction"].to_numpy(float)[rows]}
    return primes, lhs, record["t"].to_numpy(float)[est.index], est.method, s


def assemble_problems(model: ManoeuvringModel, primes: np.ndarray, lhs: np.ndarray, fixed: dict,
                      which=None, time=None, states=None, row_weights=None) -> dict:
    """``{dof: RegressionProblem}`` from prime states (n, 4) and the prime
    generalised forces to explain (n, 3): known coefficients moved to ``y``;
    rows scaled by ``row_weights`` (the square roots of weights) when given."""
    problems = {}
    for k, dof in enumerate(DOFS):
        terms = model.terms_of(dof)
        if not terms:
            continue
        free = [t for t in terms if t.name not in fixed]
        y = lhs[:, k].copy()
        for t in terms:
            if t.name in fixed:
                y -= fixed[t.name] * t.feature(primes)
        theta = np.column_stack([t.feature(primes) for t in free]) if free else np.empty((len(y), 0))
        if row_weights is not None:
            theta = theta * row_weights[:, None]
            y = y * row_weights
        problems[dof] = RegressionProblem(dof, theta, y, [t.name for t in free],
                                          {t.name: fixed[t.name] for t in terms if t.name in fixed},
                                          which, time, states)
    return problems


def build_problems(model: ManoeuvringModel, vessel: Vessel, records, derivative: str = "auto",
                   fixed: dict | None = None) -> dict:
    """Regression problems ``{dof: RegressionProblem}`` from one or more records.

    Parameters
    ----------
    model : ManoeuvringModel
        Gives the terms (columns) per DOF.
    vessel : Vessel
        Prime mass matrix, speed U0 and length (prior knowledge).
    records : DataFrame or list of DataFrame
        Data contract records; rows of all records are stacked.
    derivative : str
        Acceleration estimator (:func:`~studies.identification.kalman.estimate_derivatives`:
        ``auto``, ``central``, ``savgol``, ``ekf``, ``ekf_kinematic``).
    fixed : dict, optional
        Known coefficients ``{name: value}``: moved to ``y``, not estimated.
    """
    if isinstance(records, pd.DataFrame):
        records = [records]
    fixed = dict(fixed or {})
    parts = [_one_record(rec, vessel, derivative) for rec in records]
    primes = np.vstack([p[0] for p in parts])
    lhs = np.vstack([p[1] for p in parts])
    time = np.concatenate([p[2] for p in parts])
    which = np.concatenate([np.full(len(p[2]), i) for i, p in enumerate(parts)])
    keys = [k for k in parts[0][4] if all(k in p[4] for p in parts)]
    states = {k: np.concatenate([p[4][k] for p in parts]) for k in keys}
    problems = assemble_problems(model, primes, lhs, fixed, which, time, states)
    problems_meta = {"derivative": parts[0][3]}
    for p in problems.values():
        p.meta = problems_meta
    return problems
