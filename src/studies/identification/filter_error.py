"""The prediction-error likelihood of a record under a model with process noise.

An output-error fit replays a record from measured states and compares the
replay with the measurement: it takes the model as exact between the
states it starts from. Real records carry process noise (waves, gusts,
what the model does not hold) that pushes the ship off any replay; an
output-error residual is then mostly that drift, correlated over minutes,
and an extension that bends its replay towards one record's drift (a
current, a wind) can look better than the model that is right. The
prediction-error method (the filter-error method of flight-test
identification, Maine & Iliff 1986; Jategaonkar 2015 ch. 5) asks instead
how well the model predicts each next sample from everything measured
before, with an extended Kalman filter whose process model is the
simulator's own right-hand side (the cause's wind, current, external
forces and rudder included) and whose process noise absorbs the drift.
Its innovations are white when the model is right, so their likelihood
scores models without a correlation correction.

State (6): ``du`` [m/s] surge perturbation through the water (``u = U0 +
du``), ``v`` [m/s] sway through the water, ``r`` [rad/s], ``x0``, ``y0``
[m], ``psi`` [rad]; the rudder is the record's, linear between samples.
Process noise: white accelerations on ``du``, ``v``, ``r`` of spectral
densities ``q`` [(m/s^2)^2/Hz, (m/s^2)^2/Hz, (rad/s^2)^2/Hz], ``Q_d =
diag(q) dt`` on those states, or (``tau`` > 0) coloured: three more states,
disturbance accelerations on ``du``, ``v``, ``r`` that wander as
first-order autoregressions of correlation time ``tau`` with the same
low-frequency density ``q`` (a shaping filter, Gelb 1974; what waves,
gusts and a model's own errors do: they push for seconds to minutes, and
white noise would read such a push as a constant force); optionally (``q`` of six) white velocities on
``x0``, ``y0``, ``psi`` too [m^2/s, m^2/s, rad^2/s]: a track and heading
that drift slowly from the integral of the measured velocities (the
position, heading and velocity sensors of a real record disagree by small
biases and scale factors; the kinematic relations are then not exact). Measurements (6): ``x0, y0, psi`` and the
over-ground ``u, v`` (through the water plus the current seen in the body
frame) and ``r``, with white noise of variances ``R``, processed one at a
time. Mean propagated by one RK4 step per sample (the simulator's
derivatives, :func:`studies.simulate.integrator._derivatives`), covariance
by the second-order expansion of the transition with the finite-difference
Jacobian of those derivatives.

References
----------
Maine, R.E., Iliff, K.W. (1986). Application of parameter estimation to
aircraft stability and control: the output-error approach. NASA RP-1168.

Jategaonkar, R.V. (2015). Flight vehicle system identification, 2nd ed.
AIAA, ch. 5 (filter error method).

Gelb, A. (ed.) (1974). Applied optimal estimation. MIT Press (correlated
process noise by a shaping filter: the augmented state).
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit
from scipy.optimize import minimize_scalar

from ..simulate.integrator import _constants, _derivatives, _ext_rows, _wind_tuple
from ..simulate.monomials import coefficient_tuple, dense_coefficients

__all__ = ["N_FILTER", "innovation_likelihood", "PredictionError", "filter_all", "side_by_side"]

#: size of the filter's state (du, v, r, x0, y0, psi)
N_FILTER = 6

#: measured channels, in this order: x0, y0, psi, u, v, r
_CHANNELS = 6


@njit(cache=True, inline="always")
def _step(s0, s1, s2, s3, s4, s5, d0, d1, dt, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext,
          f0, f1, f2, k1):
    """One RK4 step of (du, v, r, x0, y0, psi), the rudder linear from ``d0`` to
    ``d1``, the disturbance accelerations ``f0, f1, f2`` [m/s^2, m/s^2,
    rad/s^2] on ``du, v, r`` held over the step; ``k1`` the derivatives at
    the step's start (:func:`_rates`)."""
    rate = (d1 - d0) / dt
    h = 0.5 * dt
    a0, a1, a2 = k1[0] + f0, k1[1] + f1, k1[2] + f2
    p5 = s5 + h * k1[5]
    k2 = _derivatives(s0 + h * a0, s1 + h * a1, s2 + h * a2, math.cos(p5), math.sin(p5),
                      d0 + h * rate, 0.0, rate, True, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext)
    b0, b1, b2 = k2[0] + f0, k2[1] + f1, k2[2] + f2
    p5 = s5 + h * k2[5]
    k3 = _derivatives(s0 + h * b0, s1 + h * b1, s2 + h * b2, math.cos(p5), math.sin(p5),
                      d0 + h * rate, 0.0, rate, True, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext)
    c0, c1, c2 = k3[0] + f0, k3[1] + f1, k3[2] + f2
    p5 = s5 + dt * k3[5]
    k4 = _derivatives(s0 + dt * c0, s1 + dt * c1, s2 + dt * c2, math.cos(p5), math.sin(p5),
                      d1, 0.0, rate, True, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext)
    w = dt / 6.0
    return (s0 + w * (a0 + 2.0 * (b0 + c0) + k4[0] + f0),
            s1 + w * (a1 + 2.0 * (b1 + c1) + k4[1] + f1),
            s2 + w * (a2 + 2.0 * (b2 + c2) + k4[2] + f2),
            s3 + w * (k1[3] + 2.0 * (k2[3] + k3[3]) + k4[3]),
            s4 + w * (k1[4] + 2.0 * (k2[4] + k3[4]) + k4[4]),
            s5 + w * (k1[5] + 2.0 * (k2[5] + k3[5]) + k4[5]))


