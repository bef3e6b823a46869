"""Model discrepancy of a roll-decay model: coefficient wander, estimated by the Kalman filter.

Why. A measured decay drifts away from the ``b1 + b2`` model: its period
grows as the amplitude decays (2.53 s at 10 deg, 2.55 s at 2 deg in the SSPA
KVLCC2 tests) and its damping does not follow ``b1 + b2 |phi'|`` (the
decrement at small amplitude is larger than the model's). Predicted from an
initial state, these errors accumulate cycle after cycle: a frequency error
gives a phase error that grows with time, a damping error an amplitude error
that grows likewise. Bands drawn from the coefficient posterior alone take
the model as exact and lose the measured decay within a few cycles.

The discrepancy is modelled where the errors arise, in the coefficients of
the roll equation::

    phi'' + (b1 + eta(t)) phi' + b2 |phi'| phi' [+ b3 phi'^3]
          + (omega0^2 + eps(t)) phi [+ c3 phi^3] = 0,

with ``eps`` [1/s^2] and ``eta`` [1/s] independent Ornstein-Uhlenbeck
processes (stationary standard deviations ``sigma_w2``, ``sigma_b1``, one
correlation time ``tau`` [s]): the decay's local stiffness and damping
wander about the model's. This is process noise that enters multiplied by
the state, so it scales with the amplitude (a decay that has died out has
no error left) and, unlike an additive error on ``phi``, grows with the
prediction horizon as the measured errors do.

Estimation: the prediction-error method, as for the manoeuvring models
(:mod:`studies.identification.discrepancy`). A continuous-discrete extended Kalman
filter of the state ``(phi, phi', eps, eta)`` (RK4 of the mean and of the
covariance between samples, a compiled kernel) gives the innovation
log-likelihood of the training decays, thinned to :data:`FILTER_POINTS_PER_PERIOD`
samples per roll period, with the measurement noise of each record taken
from its roughness (:func:`studies.roll.decay.noise_std`); ``sigma_w2``,
``sigma_b1`` and ``tau`` maximise it (Powell's method of
:func:`scipy.optimize.minimize` in ``log sigma`` and ``log tau`` from a
small grid of starts) with the coefficients fixed at the posterior medians.
The estimate is a plug-in (empirical Bayes) one: the coefficients' posterior
is not changed by it. Sampling the coefficients on this filter's likelihood
together with the wander (the joint estimate) was measured to trade the
mean damping against the wander: on the first 70 % of test 21338 it gave
``b2`` between -0.10 and -0.03 (damping falling with amplitude, the
opposite of the decay curve; NLS: 0.078) and, with ``tau`` free up to 200
periods, bands wider than the decay. ``tau`` is bounded to
``[T0 / 2, duration / 2]``: a wander slower than half the record cannot be
told from the coefficients themselves.

Realisation in the bands (:mod:`studies.roll.bands`): every replay draws a
coefficient set from the posterior and its own realisation of ``eps`` and
``eta`` from their stationary distribution
(:meth:`RollDiscrepancy.realise`, the exact AR(1) step means of
:meth:`studies.identification.discrepancy.Discrepancy.realise`), applied through
:meth:`studies.roll.model.RollModel.simulate` (``wander``).

References
----------
Brynjarsdottir, J., O'Hagan, A. (2014). Learning about physical parameters:
the importance of model discrepancy. Inverse Problems 30, 114007.

Jazwinski, A.H. (1970). Stochastic processes and filtering theory. Academic
Press (continuous-discrete extended Kalman filter, ch. 8).

Ljung, L. (1999). System identification: theory for the user, 2nd ed.
Prentice Hall (prediction-error methods, ch. 7).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.optimize import minimize

from studies.identification.discrepancy import DISCREPANCIES, Discrepancy
from studies.roll.decay import noise_std
from studies.roll.model import RollModel
from studies.roll.records import initial_state_covariance

__all__ = ["DISCREPANCIES", "RollDiscrepancy", "FILTER_POINTS_PER_PERIOD", "compiled_filter",
           "innovation_loglik", "estimate_wander", "noise_level"]

log = logging.getLogger(__name__)

#: samples per roll period the filter runs on (the records are thinned to it)
FILTER_POINTS_PER_PERIOD = 20
#: RK4 sub-steps of the filter between two samples (T0 / 40 each)
FILTER_SUBSTEPS = 2
#: [rad] floor of a record's measurement noise (noise-free simulated decays)
NOISE_FLOOR = 1.0e-5


@dataclass(frozen=True)
class RollDiscrepancy:
    """Ornstein-Uhlenbeck wander of the roll stiffness and linear damping.

    Attributes
    ----------
    kind : str
        How it was estimated (:data:`DISCREPANCIES`: ``process_noise``).
    sigma_w2 : float
        Stationary standard deviation of the stiffness wander ``eps`` [1/s^2]
        (added to ``omega0^2``).
    sigma_b1 : float
        Stationary standard deviation of the damping wander ``eta`` [1/s]
        (added to ``b1``).
    tau : float
        Correlation time of both [s].
    loglik : float
        Innovation log-likelihood of the training decays at the estimate.
    info : dict
        Diagnostics (numbers only).
    """

    kind: str
    sigma_w2: float
    sigma_b1: float
    tau: float
    loglik: float = float("nan")
    info: dict = field(default_factory=dict)

    def realise(self, n_intervals: int, step: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """One realisation ``(dw2, db1)`` over ``n_intervals`` output intervals of ``step`` [s]:
        the means of ``eps`` and ``eta`` over each, the first from the
        stationary distribution."""
        ou = Discrepancy(self.kind, np.array([self.sigma_w2, self.sigma_b1, 0.0]), self.tau)
        a = ou.realise(int(n_intervals), float(step), rng)
        return a[:, 0].copy(), a[:, 1].copy()

    def frequency_sd(self, omega0: float) -> float:
        """Standard deviation of the natural frequency it implies, relative to ``omega0`` [-]
        (``sigma_w2 / (2 omega0^2)`` to first order)."""
        return self.sigma_w2 / (2.0 * omega0 * omega0)

    def metrics(self, params: Mapping[str, float] | None = None, prefix: str = "discrepancy") -> dict:
        """``discrepancy/...`` numbers for ``metrics.json``."""
        out = {f"{prefix}/sigma_w2_1_s2": float(self.sigma_w2), f"{prefix}/sigma_b1_1_s": float(self.sigma_b1),
               f"{prefix}/tau_s": float(self.tau), f"{prefix}/loglik": float(self.loglik)}
        if params is not None:
            w0 = float(params["omega0"])
            out[f"{prefix}/frequency_sd_rel"] = self.frequency_sd(w0)
            out[f"{prefix}/zeta_sd"] = float(self.sigma_b1) / (2.0 * w0)
        out.update({f"{prefix}/{k}": float(v) for k, v in self.info.items()})
        return out

    def describe(self, params: Mapping[str, float]) -> str:
        """One sentence for people: the wander's size and time scale."""
        w0 = float(params["omega0"])
        return (f"the roll stiffness and linear damping wander about the model's as Ornstein-Uhlenbeck "
                f"processes: natural frequency by {100 * self.frequency_sd(w0):.2g} % (sd), damping ratio "
                f"by {self.sigma_b1 / (2 * w0):.2g} (sd of b1 {self.sigma_b1:.2g} 1/s), correlation time "
                f"{self.tau:.3g} s")

    def as_sample(self) -> dict:
        """A plain dict (for ``RollFit.meta``)."""
        return {"kind": self.kind, "sigma_w2": float(self.sigma_w2), "sigma_b1": float(self.sigma_b1),
                "tau": float(self.tau), "loglik": float(self.loglik)}


