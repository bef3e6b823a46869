"""State and acceleration estimation with an extended Kalman filter and RTS smoother.

Inverse-dynamics identification needs the accelerations ``u_dot, v_dot,
r_dot`` of the body-fixed velocities. Differentiating noisy, quantised
measurements (the MARIN files print three significant digits, so above
1000 m a position moves in 10 m steps and above 100 deg the heading in 1 deg
steps) amplifies the noise; Savitzky-Golay filters
(:mod:`studies.data.derivatives`) trade it against lag and bias. The method
of Alexandersson et al. (2022) estimates states and accelerations with an
extended Kalman filter (EKF) whose process model is the ship model, and a
Rauch-Tung-Striebel (RTS) smoother, and iterates: identify, filter with the
identified model, re-identify on the smoothed states.

State (12): ``x0, y0`` [m] earth-fixed position, ``psi`` [rad], ``u, v``
[m/s] body-fixed velocities, ``r`` [rad/s], three acceleration states
``a_u, a_v, a_r`` and three sensor biases ``b_u, b_v, b_r`` of the measured
velocity channels (random walks; a measured ``r`` is ``r + b_r + noise``).
The biases matter on the MARIN files: their yaw rate integrates to a heading
that drifts from the measured one by about 0.005 deg/s in all three runs,
and their velocity channels integrate to tracks up to 140 m off the
measured positions; without bias states the likelihood can only reconcile
the channels with a large process noise, and the accelerations come out
noisy (regression R^2 0.06-0.8 instead of 0.92-0.97). Process models:

``kinematic`` (first pass, no ship model needed)
    ``u_dot = a_u``, ``v_dot = a_v``, ``r_dot = a_r`` with the accelerations
    driven by white jerk (a constant-acceleration / integrated Wiener model
    in the body frame), positions by ``x0_dot = u cos psi - v sin psi``,
    ``y0_dot = u sin psi + v cos psi``, ``psi_dot = r``.
``model`` (the better option)
    ``[u_dot, v_dot, r_dot] = f(u, v, r, delta) + [a_u, a_v, a_r]``, with
    ``f`` the manoeuvring model (prime forces of its terms through the
    vessel's mass matrix, exactly as the simulator) and ``a`` a random-walk
    model discrepancy with a smaller spectral density. The smoothed
    acceleration ``f(x_s, delta) + a_s`` therefore follows the data where
    the model is wrong, so re-identifying on it is not circular.
    With an :class:`~studies.vessels.kvlcc2_mmg.MMGVessel` the ship model is
    the MMG model (hull terms, propeller at the record's rate ``n``, rudder
    in the slipstream: the simulator's own right-hand side,
    :func:`studies.simulate.mmg.mmg_acceleration`), as the model
    discrepancy of ``model=mmg`` needs (:func:`innovation_loglik`).

Measurements: any of ``x0, y0, psi, u, v, r`` of the record (body-fixed
``u, v`` as in the data contract), a linear selection of the state.
Measurement noise variances come, by default, from the data: per channel,
the rolling variance of the residual of a smooth (Savitzky-Golay) fit, so
that a channel whose quantisation step grows (position beyond 1000 m,
heading beyond 100 deg) gets a larger variance from that sample on. The
process-noise spectral densities start from the record's own acceleration
scale (Savitzky-Golay) and are scaled by the factor that maximises the
innovation likelihood on a logarithmic grid (a one-parameter maximum
likelihood estimate of the noise, cheap because the filter is compiled).

Discretisation: RK4 for the mean (rudder linear between samples), and
``F = I + J dt + (J dt)^2 / 2``, ``Q_d = Q dt + (J Q + Q J^T) dt^2 / 2 + J Q
J^T dt^3 / 3`` for the covariance (J the Jacobian of the continuous
dynamics; the model's Jacobian by central differences).

:func:`estimate_derivatives` is the entry point for every acceleration
estimator of the regression: ``ekf`` and ``ekf_kinematic`` run the filter
here, ``auto``, ``central`` and ``savgol`` the model-free estimators of
:mod:`studies.data.derivatives`.

References
----------
Alexandersson, M., Mao, W., Ringsberg, J.W. (2022). System identification
of vessel manoeuvring models. Ocean Engineering 266, 112940.
doi:10.1016/j.oceaneng.2022.112940

Rauch, H.E., Tung, F., Striebel, C.T. (1965). Maximum likelihood estimates
of linear dynamic systems. AIAA Journal 3(8), 1445-1450.

Sarkka, S. (2013). Bayesian filtering and smoothing. Cambridge University
Press (EKF ch. 5, RTS smoother ch. 8-9, discretisation ch. 4/6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numba import njit

from ..data.derivatives import MODEL_FREE_METHODS, DerivativeEstimate, savgol_filter
from ..data.derivatives import estimate_derivatives as model_free_derivatives
from ..data.resample import uniform_step
from ..errors import ConfigError
from ..models.mmg import HULL_TERMS, MODULE_CONSTANTS
from ..simulate.mmg import mmg_acceleration, process_constants
from ..simulate.monomials import dense_coefficients, scaled_forces
from ..vessels.kvlcc2_mmg import MMGVessel

__all__ = ["KalmanSettings", "KalmanResult", "kalman_smooth", "ekf_derivatives", "innovation_loglik",
           "estimate_derivatives", "measurement_variance", "smoothed_record", "MEASURABLE",
           "STATE_NAMES", "EKF_METHODS"]

#: state vector of the filter
STATE_NAMES = ("x0", "y0", "psi", "u", "v", "r", "a_u", "a_v", "a_r", "b_u", "b_v", "b_r")
#: record channels the filter can use as measurements, and their state index
MEASURABLE = {"x0": 0, "y0": 1, "psi": 2, "u": 3, "v": 4, "r": 5}
N_STATE = 12
#: bias state of each velocity channel
BIAS_INDEX = {"u": 9, "v": 10, "r": 11}
#: ``method=`` values of :func:`estimate_derivatives` that run the filter
EKF_METHODS = ("ekf", "ekf_kinematic")


@dataclass(frozen=True)
class KalmanSettings:
    """Settings of :func:`kalman_smooth` (the ``kalman.*`` config keys).

    Attributes
    ----------
    channels : tuple of str
        Measured channels used (subset of ``x0 y0 psi u v r``).
    noise_window : float
        Window [s] of the smooth fit whose residual gives the measurement
        noise.
    noise_span : float
        Window [s] of the rolling variance of that residual.
    measurement_std : dict
        Fixed measurement standard deviations per channel (SI units),
        overriding the data-driven ones.
    process_scale : float or None
        Multiplier of the default process-noise spectral densities; None
        chooses it by maximum innovation likelihood over ``scale_grid``.
    scale_grid : tuple of float
        Candidate multipliers (log-spaced) for the likelihood search.
    discrepancy : float
        With the ship model as process model, the spectral density of the
        model discrepancy relative to the kinematic one.
    bias : bool or tuple of str
        Estimate a slowly varying bias of each measured velocity channel
        (``u, v, r``; or of the channels named) against the positions and
        heading (random walks), as for a rate gyro whose integral drifts
        from the heading. Only with a position or heading channel measured.
    bias_fraction : float
        Prior standard deviation of the biases, as a fraction of the
        channel's scale (median speed for ``u, v``; RMS yaw rate for ``r``).
    bias_time : float
        Time [s] over which a bias may wander by its prior size.
    """

    channels: tuple = ("x0", "y0", "psi", "u", "v", "r")
    noise_window: float = 10.0
    noise_span: float = 30.0
    measurement_std: dict = field(default_factory=dict)
    process_scale: float | None = None
    scale_grid: tuple = tuple(10.0 ** np.arange(-3.0, 3.01, 0.5))
    discrepancy: float = 0.1
    bias: bool | tuple = True
    bias_fraction: float = 0.01
    bias_time: float = 300.0

    @classmethod
    def from_config(cls, node) -> "KalmanSettings":
        """From a mapping (``kalman`` config node); unknown keys are refused."""
        node = dict(node or {})
        known = set(cls.__dataclass_fields__)
        unknown = set(node) - known - {"iterations"}
        if unknown:
            raise ConfigError(f"unknown kalman settings {sorted(unknown)}; known: {sorted(known)}")
        kwargs = {k: v for k, v in node.items() if k in known and v is not None}
        if "channels" in kwargs:
            kwargs["channels"] = tuple(str(c) for c in kwargs["channels"])
            bad = [c for c in kwargs["channels"] if c not in MEASURABLE]
            if bad or not kwargs["channels"]:
                raise ConfigError(f"kalman.channels must be a non-empty subset of "
                                  f"{list(MEASURABLE)}, got {list(kwargs['channels'])}")
        if "bias" in kwargs and not isinstance(kwargs["bias"], bool):
            kwargs["bias"] = tuple(str(c) for c in kwargs["bias"])
            if set(kwargs["bias"]) - set(BIAS_INDEX):
                raise ConfigError(f"kalman.bias must be true, false or a subset of {list(BIAS_INDEX)}")
        if "scale_grid" in kwargs:
            kwargs["scale_grid"] = tuple(float(s) for s in kwargs["scale_grid"])
        if "measurement_std" in kwargs:
            kwargs["measurement_std"] = {str(k): float(v) for k, v in dict(kwargs["measurement_std"]).items()}
        return cls(**kwargs)


@dataclass
class KalmanResult:
    """Smoothed states and accelerations of one record.

    Attributes
    ----------
    t : ndarray
    states : ndarray (n, 9)
        Smoothed state (:data:`STATE_NAMES`).
    std : ndarray (n, 9)
        Smoothed standard deviations.
    rates : ndarray (n, 3)
        ``u_dot, v_dot, r_dot`` (the acceleration states, plus the model's
        acceleration with the ship model as process model).
    delta : ndarray
        Rudder angle used as input (the record's).
    loglik : float
        Innovation log-likelihood of the filter at the chosen noise.
    process_scale : float
        Multiplier of the default process noise that was used.
    process : str
        ``"kinematic"`` or ``"model"``.
    """

    t: np.ndarray
    states: np.ndarray
    std: np.ndarray
    rates: np.ndarray
    delta: np.ndarray
    loglik: float
    process_scale: float
    process: str
    measurement_std: dict = field(default_factory=dict)
    likelihoods: dict = field(default_factory=dict)

    @property
    def bias(self) -> dict:
        """Smoothed sensor biases of the velocity channels (median over the record)."""
        return {name: float(np.median(self.states[:, idx])) for name, idx in BIAS_INDEX.items()}


# --------------------------------------------------------------- measurement noise

def _odd_length(window: float, dt: float, n: int, minimum: int = 5) -> int:
    length = max(minimum, int(round(window / dt)))
    length = min(length, n if n % 2 else n - 1)
    return length + 1 - length % 2


def measurement_variance(record: pd.DataFrame, channels, window: float = 10.0,
                         span: float = 30.0) -> np.ndarray:
    """Per-sample measurement variances (n, m) from the residual of a smooth fit.

    For each channel, a cubic Savitzky-Golay fit over ``window`` seconds is
    taken as the signal; the rolling mean square of the residual over
    ``span`` seconds (centred) is the variance. Over a cubic fit, ship
    motions are smooth, so the residual is the sensor noise, including the
    quantisation of printed values whose step changes along the record. A
    floor of 1e-6 of the channel's own variance keeps the filter defined on
    perfectly clean data.
    """
    t = record["t"].to_numpy(float)
    dt = uniform_step(t)
    n = len(t)
    length = _odd_length(window, dt, n)
    roll = max(3, int(round(span / dt)))
    out = np.empty((n, len(channels)))
    for j, c in enumerate(channels):
        x = record[c].to_numpy(float)
        resid = x - savgol_filter(x, length, 3, mode="interp")
        # the fit's own residual has (length - 4) / length of the noise variance
        var = pd.Series(resid ** 2).rolling(roll, center=True, min_periods=1).mean().to_numpy()
        var = var * (length / max(length - 4, 1))
        floor = 1e-6 * max(np.var(x), 1e-30) + 1e-18
        out[:, j] = np.maximum(var, floor)
    return out


#: :func:`measurement_variance` of the records filtered lately, by their content: a likelihood
#: search filters the same records hundreds of times, and the variances depend on the record alone
_VARIANCES: dict = {}
_VARIANCES_KEPT = 16


def _measurement_variance_of(record: pd.DataFrame, channels, window: float, span: float) -> np.ndarray:
    """:func:`measurement_variance`, computed once per record content (a copy: callers change it)."""
    import hashlib

    digest = hashlib.blake2b(digest_size=16)
    for c in ["t", *channels]:
        digest.update(np.ascontiguousarray(record[c].to_numpy(float)).tobytes())
    key = (tuple(channels), float(window), float(span), digest.hexdigest())
    found = _VARIANCES.get(key)
    if found is None:
        found = measurement_variance(record, channels, window, span)
        if len(_VARIANCES) >= _VARIANCES_KEPT:
            _VARIANCES.pop(next(iter(_VARIANCES)))
        _VARIANCES[key] = found
    return found.copy()


# --------------------------------------------------------------- compiled filter

@njit(cache=True)
def _model_acc(u, v, r, delta, c, k):
    """Accelerations (u_dot, v_dot, r_dot) of the manoeuvring model.

    ``k``: speed0, length, 1/m11, m33/det, -m23/det, -m32/det, m22/det (and the
    discrepancy's constants, unused here: :func:`_model_constants`).
    """
    speed0 = k[0]
    length = k[1]
    speed2 = u * u + v * v
    if speed2 < 1e-12:
        speed2 = 1e-12
    speed = math.sqrt(speed2)
    fx, fy, fn = scaled_forces(c, u - speed0, v, r * length, delta, speed, 1.0 / speed)
    return (fx * k[2] / length, (k[3] * fy + k[4] * fn) / length,
            (k[5] * fy + k[6] * fn) / (length * length))


NS = 12  # compiled code's state size (see STATE_NAMES)

#: process models of the compiled filter
KINEMATIC, ABKOWITZ, MMG = 0, 1, 2


@njit(cache=True)
def _process_acc(u, v, r, delta, n, mode, c, k, mp):
    """Accelerations of the ship model: the cubic (Abkowitz-type) model of
    :func:`_model_acc`, or with ``mode == MMG`` the MMG model
    (:func:`studies.simulate.mmg.mmg_acceleration`, ``mp`` its constants,
    ``n`` the propeller rate [rps])."""
    if mode == MMG:
        return mmg_acceleration(u, v, r, delta, n, mp[0], mp[1], mp[2], mp[3])
    return _model_acc(u, v, r, delta, c, k)


@njit(cache=True)
def _gain(u, v, r, k):
    """State-dependent size of the discrepancy, ``1 + k[10] |r'|`` (``r' = r L
    / U``): exactly 1 when the slope is zero."""
    if k[10] == 0.0:
        return 1.0
    speed = math.sqrt(u * u + v * v)
    if speed < 1e-9:
        speed = 1e-9
    return 1.0 + k[10] * abs(r) * k[1] / speed


@njit(cache=True)
def _f(x, delta, n, mode, c, k, mp, out):
    """Continuous dynamics of the filter's state (biases and accelerations are
    random walks: zero drift)."""
    psi, u, v, r = x[2], x[3], x[4], x[5]
    cp = math.cos(psi)
    sp = math.sin(psi)
    for i in range(NS):
        out[i] = 0.0
    out[0] = u * cp - v * sp
    out[1] = u * sp + v * cp
    out[2] = r
    if mode >= 1:
        au, av, ar = _process_acc(u, v, r, delta, n, mode, c, k, mp)
        g = _gain(u, v, r, k)
        out[3] = au + g * x[6]
        out[4] = av + g * x[7]
        out[5] = ar + g * x[8]
        # AR(1) discrepancy (Ornstein-Uhlenbeck) when k[7 + j] = 1 / tau_j > 0, else a random walk
        out[6] = -k[7] * x[6]
        out[7] = -k[8] * x[7]
        out[8] = -k[9] * x[8]
    else:
        out[3] = x[6]
        out[4] = x[7]
        out[5] = x[8]


@njit(cache=True)
def _jacobian(x, delta, n, mode, c, k, mp, J):
    for i in range(NS):
        for j in range(NS):
            J[i, j] = 0.0
    psi, u, v = x[2], x[3], x[4]
    cp = math.cos(psi)
    sp = math.sin(psi)
    J[0, 2] = -u * sp - v * cp
    J[0, 3] = cp
    J[0, 4] = -sp
    J[1, 2] = u * cp - v * sp
    J[1, 3] = sp
    J[1, 4] = cp
    J[2, 5] = 1.0
    J[3, 6] = 1.0
    J[4, 7] = 1.0
    J[5, 8] = 1.0
    if mode >= 1:
        g = _gain(u, v, x[5], k)
        for j in range(3):
            J[6 + j, 6 + j] = -k[7 + j]
            J[3 + j, 6 + j] = g
        varying = k[10] != 0.0
        for j in range(3):
            base = x[3 + j]
            h = 1e-6 * max(abs(base), 1.0) if j < 2 else 1e-7
            up, vp, rp = x[3], x[4], x[5]
            um, vm, rm = x[3], x[4], x[5]
            if j == 0:
                up, um = base + h, base - h
            elif j == 1:
                vp, vm = base + h, base - h
            else:
                rp, rm = base + h, base - h
            ap = _process_acc(up, vp, rp, delta, n, mode, c, k, mp)
            am = _process_acc(um, vm, rm, delta, n, mode, c, k, mp)
            dg = 0.0
            if varying:
                dg = _gain(up, vp, rp, k) - _gain(um, vm, rm, k)
            for i in range(3):
                J[3 + i, 3 + j] = (ap[i] - am[i] + dg * x[6 + i]) / (2.0 * h)


@njit(cache=True)
def _rk4(x, d0, d1, n0, n1, dt, mode, c, k, mp, work):
    """One RK4 step of the filter's state (:func:`_f`), the rudder and the
    propeller rate linear over the step (``d0``, ``n0`` at its start, ``d1``,
    ``n1`` at its end).

    The simulator's integrator (:mod:`studies.simulate.integrator`) is a
    different system: seven states with the rudder servo, wind, current and
    external forces, the heading's cosine and sine carried through the
    stages by a Taylor series, compiled with floating-point contraction, and
    no single step exposed. The filter's twelve states (kinematic or model
    process, acceleration and bias states) do not fit it without changing
    the filter's numbers.

    Written out in loops over a workspace ``work`` (5, NS), ``x`` updated in
    place: array expressions would allocate per step, and compiling their
    shape checks is most of the filter's compile time.
    """
    k1, k2, k3, k4, stage = work[0], work[1], work[2], work[3], work[4]
    dm = 0.5 * (d0 + d1)
    nm = 0.5 * (n0 + n1)
    _f(x, d0, n0, mode, c, k, mp, k1)
    for i in range(NS):
        stage[i] = x[i] + 0.5 * dt * k1[i]
    _f(stage, dm, nm, mode, c, k, mp, k2)
    for i in range(NS):
        stage[i] = x[i] + 0.5 * dt * k2[i]
    _f(stage, dm, nm, mode, c, k, mp, k3)
    for i in range(NS):
        stage[i] = x[i] + dt * k3[i]
    _f(stage, d1, n1, mode, c, k, mp, k4)
    for i in range(NS):
        x[i] = x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True, nogil=True)
def _filter_smooth(z, R, sel, bsel, delta, rps, dt, x0, P0, qc, mode, c, k, mp, smooth):
    """EKF over all samples, then (if ``smooth``) the RTS smoother.

    ``z`` (n, m) measurements (NaN = missing), ``R`` (n, m) their
    variances, ``sel`` (m,) the state measured by each channel and ``bsel``
    (m,) its bias state (-1: none), so ``z_j = x[sel_j] + x[bsel_j] + e``.
    ``qc`` (NS,) continuous white-noise spectral densities per state;
    ``rps`` (n,) the propeller rate (the MMG process model's input).
    Returns ``(states, variances, loglik)``.
    """
    n, m = z.shape
    xf = np.empty((n, NS))
    Pf = np.empty((n, NS, NS))
    xp = np.empty((n, NS))
    Pp = np.empty((n, NS, NS))
    Fs = np.empty((n, NS, NS))
    J = np.empty((NS, NS))
    F = np.empty((NS, NS))
    Qd = np.empty((NS, NS))
    T = np.empty((NS, NS))
    ph = np.empty(NS)
    work = np.empty((5, NS))
    x = x0.copy()
    P = P0.copy()
    loglik = 0.0
    dt2 = dt * dt
    dt3 = dt2 * dt / 3.0
    for i in range(n):
        if i > 0:
            _jacobian(x, delta[i - 1], rps[i - 1], mode, c, k, mp, J)
            # F = I + J dt + (J dt)^2 / 2; Qd = Qc dt + (J Qc + Qc J^T) dt^2 / 2 + J Qc J^T dt^3 / 3
            for a in range(NS):
                for b in range(NS):
                    jj = 0.0
                    jqj = 0.0
                    for q in range(NS):
                        jj += J[a, q] * J[q, b]
                        jqj += J[a, q] * qc[q] * J[b, q]
                    F[a, b] = (1.0 if a == b else 0.0) + J[a, b] * dt + 0.5 * dt2 * jj
                    Qd[a, b] = ((qc[a] * dt if a == b else 0.0)
                                + 0.5 * (J[a, b] * qc[b] + J[b, a] * qc[a]) * dt2 + jqj * dt3)
            _rk4(x, delta[i - 1], delta[i], rps[i - 1], rps[i], dt, mode, c, k, mp, work)
            _sandwich(F, P, T)
            for a in range(NS):
                for b in range(NS):
                    P[a, b] += Qd[a, b]
                    Fs[i - 1, a, b] = F[a, b]
        _store(x, P, xp, Pp, i)
        # sequential scalar updates (R diagonal)
        for j in range(m):
            y = z[i, j]
            if not math.isfinite(y):
                continue
            s_idx = sel[j]
            b_idx = bsel[j]
            for a in range(NS):
                ph[a] = P[a, s_idx] + (P[a, b_idx] if b_idx >= 0 else 0.0)
            if b_idx >= 0:
                S = ph[s_idx] + ph[b_idx] + R[i, j]
                e = y - x[s_idx] - x[b_idx]
            else:
                S = ph[s_idx] + R[i, j]
                e = y - x[s_idx]
            loglik += -0.5 * (math.log(2.0 * math.pi * S) + e * e / S)
            for a in range(NS):
                x[a] += ph[a] / S * e
            for a in range(NS):
                ka = ph[a] / S
                for b in range(NS):
                    P[a, b] -= ka * ph[b]
        for a in range(NS):
            for b in range(a + 1, NS):
                mean = 0.5 * (P[a, b] + P[b, a])
                P[a, b] = mean
                P[b, a] = mean
        _store(x, P, xf, Pf, i)
    var = np.empty((n, NS))
    if not smooth:
        for i in range(n):
            for j in range(NS):
                var[i, j] = Pf[i, j, j]
        return xf, var, loglik
    xs = xf.copy()
    Ps = Pf.copy()
    C = np.empty((NS, NS))
    D = np.empty((NS, NS))
    dx = np.empty(NS)
    for i in range(n - 2, -1, -1):
        # C = Pf F^T Pp^-1
        _times_transposed(Pf[i], Fs[i], T)
        _times(T, np.linalg.inv(Pp[i + 1]), C)
        for a in range(NS):
            dx[a] = xs[i + 1, a] - xp[i + 1, a]
        for a in range(NS):
            acc = 0.0
            for q in range(NS):
                acc += C[a, q] * dx[q]
            xs[i, a] = xf[i, a] + acc
        # Ps = Pf + C (Ps' - Pp') C^T
        for a in range(NS):
            for b in range(NS):
                D[a, b] = Ps[i + 1, a, b] - Pp[i + 1, a, b]
        _sandwich(C, D, T)
        for a in range(NS):
            for b in range(NS):
                Ps[i, a, b] = Pf[i, a, b] + D[a, b]
    for i in range(n):
        for j in range(NS):
            var[i, j] = Ps[i, j, j]
    return xs, var, loglik


@njit(cache=True)
def _store(x, P, xs, Ps, i):
    """``xs[i] = x``, ``Ps[i] = P`` element by element."""
    for a in range(NS):
        xs[i, a] = x[a]
        for b in range(NS):
            Ps[i, a, b] = P[a, b]


@njit(cache=True)
def _times(A, B, out):
    """``out = A B`` (square matrices of one size)."""
    size = A.shape[0]
    for a in range(size):
        for b in range(size):
            acc = 0.0
            for q in range(size):
                acc += A[a, q] * B[q, b]
            out[a, b] = acc


@njit(cache=True)
def _times_transposed(A, B, out):
    """``out = A B^T`` (square matrices of one size)."""
    size = A.shape[0]
    for a in range(size):
        for b in range(size):
            acc = 0.0
            for q in range(size):
                acc += A[a, q] * B[b, q]
            out[a, b] = acc


@njit(cache=True)
def _sandwich(A, B, work):
    """``B <- A B A^T`` in place (``work`` a matrix of the same size)."""
    _times(A, B, work)
    _times_transposed(work, A, B)


@njit(cache=True)
def _model_rates(states, delta, c, k):
    """Accelerations of the smoothed states under the cubic model, plus the discrepancy states."""
    n = states.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        a = _model_acc(states[i, 3], states[i, 4], states[i, 5], delta[i], c, k)
        out[i, 0] = a[0] + states[i, 6]
        out[i, 1] = a[1] + states[i, 7]
        out[i, 2] = a[2] + states[i, 8]
    return out


@njit(cache=True)
def _process_rates(states, delta, rps, mode, c, k, mp):
    """:func:`_model_rates` under either ship model (:func:`_process_acc`)."""
    n = states.shape[0]
    out = np.empty((n, 3))
    for i in range(n):
        a = _process_acc(states[i, 3], states[i, 4], states[i, 5], delta[i], rps[i], mode, c, k, mp)
        g = _gain(states[i, 3], states[i, 4], states[i, 5], k)
        out[i, 0] = a[0] + g * states[i, 6]
        out[i, 1] = a[1] + g * states[i, 7]
        out[i, 2] = a[2] + g * states[i, 8]
    return out


# --------------------------------------------------------------- python API

def _rates_of(tau) -> np.ndarray:
    """``1 / tau`` of the three discrepancy states (``tau`` one value or three
    [s]; None or 0: random walks)."""
    if tau is None:
        return np.zeros(3)
    tau = np.broadcast_to(np.asarray(tau, float), (3,))
    return np.where(tau > 0, 1.0 / np.where(tau > 0, tau, 1.0), 0.0)


def _model_constants(vessel, tau=None, gain: float = 0.0) -> np.ndarray:
    """Constants of the compiled model (11): speed, length, the inverse mass
    matrix, ``1 / tau`` of each discrepancy state (0: random walks; ``tau``
    one value or one per channel) and the slope of the discrepancy's size in
    ``|r'|`` (:func:`_gain`)."""
    M = vessel.mass_matrix()
    det = M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]
    return np.concatenate([[vessel.speed, vessel.length, 1.0 / M[0, 0], M[2, 2] / det, -M[1, 2] / det,
                            -M[2, 1] / det, M[1, 1] / det], _rates_of(tau), [float(gain)]])