@njit(cache=True, inline="always")
def _rates(s0, s1, s2, s5, d, rate, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext):
    """Continuous derivative of (du, v, r, x0, y0, psi) at one state."""
    return _derivatives(s0, s1, s2, math.cos(s5), math.sin(s5), d, 0.0, rate, True, c, k, wp,
                        e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext)




@njit(cache=True, inline="always")
def work_arrays(speed0, n):
    """The filter's work arrays for ``n`` states: ``J``, ``F``, ``FP`` (n, n),
    ``ph`` (n,), and the Jacobian's steps per ship state (six) at the
    approach speed ``speed0``."""
    return (np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n)),
            np.zeros(n), np.array([1e-6 * speed0, 1e-6 * speed0, 1e-8, 1.0, 1.0, 1e-7]))


@njit(cache=True, inline="always")
def propagate_covariance(J, dt, q, P, F, FP, decay):
    """``P <- F P F^T + Q`` in place, ``F = I + J dt + (J dt)^2 / 2`` from the
    Jacobian ``J`` of the continuous dynamics (its position columns zeroed:
    positions do not enter the dynamics), ``Q = diag(q) dt`` on the first
    ``len(q)`` states (the three velocities; with six, the track and heading
    too; with nine, the disturbance states of the coloured process noise,
    whose transition is ``decay``: their autoregression's coefficient per
    step); ``F`` and ``FP`` are work arrays. The size of the state is ``P``'s."""
    n = P.shape[0]
    for a in range(n):
        J[a, 3] = 0.0
        J[a, 4] = 0.0
    # F = I + J dt + (J dt)^2 / 2, over J's nonzero entries (most are zero: positions do not enter
    # the dynamics, the heading only through the kinematics and a wind or current)
    for a in range(n):
        for b in range(n):
            F[a, b] = J[a, b] * dt
    for a in range(n):
        for m in range(n):
            w = J[a, m]
            if w != 0.0:
                w *= 0.5 * dt * dt
                for b in range(n):
                    F[a, b] += w * J[m, b]
        F[a, a] += 1.0
    for a in range(N_FILTER, n):
        F[a, a] = decay
    # FP = F P, then P = FP F^T (symmetric), over F's nonzero entries
    for a in range(n):
        for b in range(n):
            FP[a, b] = 0.0
        for m in range(n):
            w = F[a, m]
            if w != 0.0:
                for b in range(n):
                    FP[a, b] += w * P[m, b]
    for a in range(n):
        for b in range(a, n):
            acc = 0.0
            for m in range(n):
                w = F[b, m]
                if w != 0.0:
                    acc += FP[a, m] * w
            P[a, b] = acc
            P[b, a] = acc
    for a in range(q.shape[0]):
        P[a, a] += q[a] * dt