# ------------------------------------------------------------------ filter
def _deriv(z, d, b1, b2, b3, w2, c3, c, qe, qh):  # pragma: no cover - compiled
    """Time derivative of the filter's mean ``(phi, phi', eps, eta)`` and of
    its covariance (10 upper-triangle entries), ``P' = F P + P F^T + Q``."""
    x = z[0]
    v = z[1]
    e = z[2]
    h = z[3]
    p00 = z[4]
    p01 = z[5]
    p02 = z[6]
    p03 = z[7]
    p11 = z[8]
    p12 = z[9]
    p13 = z[10]
    p22 = z[11]
    p23 = z[12]
    p33 = z[13]
    d[0] = v
    d[1] = -((b1 + h) * v + b2 * abs(v) * v + b3 * v * v * v + (w2 + e) * x + c3 * x * x * x)
    d[2] = -c * e
    d[3] = -c * h
    # Jacobian row of phi'': [a, b, -phi, -phi']
    a = -(w2 + e) - 3.0 * c3 * x * x
    b = -(b1 + h) - 2.0 * b2 * abs(v) - 3.0 * b3 * v * v
    d[4] = 2.0 * p01
    d[5] = p11 + a * p00 + b * p01 - x * p02 - v * p03
    d[6] = p12 - c * p02
    d[7] = p13 - c * p03
    d[8] = 2.0 * (a * p01 + b * p11 - x * p12 - v * p13)
    d[9] = a * p02 + b * p12 - x * p22 - v * p23 - c * p12
    d[10] = a * p03 + b * p13 - x * p23 - v * p33 - c * p13
    d[11] = -2.0 * c * p22 + qe
    d[12] = -2.0 * c * p23
    d[13] = -2.0 * c * p33 + qh