def _default_qc(record: pd.DataFrame, dt: float) -> np.ndarray:
    """Jerk spectral densities from the record's own acceleration scale.

    ``q = a_ref^2 / T`` with ``a_ref`` the RMS of a Savitzky-Golay
    acceleration (20 s window) and ``T = 20 s``: the acceleration wanders
    by its own size in 20 s. The likelihood search rescales it.
    """
    n = len(record)
    length = _odd_length(20.0, dt, n, 7)
    out = np.empty(3)
    for j, c in enumerate(("u", "v", "r")):
        acc = savgol_filter(record[c].to_numpy(float), length, 3, deriv=1, delta=dt, mode="interp")
        scale = float(np.sqrt(np.mean(acc ** 2)))
        if scale == 0.0:
            scale = 1e-6 if c != "r" else 1e-8
        out[j] = scale ** 2 / 20.0
    return out


def _bias_prior(record: pd.DataFrame, settings: KalmanSettings) -> dict:
    """Prior standard deviation of the bias of each velocity channel.

    A fraction ``bias_fraction`` of the channel's scale: the median speed
    for ``u`` and ``v``, the RMS yaw rate for ``r``.
    """
    speed = float(np.median(np.hypot(record["u"].to_numpy(float), record["v"].to_numpy(float))))
    yaw = float(np.sqrt(np.mean(record["r"].to_numpy(float) ** 2)))
    f = settings.bias_fraction
    return {"u": f * max(speed, 1e-3), "v": f * max(speed, 1e-3), "r": f * max(yaw, 1e-6)}