@njit(cache=True, inline="always")
def measurement_update(s, P, z, R, speed0, current_north, current_east, innovations, variances, ph):
    """The six channels of one sample ``z`` (x0, y0, psi, u, v, r; NaN = not
    measured) processed one at a time into the state ``s`` (du, v, r through
    the water, x0, y0, psi; ``u = speed0 + du``) and its covariance ``P``, in
    place; the over-ground velocities are the state's plus the current's
    earth-fixed components (north, east) [m/s] seen in the body frame. Fills
    ``innovations`` and ``variances`` (6,) and returns the sample's
    log-likelihood; ``ph`` is a work array. The size of the state
    is ``P``'s (six, or nine with the coloured process noise's disturbances,
    which no channel measures)."""
    n = P.shape[0]
    loglik = 0.0
    for j in range(_CHANNELS):
        y = z[j]
        if not math.isfinite(y):
            innovations[j] = np.nan
            variances[j] = np.nan
            continue
        cp = math.cos(s[5])
        sp_ = math.sin(s[5])
        uc = cp * current_north + sp_ * current_east
        vc = cp * current_east - sp_ * current_north
        # the channel's row of the measurement matrix: 1 on its state, and for an over-ground
        # velocity the current's turn with the heading
        hc = 0.0
        if j == 0:
            pred = s[3]
            main = 3
        elif j == 1:
            pred = s[4]
            main = 4
        elif j == 2:
            pred = s[5]
            main = 5
        elif j == 3:
            pred = speed0 + s[0] + uc
            main = 0
            hc = vc
        elif j == 4:
            pred = s[1] + vc
            main = 1
            hc = -uc
        else:
            pred = s[2]
            main = 2
        if hc != 0.0:
            for a in range(n):
                ph[a] = P[a, main] + hc * P[a, 5]
        else:
            for a in range(n):
                ph[a] = P[a, main]
        S = R[j] + ph[main] + hc * ph[5]
        e = y - pred
        innovations[j] = e
        variances[j] = S
        loglik += -0.5 * (math.log(2.0 * math.pi * S) + e * e / S)
        for a in range(n):
            s[a] += ph[a] * e / S
        for a in range(n):
            for b in range(n):
                P[a, b] -= ph[a] * ph[b] / S
    return loglik


