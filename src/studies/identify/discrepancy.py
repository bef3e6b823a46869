"""Model discrepancy of a manoeuvring model: estimated on the training records,
realised in the predictive bands (``method.discrepancy``).

The regression posterior of :mod:`studies.identify.bayes` treats the model
as exact: on measured data it shrinks around the coefficients that best fit
a wrong model, and bands drawn from it alone lose the measured track within
a minute (Brynjarsdottir & O'Hagan 2014). The discrepancy is the force the
model misses. It is modelled here as process noise in the state equations::

    [u_dot, v_dot, r_dot] = f(u, v, r, delta; c) + a(t),
    a_dot = -a / tau + w,   w white, spectral density 2 sigma^2 / tau,

an Ornstein-Uhlenbeck (continuous AR(1)) acceleration per degree of
freedom, independent between surge, sway and yaw, with stationary standard
deviations ``sigma`` [m/s^2, m/s^2, rad/s^2] and one correlation time
``tau`` [s]. It is dimensional (the same in SI units at every speed): a
missing force of the hull or a sensor-level effect does not shrink as the
ship slows down in a turn.

Estimation (``process_noise``): the prediction-error method. The extended
Kalman filter of :mod:`studies.identify.kalman`, with the identified model
(posterior medians) as process model and ``a`` as three of its states,
gives the innovation likelihood of each training record; ``sigma`` and
``tau`` maximise its sum over the training records (a small grid, then
Powell's method of :func:`scipy.optimize.minimize` within bounds, in the
coordinates ``log(2 sigma^2 tau)``, the spectral density at zero frequency
that moves the ship over long horizons, and ``log tau``: in ``sigma`` and
``tau`` the likelihood is a long curved ridge). The scale of the filter's
sensor biases (``KalmanSettings.bias_fraction``) is estimated with them: a
slowly drifting velocity sensor and a slowly varying missing force explain
the same departures, and with the bias prior fixed the sway discrepancy of
simulated records without sensor bias came out a third of the truth. The
likelihood is flat along the ridge: estimates within two units of
log-likelihood differ by up to a factor two in the spectral density. The measurement noise and the sensor biases of the velocity
channels are the filter's own (data-driven). The records are thinned to
about ``step`` seconds for the filter: the discrepancy is meant to describe
how the prediction departs over tens to hundreds of seconds, and at the
native 0.135 s of the MARIN files correlated sensor jitter in the velocity
channels is otherwise taken for process noise (the estimate of sigma grows
twenty-fold). Only the training records are used; nothing is tuned on the
validation records.

The estimate is a plug-in (empirical Bayes) one: the coefficient posterior
is not widened by it, and ``sigma``, ``tau`` are not sampled. The
predictive bands (:func:`studies.analysis.bands.predictive_draws`) draw a
coefficient set from the posterior *and* a realisation of ``a`` for every
replay.

References
----------
Brynjarsdottir, J., O'Hagan, A. (2014). Learning about physical parameters:
the importance of model discrepancy. Inverse Problems 30, 114007.

Kennedy, M.C., O'Hagan, A. (2001). Bayesian calibration of computer
models. J. R. Stat. Soc. B 63(3), 425-464.

Ljung, L. (1999). System identification: theory for the user, 2nd ed.
Prentice Hall (prediction-error methods, ch. 7).

Sarkka, S., Solin, A. (2019). Applied stochastic differential equations.
Cambridge University Press (the Ornstein-Uhlenbeck process, ch. 6).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from scipy.signal import lfilter

from ..errors import ConfigError
from ..simulate.simulator import acceleration_forces
from .kalman import KalmanSettings, _default_qc, innovation_loglik

__all__ = ["DISCREPANCIES", "Discrepancy", "estimate_process_noise", "thin_record"]

#: ``method.discrepancy``
DISCREPANCIES = ("none", "process_noise")
#: names of the three discrepancy accelerations
CHANNELS = ("u", "v", "r")


@dataclass(frozen=True)
class Discrepancy:
    """An Ornstein-Uhlenbeck acceleration discrepancy per degree of freedom.

    Attributes
    ----------
    kind : str
        How it was estimated (:data:`DISCREPANCIES`).
    sigma : ndarray (3,)
        Stationary standard deviations of the missing surge, sway and yaw
        accelerations [m/s^2, m/s^2, rad/s^2].
    tau : float
        Correlation time [s].
    loglik : float
        Innovation log-likelihood of the training records at the estimate.
    initial_sd : ndarray (3,)
        Standard deviations of the error of a measured initial ``u, v, r``
        beyond the sensor noise: the RMS of the sensor biases the smoother
        finds on the training records [m/s, m/s, rad/s].
    info : dict
        Diagnostics (evaluations, run time, ...), numbers only.
    """

    kind: str
    sigma: np.ndarray
    tau: float
    loglik: float = float("nan")
    initial_sd: np.ndarray = field(default_factory=lambda: np.zeros(3))
    info: dict = field(default_factory=dict)

    def realise(self, n_steps: int, step: float, rng: np.random.Generator) -> np.ndarray:
        """One realisation (n_steps, 3) [SI] of the accelerations averaged over
        each integration step of ``step`` seconds.

        An exact AR(1) at the step: correlation ``exp(-step / tau)`` and the
        variance of the step mean of the process,
        ``2 sigma^2 (tau / step) [1 - (tau / step)(1 - exp(-step / tau))]``,
        so that the low-frequency content (what moves the ship) does not
        depend on the step, also when ``tau`` is shorter than it. The first
        step starts in the stationary distribution.
        """
        phi = math.exp(-step / self.tau)
        ratio = self.tau / step
        share = 2.0 * ratio * (1.0 - ratio * (1.0 - phi))
        sd = np.asarray(self.sigma, float) * math.sqrt(max(share, 0.0))
        start = rng.standard_normal(3) * sd
        shocks = rng.standard_normal((n_steps, 3)) * (sd * math.sqrt(1.0 - phi * phi))
        out, _ = lfilter([1.0], [1.0, -phi], shocks, axis=0, zi=(phi * start)[None, :])
        return out

    @staticmethod
    def external(accelerations: np.ndarray, vessel) -> np.ndarray:
        """Prime external forces (n, 9) for the Abkowitz-type simulator from SI
        accelerations (n, 3) (:func:`studies.simulate.simulator.acceleration_forces`;
        the MMG simulator takes the accelerations themselves)."""
        return acceleration_forces(accelerations, vessel)

    def force_sigma(self, vessel) -> np.ndarray:
        """Standard deviations of the discrepancy as prime forces at ``U0`` (X', Y', N'):
        over ``0.5 rho L^2 U0^2`` (moment ``0.5 rho L^3 U0^2``) for the
        Abkowitz-type models, over ``0.5 rho L d U0^2`` (moment ``0.5 rho L^2 d
        U0^2``) for the MMG model (an MMG vessel)."""
        L, U0 = float(vessel.length), float(vessel.speed)
        if hasattr(vessel, "mass_matrix"):
            scale = np.asarray(self.sigma, float) * np.array([L, L, L * L]) / (U0 * U0)
            M = vessel.mass_matrix()
        else:
            mx, my, jz = vessel.added_masses()
            m, xgm = vessel.mass, vessel.xg * vessel.mass
            M = np.array([[m + mx, 0.0, 0.0], [0.0, m + my, xgm],
                          [0.0, xgm, vessel.iz + vessel.xg * xgm + jz]])
            M = M / vessel.force_scale(U0)[:, None]
            scale = np.asarray(self.sigma, float)
        return np.sqrt(np.diag(M @ np.diag(scale ** 2) @ M.T))

    def metrics(self, vessel=None, prefix: str = "discrepancy") -> dict:
        """``discrepancy/...`` numbers for ``metrics.json``."""
        out = {f"{prefix}/sigma_u_m_s2": float(self.sigma[0]),
               f"{prefix}/sigma_v_m_s2": float(self.sigma[1]),
               f"{prefix}/sigma_r_rad_s2": float(self.sigma[2]),
               f"{prefix}/tau_s": float(self.tau),
               f"{prefix}/loglik": float(self.loglik),
               f"{prefix}/initial_sd_u_m_s": float(self.initial_sd[0]),
               f"{prefix}/initial_sd_v_m_s": float(self.initial_sd[1]),
               f"{prefix}/initial_sd_r_rad_s": float(self.initial_sd[2])}
        if vessel is not None:
            for dof, value in zip("XYN", self.force_sigma(vessel)):
                out[f"{prefix}/sigma_{dof}_prime"] = float(value)
        out.update({f"{prefix}/{k}": float(v) for k, v in self.info.items()})
        return out

    def as_sample(self) -> dict:
        """The entry kept in ``Identification.samples["discrepancy"]``."""
        return {"kind": self.kind, "sigma": np.asarray(self.sigma, float).copy(), "tau": float(self.tau),
                "loglik": float(self.loglik), "initial_sd": np.asarray(self.initial_sd, float).copy()}

    @classmethod
    def from_sample(cls, entry: dict | None) -> "Discrepancy | None":
        """Inverse of :meth:`as_sample`; None for None or ``kind == "none"``."""
        if not entry or entry.get("kind", "none") == "none":
            return None
        return cls(str(entry["kind"]), np.asarray(entry["sigma"], float), float(entry["tau"]),
                   float(entry.get("loglik", float("nan"))),
                   np.asarray(entry.get("initial_sd", np.zeros(3)), float))


def thin_record(record: pd.DataFrame, step: float | None) -> pd.DataFrame:
    """Every k-th row of a uniformly sampled record, ``k = round(step / dt)``
    (at least 1): the measured values themselves, no interpolation."""
    if not step:
        return record
    t = record["t"].to_numpy(float)
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(float(step) / dt)))
    if k == 1:
        return record
    out = record.iloc[::k].reset_index(drop=True)
    out.attrs = dict(record.attrs)
    return out


def _reference_acceleration(records) -> np.ndarray:
    """RMS accelerations of the records (u, v, r), from :func:`kalman._default_qc`."""
    ref = []
    for rec in records:
        dt = float(np.median(np.diff(rec["t"].to_numpy(float))))
        ref.append(np.sqrt(_default_qc(rec, dt) * 20.0))
    return np.maximum(np.mean(ref, axis=0), np.array([1e-6, 1e-6, 1e-9]))


def estimate_process_noise(model, values: dict, vessel, records, settings: KalmanSettings | None = None,
                           step: float | None = 0.5, max_evaluations: int = 300,
                           modules=None) -> Discrepancy:
    """Prediction-error estimate of the discrepancy (module docstring).

    Parameters
    ----------
    model, values, vessel
        The identified model (posterior medians) and its vessel; an
        :class:`~studies.vessels.kvlcc2_mmg.MMGVessel` makes the filter's
        process model the MMG model (propeller rate from each record's ``n``).
    records : list of DataFrame
        The training records (data contract, uniformly sampled).
    settings : KalmanSettings, optional
        The filter's measurement channels, noise and sensor biases.
    step : float or None
        Records thinned to about this step [s] for the filter; None: as sampled.
    max_evaluations : int
        Most likelihood evaluations of the Powell search.
    modules : MMGParameters, optional
        The MMG model's propeller and rudder parameters (default the vessel's).
    """
    started = time.perf_counter()
    if not records:
        raise ConfigError("method.discrepancy=process_noise needs training records")
    settings = settings or KalmanSettings()
    thinned = [thin_record(rec, step) for rec in records]
    ref = _reference_acceleration(thinned)
    dt = min(float(np.median(np.diff(r["t"].to_numpy(float)))) for r in thinned)
    evaluations = [0]

    biased = bool(settings.bias)

    def unpack(theta):
        # coordinates: log of the zero-frequency spectral densities 2 sigma^2 tau (what moves
        # the ship over long horizons) and log tau; sigma and tau alone lie on a ridge
        tau = float(np.exp(theta[3]))
        sigma = np.sqrt(np.exp(theta[:3]) / (2.0 * tau))
        used = replace(settings, bias_fraction=float(np.exp(theta[4]))) if biased else settings
        return sigma, tau, used

    def negative(theta):
        evaluations[0] += 1
        sigma, tau, used = unpack(theta)
        total = 0.0
        for rec in thinned:
            total += innovation_loglik(rec, model, values, vessel, sigma, tau, used, modules=modules)
        return -total if np.isfinite(total) else 1e300

    best = None
    bias0 = np.log(settings.bias_fraction) if biased else 0.0
    for tau in (1.0, 5.0, 30.0):
        for fraction in (0.01, 0.03, 0.1, 0.3):
            theta = np.log(np.r_[2.0 * (fraction * ref) ** 2 * tau, tau])
            if biased:
                theta = np.r_[theta, bias0]
            value = negative(theta)
            if best is None or value < best[0]:
                best = (value, theta)
    low = np.log(np.r_[2.0 * (1e-4 * ref) ** 2 * max(dt, 0.05), max(dt, 0.05)])
    high = np.log(np.r_[2.0 * (10.0 * ref) ** 2 * 3600.0, 3600.0])
    if biased:
        low, high = np.r_[low, np.log(1e-5)], np.r_[high, np.log(0.1)]
    opt = minimize(negative, best[1], method="Powell", bounds=list(zip(low, high)),
                   options={"maxfev": int(max_evaluations), "xtol": 0.02, "ftol": 1e-6})
    theta = opt.x if opt.fun <= best[0] else best[1]
    sigma, tau, used = unpack(theta)
    biases = []
    for rec in thinned:
        _, states = innovation_loglik(rec, model, values, vessel, sigma, tau, used, smooth=True,
                                      modules=modules)
        biases.append(states[:, 9:12])
    initial_sd = np.sqrt(np.mean(np.vstack(biases) ** 2, axis=0))
    info = {"evaluations": float(evaluations[0]), "runtime_s": time.perf_counter() - started,
            "bias_fraction": float(used.bias_fraction) if biased else 0.0,
            "step_s": float(dt), "converged": float(bool(opt.success)),
            "at_bound": float(bool(np.any(np.isclose(theta, low, atol=1e-3))
                                   or np.any(np.isclose(theta, high, atol=1e-3))))}
    return Discrepancy("process_noise", sigma, tau, -float(min(opt.fun, best[0])), initial_sd, info)