def _filter_kernel(t, y, r_var, phi0, v0, p_phi, p_pv, p_v, b1, b2, b3, w2, c3, s_e, s_h, tau, nsub,
                   deriv):  # pragma: no cover - compiled
    """Innovation log-likelihood of ``y`` at ``t`` (continuous-discrete EKF)."""
    n = t.shape[0]
    z = np.zeros(14)
    k1 = np.empty(14)
    k2 = np.empty(14)
    k3 = np.empty(14)
    k4 = np.empty(14)
    zt = np.empty(14)
    z[0] = phi0
    z[1] = v0
    z[4] = p_phi
    z[5] = p_pv
    z[8] = p_v
    z[11] = s_e * s_e
    z[13] = s_h * s_h
    c = 1.0 / tau
    qe = 2.0 * s_e * s_e * c
    qh = 2.0 * s_h * s_h * c
    ll = 0.0
    for i in range(n):
        if i > 0:
            hs = (t[i] - t[i - 1]) / nsub
            for _ in range(nsub):
                deriv(z, k1, b1, b2, b3, w2, c3, c, qe, qh)
                for j in range(14):
                    zt[j] = z[j] + 0.5 * hs * k1[j]
                deriv(zt, k2, b1, b2, b3, w2, c3, c, qe, qh)
                for j in range(14):
                    zt[j] = z[j] + 0.5 * hs * k2[j]
                deriv(zt, k3, b1, b2, b3, w2, c3, c, qe, qh)
                for j in range(14):
                    zt[j] = z[j] + hs * k3[j]
                deriv(zt, k4, b1, b2, b3, w2, c3, c, qe, qh)
                for j in range(14):
                    z[j] += hs / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
            if not (abs(z[0]) < 10.0 and abs(z[1]) < 1.0e3):
                return -np.inf
        s = z[4] + r_var
        if not (s > 0.0):
            return -np.inf
        nu = y[i] - z[0]
        ll -= 0.5 * (math.log(2.0 * math.pi * s) + nu * nu / s)
        # gain K = P[:, 0] / s; P -= K P[0, :] (upper triangle)
        g0 = z[4] / s
        g1 = z[5] / s
        g2 = z[6] / s
        g3 = z[7] / s
        r0 = z[4]
        r1 = z[5]
        r2 = z[6]
        r3 = z[7]
        z[0] += g0 * nu
        z[1] += g1 * nu
        z[2] += g2 * nu
        z[3] += g3 * nu
        z[4] -= g0 * r0
        z[5] -= g0 * r1
        z[6] -= g0 * r2
        z[7] -= g0 * r3
        z[8] -= g1 * r1
        z[9] -= g1 * r2
        z[10] -= g1 * r3
        z[11] -= g2 * r2
        z[12] -= g2 * r3
        z[13] -= g3 * r3
    return ll