@njit(cache=True, nogil=True)
def _filter(cm, k, wp, cmd, ext, dt, z, R, q, s_init, P_init, innovations, variances, decay):
    """EKF over the samples of ``z`` (n, 6: x0, y0, psi, u, v, r over ground;
    NaN = missing); ``cmd`` (n,) the rudder at the samples, ``ext`` (n - 1, 9)
    or (0, 9) the external forces per step. Fills ``innovations`` and
    ``variances`` (n, 6) with each scalar update's innovation and its
    variance (NaN where not measured) and returns the log-likelihood; -inf
    when the prediction leaves the physical range.

    With nine states (``s_init``), the last three are disturbance
    accelerations on ``du, v, r``, held over each step, then multiplied by
    ``decay`` (``exp(-dt / tau)``) and driven by the process noise ``q[6:9]``:
    a first-order autoregression per step.

    The covariance is propagated with ``F = I + J dt + (J dt)^2 / 2``, ``J``
    the Jacobian of the continuous dynamics at the step's start (forward
    differences of the simulator's derivatives; the position and heading
    columns only through the heading)."""
    c = coefficient_tuple(cm)
    n = z.shape[0]
    has_ext = ext.shape[0] > 0
    speed0_2 = k[0] * k[0]
    limit = 5.0 * k[0]
    s = s_init.copy()
    P = P_init.copy()
    m = s.shape[0]
    J, F, FP, ph, hstep = work_arrays(k[0], m)
    coloured = m > N_FILTER
    if coloured:
        for a in range(3):
            J[a, N_FILTER + a] = 1.0
    loglik = 0.0
    f0 = f1 = f2 = 0.0
    e0 = e1 = e2 = e3 = e4 = e5 = g0 = g1 = g2 = 0.0
    for i in range(n):
        if i > 0:
            if has_ext:
                e0, e1, e2 = ext[i - 1, 0], ext[i - 1, 1], ext[i - 1, 2]
                e3, e4, e5 = ext[i - 1, 3], ext[i - 1, 4], ext[i - 1, 5]
                g0, g1, g2 = ext[i - 1, 6] * speed0_2, ext[i - 1, 7] * speed0_2, ext[i - 1, 8] * speed0_2
            d0, d1 = cmd[i - 1], cmd[i]
            rate = (d1 - d0) / dt
            # Jacobian of the continuous dynamics (positions do not enter it): forward differences
            # from the derivatives at the step's start, which also start its RK4 step
            base = _rates(s[0], s[1], s[2], s[5], d0, rate, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext)
            for j in (0, 1, 2, 5):
                h = hstep[j]
                a0, a1, a2, a5 = s[0], s[1], s[2], s[5]
                if j == 0:
                    a0 += h
                elif j == 1:
                    a1 += h
                elif j == 2:
                    a2 += h
                else:
                    a5 += h
                fp = _rates(a0, a1, a2, a5, d0, rate, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext)
                for a in range(N_FILTER):
                    J[a, j] = (fp[a] - base[a]) / h
            if coloured:
                f0, f1, f2 = s[6], s[7], s[8]
            nxt = _step(s[0], s[1], s[2], s[3], s[4], s[5], d0, d1, dt, c, k, wp,
                        e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext, f0, f1, f2, base)
            for a in range(N_FILTER):
                s[a] = nxt[a]
            if coloured:
                for a in range(N_FILTER, m):
                    s[a] *= decay
            propagate_covariance(J, dt, q, P, F, FP, decay)
            u = k[0] + s[0]
            if not (u > 0.0 and u < limit and abs(s[1]) < limit and abs(s[2]) < 1.0
                    and math.isfinite(s[3]) and math.isfinite(s[4])):
                return -np.inf
        loglik += measurement_update(s, P, z[i], R, k[0], k[11], k[12], innovations[i], variances[i], ph)
    return loglik


#: standard deviation of the initial surge and sway velocity when the record does not measure
#: them, as a share of the approach speed (and of ``U0 / L`` for the yaw rate)
UNMEASURED_START_SHARE = 0.05


def initial_covariance(R: np.ndarray, measured: np.ndarray, speed0: float, length: float) -> np.ndarray:
    """The filter's initial state covariance (``du, v, r, x0, y0, psi``): each
    channel's measurement-noise variance ``R`` where the first sample measures
    it; a velocity the record does not measure (NaN, e.g. velocities derived
    from the track and not read as measured) starts with a standard deviation
    of :data:`UNMEASURED_START_SHARE` of ``U0`` [m/s] (``U0 / L`` [rad/s] for
    ``r``), so the first samples of the track set it. A start held to a
    derived velocity's noise would hold the filter to that velocity's error,
    which only a large process noise could then undo."""
    R = np.asarray(R, float)
    first = np.asarray(measured, float)[0] if len(measured) else np.zeros(6)
    floor = np.array([1e-12, 1e-12, 1e-16])
    wide = (UNMEASURED_START_SHARE * float(speed0)) ** 2 * np.array([1.0, 1.0, 1.0 / float(length) ** 2])
    velocity = np.where(np.isfinite(first[3:6]), np.maximum(R[3:6], floor), np.maximum(wide, floor))
    return np.diag([*velocity, max(R[0], 1e-12), max(R[1], 1e-12), max(R[2], 1e-16)])