def _biased_channels(settings: KalmanSettings) -> tuple:
    if settings.bias is True:
        return tuple(BIAS_INDEX)
    if not settings.bias:
        return ()
    return tuple(settings.bias)


#: the MMG constants of a filter without the MMG process model (one compiled signature)
_NO_MMG = ((0.0,) * len(HULL_TERMS), (0.0,) * len(MODULE_CONSTANTS), (0.0,) * 15, (0.0,) * 4)


def _process(model, values: dict, vessel, modules=None, tau=None, gain: float = 0.0) -> tuple:
    """``(mode, c, k, m)`` of the compiled filter with a ship model as process
    model: the MMG model (:func:`studies.simulate.mmg.mmg_acceleration`) for
    an :class:`~studies.vessels.kvlcc2_mmg.MMGVessel` (``modules`` its
    propeller and rudder parameters, default the vessel's), the cubic
    Abkowitz-type model of the simulator otherwise; ``tau`` [s] of the
    discrepancy states (None: random walks; one value or one per channel),
    ``gain`` the slope of their size in ``|r'|``."""
    if isinstance(vessel, MMGVessel):
        hull, mk, ma, mg = process_constants(model, values, vessel, modules)
        k = np.zeros(11)
        k[0], k[1] = float(vessel.speed), float(vessel.length)
        k[7:10] = _rates_of(tau)
        k[10] = float(gain)
        return MMG, np.zeros(105), k, (tuple(float(x) for x in hull), mk, ma, mg)
    c = dense_coefficients(model.vector(values), model.powers_array(), model.dof_array())[0].ravel()
    return ABKOWITZ, c, _model_constants(vessel, tau, gain), _NO_MMG


