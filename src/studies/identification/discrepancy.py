"""Model discrepancy of a manoeuvring model: estimated on the training records,
realised in the predictive bands (``method.discrepancy``).

The regression posterior of :mod:`studies.identification.bayes` treats the model
as exact: on measured data it shrinks around the coefficients that best fit
a wrong model, and bands drawn from it alone lose the measured track within
a minute (Brynjarsdottir & O'Hagan 2014). The discrepancy is the force the
model misses. It is modelled here as process noise in the state equations::

    [u_dot, v_dot, r_dot] = f(u, v, r, delta; c) + (1 + k |r'|) a(t),
    a_j_dot = -a_j / tau_j + w_j,   w_j white, spectral density 2 sigma_j^2 / tau_j,

an Ornstein-Uhlenbeck (continuous AR(1)) acceleration per degree of
freedom, independent between surge, sway and yaw, with stationary standard
deviations ``sigma`` [m/s^2, m/s^2, rad/s^2] and a correlation time
``tau_j`` [s] per channel, whose size grows with the prime yaw rate ``r' =
r L / U`` at the rate ``k`` (``rate_gain``). It is dimensional (the same in
SI units at every speed): a missing force of the hull or a sensor-level
effect does not shrink as the ship slows down in a turn. The growth with
``|r'|`` is there because the missing forces of a manoeuvring model are
largest in its nonlinear range: the accelerations the Kalman smoother
attributes to the discrepancy on the MARIN KVLCC2 records (MMG model fitted
to the two zig-zags) grow from about 1e-3 m/s^2 in sway at ``|r'| < 0.1`` to
1.5e-3 at 0.3 and 4e-3 in the turning circle's steady turn (``|r'| > 0.7``);
``k`` is estimated with the rest and is 0 when the training records do not
show such a growth.

Estimation (``process_noise``): the prediction-error method. The extended
Kalman filter of :mod:`studies.identification.kalman`, with the identified model
(posterior medians) as process model (the MMG model for an MMG vessel) and
``a`` as three of its states, gives the innovation likelihood of each
training record; the parameters maximise its sum over the training records,
in nested stages, each from the previous one's solution and kept only when
the likelihood rises: one correlation time shared by the channels (a small
grid, then Powell's method of :func:`scipy.optimize.minimize` within
bounds), then one per channel, then the growth ``k`` (Powell again), within
``max_evaluations`` likelihood evaluations in all. The coordinates are
``log(2 sigma^2 tau)``, the spectral density at zero frequency that moves
the ship over long horizons, and ``log tau`` (in ``sigma`` and ``tau`` the
likelihood is a long curved ridge). The scale of the filter's sensor
biases (``KalmanSettings.bias_fraction``) is estimated with them: a slowly
drifting velocity sensor and a slowly varying missing force explain the
same departures, and with the bias prior fixed the sway discrepancy of
simulated records without sensor bias came out a third of the truth. The
likelihood is flat along the ridge, and not unimodal (on the MARIN records
the sway channel has a second optimum with ``tau`` at its lower bound, the
filter's step, where the discrepancy takes up correlated sensor jitter):
estimates within two units of log-likelihood differ by up to a factor two
in the spectral density, and a search that stops at its evaluation budget
(``info["converged"]`` = 0, usual with 600) lands within a few units of
log-likelihood of a longer one. The measurement noise and the sensor biases
of the velocity channels are the filter's own (data-driven). The records
are thinned to about ``step`` seconds for the filter: the discrepancy is
meant to describe how the prediction departs over tens to hundreds of
seconds, and at the native 0.135 s of the MARIN files correlated sensor
jitter in the velocity channels is otherwise taken for process noise (the
estimate of sigma grows twenty-fold). Only the training records are used;
nothing is tuned on the validation records.

Out of sample (the estimator's default with three training records or
more): each training record is filtered by the coefficients identified
without it (:func:`out_of_sample_values`), so the innovations are those of
a model predicting a record it did not train on, which is what a band of a
new record needs. Filtered by coefficients fitted to them, the records'
one-step errors understate it: on the 16 KVLCC2 free-running records the
sway and yaw accelerations estimated out of sample are 1.5 and 1.4 times
the in-sample ones.

Records of the same ship also differ by what stays the same over a run (the
day's rudder zero, a propeller's side force, a basin's drift): a constant
acceleration per record, which an Ornstein-Uhlenbeck process correlated over
tens of seconds does not hold. Its spread (``offset_sd``) is estimated from
the training records' mean smoothed discrepancy at the estimate, beyond what
the process alone leaves in a mean over a record (:func:`record_offsets`, a
method-of-moments random effect; zero with fewer than three records), and
each replay of a band draws one constant from it.

The error of a replay's measured initial ``u, v, r`` (``initial_sd``) is
the sensor bias at the start of a record: the smoothed bias at the first
sample of each training record, with its posterior variance. The RMS of
the biases over whole records is not: on the MARIN turning circle the
velocity channels depart from the track by up to 0.2 m/s in the turn (an
earth-fixed pattern that turns with the ship), which the bias states
absorb, while every record starts with biases of 0.004-0.016 m/s.

A mean that depends on the state (``mean``; ``method.discrepancy_mean``): what
the model misses on average in a given state, e.g. the speed a hull model
fitted to smaller manoeuvres fails to lose in a large turn, which a
zero-mean process, however large, only widens around the wrong track. It
is fitted by least squares to the training records' smoothed discrepancy
at the estimate (:func:`fit_mean`) on three features per channel
(:data:`MEAN_FEATURES`: surge even in the turn, ``r'^2``, ``v'^2`` and a
constant; sway and yaw odd, ``r'``, ``v'``, ``r'^3``), in SI accelerations
per unit prime feature; the bands add it along their centre
(:func:`studies.analysis.bands.predictive_draws`). On KVLCC2 zig-zags of a
hull whose ``X'vv`` is 0.15 more negative than the model's it recovers the
missing surge acceleration's ``v'^2`` coefficient within 4 %
(``tests/test_discrepancy_mean.py``). Out of sample it learns the model's
average error on records it did not train on; in sample, only what the
regression left. It is not the default: learnt on the training records, it
is extrapolated to whatever the new record does, and on the 16 KVLCC2
records it brings the largest zig-zags in (HSVA 35/5 at 90 %: 0.07 ->
0.34) while it sends the turning circle, held out and beyond every
zig-zag's yaw rate, out of its band (0.45 -> 0.15).

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

from ..errors import ConfigError
from ..simulate.simulator import acceleration_forces
from .kalman import KalmanSettings, _default_qc, innovation_loglik
from .ls import LeastSquares
from ..config import BAYES_DISCREPANCIES

__all__ = ["DISCREPANCIES", "Discrepancy", "MEAN_FEATURES", "estimate_process_noise", "fit_mean", "mean_features",
           "out_of_sample_values", "record_offsets", "thin_record"]

#: ``method.discrepancy``
DISCREPANCIES = BAYES_DISCREPANCIES
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
    tau : float or ndarray (3,)
        Correlation time [s], shared or one per channel (surge, sway, yaw).
    loglik : float
        Innovation log-likelihood of the training records at the estimate.
    initial_sd : ndarray (3,)
        Standard deviations of the error of a measured initial ``u, v, r``
        beyond the sensor noise: the RMS (with its posterior variance) of the
        sensor biases the smoother finds at the first samples of the training
        records [m/s, m/s, rad/s].
    info : dict
        Diagnostics (evaluations, run time, ...), numbers only.
    rate_gain : float
        How the discrepancy's size grows with the turn: the accelerations act
        as ``(1 + rate_gain |r'|) a`` with ``r' = r L / U`` the prime yaw
        rate (0: the same size in every state).
    offset_sd : ndarray (3,)
        Standard deviations of a constant acceleration per record [m/s^2,
        m/s^2, rad/s^2]: records of the same ship differ by what stays the
        same over a run (the day's rudder zero, a propeller's side force, a
        basin's drift), which the Ornstein-Uhlenbeck part, correlated over
        tens of seconds, does not hold. Estimated from the spread between the
        training records' mean smoothed discrepancy beyond what the
        Ornstein-Uhlenbeck part alone gives a mean over the record
        (:func:`record_offsets`); each replay draws one constant. Zero: none.
    mean_coef : ndarray (3, 3) or None
        A mean of the accelerations that depends on the state
        (:func:`mean_features`): row ``j`` holds channel ``j``'s coefficients
        [m/s^2 or rad/s^2 per unit feature] of its three features; None: the
        discrepancy is centred on the model. Fitted to the training records'
        smoothed discrepancy (:func:`fit_mean`), it is what the model misses
        on average in a given state, e.g. the speed it loses in a turn.
    """

    kind: str
    sigma: np.ndarray
    tau: float
    loglik: float = float("nan")
    initial_sd: np.ndarray = field(default_factory=lambda: np.zeros(3))
    info: dict = field(default_factory=dict)
    rate_gain: float = 0.0
    offset_sd: np.ndarray = field(default_factory=lambda: np.zeros(3))
    mean_coef: np.ndarray | None = None

    def mean_along(self, u, v, r, length: float) -> np.ndarray:
        """The mean accelerations (n, 3) [m/s^2, m/s^2, rad/s^2] along the
        states ``u, v, r`` (n,) [m/s, rad/s] of a ship of ``length`` [m]
        (zeros without ``mean_coef``); like the rest of the discrepancy they
        act scaled by ``1 + rate_gain |r'|``."""
        u = np.asarray(u, float)
        if self.mean_coef is None:
            return np.zeros((u.shape[0], 3))
        features = mean_features(u, v, r, length)
        return np.column_stack([features[j] @ np.asarray(self.mean_coef, float)[j] for j in range(3)])

    @property
    def taus(self) -> np.ndarray:
        """The correlation time of each channel (3,) [s]."""
        return np.broadcast_to(np.asarray(self.tau, float), (3,)).copy()

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
        from scipy.signal import lfilter  # loads scipy.stats: only when a discrepancy is drawn

        taus = self.taus
        phi = np.exp(-step / taus)
        ratio = taus / step
        share = 2.0 * ratio * (1.0 - ratio * (1.0 - phi))
        sd = np.asarray(self.sigma, float) * np.sqrt(np.maximum(share, 0.0))
        start = rng.standard_normal(3) * sd
        shocks = rng.standard_normal((n_steps, 3)) * (sd * np.sqrt(1.0 - phi * phi))
        out = np.empty_like(shocks)
        for j in range(3):
            out[:, j], _ = lfilter([1.0], [1.0, -phi[j]], shocks[:, j], zi=[phi[j] * start[j]])
        offset_sd = np.asarray(self.offset_sd, float)
        if np.any(offset_sd > 0):
            out += rng.standard_normal(3) * offset_sd
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

    def force_density(self, vessel) -> np.ndarray:
        """Zero-frequency spectral densities ``2 sigma_j^2 tau_j`` of the discrepancy
        as prime forces at ``U0`` (X', Y', N'; primes as :meth:`force_sigma`) [s],
        at ``r' = 0``: what moves the ship over long horizons."""
        taus = self.taus
        per_channel = Discrepancy(self.kind, np.asarray(self.sigma, float) * np.sqrt(2.0 * taus), 1.0)
        return per_channel.force_sigma(vessel) ** 2

    def metrics(self, vessel=None, prefix: str = "discrepancy") -> dict:
        """``discrepancy/...`` numbers for ``metrics.json``."""
        out = {f"{prefix}/sigma_u_m_s2": float(self.sigma[0]),
               f"{prefix}/sigma_v_m_s2": float(self.sigma[1]),
               f"{prefix}/sigma_r_rad_s2": float(self.sigma[2]),
               f"{prefix}/tau_s": float(np.exp(np.mean(np.log(self.taus)))),
               f"{prefix}/tau_u_s": float(self.taus[0]),
               f"{prefix}/tau_v_s": float(self.taus[1]),
               f"{prefix}/tau_r_s": float(self.taus[2]),
               f"{prefix}/rate_gain": float(self.rate_gain),
               f"{prefix}/loglik": float(self.loglik),
               f"{prefix}/initial_sd_u_m_s": float(self.initial_sd[0]),
               f"{prefix}/initial_sd_v_m_s": float(self.initial_sd[1]),
               f"{prefix}/initial_sd_r_rad_s": float(self.initial_sd[2]),
               f"{prefix}/offset_sd_u_m_s2": float(self.offset_sd[0]),
               f"{prefix}/offset_sd_v_m_s2": float(self.offset_sd[1]),
               f"{prefix}/offset_sd_r_rad_s2": float(self.offset_sd[2])}
        if self.mean_coef is not None:
            for j, channel in enumerate(CHANNELS):
                for name, value in zip(MEAN_FEATURES[channel], np.asarray(self.mean_coef, float)[j]):
                    out[f"{prefix}/mean_{channel}_{name}"] = float(value)
        if vessel is not None:
            for dof, value in zip("XYN", self.force_sigma(vessel)):
                out[f"{prefix}/sigma_{dof}_prime"] = float(value)
        out.update({f"{prefix}/{k}": float(v) for k, v in self.info.items()})
        return out

    def as_sample(self) -> dict:
        """The entry kept in ``Identification.samples["discrepancy"]``."""
        return {"kind": self.kind, "sigma": np.asarray(self.sigma, float).copy(), "tau": self.taus,
                "loglik": float(self.loglik), "initial_sd": np.asarray(self.initial_sd, float).copy(),
                "rate_gain": float(self.rate_gain), "offset_sd": np.asarray(self.offset_sd, float).copy(),
                "mean_coef": None if self.mean_coef is None else np.asarray(self.mean_coef, float).copy()}

    @classmethod
    def from_sample(cls, entry: dict | None) -> "Discrepancy | None":
        """Inverse of :meth:`as_sample`; None for None or ``kind == "none"``."""
        if not entry or entry.get("kind", "none") == "none":
            return None
        return cls(str(entry["kind"]), np.asarray(entry["sigma"], float),
                   np.broadcast_to(np.asarray(entry["tau"], float), (3,)).copy(),
                   float(entry.get("loglik", float("nan"))),
                   np.asarray(entry.get("initial_sd", np.zeros(3)), float), {},
                   float(entry.get("rate_gain", 0.0)),
                   np.asarray(entry.get("offset_sd", np.zeros(3)), float),
                   None if entry.get("mean_coef") is None else np.asarray(entry["mean_coef"], float))