_COMPILED: dict[str, object] = {}


def compiled_filter():
    """The filter's log-likelihood ``f(t, y, r_var, phi0, v0, P00, P01, P11, b1, b2, b3,
    omega0^2, c3, sigma_w2, sigma_b1, tau, nsub)``, numba-compiled on the first call
    (plain Python, much slower, without numba)."""
    kern = _COMPILED.get("filter")
    if kern is None:
        deriv, body = _deriv, _filter_kernel
        for cache in (True, False):
            try:
                import numba

                deriv = numba.njit(cache=cache, nogil=True)(_deriv)
                body = numba.njit(cache=cache, nogil=True)(_filter_kernel)
                body(np.array([0.0, 0.1]), np.zeros(2), 1e-6, 0.1, 0.0, 1e-6, 0.0, 1e-6, 0.0, 0.0, 0.0,
                     1.0, 0.0, 0.1, 0.01, 1.0, 1, deriv)
                break
            except Exception as exc:  # noqa: BLE001 - numba's errors are of many types
                deriv, body = _deriv, _filter_kernel
                failure = exc
                continue
        else:
            log.warning("numba cannot compile the roll Kalman filter (%s): it runs in plain Python, about 100 times "
                        "slower", failure)

        def kern(*args, _body=body, _deriv=deriv):
            return _body(*args, _deriv)

        _COMPILED["filter"] = kern
    return kern


def noise_level(record: pd.DataFrame) -> float:
    """Measurement noise of a record [rad]: its roughness (white-noise estimate from
    second differences, :func:`studies.roll.decay.noise_std`), at least :data:`NOISE_FLOOR`."""
    return max(noise_std(record["phi"].to_numpy(float)), NOISE_FLOOR)


@dataclass
class _FilterRecord:
    t: np.ndarray
    y: np.ndarray
    r_var: float
    start: np.ndarray
    cov: np.ndarray


def _filter_records(records: Sequence[pd.DataFrame], period: float,
                    points_per_period: int) -> list[_FilterRecord]:
    out = []
    for rec in records:
        t = rec["t"].to_numpy(float)
        dt = float(t[1] - t[0])
        step = max(1, int(round(period / points_per_period / dt)))
        noise = noise_level(rec)
        mean, cov = initial_state_covariance(rec, noise)
        # the filter's prior of the initial state: the fit's error, at least the noise (angle and rate)
        w = 2.0 * math.pi / period
        cov = cov + np.diag([noise**2, (w * noise) ** 2])
        out.append(_FilterRecord(t[::step].copy(), rec["phi"].to_numpy(float)[::step].copy(), noise**2, mean, cov))
    return out


def innovation_loglik(params: Mapping[str, float], terms: Sequence[str], records: Sequence[pd.DataFrame],
                      sigma_w2: float, sigma_b1: float, tau: float,
                      points_per_period: int = FILTER_POINTS_PER_PERIOD, _prepared=None) -> float:
    """Innovation log-likelihood of the decays under the model with coefficient wander.

    Parameters
    ----------
    params : mapping
        ``omega0`` [rad/s] and the coefficients of ``terms``.
    terms : sequence of str
        Model terms.
    records : sequence of DataFrame
        Prepared decays (the filter starts at each one's initial state,
        :func:`studies.roll.records.initial_state_covariance`).
    sigma_w2, sigma_b1, tau : float
        The wander (:class:`RollDiscrepancy`); zeros give the model as exact.
    points_per_period : int
        Samples per roll period the records are thinned to.
    """
    b1, b2, b3, w2, c3 = RollModel(tuple(terms)).coefficients(params)
    period = 2.0 * math.pi / float(params["omega0"])
    prepared = _prepared if _prepared is not None else _filter_records(records, period, points_per_period)
    kern = compiled_filter()
    total = 0.0
    for fr in prepared:
        total += kern(fr.t, fr.y, fr.r_var, float(fr.start[0]), float(fr.start[1]), float(fr.cov[0, 0]),
                      float(fr.cov[0, 1]), float(fr.cov[1, 1]), b1, b2, b3, w2, c3, float(sigma_w2),
                      float(sigma_b1), float(tau), FILTER_SUBSTEPS)
    return float(total)