def _propeller_rate(record: pd.DataFrame, vessel=None) -> np.ndarray:
    """The record's propeller rate ``n`` [rps] (the vessel's approach rate, or
    zeros, when it has none): an input of the MMG process model."""
    if "n" in record:
        return np.ascontiguousarray(record["n"].to_numpy(float))
    return np.full(len(record), float(getattr(vessel, "rps", 0.0) or 0.0))


def _run(record, settings: KalmanSettings, mode: int, c: np.ndarray, k: np.ndarray,
         qa: np.ndarray, smooth: bool, m: tuple = _NO_MMG, rps: np.ndarray | None = None):
    t = record["t"].to_numpy(float)
    dt = uniform_step(t)
    channels = list(settings.channels)
    z = np.column_stack([record[ch].to_numpy(float) for ch in channels])
    R = _measurement_variance_of(record, channels, settings.noise_window, settings.noise_span)
    for j, ch in enumerate(channels):
        if ch in settings.measurement_std:
            R[:, j] = float(settings.measurement_std[ch]) ** 2
    sel = np.array([MEASURABLE[ch] for ch in channels], dtype=np.int64)
    bias_on = settings.bias and ("x0" in channels or "y0" in channels or "psi" in channels)
    biased = _biased_channels(settings) if bias_on else ()
    bsel = np.array([BIAS_INDEX[ch] if ch in biased else -1 for ch in channels], dtype=np.int64)
    delta = record["delta"].to_numpy(float)
    first = record.iloc[0]
    x0 = np.zeros(N_STATE)
    for name, idx in MEASURABLE.items():
        if name in record:
            x0[idx] = float(first[name])
    P0 = np.zeros((N_STATE, N_STATE))
    loose = {0: 100.0, 1: 100.0, 2: 0.01, 3: 1.0, 4: 1.0, 5: 1e-4}
    for name, idx in MEASURABLE.items():
        P0[idx, idx] = 10.0 * float(R[0, channels.index(name)]) if name in channels else loose[idx]
    qc = np.zeros(N_STATE)
    for j in range(3):
        qc[6 + j] = qa[j]
        # a random walk starts loose; an Ornstein-Uhlenbeck state at its stationary variance
        P0[6 + j, 6 + j] = qa[j] * 100.0 if mode == 0 or k[7 + j] == 0.0 else 0.5 * qa[j] / k[7 + j]
    prior = _bias_prior(record, settings)
    for name, idx in BIAS_INDEX.items():
        if name in biased:
            P0[idx, idx] = prior[name] ** 2
            qc[idx] = prior[name] ** 2 / settings.bias_time
        else:
            P0[idx, idx] = 1e-30
    xs, var, loglik = _filter_smooth(np.ascontiguousarray(z), np.ascontiguousarray(R), sel, bsel,
                                     delta, _propeller_rate(record) if rps is None else rps, float(dt),
                                     x0, P0, qc, mode, c, k, m, smooth)
    return xs, var, loglik, R