#: the features of the discrepancy's mean per channel, prime (``r' = r L / U``, ``v' = v / U``):
#: surge is even in the turn (the speed lost to drift and yaw, and a constant), sway and yaw odd
MEAN_FEATURES = {"u": ("rr", "vv", "1"), "v": ("r", "v", "rrr"), "r": ("r", "v", "rrr")}


def mean_features(u, v, r, length: float) -> list:
    """The features (n, 3) of each channel's mean (:data:`MEAN_FEATURES`) from
    the states ``u, v`` [m/s], ``r`` [rad/s] of a ship of ``length`` [m]."""
    u, v, r = (np.asarray(x, float) for x in (u, v, r))
    speed = np.maximum(np.hypot(u, v), 1e-9)
    rp, vp = r * float(length) / speed, v / speed
    odd = np.column_stack([rp, vp, rp ** 3])
    return [np.column_stack([rp ** 2, vp ** 2, np.ones_like(rp)]), odd, odd]


def fit_mean(features: list, accelerations: list) -> np.ndarray:
    """Least-squares coefficients (3, 3) of each channel's mean: ``features``
    holds one :func:`mean_features` list per record, ``accelerations`` the
    records' smoothed discrepancy accelerations (n, 3)."""
    out = np.zeros((3, 3))
    for j in range(3):
        x = np.vstack([f[j] for f in features])
        y = np.concatenate([a[:, j] for a in accelerations])
        out[j] = np.linalg.lstsq(x, y, rcond=None)[0]
    return out


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
                           step: float | None = 0.5, max_evaluations: int = 600, modules=None,
                           channel_taus: bool = True, rate_gain: bool = True,
                           offsets: bool = True, mean: bool = False) -> Discrepancy:
    """Prediction-error estimate of the discrepancy (module docstring).

    Parameters
    ----------
    model, vessel
        The identified model and its vessel; an
        :class:`~studies.vessels.kvlcc2_mmg.MMGVessel` makes the filter's
        process model the MMG model (propeller rate from each record's ``n``).
    values : dict or list of dict
        The coefficients every record is filtered with (posterior medians),
        or one set per record: each record's out-of-sample coefficients
        (:func:`out_of_sample_values`), so that the discrepancy is what a
        model misses on a record it was not fitted to.
    records : list of DataFrame
        The training records (data contract, uniformly sampled).
    settings : KalmanSettings, optional
        The filter's measurement channels, noise and sensor biases.
    step : float or None
        Records thinned to about this step [s] for the filter; None: as sampled.
    max_evaluations : int
        Most likelihood evaluations of the Powell searches (both stages).
    modules : MMGParameters, optional
        The MMG model's propeller and rudder parameters (default the vessel's).
    channel_taus : bool
        One correlation time per channel (else one shared by the three).
    rate_gain : bool
        Estimate the growth of the discrepancy's size with ``|r'|`` (else 0).
    offsets : bool
        Estimate the spread of a constant acceleration per record
        (:func:`record_offsets`; else none).
    mean : bool
        Fit a mean that depends on the state to the smoothed discrepancy of
        the training records (:func:`fit_mean`; else none).
    """
    started = time.perf_counter()
    if not records:
        raise ConfigError("method.discrepancy=process_noise needs training records")
    per_record = _values_per_record(values, len(records))
    settings = settings or KalmanSettings()
    thinned = [thin_record(rec, step) for rec in records]
    ref = _reference_acceleration(thinned)
    dt = min(float(np.median(np.diff(r["t"].to_numpy(float)))) for r in thinned)
    evaluations = [0]
    biased = bool(settings.bias)
    tau_low, tau_high = max(dt, 0.05), 3600.0

    def split(theta, n_tau, with_gain):
        tau = np.broadcast_to(np.exp(theta[3:3 + n_tau]), (3,)).copy()
        sigma = np.sqrt(np.exp(theta[:3]) / (2.0 * tau))
        at = 3 + n_tau
        used = replace(settings, bias_fraction=float(np.exp(theta[at]))) if biased else settings
        gain = float(theta[at + int(biased)]) if with_gain else 0.0
        return sigma, tau, used, gain

    def negative(theta, n_tau, with_gain):
        evaluations[0] += 1
        sigma, tau, used, gain = split(theta, n_tau, with_gain)
        total = 0.0
        for rec, at in zip(thinned, per_record):
            total += innovation_loglik(rec, model, at, vessel, sigma, tau, used, modules=modules,
                                       gain=gain)
        return -total if np.isfinite(total) else 1e300

    def bounds(n_tau, with_gain):
        low = np.log(np.r_[2.0 * (1e-4 * ref) ** 2 * tau_low, [tau_low] * n_tau])
        high = np.log(np.r_[2.0 * (10.0 * ref) ** 2 * tau_high, [tau_high] * n_tau])
        if biased:
            low, high = np.r_[low, np.log(1e-5)], np.r_[high, np.log(0.1)]
        if with_gain:
            low, high = np.r_[low, 0.0], np.r_[high, 20.0]
        return low, high

    def search(theta, n_tau, with_gain, budget):
        low, high = bounds(n_tau, with_gain)
        opt = minimize(negative, np.clip(theta, low, high), args=(n_tau, with_gain), method="Powell",
                       bounds=list(zip(low, high)),
                       options={"maxfev": int(max(budget, 1)), "xtol": 0.02, "ftol": 1e-6})
        return opt, low, high

    # stage 1: one correlation time, the same size everywhere (a grid, then Powell)
    best = None
    bias0 = np.log(settings.bias_fraction) if biased else 0.0
    for tau in (1.0, 5.0, 30.0):
        for fraction in (0.01, 0.03, 0.1, 0.3):
            theta = np.log(np.r_[2.0 * (fraction * ref) ** 2 * tau, tau])
            if biased:
                theta = np.r_[theta, bias0]
            value = negative(theta, 1, False)
            if best is None or value < best[0]:
                best = (value, theta)
    stages = [(3, False)] * bool(channel_taus) + [(3 if channel_taus else 1, True)] * bool(rate_gain)
    share = max_evaluations // (1 + len(stages))
    opt, low, high = search(best[1], 1, False, share)
    value, theta, n_tau, with_gain = best[0], best[1], 1, False
    if opt.fun <= value:
        value, theta = float(opt.fun), opt.x
    converged = [bool(opt.success)]
    # then nested extensions, each from the previous solution and kept only when the
    # likelihood rises: a correlation time per channel, then the growth with |r'|
    for n_next, gain_next in stages:
        start = np.r_[theta[:3], np.broadcast_to(theta[3:3 + n_tau], (n_next,)),
                      theta[3 + n_tau:3 + n_tau + int(biased)], [0.0] * int(gain_next and not with_gain),
                      theta[3 + n_tau + int(biased):]]
        budget = share if n_next != n_tau or gain_next != with_gain else 0
        if budget <= 0:
            continue
        opt, low_n, high_n = search(start, n_next, gain_next, budget)
        converged.append(bool(opt.success))
        if opt.fun <= value:
            value, theta, n_tau, with_gain, low, high = float(opt.fun), opt.x, n_next, gain_next, low_n, high_n
        else:
            # the nested start itself is as good as the previous solution
            theta, n_tau, with_gain = start, n_next, gain_next
            low, high = low_n, high_n
    sigma, tau, used, gain = split(theta, n_tau, with_gain)
    # the error of a record's measured first u, v, r beyond the sensor noise: the smoothed
    # sensor bias at the training records' first samples, with its posterior variance (the
    # RMS over whole records would count what the biases absorb later, e.g. in a turn)
    starts, means, durations, features, smoothed = [], [], [], [], []
    for rec, at in zip(thinned, per_record):
        _, states, var = innovation_loglik(rec, model, at, vessel, sigma, tau, used, smooth=True,
                                           modules=modules, gain=gain)
        starts.append(states[0, 9:12] ** 2 + var[0, 9:12])
        means.append(np.mean(states[:, 6:9], axis=0))
        if mean:
            features.append(mean_features(rec["u"].to_numpy(float), rec["v"].to_numpy(float),
                                          rec["r"].to_numpy(float), vessel.length))
            smoothed.append(states[:, 6:9])
        t = rec["t"].to_numpy(float)
        durations.append(float(t[-1] - t[0]))
    initial_sd = np.sqrt(np.mean(starts, axis=0))
    offset_sd = record_offsets(np.asarray(means), np.asarray(durations), sigma, tau) if offsets \
        else np.zeros(3)
    free = slice(0, len(theta) - int(with_gain))          # a slope of zero is no bound
    info = {"evaluations": float(evaluations[0]), "runtime_s": time.perf_counter() - started,
            "bias_fraction": float(used.bias_fraction) if biased else 0.0,
            "step_s": float(dt), "converged": float(all(converged)),
            "out_of_sample": float(not isinstance(values, dict)),
            "at_bound": float(bool(np.any(np.isclose(theta[free], low[free], atol=1e-3))
                                   or np.any(np.isclose(theta, high, atol=1e-3))))}
    mean_coef = fit_mean(features, smoothed) if mean else None
    return Discrepancy("process_noise", sigma, tau, -value, initial_sd, info, gain, offset_sd, mean_coef)