def innovation_likelihood(plan, vector: np.ndarray, measured: np.ndarray, R: np.ndarray, q: np.ndarray,
                          initial: np.ndarray | None = None,
                          tau: float = 0.0) -> tuple[float, np.ndarray, np.ndarray]:
    """Prediction-error log-likelihood of one record replayed by ``plan``.

    Parameters
    ----------
    plan : studies.simulate.simulator.ReplayPlan or MMGFilterPlan
        The record's replay (its rudder, wind, current and external forces as
        the cause reads them), prepared with one integration step per sample;
        or a plan with its own process model and ``likelihood`` method
        (:class:`studies.identification.mmg_filter.MMGFilterPlan`), which runs instead.
    vector : ndarray
        Prime coefficients in the plan's model order.
    measured : ndarray (n, 6)
        ``x0, y0`` [m], unwrapped ``psi`` [rad], over-ground ``u, v`` [m/s]
        and ``r`` [rad/s] at the plan's samples.
    R : ndarray (6,)
        Measurement-noise variances of those channels.
    q : ndarray (3,) or (6,)
        Process-noise spectral densities on ``du``, ``v``, ``r`` (and ``x0``,
        ``y0``, ``psi``).
    initial : ndarray (6,), optional
        Initial ``du, v, r, x0, y0, psi`` through the water (default: the
        plan's start, the record's first row).
    tau : float
        Correlation time [s] of the process noise on ``du, v, r`` (0: white). With ``tau``, the noise is a disturbance
        acceleration that wanders as a first-order autoregression (three more
        states: waves, gusts and a model's own errors push a ship for seconds
        to minutes, not for one sample), of the same low-frequency spectral
        density ``q[:3]`` (its variance ``q / (2 tau)``); white is its limit
        as ``tau`` goes to zero.

    Returns
    -------
    (loglik, innovations (n, 6), variances (n, 6))
    """
    if hasattr(plan, "likelihood"):
        # a plan with its own process model (the MMG model: studies.identification.mmg_filter)
        return plan.likelihood(vector, measured, R, q, initial, tau)
    inputs = plan.inputs
    if inputs.substeps != 1:
        raise ValueError("the prediction-error filter takes one integration step per sample")
    n = len(measured)
    cm = dense_coefficients(np.asarray(vector, float), inputs.powers, inputs.dofs)[0]
    k = _constants(inputs.mass, inputs.length, inputs.speed0, inputs.env, inputs.rho, inputs.servo)
    cmd = np.ascontiguousarray(inputs.cmd[:n], float)
    ext = _ext_rows(inputs.ext, len(inputs.cmd))
    start = plan.initial_state()[:N_FILTER] if initial is None else np.asarray(initial, float)
    R = np.asarray(R, float)
    q = np.asarray(q, float)
    P0 = initial_covariance(R, measured, inputs.speed0, inputs.length)
    dt = float(inputs.step)
    decay = 1.0
    if tau > 0.0:
        q, start, P0, decay = coloured_noise(q, start, P0, dt, float(tau))
    innovations = np.empty((n, _CHANNELS))
    variances = np.empty((n, _CHANNELS))
    loglik = _filter(cm, k, _wind_tuple(inputs.wind), cmd, np.ascontiguousarray(ext[: max(n - 1, 0)]),
                     dt, np.ascontiguousarray(measured, float), R, np.ascontiguousarray(q),
                     np.ascontiguousarray(start, float), np.ascontiguousarray(P0), innovations, variances, decay)
    return float(loglik), innovations, variances


#: threads that filter a model's records side by side (the compiled filters release the GIL):
#: one per core this process may use, at most four
FILTER_THREADS = max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                            else (os.cpu_count() or 1)))
_pool: tuple[int, ThreadPoolExecutor] | None = None


def _threads() -> ThreadPoolExecutor:
    """The process's pool of :data:`FILTER_THREADS` threads (made again in a
    forked child, whose copy of the parent's pool has no threads)."""
    global _pool
    if _pool is None or _pool[0] != os.getpid():
        _pool = (os.getpid(), ThreadPoolExecutor(FILTER_THREADS, thread_name_prefix="filter"))
    return _pool[1]