def kalman_smooth(record: pd.DataFrame, settings: KalmanSettings | None = None, model=None,
                  values: dict | None = None, vessel=None, modules=None) -> KalmanResult:
    """EKF + RTS smoother of one uniformly sampled record.

    Parameters
    ----------
    record : DataFrame
        Data contract record (t, x0, y0, psi, u, v, r, delta).
    settings : KalmanSettings, optional
    model, values, vessel : optional
        A manoeuvring model with coefficient ``values`` and its vessel: the
        ship model becomes the process model (``process="model"``);
        without them the kinematic model is used. With an
        :class:`~studies.vessels.kvlcc2_mmg.MMGVessel` the process model is
        the MMG model (propeller rate from the record's ``n``).
    modules : MMGParameters, optional
        The MMG model's propeller and rudder parameters (default the vessel's).
    """
    settings = settings or KalmanSettings()
    missing = [c for c in ("t", "u", "v", "r", "delta", *settings.channels) if c not in record]
    if missing:
        raise ValueError(f"record lacks the columns {missing} for the Kalman filter")
    t = record["t"].to_numpy(float)
    dt = uniform_step(t)
    qa = _default_qc(record, dt)
    if model is not None:
        if values is None or vessel is None:
            raise ValueError("a ship model needs its coefficient values and the vessel")
        mode, c, k, m = _process(model, values, vessel, modules)
        qa = qa * settings.discrepancy
    else:
        mode = KINEMATIC
        c = np.zeros(105)
        k = np.zeros(11)
        k[1] = 1.0
        m = _NO_MMG
    rps = _propeller_rate(record, vessel)
    likelihoods = {}
    if settings.process_scale is not None:
        scale = float(settings.process_scale)
    else:
        best = (-np.inf, 1.0)
        for s in settings.scale_grid:
            _, _, ll, _ = _run(record, settings, mode, c, k, qa * s, False, m, rps)
            likelihoods[float(s)] = float(ll)
            if np.isfinite(ll) and ll > best[0]:
                best = (ll, float(s))
        scale = best[1]
    states, var, loglik, R = _run(record, settings, mode, c, k, qa * scale, True, m, rps)
    if mode != KINEMATIC:
        rates = _process_rates(states, record["delta"].to_numpy(float), rps, mode, c, k, m)
    else:
        rates = states[:, 6:9].copy()
    mstd = {ch: float(np.sqrt(np.median(R[:, j]))) for j, ch in enumerate(settings.channels)}
    return KalmanResult(t, states, np.sqrt(np.maximum(var, 0.0)), rates,
                        record["delta"].to_numpy(float), float(loglik), scale,
                        "kinematic" if mode == KINEMATIC else "model", mstd, likelihoods)