def _values_per_record(values, n_records: int) -> list:
    """One coefficient set per record from a set for all or a list of sets."""
    if isinstance(values, dict):
        return [values] * n_records
    values = list(values)
    if len(values) != n_records:
        raise ValueError(f"{len(values)} coefficient sets for {n_records} records")
    return values


def out_of_sample_values(problems: dict, values: dict, n_records: int) -> list | None:
    """Each record's coefficients as the model identified without it.

    For record ``j`` the regression of every DOF is solved by least squares
    (:class:`~studies.identification.ls.LeastSquares`) on the rows of the other
    records (prior and captive rows kept), and ``values`` shifted by what
    that changes: ``values + (c_{-j} - c_all)``, so that the posterior
    medians stay the centre and each record is filtered by a model it did
    not train (the leave-one-record-out innovations). ``problems`` is
    ``{dof: RegressionProblem}`` with ``record`` the index of each row's
    record in the training records' order. None when fewer than three
    records, or the problems do not say which record a row comes from, or a
    record's removal leaves a DOF with fewer rows than terms.

    Why: the filter's one-step errors on the records the coefficients were
    fitted to understate how a prediction departs on a new record; on the 16
    KVLCC2 free-running records (MMG model) the sway and yaw accelerations
    estimated out of sample are 1.5 and 1.4 times the in-sample ones
    (``docs/calibration.md``).
    """
    if n_records < 3 or any(getattr(p, "record", None) is None for p in problems.values()):
        return None
    solver = LeastSquares()
    full = {}
    for problem in problems.values():
        full.update(zip(problem.names, solver.fit_one(problem)))
    out = []
    for j in range(n_records):
        shifted = dict(values)
        for problem in problems.values():
            keep = np.asarray(problem.record) != j
            if keep.sum() < problem.theta.shape[1]:
                return None
            part = replace(problem, theta=problem.theta[keep], y=problem.y[keep],
                               record=np.asarray(problem.record)[keep], time=None, states=None)
            for name, value in zip(problem.names, solver.fit_one(part)):
                if name in shifted:
                    shifted[name] = shifted[name] + (float(value) - float(full[name]))
        out.append(shifted)
    return out