def side_by_side(fn, items) -> list:
    """``[fn(item) for item in items]``, the items on :data:`FILTER_THREADS`
    threads when there are several (``fn`` must spend its time in compiled
    code that releases Python's lock, as the filters and smoothers do); in
    order."""
    items = list(items)
    if FILTER_THREADS < 2 or len(items) < 2:
        return [fn(item) for item in items]
    return list(_threads().map(fn, items))


def filter_all(jobs: list) -> list:
    """Every job's records filtered, side by side on :data:`FILTER_THREADS`
    threads: ``jobs`` are ``(PredictionError, vector, log10 process-noise
    scale)``; returns per job its records' ``(loglik, innovations,
    variances)`` (:func:`innovation_likelihood`), in order. A Jacobian's
    columns or a gradient's finite differences filtered together keep both
    cores busy where one model's few records of unequal length do not."""
    tasks = [(like, vector, a, i) for like, vector, a in jobs for i in range(len(like.plans))]

    def run(task):
        like, vector, a, i = task
        return like.record_likelihood(i, vector, a)

    done = side_by_side(run, tasks)
    out, k = [], 0
    for like, _, _ in jobs:
        out.append(done[k:k + len(like.plans)])
        k += len(like.plans)
    return out


def coloured_noise(q: np.ndarray, start: np.ndarray, P0: np.ndarray, dt: float, tau: float) -> tuple:
    """The filter's process noise, start and initial covariance with three
    disturbance states of correlation time ``tau`` [s] on ``du, v, r``
    (:func:`innovation_likelihood`): ``(q (9,), start (9,), P0 (9, 9),
    decay per step exp(-dt / tau))``. Their stationary variance is ``q[:3] /
    (2 tau)``, the variance they start with, kept by the noise per step;
    at ``tau = dt / 2`` their effect per step is nearly the white noise's."""
    decay = float(np.exp(-dt / tau))
    variance = q[:3] / (2.0 * tau)
    out = np.zeros(N_FILTER + 3)
    out[3:len(q)] = q[3:]
    out[N_FILTER:] = variance * (1.0 - decay ** 2) / dt
    P = np.zeros((N_FILTER + 3, N_FILTER + 3))
    P[:N_FILTER, :N_FILTER] = P0
    P[N_FILTER:, N_FILTER:] = np.diag(variance)
    return out, np.concatenate([np.asarray(start, float)[:N_FILTER], np.zeros(3)]), P, decay


