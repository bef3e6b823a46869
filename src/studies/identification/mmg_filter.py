"""The prediction-error filter with the MMG model as its process model.

The same extended Kalman filter as :mod:`studies.identification.filter_error`
(state, process noise, measurements, covariance propagation and the scalar
updates are that module's), whose mean is propagated by the MMG model's
right-hand side (:func:`studies.simulate.mmg._derivatives`: hull, propeller
thrust from the record's propeller rate, rudder in the slipstream) instead
of the polynomial model's.

State (6): ``du`` [m/s] (``u = U0 + du`` through the water), ``v`` [m/s]
through the water, ``r`` [rad/s], ``x0``, ``y0`` [m], ``psi`` [rad]. Inputs
per sample: the rudder ``delta`` [rad] (the data contract's sign: positive
turns the ship to negative heading), linear between samples, and the
propeller rate ``n`` [rps], linear between samples. A uniform current
(earth-fixed north and east components [m/s]) moves the track and adds to
the measured over-ground velocities; it leaves the motion through the water
as it is (a uniform, steady current). External accelerations [m/s^2,
m/s^2, rad/s^2] held over each step add to ``u_dot, v_dot, r_dot``: a
cause's forces (a bias, a propeller's side force) and hull terms the MMG
simulator does not hold, evaluated along the measured record.

Numba keys the cache of the compiled filter on this file alone: after
editing the functions it compiles inline (the covariance propagation and
the measurement update of :mod:`studies.identification.filter_error`, the MMG
right-hand side of :mod:`studies.simulate.mmg` and the forces of
:mod:`studies.models.mmg`), clear this folder's ``__pycache__``.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numba import njit

from ..models.mmg import HULL_TERMS
from ..simulate.mmg import _derivatives, _module_accelerations, mmg_inputs
from .filter_error import (N_FILTER, coloured_noise, initial_covariance, measurement_update, propagate_covariance,
                           work_arrays)

__all__ = ["MMGFilterPlan"]

#: the MMG simulator's hull coefficients, in the order its compiled right-hand side takes them
_HULL_ORDER = tuple(name for name, *_ in HULL_TERMS)


@njit(cache=True, inline="always")
def _rates(s0, s1, s2, s5, d, rate, n, c, k, a, g, e0, e1, e2, cn, ce, speed0):
    """Continuous derivative of (du, v, r, x0, y0, psi) at one state; ``d`` the
    rudder [rad] moving at ``rate`` [rad/s], ``n`` [rps], ``cn, ce`` the current."""
    cp = math.cos(s5)
    sp = math.sin(s5)
    f = _derivatives(speed0 + s0, s1, s2, cp, sp, d, math.sin(d), math.cos(d), 0.0, rate, True, n,
                     c, k, a, g, e0, e1, e2, 0.0)
    return f[0], f[1], f[2], f[3] + cn, f[4] + ce, f[5]


@njit(cache=True, nogil=True)
def _mmg_filter(c, k, a, g, delta, rps, ext, cn, ce, speed0, dt, z, R, q, s_init, P_init,
                innovations, variances, decay):
    """EKF over the samples of ``z`` (n, 6: x0, y0, psi, u, v, r over ground;
    NaN = missing) with the MMG model; ``delta``, ``rps`` (n,) at the samples,
    ``ext`` (n - 1, 3) or (0, 3) accelerations per step. Fills ``innovations``
    and ``variances`` (n, 6) and returns the log-likelihood; -inf when the
    prediction leaves the physical range (``0 < u < 5 U0``, ``|v| < 5 U0``,
    ``|r| < 1 rad/s``).

    With nine states (``s_init``), the last three are disturbance
    accelerations [m/s^2, m/s^2, rad/s^2] on ``du, v, r``, held over each
    step beside ``ext``, then multiplied by ``decay`` (``exp(-dt / tau)``)
    and driven by the process noise ``q[6:9]``: the coloured process noise
    of :func:`studies.identification.filter_error.innovation_likelihood`."""
    n = z.shape[0]
    has_ext = ext.shape[0] > 0
    limit = 5.0 * speed0
    s = s_init.copy()
    P = P_init.copy()
    m_states = s.shape[0]
    J, F, FP, ph, hstep = work_arrays(speed0, m_states)
    coloured = m_states > N_FILTER
    if coloured:
        for b in range(3):
            J[b, N_FILTER + b] = 1.0
    loglik = 0.0
    half = 0.5 * dt
    for i in range(n):
        if i > 0:
            e0 = e1 = e2 = 0.0
            if has_ext:
                e0, e1, e2 = ext[i - 1, 0], ext[i - 1, 1], ext[i - 1, 2]
            if coloured:
                e0 += s[6]
                e1 += s[7]
                e2 += s[8]
            d0, d1 = delta[i - 1], delta[i]
            n0, n1 = rps[i - 1], rps[i]
            rate = (d1 - d0) / dt
            # Jacobian of the continuous dynamics (positions do not enter it)
            for j in (0, 1, 2, 5):
                h = hstep[j]
                p0, p1, p2, p5 = s[0], s[1], s[2], s[5]
                m0, m1, m2, m5 = s[0], s[1], s[2], s[5]
                if j == 0:
                    p0 += h
                    m0 -= h
                elif j == 1:
                    p1 += h
                    m1 -= h
                elif j == 2:
                    p2 += h
                    m2 -= h
                else:
                    p5 += h
                    m5 -= h
                fp = _rates(p0, p1, p2, p5, d0, rate, n0, c, k, a, g, e0, e1, e2, cn, ce, speed0)
                fm = _rates(m0, m1, m2, m5, d0, rate, n0, c, k, a, g, e0, e1, e2, cn, ce, speed0)
                for b in range(N_FILTER):
                    J[b, j] = (fp[b] - fm[b]) / (2.0 * h)
            # one RK4 step of the mean, rudder and propeller rate linear over it
            dm, nm = d0 + half * rate, 0.5 * (n0 + n1)
            k1 = _rates(s[0], s[1], s[2], s[5], d0, rate, n0, c, k, a, g, e0, e1, e2, cn, ce, speed0)
            k2 = _rates(s[0] + half * k1[0], s[1] + half * k1[1], s[2] + half * k1[2], s[5] + half * k1[5],
                        dm, rate, nm, c, k, a, g, e0, e1, e2, cn, ce, speed0)
            k3 = _rates(s[0] + half * k2[0], s[1] + half * k2[1], s[2] + half * k2[2], s[5] + half * k2[5],
                        dm, rate, nm, c, k, a, g, e0, e1, e2, cn, ce, speed0)
            k4 = _rates(s[0] + dt * k3[0], s[1] + dt * k3[1], s[2] + dt * k3[2], s[5] + dt * k3[5],
                        d1, rate, n1, c, k, a, g, e0, e1, e2, cn, ce, speed0)
            w = dt / 6.0
            for b in range(N_FILTER):
                s[b] += w * (k1[b] + 2.0 * (k2[b] + k3[b]) + k4[b])
            if coloured:
                for b in range(N_FILTER, m_states):
                    s[b] *= decay
            propagate_covariance(J, dt, q, P, F, FP, decay)
            u = speed0 + s[0]
            if not (u > 0.0 and u < limit and abs(s[1]) < limit and abs(s[2]) < 1.0
                    and math.isfinite(s[3]) and math.isfinite(s[4])):
                return -np.inf
        loglik += measurement_update(s, P, z[i], R, speed0, cn, ce, innovations[i], variances[i], ph)
    return loglik


class MMGFilterPlan:
    """One record's MMG model in the prediction-error filter: what
    :func:`studies.identification.filter_error.innovation_likelihood` runs for an
    MMG baseline.

    Parameters
    ----------
    model : ManoeuvringModel
        The hull terms of the coefficient vectors (``model.names`` order): the
        MMG hull's, and terms outside it (a missing term), which act as
        external accelerations evaluated along the record.
    vessel : MMGVessel
        At the record's scale.
    record : DataFrame
        The record as the model sees it (a rudder offset applied), uniformly
        sampled at the filter's step, with ``t, u, v, r, psi, delta, n``.
    current : (float, float)
        Earth-fixed current (north, east) [m/s].
    external : ndarray (n - 1, 3), optional
        Accelerations [m/s^2, m/s^2, rad/s^2] per step besides the model's.
    term_accelerations : callable, optional
        ``f(terms) -> {term name: (n - 1, 3) accelerations per unit
        coefficient}`` for the terms outside the MMG hull, along the record.
    modules : MMGParameters, optional
        Propeller and rudder (default ``vessel.modules``).
    """

    def __init__(self, model, vessel, record: pd.DataFrame, current=(0.0, 0.0), external=None,
                 term_accelerations=None, modules=None):
        t = record["t"].to_numpy(float)
        self.step = float(np.median(np.diff(t)))
        self.names = list(model.names)
        self.hull_index = [self.names.index(n) if n in self.names else -1 for n in _HULL_ORDER]
        extra = [term for term in model.terms if term.name not in _HULL_ORDER]
        n = len(t)
        self.delta = np.ascontiguousarray(record["delta"].to_numpy(float))
        self.rps = np.ascontiguousarray(record["n"].to_numpy(float))
        self.current = (float(current[0]), float(current[1]))
        self.external = None if external is None else np.asarray(external, float)[: n - 1]
        self.terms = {}
        if extra:
            unit = term_accelerations(extra)
            self.terms = {self.names.index(name): np.asarray(acc, float)[: n - 1] for name, acc in unit.items()}
        self.k, self.a = mmg_inputs(vessel, modules)
        self.g = _module_accelerations(self.k, self.a)
        self.speed0 = float(vessel.speed)
        self.length = float(vessel.length)
        cn, ce = self.current
        first = record.iloc[0]
        psi = float(first["psi"])
        uc = math.cos(psi) * cn + math.sin(psi) * ce
        vc = math.cos(psi) * ce - math.sin(psi) * cn
        self.start = np.array([float(first["u"]) - uc - self.speed0, float(first["v"]) - vc, float(first["r"]),
                               float(first["x0"]), float(first["y0"]), psi])

    def accelerations(self, vector: np.ndarray, n: int) -> np.ndarray:
        """External accelerations per step (n - 1, 3) with the added terms' coefficients of ``vector``."""
        parts = [] if self.external is None else [self.external[: n - 1]]
        parts += [float(vector[i]) * acc[: n - 1] for i, acc in self.terms.items() if vector[i] != 0.0]
        if not parts:
            return np.zeros((0, 3))
        return np.ascontiguousarray(sum(parts[1:], parts[0]))

    def likelihood(self, vector: np.ndarray, measured: np.ndarray, R: np.ndarray, q: np.ndarray,
                   initial: np.ndarray | None = None, tau: float = 0.0) -> tuple[float, np.ndarray, np.ndarray]:
        """``(loglik, innovations (n, 6), variances (n, 6))`` of the record's
        measured channels (``x0, y0, psi, u, v, r`` over ground) under the
        coefficients ``vector`` (prime, ``model.names`` order), measurement
        variances ``R`` and process-noise densities ``q``; ``tau`` [s] the
        correlation time of the process noise on ``du, v, r`` (0: white;
        :func:`studies.identification.filter_error.innovation_likelihood`)."""
        vector = np.asarray(vector, float)
        n = len(measured)
        hull = tuple(float(vector[i]) if i >= 0 else 0.0 for i in self.hull_index)
        start = self.start if initial is None else np.asarray(initial, float)
        R = np.asarray(R, float)
        P0 = initial_covariance(R, measured, self.speed0, self.length)
        q = np.asarray(q, float)
        decay = 1.0
        if tau > 0.0:
            q, start, P0, decay = coloured_noise(q, start, P0, self.step, float(tau))
        innovations = np.empty((n, 6))
        variances = np.empty((n, 6))
        cn, ce = self.current
        loglik = _mmg_filter(hull, self.k, self.a, self.g, self.delta[:n], self.rps[:n],
                             self.accelerations(vector, n), cn, ce, self.speed0, self.step,
                             np.ascontiguousarray(measured, float), R, np.ascontiguousarray(q),
                             np.ascontiguousarray(start, float), np.ascontiguousarray(P0), innovations,
                             variances, decay)
        return float(loglik), innovations, variances