def record_offsets(means: np.ndarray, durations: np.ndarray, sigma, tau) -> np.ndarray:
    """Standard deviations (3,) of a constant acceleration per record.

    ``means`` (records, 3) are the records' mean smoothed discrepancy
    accelerations, ``durations`` (records,) their lengths [s]. An
    Ornstein-Uhlenbeck process of standard deviation ``sigma`` and
    correlation time ``tau`` averaged over ``T`` seconds has the variance
    ``2 sigma^2 tau / T`` (``T >> tau``; at most ``sigma^2``); what the
    records' mean squares hold beyond that, averaged over the records, is
    the variance of the constant (the method of moments of a random effect,
    zero when the records do not differ more than the process explains).
    Fewer than three records: zeros (a spread needs several).
    """
    means = np.atleast_2d(np.asarray(means, float))
    if len(means) < 3:
        return np.zeros(3)
    sigma = np.asarray(sigma, float)
    tau = np.broadcast_to(np.asarray(tau, float), (3,))
    durations = np.maximum(np.asarray(durations, float), 1e-9)
    explained = np.minimum(2.0 * sigma[None, :] ** 2 * tau[None, :] / durations[:, None], sigma[None, :] ** 2)
    excess = np.mean(means ** 2 - explained, axis=0)
    return np.sqrt(np.maximum(excess, 0.0))