class PredictionError:
    """The prediction-error likelihood of several records under one model and
    cause, with the process-noise intensity estimated.

    ``plans`` are the records' replays (one integration step per sample),
    ``measured`` their measured channels (:func:`innovation_likelihood`), ``R``
    the measurement-noise variances, ``q0`` the shape of the process noise
    (spectral densities on ``du``, ``v``, ``r``): the filter uses ``q0 *
    10**a`` and :meth:`fit` finds the ``a`` that maximises the likelihood;
    ``tau`` the correlation time [s] of the noise on ``du, v, r`` (0: white;
    :func:`innovation_likelihood`).
    """

    def __init__(self, plans: list, measured: list, R: np.ndarray, q0: np.ndarray, tau: float = 0.0):
        self.plans, self.measured = plans, measured
        self.R, self.q0 = np.asarray(R, float), np.asarray(q0, float)
        self.tau = float(tau)

    def record_likelihood(self, i: int, vector: np.ndarray, log_scale: float) -> tuple:
        """:func:`innovation_likelihood` of record ``i`` at process-noise scale ``10**log_scale``."""
        q = self.q0 * 10.0 ** float(log_scale)
        return innovation_likelihood(self.plans[i], vector, self.measured[i], self.R, q, tau=self.tau)

    def with_noises(self, q0: np.ndarray, R: np.ndarray, tau: float) -> "PredictionError":
        """The same records and plans under other noises (process-noise shape ``q0``,
        measurement variances ``R``, correlation time ``tau`` [s])."""
        return PredictionError(self.plans, self.measured, R, q0, tau)

    def _each_record(self, vector: np.ndarray, log_scale: float) -> list:
        """:meth:`record_likelihood` of every record, in the records' order."""
        return filter_all([(self, vector, log_scale)])[0]

    @staticmethod
    def total(results: list) -> float:
        """Summed log-likelihood of one model's records (:func:`filter_all`'s
        per-record results); -inf when a prediction left the physical range."""
        total = 0.0
        for ll, _, _ in results:
            if not np.isfinite(ll):
                return -np.inf
            total += ll
        return total

    def loglik(self, vector: np.ndarray, log_scale: float) -> float:
        """Summed log-likelihood of the records at process-noise scale ``10**log_scale``."""
        return self.total(self._each_record(vector, log_scale))

    def _filtered(self, vector: np.ndarray, log_scale: float):
        """Per record ``(z, innovations, variances)`` at process-noise scale
        ``10**log_scale``; ``None`` for the innovations and variances of a
        record whose prediction leaves the physical range."""
        return self._unpacked(self._each_record(vector, log_scale))

    def _unpacked(self, results: list):
        for z, (ll, e, S) in zip(self.measured, results):
            yield (z, e, S) if np.isfinite(ll) else (z, None, None)

    def residuals(self, vector: np.ndarray, log_scale: float) -> np.ndarray:
        """The records' innovations over their standard deviations (zero where a
        channel is not measured; 1e3 everywhere when a prediction leaves the
        physical range): the sum of their squares is ``-2 ln L`` less the
        ``ln(2 pi S)`` terms: what the filter-error method's Gauss-Newton
        form minimises with ``S`` held; where ``S`` changes with the model,
        :meth:`deviance_residuals` carries those terms too."""
        return np.concatenate([np.full(z.size, 1e3) if e is None else np.nan_to_num((e / np.sqrt(S)).ravel(), nan=0.0)
                               for z, e, S in self._filtered(vector, log_scale)])

    def deviance_residuals(self, vector: np.ndarray, log_scale: float) -> np.ndarray:
        """Residuals whose sum of squares is the records' whole ``-2 ln L`` less a
        constant of the filter (``sum ln(2 pi R)``): per sample, the six
        standardised innovations ``e / sqrt(S)`` (:meth:`residuals`), then the
        six ``sqrt(ln(S / R))`` (``S >= R``: the prediction's variance adds to
        the measurement noise's; zero where a channel is not measured; 1e3
        everywhere when a prediction leaves the physical range).

        The standardised innovations alone leave out ``sum ln S``: a model
        that predicts the tracks no better but is less damped (its state
        covariance, hence ``S``, grows) lowers their sum of squares, and a
        least-squares fit or a likelihood ratio on them alone credits it."""
        return self.deviance_of(self._each_record(vector, log_scale))

    def deviance_of(self, results: list) -> np.ndarray:
        """:meth:`deviance_residuals` of :func:`filter_all`'s per-record results
        for this model."""
        parts = []
        for z, e, S in self._unpacked(results):
            if e is None:
                parts.append(np.full(2 * z.size, 1e3))
                continue
            w = np.nan_to_num(e / np.sqrt(S), nan=0.0)
            spread = np.sqrt(np.maximum(np.nan_to_num(np.log(S / self.R), nan=0.0), 0.0))
            parts.append(np.hstack([w, spread]).ravel())
        return np.concatenate(parts)

    def fit(self, vector: np.ndarray, bounds=(-4.0, 3.0)) -> tuple[float, float]:
        """``(log-likelihood, log10 scale)`` at the process-noise scale that
        maximises the likelihood (scipy's bounded scalar search)."""
        def cost(a):
            ll = self.loglik(vector, a)
            return -ll if np.isfinite(ll) else 1e300

        res = minimize_scalar(cost, bounds=bounds, method="bounded", options={"xatol": 0.02})
        return -float(res.fun), float(res.x)