def innovation_loglik(record: pd.DataFrame, model, values: dict, vessel, sigma, tau,
                      settings: KalmanSettings | None = None, smooth: bool = False, modules=None,
                      gain: float = 0.0):
    """Innovation log-likelihood of a record under the ship model with an
    Ornstein-Uhlenbeck (continuous AR(1)) model discrepancy.

    The filter's acceleration states become ``a_dot = -a / tau + w`` with
    ``w`` white of spectral density ``2 sigma^2 / tau``: stationary standard
    deviations ``sigma`` (3,) [m/s^2, m/s^2, rad/s^2] of the surge, sway and
    yaw accelerations the model misses, correlation time ``tau`` [s] (one
    value, or one per channel). The
    prediction-error (maximum-likelihood) estimate of ``sigma, tau``
    maximises the sum of this over the training records
    (:mod:`studies.identification.discrepancy`). The sensor biases and the
    measurement noise are as in :func:`kalman_smooth`. With ``smooth`` the
    RTS-smoothed states (n, 12) (:data:`STATE_NAMES`) and their variances
    (n, 12) are returned too. ``gain`` makes the discrepancy's size depend on
    the state: the accelerations enter as ``(1 + gain |r'|) a`` (``r' = r L /
    U``, the prime yaw rate). The
    ship model is the MMG model for an
    :class:`~studies.vessels.kvlcc2_mmg.MMGVessel` (``modules`` its
    propeller and rudder parameters, the record's ``n`` its rate), as in
    :func:`kalman_smooth`.
    """
    settings = settings or KalmanSettings()
    sigma = np.asarray(sigma, float)
    mode, c, k, m = _process(model, values, vessel, modules, tau, gain)
    tau = np.broadcast_to(np.asarray(tau, float), (3,))
    states, var, loglik, _ = _run(record, settings, mode, c, k, 2.0 * sigma ** 2 / tau, smooth,
                                  m, _propeller_rate(record, vessel))
    return (float(loglik), states, var) if smooth else float(loglik)