def estimate_wander(params: Mapping[str, float], terms: Sequence[str], records: Sequence[pd.DataFrame],
                    max_evaluations: int = 300,
                    points_per_period: int = FILTER_POINTS_PER_PERIOD) -> RollDiscrepancy:
    """Maximum-likelihood (prediction-error) estimate of the coefficient wander.

    Parameters
    ----------
    params : mapping
        The model's coefficients (posterior medians), held fixed.
    terms : sequence of str
        Model terms.
    records : sequence of DataFrame
        Training decays only.
    max_evaluations : int
        Most likelihood evaluations of each Powell search (four starts).
    points_per_period : int
        Samples per roll period the filter runs on.

    Returns
    -------
    RollDiscrepancy
        ``info`` holds ``evaluations``, ``runtime_s``, ``loglik_exact`` (the
        model taken as exact) and ``tau_at_bound`` (1 when ``tau`` ended at a
        bound of ``[T0 / 2, duration / 2]``).
    """
    started = time.perf_counter()
    w0 = float(params["omega0"])
    period = 2.0 * math.pi / w0
    prepared = _filter_records(records, period, points_per_period)
    duration = max(float(fr.t[-1] - fr.t[0]) for fr in prepared)
    lo_tau, hi_tau = math.log(0.5 * period), math.log(max(period, 0.5 * duration))
    lo_w2, hi_w2 = math.log(1e-8 * w0 * w0), math.log(w0 * w0)
    lo_b1, hi_b1 = math.log(1e-8 * w0), math.log(w0)
    count = [0]

    def negative(x):
        count[0] += 1
        lw, lb, lt = (float(v) for v in x)
        if not (lo_w2 <= lw <= hi_w2 and lo_b1 <= lb <= hi_b1 and lo_tau <= lt <= hi_tau):
            return 1e300
        value = innovation_loglik(params, terms, records, math.exp(lw), math.exp(lb), math.exp(lt),
                                  points_per_period, prepared)
        return -value if np.isfinite(value) else 1e300

    best = None
    for rel in (1e-4, 1e-2):
        for lt in (lo_tau + 0.5, hi_tau - 0.5):
            x0 = [math.log(rel * w0 * w0), math.log(rel * w0), float(np.clip(lt, lo_tau, hi_tau))]
            sol = minimize(negative, x0, method="Powell",
                           bounds=[(lo_w2, hi_w2), (lo_b1, hi_b1), (lo_tau, hi_tau)],
                           options={"maxfev": int(max_evaluations), "xtol": 1e-3, "ftol": 1e-7})
            if best is None or sol.fun < best.fun:
                best = sol
    lw, lb, lt = (float(v) for v in best.x)
    exact = innovation_loglik(params, terms, records, 0.0, 0.0, 1.0, points_per_period, prepared)
    at_bound = float(min(lt - lo_tau, hi_tau - lt) < 0.05)
    return RollDiscrepancy("process_noise", math.exp(lw), math.exp(lb), math.exp(lt), -float(best.fun),
                           {"evaluations": float(count[0]), "runtime_s": time.perf_counter() - started,
                            "loglik_exact": exact, "tau_at_bound": at_bound,
                            "filter_points_per_period": float(points_per_period)})
