"""Compiled fixed-step RK4 integrator of the 3-DOF manoeuvring equations.

Everything here is a pure function of its arguments (no model object is
mutated); :mod:`studies.simulate.simulator` wraps it with the model's terms.
Coefficients enter as dense ``(3, 35)`` matrices over the cubic monomial
basis of :mod:`studies.simulate.monomials`.

State vector (7): ``du`` [m/s] surge perturbation through the water
(``u = U0 + du``), ``v`` [m/s] sway through the water, ``r`` [rad/s],
``x0``, ``y0`` [m] earth-fixed position (x0 north), ``psi`` [rad], ``delta``
[rad] actual rudder angle. Forces are evaluated from the terms' monomials::

    F_dof = sum_k coef_k * u'^a_k v'^b_k r'^c_k delta^d_k

then ``M [u'_dot, v'_dot, r'_dot] = F + tau'_wind + R(psi)^T b' + w'``
(thesis eq. 3.7/3.20, SVM paper eq. 12) with ``u'_dot = du_dot L / U^2``,
``v'_dot = v_dot L / U^2``, ``r'_dot = r_dot L^2 / U^2``.

Rudder modes (``mode``):

0. ``cmd`` is the commanded rudder; the servo saturates at ``rudder_max``
   and follows ``delta_dot = (delta_c - delta) / T`` limited to the rate.
1. zig-zag: ``params = [amplitude, heading_switch, yaw_sign, first_sign]``;
   ``cmd`` is 1 from the execute time on (0 before it: rudder amidships).
2. heading autopilot (PD): ``cmd`` is the heading reference,
   ``params = [kp, kd, yaw_sign]``; ``delta_c = yaw_sign (kp e - kd r)``.
3. prescribed actual rudder: ``delta`` follows ``cmd`` exactly (linear
   between samples), for replaying a measured record.
4. turning circle with pull-out: ``params = [amplitude, pullout_heading,
   yaw_sign]``; rudder to ``amplitude`` until the heading has changed by
   ``pullout_heading`` (<= 0: never), then to zero; ``cmd`` as for the
   zig-zag (the execute time).

``yaw_sign`` is the sign of the heading change a positive rudder gives
(``sign(Nd)``, -1 for the Mariner).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..environment.wind import wind_load
from .monomials import coefficient_tuple, dense_coefficients, scaled_forces
from ..config import DATA_SCHEMES

__all__ = ["rk4_simulate", "rk4_simulate_many", "N_STATES"]

N_STATES = 7
#: fixed-step schemes: classical RK4 (the default), or forward Euler, ``x += dt f(x)``, as
#: the Marine Systems Simulator's ``zigzag.m`` (its ``euler2``) steps the ship (the thesis' data)
SCHEMES = DATA_SCHEMES
DIVERGED_SPEED_FACTOR = 5.0


@njit(cache=True, inline="always")
def _derivatives(du, v, r, cpsi, spsi, delta, delta_c, prescribed_rate, prescribed, c, k, wp,
                 e0, e1, e2, e3, e4, e5, g0, g1, g2, has_ext):
    """State derivative at one RK4 stage. ``c`` is :func:`coefficient_tuple`,
    ``k`` the tuple of :func:`_constants`, ``e0..e5`` this step's external
    forces (prime: earth-fixed X, Y, N bias then body X, Y, N noise),
    ``g0..g2`` its body-fixed forces of given magnitude (prime at the
    approach speed times ``U0^2``). Only scalars and tuples come in: no
    array reference counting per stage."""
    u = k[0] + du
    speed2 = u * u + v * v
    speed = math.sqrt(speed2)
    # forces times U^2 (prime x U^2): the hydrodynamic sums do not wait for the square root
    fx, fy, fn = scaled_forces(c, du, v, r * k[1], delta, speed, 1.0 / speed)
    # current (earth-fixed components k[11], k[12]) seen in the body frame
    uc = cpsi * k[11] + spsi * k[12]
    vc = cpsi * k[12] - spsi * k[11]
    if k[9] != 0.0:
        wx, wy, wn = wind_load(u + uc, v + vc, math.atan2(spsi, cpsi), k[9], k[10], wp)
        fx += wx * k[13]
        fy += wy * k[13]
        fn += wn * k[13] * k[14]
    if has_ext:
        # earth-fixed slowly varying bias rotated into the body, plus body noise
        fx += (cpsi * e0 + spsi * e1 + e3) * speed2
        fy += (cpsi * e1 - spsi * e0 + e4) * speed2
        fn += (e2 + e5) * speed2
        # body-fixed forces whose magnitude does not scale with the speed (a propeller's side
        # force), times 1 + k[18] |r'| (a model discrepancy growing with the turn)
        if k[18] != 0.0:
            gs = 1.0 + k[18] * abs(r) * k[1] / speed
            g0 = g0 * gs
            g1 = g1 * gs
            g2 = g2 * gs
        fx += g0
        fy += g1
        fn += g2
    du_dot = fx * k[2]
    v_dot = k[5] * fy + k[6] * fn
    r_dot = k[7] * fy + k[8] * fn
    x_dot = cpsi * (u + uc) - spsi * (v + vc)
    y_dot = spsi * (u + uc) + cpsi * (v + vc)
    if prescribed:
        delta_dot = prescribed_rate
    else:
        dc = min(max(delta_c, -k[15]), k[15])
        delta_dot = min(max((dc - delta) * k[17], -k[16]), k[16])
    return du_dot, v_dot, r_dot, x_dot, y_dot, r, delta_dot


def _constants(mass, length, speed0, env, rho, servo, ext_gain: float = 0.0,
               scheme: str = "rk4") -> tuple:
    """Pack the constants of the right-hand side, reciprocals precomputed,
    and the integration scheme (:data:`SCHEMES`) as the last entry.

    The mass-matrix inverse is scaled so that ``U^2``-scaled prime forces give
    ``du_dot``, ``v_dot`` [m/s^2] and ``r_dot`` [rad/s^2] directly.
    """
    det = mass[1, 1] * mass[2, 2] - mass[1, 2] * mass[2, 1]
    k = np.zeros(20)
    k[0] = speed0
    k[1] = length
    k[2] = 1.0 / (mass[0, 0] * length)
    # inverse of the sway-yaw block [[m22, m23], [m32, m33]], over L (sway) and L^2 (yaw)
    k[5] = mass[2, 2] / det / length
    k[6] = -mass[1, 2] / det / length
    k[7] = -mass[2, 1] / det / length ** 2
    k[8] = mass[1, 1] / det / length ** 2
    k[9] = env[0]
    k[10] = env[1]
    k[11] = env[2] * math.cos(env[3])
    k[12] = env[2] * math.sin(env[3])
    k[13] = 1.0 / (0.5 * rho * length * length)
    k[14] = 1.0 / length
    k[15] = servo[0]
    k[16] = servo[1]
    k[17] = 1.0 / servo[2]
    k[18] = ext_gain
    try:
        k[19] = SCHEMES.index(scheme)
    except ValueError:
        raise ValueError(f"integration scheme must be one of {', '.join(SCHEMES)}, got {scheme!r}") from None
    return tuple(float(x) for x in k)


@njit(cache=True, inline="always")
def _small_rotation(a):
    """(cos a, sin a) by their Taylor series, exact to 1e-12 for the heading
    increment of a stage (|a| <= step x |r| < 0.1 rad)."""
    a2 = a * a
    return (1.0 - a2 * (0.5 - a2 * (1.0 / 24.0 - a2 / 720.0)),
            a * (1.0 - a2 * (1.0 / 6.0 - a2 * (1.0 / 120.0 - a2 / 5040.0))))


@njit(cache=True, inline="always")
def _command(mode, cmd_i, psi, r, psi0, p0, p1, p2, memory):
    """Commanded rudder held over a step, and the updated ``memory`` (the
    zig-zag sign / the turning phase carried between steps)."""
    if mode == 0:
        return cmd_i, memory
    if mode == 1:
        if cmd_i < 0.5:                 # before the execute time: rudder amidships
            return 0.0, memory
        if memory * p2 * (psi - psi0) >= p1:
            memory = -memory
        return memory * p0, memory
    if mode == 2:
        return p2 * (p0 * (cmd_i - psi) - p1 * r), memory
    if mode == 4:
        if cmd_i < 0.5:
            return 0.0, memory
        if memory > 0.0 and p1 > 0.0 and abs(psi - psi0) >= p1:
            memory = 0.0
        return memory * p0, memory
    return 0.0, memory


# contraction only: NaN and inf semantics are kept for the divergence check, and no
# reassociation (it would turn the balanced force sums back into one long chain)
_FAST = {"contract", "arcp", "nsz"}


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _integrate(cm, k, x0, dt, cmd, mode, params, wp, ext, out):
    """RK4 (or forward Euler, ``k[19] == 1``) over ``out.shape[0] - 1``
    steps; ``ext`` with no rows means no external forces. Returns -1, or the
    first step that left the physical range."""
    c = coefficient_tuple(cm)
    n = out.shape[0]
    s0, s1, s2, s3, s4, s5, s6 = x0[0], x0[1], x0[2], x0[3], x0[4], x0[5], x0[6]
    for j in range(N_STATES):
        out[0, j] = x0[j]
    psi0 = s5
    p0, p1, p2 = params[0], params[1], params[2]
    memory = params[3] if mode == 1 else 1.0
    prescribed = mode == 3
    limit = DIVERGED_SPEED_FACTOR * k[0]
    has_ext = ext.shape[0] > 0
    e0 = e1 = e2 = e3 = e4 = e5 = g0 = g1 = g2 = 0.0
    speed0_2 = k[0] * k[0]
    h = 0.5 * dt
    sixth = dt / 6.0
    euler = k[19] == 1.0
    n_stages = 1 if euler else 4
    weight = dt if euler else sixth
    for i in range(n - 1):
        dc, memory = _command(mode, cmd[i], s5, s2, psi0, p0, p1, p2, memory)
        rate = 0.0
        if prescribed:
            s6 = cmd[i]
            rate = (cmd[i + 1] - cmd[i]) / dt
        if has_ext:
            e0, e1, e2, e3, e4, e5 = ext[i, 0], ext[i, 1], ext[i, 2], ext[i, 3], ext[i, 4], ext[i, 5]
            g0, g1, g2 = ext[i, 6] * speed0_2, ext[i, 7] * speed0_2, ext[i, 8] * speed0_2
        # one cosine/sine per step: the stages rotate it by their small heading increments
        cp = math.cos(s5)
        sp = math.sin(s5)
        # the stages in one loop: the force evaluation is compiled once, not once per stage
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = 0.0
        d0 = d1 = d2 = d3 = d4 = d5 = d6 = 0.0
        for stage in range(n_stages):
            if stage == 0:
                w, hs = 1.0, 0.0
            elif stage == 3:
                w, hs = 1.0, dt
            else:
                w, hs = 2.0, h
            ca, sa = _small_rotation(hs * d5)
            d0, d1, d2, d3, d4, d5, d6 = _derivatives(
                s0 + hs * d0, s1 + hs * d1, s2 + hs * d2, cp * ca - sp * sa, sp * ca + cp * sa,
                s6 + hs * d6, dc, rate, prescribed, c, k, wp, e0, e1, e2, e3, e4, e5, g0, g1, g2,
                has_ext)
            a0 += w * d0
            a1 += w * d1
            a2 += w * d2
            a3 += w * d3
            a4 += w * d4
            a5 += w * d5
            a6 += w * d6
        s0 += weight * a0
        s1 += weight * a1
        s2 += weight * a2
        s3 += weight * a3
        s4 += weight * a4
        s5 += weight * a5
        s6 += weight * a6
        if prescribed:
            s6 = cmd[i + 1]
        u_tot = k[0] + s0
        if not (u_tot > 0.0 and u_tot < limit and abs(s1) < limit and abs(s2) < 1.0
                and math.isfinite(s3) and math.isfinite(s4)):
            for m in range(i + 1, n):
                for j in range(N_STATES):
                    out[m, j] = np.nan
            return i + 1
        out[i + 1, 0] = s0
        out[i + 1, 1] = s1
        out[i + 1, 2] = s2
        out[i + 1, 3] = s3
        out[i + 1, 4] = s4
        out[i + 1, 5] = s5
        out[i + 1, 6] = s6
    return -1


#: columns of the external forces per step: earth-fixed bias (bx, by, bn) and body-fixed
#: process noise (wx, wy, wn), prime at the current speed; body-fixed forces of given
#: magnitude (fx, fy, fn), prime at the approach speed U0 (optional, zero when absent)
EXTERNAL_COLUMNS = 9


def _ext_rows(ext, n):
    """External forces per step (:data:`EXTERNAL_COLUMNS`, a 6-column array
    padded with zeros), or an empty array when there are none."""
    ext = np.ascontiguousarray(ext, dtype=float)
    if not ext.any():
        return np.zeros((0, EXTERNAL_COLUMNS))
    if ext.shape[0] < n - 1:
        raise ValueError(f"external forces cover {ext.shape[0]} steps, need {n - 1}")
    if ext.ndim != 2 or ext.shape[1] not in (6, EXTERNAL_COLUMNS):
        raise ValueError(f"external forces have {ext.shape[-1]} columns, need 6 or {EXTERNAL_COLUMNS}")
    if ext.shape[1] == 6:
        ext = np.ascontiguousarray(np.hstack([ext, np.zeros((ext.shape[0], 3))]))
    return ext


#: length of :meth:`~studies.vessels.base.WindParticulars.as_array` (the particulars and
#: the convention's two flags): a vessel without wind particulars gets as many zeros, so
#: that its simulations type-check (``wind_load`` reads every index) and share the
#: compiled code of a vessel with them
WIND_PARTICULARS = 11


def _wind_tuple(wp):
    """Wind particulars as a tuple of :data:`WIND_PARTICULARS` (zeros for a vessel without them)."""
    wp = np.asarray(wp, dtype=float)
    return tuple(float(x) for x in wp) if wp.size else (0.0,) * WIND_PARTICULARS


def rk4_simulate(coef, powers, dofs, mass, length, speed0, x0, dt, cmd, mode, params,
                 env, wp, rho, ext, servo, ext_gain: float = 0.0, scheme: str = "rk4"):
    """Integrate one parameter set; returns ``(states (n, 7), diverged_at)``.

    ``coef`` is the coefficient vector in the order of ``powers``/``dofs``;
    the external forces of given magnitude (columns 6-8 of ``ext``) act times
    ``1 + ext_gain |r'|`` (``r' = r L / U``).
    ``diverged_at`` is -1 when the run stayed bounded, else the first step
    index that left the physical range (rows from there on are NaN).
    """
    n = cmd.shape[0]
    c = dense_coefficients(coef, powers, dofs)[0]
    k = _constants(mass, length, speed0, env, rho, servo, float(ext_gain), scheme)
    out = np.empty((n, N_STATES))
    diverged = _integrate(c, k, np.asarray(x0, float), float(dt), cmd, int(mode),
                          np.asarray(params, float), _wind_tuple(wp), _ext_rows(ext, n), out)
    return out, diverged


@njit(cache=True, parallel=True)
def _integrate_many(cs, k, x0s, dt, cmd, mode, params, wp, ext, out, diverged):
    for i in prange(cs.shape[0]):
        diverged[i] = _integrate(cs[i], k, x0s[i], dt, cmd, mode, params, wp, ext, out[i])


@njit(cache=True)
def _integrate_many_serial(cs, k, x0s, dt, cmd, mode, params, wp, ext, out, diverged):
    for i in range(cs.shape[0]):
        diverged[i] = _integrate(cs[i], k, x0s[i], dt, cmd, mode, params, wp, ext, out[i])


#: below this many set-steps (sets x integration steps, a few milliseconds of work) the sets
#: are integrated one after the other: starting the threads costs more than they save
#: (measured 0.9 ms serial against 3-8 ms on two threads for 45 sets of 120 steps on a
#: loaded two-core machine), and the many short replays of an output-error fit are this size
PARALLEL_WORK = 200_000


def rk4_simulate_many(coefs, powers, dofs, mass, length, speed0, x0, dt, cmd, mode, params,
                      env, wp, rho, ext, servo, ext_gain: float = 0.0, scheme: str = "rk4"):
    """Integrate many parameter sets in parallel (one row of ``coefs`` each).

    ``x0`` is one initial state (7,) for every set, or one per set
    ``(n_sets, 7)`` (a sensitivity to the initial state then rides in the
    same parallel call as those to the coefficients).
    Returns ``(states (n_sets, n, 7), diverged_at (n_sets,))``.
    """
    n = cmd.shape[0]
    cs = dense_coefficients(coefs, powers, dofs)
    k = _constants(mass, length, speed0, env, rho, servo, float(ext_gain), scheme)
    x0s = np.asarray(x0, float)
    if x0s.ndim == 1:
        x0s = np.broadcast_to(x0s, (cs.shape[0], N_STATES))
    if x0s.shape != (cs.shape[0], N_STATES):
        raise ValueError(f"initial states have shape {x0s.shape}, need ({cs.shape[0]}, {N_STATES})")
    x0s = np.ascontiguousarray(x0s)
    out = np.empty((cs.shape[0], n, N_STATES))
    diverged = np.empty(cs.shape[0], dtype=np.int64)
    run = _integrate_many if cs.shape[0] * n >= PARALLEL_WORK else _integrate_many_serial
    run(cs, k, x0s, float(dt), cmd, int(mode), np.asarray(params, float), _wind_tuple(wp),
        _ext_rows(ext, n), out, diverged)
    return out, diverged