def smoothed_record(result: KalmanResult, record: pd.DataFrame) -> pd.DataFrame:
    """The record with ``x0, y0, psi, u, v, r`` replaced by the smoothed states
    and the accelerations added as ``u_dot, v_dot, r_dot``."""
    out = record.copy()
    for name, idx in MEASURABLE.items():
        out[name] = result.states[:, idx]
    for j, name in enumerate(("u_dot", "v_dot", "r_dot")):
        out[name] = result.rates[:, j]
    out.attrs = dict(record.attrs)
    return out


def ekf_derivatives(record: pd.DataFrame, settings: KalmanSettings | None = None, model=None,
                    values: dict | None = None, vessel=None, trim: float = 0.0) -> DerivativeEstimate:
    """:class:`~studies.data.derivatives.DerivativeEstimate` from the EKF/RTS smoother.

    The same result type as ``estimate_derivatives(record, "savgol")`` so the
    regression treats both alike; ``trim`` seconds are left out at both
    ends (the smoother's edges carry the initial-covariance transient).
    """
    res = kalman_smooth(record, settings, model, values, vessel)
    n = len(res.t)
    dt = float(res.t[1] - res.t[0]) if n > 1 else 1.0
    cut = int(round(trim / dt))
    index = np.arange(cut, n - cut) if n > 2 * cut + 5 else np.arange(n)
    s = res.states
    states = {"u": s[index, 3], "v": s[index, 4], "r": s[index, 5],
              "delta": res.delta[index], "psi": s[index, 2]}
    rates = {"u_dot": res.rates[index, 0], "v_dot": res.rates[index, 1],
             "r_dot": res.rates[index, 2]}
    return DerivativeEstimate(index, states, rates, "ekf" if res.process == "kinematic" else "ekf_model")


def estimate_derivatives(record: pd.DataFrame, method: str = "auto", window: float | None = None,
                         polyorder: int = 3) -> DerivativeEstimate:
    """States and accelerations of a uniformly sampled record, by any estimator.

    Parameters
    ----------
    record : DataFrame
        Data contract record (t, x0, y0, psi, u, v, r, delta, ...).
    method : {"auto", "central", "savgol", "ekf", "ekf_kinematic"}
        ``"ekf"`` and ``"ekf_kinematic"`` run :func:`ekf_derivatives` with the
        default settings and the kinematic process model (no ship model is
        known here); the others are the model-free estimators of
        :func:`studies.data.derivatives.estimate_derivatives`.
    window, polyorder
        Savitzky-Golay window [s] and polynomial order of the model-free
        estimators (unused by the filter).

    Raises
    ------
    ValueError
        ``method`` is none of the above, or the record is not uniformly
        sampled.
    """
    if method in EKF_METHODS:
        return ekf_derivatives(record)
    if method not in MODEL_FREE_METHODS:
        raise ValueError(f"unknown derivative method '{method}' (auto, central, savgol, ekf)")
    return model_free_derivatives(record, method, window, polyorder)
