"""Compiled RK4 simulator of the MMG model: hull terms, propeller and rudder.

The equations and the forces are those of :mod:`studies.models.mmg`; its
functions :func:`~studies.models.mmg.hull_forces`,
:func:`~studies.models.mmg.thrust_normal_force` and
:func:`~studies.models.mmg.module_gains` (what
:func:`~studies.models.mmg.module_forces` is made of) are compiled here as
they are (one definition of the physics for the simulator and the
regression). Two things are arranged for speed, the forces staying the
same to rounding: the drift angle ``atan2(-v, u)`` is taken as
``atan(-v / u)`` going ahead (:func:`_drift`), and the module gains are
multiplied through the inverse mass matrix once per run
(:func:`_module_accelerations`), so the rudder's normal force, the last
value of a stage, is one product-sum away from the accelerations.
The loop is scalar and allocation-free like
:mod:`studies.simulate.integrator`, and shares its rudder logic
(:func:`~studies.simulate.integrator._command`: zig-zag switching on heading,
turning circle with pull-out, autopilot, prescribed rudder) and the rudder
servo (saturation, rate limit, first-order lag of the vessel).

State vector (7): ``u`` [m/s] total surge and ``v`` [m/s] sway at midship
through the water, ``r`` [rad/s], ``x0``, ``y0`` [m] earth-fixed position
(x0 north), ``psi`` [rad], ``delta`` [rad] actual rudder angle in the data
contract's sign (positive turns to negative heading; the MMG's own rudder
angle is ``-delta``). The propeller rate ``n`` [rps] is an input per
integration step (constant for the standard manoeuvres, a measured record's
``n`` when replaying), linear within a step.

Records have the columns ``t, x0, y0, psi, u, v, r, delta, n`` (data
contract, SI units and radians). Calm water: no wind or current; external
accelerations (a model discrepancy's realisation,
:mod:`studies.identification.discrepancy`) may be added per step
(:func:`rk4_mmg`, :class:`MMGReplayPlan`). :func:`mmg_acceleration` is the
same right-hand side at one state, for the model-based Kalman filter of
:mod:`studies.identification.kalman`.

The heading's and the rudder's sine and cosine are computed once per step and
rotated through the stages by their increments (exact to 1e-12 for
increments below 0.1 rad: a rudder rate below 1 rad/s at a 0.1 s step); a
rudder at rest (held at its angle, most of a zig-zag or a turning circle)
keeps them from step to step.

Numba keys the cache of the compiled loop on this file alone (its content or,
in older versions, its time stamp): after editing the force functions of
:mod:`studies.models.mmg` (compiled inline here), clear this folder's
``__pycache__`` so the cache is rebuilt; touching this file is not enough
when the key is the content (numba 0.68).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numba import njit
from scipy.optimize import brentq

from ..data.resample import resample
from ..models.abkowitz import ManoeuvringModel
from ..models.mmg import (HULL_TERMS, MMGParameters, crossflow_factors, crossflow_integrals, hull_forces,
                          hull_primes, module_constants,
                          module_forces,
                          module_gains, thrust_normal_force)
from ..vessels.kvlcc2_mmg import MMGVessel
from .integrator import DIVERGED_SPEED_FACTOR, N_STATES, _command, _small_rotation
from .manoeuvres import Manoeuvre, zigzag_of_record

__all__ = ["simulate_mmg", "replay_mmg", "rk4_mmg", "hull_vector", "mmg_inputs", "mmg_forces",
           "self_propulsion_rps", "MMGReplayPlan", "mmg_acceleration", "process_constants"]

# the same contraction-only fast-math as the Abkowitz integrator
_FAST = {"contract", "arcp", "nsz"}

_hull = njit(cache=True, inline="always", fastmath=_FAST)(hull_forces)
_thrust_normal = njit(cache=True, inline="always", fastmath=_FAST)(thrust_normal_force)
_crossflow = njit(cache=True, fastmath=_FAST)(crossflow_integrals)

#: yaw sign of the contract: a positive rudder turns the ship to negative heading
YAW_SIGN = -1.0


@njit(cache=True, inline="always", fastmath=_FAST)
def _drift(u, v):
    """Drift angle ``beta = atan2(-v, u)`` [rad]; going ahead (``u > 0``) as
    ``atan(-v / u)``, the same angle to a unit in the last place and a
    shorter call than the two-argument arctangent."""
    if u > 0.0:
        return math.atan(-v / u)
    return math.atan2(-v, u)


@njit(cache=True, inline="always", fastmath=_FAST)
def _derivatives(u, v, r, cpsi, spsi, delta, sdelta, cdelta, delta_c, prescribed_rate, prescribed,
                 n, c, k, a, g, e0, e1, e2, eg):
    """State derivative at one RK4 stage; ``sdelta``, ``cdelta`` the sine and
    cosine of the rudder angle ``delta``, ``c`` hull coefficients, ``k`` the
    module constants, ``a`` the rigid-body constants of :func:`_body_constants`,
    ``g`` the module gains through the inverse mass matrix
    (:func:`_module_accelerations`), ``e0, e1, e2`` external accelerations
    [m/s^2, m/s^2, rad/s^2] added to ``u_dot, v_dot, r_dot`` times ``1 + eg
    |r'|`` (zero without them: adding 0.0 leaves every bit of the sums as it
    was)."""
    speed = math.sqrt(u * u + v * v)
    inv = 1.0 / speed
    rp = r * a[0] * inv
    thrust, normal = _thrust_normal(u, speed, _drift(u, v), rp, sdelta, cdelta, n, k)
    q = a[1] * speed * speed
    vp = v * inv
    fy = fn = 0.0
    if c[34] != 0.0 or c[35] != 0.0:          # a cross-flow hull (model.hull=crossflow)
        fy, fn = _crossflow(vp, rp, a[13], a[14])
    xh, yh, nh = _hull(u * inv, vp, rp, delta, thrust / q, fy, fn, c)
    ge = 1.0 + eg * abs(rp)
    fx = q * xh + a[3] * v * r + a[4] * r * r
    fy = q * yh - a[2] * u * r
    fn = q * a[0] * nh - a[4] * u * r
    # module forces through the inverse mass matrix; the rudder's normal force, the last
    # value to be known, is added last
    # the external accelerations join the hull's part, which is ready long before the
    # rudder's normal force: they do not lengthen the chain of dependent operations
    u_dot = (fx * a[5] + e0 * ge) + g[0] * thrust - g[1] * sdelta * normal
    v_dot = (a[6] * fy + a[7] * fn + e1 * ge) + g[2] * cdelta * normal
    r_dot = (a[8] * fy + a[9] * fn + e2 * ge) + g[3] * cdelta * normal
    x_dot = cpsi * u - spsi * v
    y_dot = spsi * u + cpsi * v
    if prescribed:
        delta_dot = prescribed_rate
    else:
        dc = min(max(delta_c, -a[10]), a[10])
        delta_dot = min(max((dc - delta) * a[12], -a[11]), a[11])
    return u_dot, v_dot, r_dot, x_dot, y_dot, r, delta_dot


@njit(cache=True, inline="always")
def _turned(cosine, sine, angle):
    """``(cos, sin)`` of an angle turned by a small ``angle`` [rad]; unchanged
    when ``angle`` is zero (a rudder at rest)."""
    if angle == 0.0:
        return cosine, sine
    ca, sa = _small_rotation(angle)
    return cosine * ca - sine * sa, sine * ca + cosine * sa


def _module_accelerations(k: tuple, a: tuple) -> tuple:
    """The module gains (:func:`~studies.models.mmg.module_gains`) through the
    inverse mass matrix of :func:`_body_constants`: ``(u_dot per T, u_dot per
    F_N sin(delta_M), v_dot per F_N cos(delta_M), r_dot per F_N
    cos(delta_M))`` [1/kg, 1/kg, 1/kg, 1/(kg m)], ``k`` the module constants."""
    g_thrust, g_surge, g_sway, g_yaw = module_gains(k)
    return (a[5] * g_thrust, a[5] * g_surge, a[6] * g_sway + a[7] * g_yaw,
            a[8] * g_sway + a[9] * g_yaw)


def _body_constants(vessel: MMGVessel) -> tuple:
    """``(L, 0.5 rho L d, m + m_x, m + m_y, x_G m, 1/(m + m_x), inverse of the
    sway-yaw mass block (4), rudder limit, rate limit, 1/time constant, C_rY, C_rN)``
    (the last two: the cross-flow's yaw-rate factors, :func:`~studies.models.mmg.crossflow_factors`)."""
    mx, my, jz = vessel.added_masses()
    m = vessel.mass
    a1, a2 = m + mx, m + my
    a3 = vessel.iz + vessel.xg ** 2 * m + jz
    xgm = vessel.xg * m
    det = a2 * a3 - xgm * xgm
    values = (vessel.length, 0.5 * vessel.rho * vessel.length * vessel.draught, a1, a2, xgm,
              1.0 / a1, a3 / det, -xgm / det, -xgm / det, a2 / det, vessel.rudder_max,
              vessel.rudder_rate, 1.0 / vessel.rudder_time_constant, *crossflow_factors(vessel))
    return tuple(float(x) for x in values)


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _integrate(c, k, a, g, x0, dt, cmd, mode, params, rps, limit, ext, eg, out):
    """RK4 over ``out.shape[0] - 1`` steps; ``ext`` (steps, 3) external
    accelerations held over each step (no rows for none), acting as ``(1 + eg
    |r'|) ext``. Returns -1, or the first step that left the physical range
    (rows from there on are NaN)."""
    n = out.shape[0]
    s0, s1, s2, s3, s4, s5, s6 = x0[0], x0[1], x0[2], x0[3], x0[4], x0[5], x0[6]
    for j in range(N_STATES):
        out[0, j] = x0[j]
    psi0 = s5
    p0, p1, p2 = params[0], params[1], params[2]
    memory = params[3] if mode == 1 else 1.0
    prescribed = mode == 3
    h = 0.5 * dt
    sixth = dt / 6.0
    # cr, sr: cosine and sine of the rudder angle `held`, kept while the rudder rests
    held = np.nan
    cr = sr = 0.0
    has_ext = ext.shape[0] > 0
    e0 = e1 = e2 = 0.0
    for i in range(n - 1):
        dc, memory = _command(mode, cmd[i], s5, s2, psi0, p0, p1, p2, memory)
        if has_ext:
            e0, e1, e2 = ext[i, 0], ext[i, 1], ext[i, 2]
        rate = 0.0
        if prescribed:
            s6 = cmd[i]
            rate = (cmd[i + 1] - cmd[i]) / dt
        n_a = rps[i]
        n_b = rps[i + 1]
        n_m = 0.5 * (n_a + n_b)
        # one cosine/sine of the heading per step, and of the rudder when it has moved: the
        # stages rotate them by their small increments (the rudder moves < 0.1 rad per step)
        cp = math.cos(s5)
        sp = math.sin(s5)
        if s6 != held:
            cr = math.cos(s6)
            sr = math.sin(s6)
            held = s6
        # the four stages in one loop: the forces are compiled once, not once per stage
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = 0.0
        d0 = d1 = d2 = d3 = d4 = d5 = d6 = 0.0
        for stage in range(4):
            if stage == 0:
                w, hs, n_s = 1.0, 0.0, n_a
            elif stage == 3:
                w, hs, n_s = 1.0, dt, n_b
            else:
                w, hs, n_s = 2.0, h, n_m
            ca, sa = _small_rotation(hs * d5)
            cb, sb = _turned(cr, sr, hs * d6)
            d0, d1, d2, d3, d4, d5, d6 = _derivatives(
                s0 + hs * d0, s1 + hs * d1, s2 + hs * d2, cp * ca - sp * sa, sp * ca + cp * sa,
                s6 + hs * d6, sb, cb, dc, rate, prescribed, n_s, c, k, a, g, e0, e1, e2, eg)
            a0 += w * d0
            a1 += w * d1
            a2 += w * d2
            a3 += w * d3
            a4 += w * d4
            a5 += w * d5
            a6 += w * d6
        s0 += sixth * a0
        s1 += sixth * a1
        s2 += sixth * a2
        s3 += sixth * a3
        s4 += sixth * a4
        s5 += sixth * a5
        s6 += sixth * a6
        if prescribed:
            s6 = cmd[i + 1]
        if not (s0 > 0.0 and s0 < limit and abs(s1) < limit and abs(s2) < 1.0
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


@njit(cache=True, fastmath=_FAST)
def mmg_acceleration(u, v, r, delta, n, c, k, a, g):
    """``(u_dot, v_dot, r_dot)`` [m/s^2, m/s^2, rad/s^2] of the MMG model at one
    state (``u, v`` through the water, ``delta`` contract sign, ``n`` [rps]):
    the simulator's own right-hand side; ``c, k, a, g`` from
    :func:`process_constants`."""
    d = _derivatives(u, v, r, 1.0, 0.0, delta, math.sin(delta), math.cos(delta), 0.0, 0.0, True,
                     n, c, k, a, g, 0.0, 0.0, 0.0, 0.0)
    return d[0], d[1], d[2]


def process_constants(model: ManoeuvringModel, values: dict, vessel: MMGVessel,
                      modules: MMGParameters | None = None) -> tuple:
    """``(hull, module constants, rigid-body constants, module gains)``: the
    tuples :func:`mmg_acceleration` takes."""
    k, a = mmg_inputs(vessel, modules)
    return hull_vector(model, values), k, a, _module_accelerations(k, a)


def hull_vector(model: ManoeuvringModel, values: dict) -> tuple:
    """The hull coefficients in the order of :data:`HULL_TERMS`; terms the
    model does not have are zero. A term outside the MMG hull is refused."""
    order = [name for name, *_ in HULL_TERMS]
    extra = [t.name for t in model.terms if t.name not in order]
    if extra:
        raise ValueError(f"model '{model.name}' has terms the MMG simulator does not know: {extra}")
    have = set(model.names)
    missing = [name for name in order if name in have and name not in values]
    if missing:
        raise KeyError(f"no value for coefficient(s) {missing} of model '{model.name}'")
    return tuple(float(values[name]) if name in have else 0.0 for name in order)


def mmg_inputs(vessel: MMGVessel, modules: MMGParameters | None = None) -> tuple:
    """``(module constants, rigid-body constants)`` of the compiled right-hand side."""
    return module_constants(vessel, modules or vessel.modules), _body_constants(vessel)


#: no external accelerations (the integrator's ``ext`` with no rows)
_NO_EXTERNAL = np.zeros((0, 3))


def _external_rows(external, steps: int) -> np.ndarray:
    """External accelerations per step as a contiguous (steps, 3) array, or no rows."""
    if external is None:
        return _NO_EXTERNAL
    ext = np.array(external, dtype=float)
    if ext.ndim != 2 or ext.shape[1] != 3:
        raise ValueError(f"external accelerations must be (steps, 3) [m/s^2, m/s^2, rad/s^2], "
                         f"got shape {ext.shape}")
    if ext.shape[0] < steps:
        raise ValueError(f"external accelerations cover {ext.shape[0]} steps, need {steps}")
    return np.ascontiguousarray(ext[:steps]) if ext.any() else _NO_EXTERNAL


def rk4_mmg(hull: tuple, k: tuple, a: tuple, x0, dt: float, cmd, mode: int, params, rps,
            speed0: float, external=None, external_gain: float = 0.0) -> tuple[np.ndarray, int]:
    """Integrate one run; returns ``(states (n, 7), diverged_at)``.

    ``cmd`` and ``rps`` have one value per integration step (``n`` rows);
    ``external`` (optional, ``n - 1`` rows) holds accelerations [m/s^2,
    m/s^2, rad/s^2] added to ``u_dot, v_dot, r_dot``, each held over its step
    (a model discrepancy's realisation, :mod:`studies.identification.discrepancy`),
    scaled by ``1 + external_gain |r'|`` at every stage (``r' = r L / U``).
    ``diverged_at`` is -1 when the run stayed bounded (``0 < u < 5 U0``,
    ``|v| < 5 U0``, ``|r| < 1 rad/s``), else the first step outside.
    """
    # writable contiguous copies: a read-only view (pandas, broadcast_to) would be
    # another compiled specialisation
    cmd = np.array(cmd, dtype=float)
    rps = np.array(np.broadcast_to(np.asarray(rps, float), cmd.shape), dtype=float)
    out = np.empty((cmd.shape[0], N_STATES))
    diverged = _integrate(tuple(float(x) for x in hull), k, a, _module_accelerations(k, a),
                          np.asarray(x0, float), float(dt),
                          cmd, int(mode), np.asarray(params, float), rps,
                          DIVERGED_SPEED_FACTOR * float(speed0),
                          _external_rows(external, cmd.shape[0] - 1), float(external_gain), out)
    return out, int(diverged)


def _to_record(states: np.ndarray, rps: np.ndarray, step: float, substeps: int) -> pd.DataFrame:
    states = states[::substeps]
    t = np.arange(states.shape[0]) * step * substeps
    block = np.column_stack([t, states[:, 3], states[:, 4], states[:, 5], states[:, 0],
                             states[:, 1], states[:, 2], states[:, 6], rps[::substeps]])
    return pd.DataFrame(block, columns=["t", "x0", "y0", "psi", "u", "v", "r", "delta", "n"],
                        copy=False)


def _initial(vessel: MMGVessel, initial: dict | None) -> np.ndarray:
    x0 = np.zeros(N_STATES)
    x0[0] = vessel.speed
    for key, idx in (("u", 0), ("v", 1), ("r", 2), ("x0", 3), ("y0", 4), ("psi", 5), ("delta", 6)):
        if initial and key in initial:
            x0[idx] = initial[key]
    return x0


def simulate_mmg(model: ManoeuvringModel, values: dict, vessel: MMGVessel, manoeuvre: Manoeuvre,
                 modules: MMGParameters | None = None, rps: float | None = None,
                 initial: dict | None = None, external=None) -> pd.DataFrame:
    """Simulate ``manoeuvre`` with the MMG model at a constant propeller rate.

    Parameters
    ----------
    model : ManoeuvringModel
        The hull term set (:func:`studies.models.mmg.mmg` or a subset of it).
    values : dict
        Hull coefficients ``{name: value}`` (MMG prime, ``R0`` positive).
    vessel : MMGVessel
        Particulars at the scale of the simulation.
    manoeuvre : Manoeuvre
        Rudder programme (zig-zag, turning circle, ...); positive rudder turns
        to negative heading.
    modules : MMGParameters, optional
        Propeller and rudder parameters; default ``vessel.modules``.
    rps : float, optional
        Propeller rate [rps]; default ``vessel.rps``.
    initial : dict, optional
        Initial ``u`` (default ``vessel.speed``), ``v``, ``r``, ``x0``, ``y0``,
        ``psi``, ``delta``.
    external : ndarray (steps, 3), optional
        Accelerations [m/s^2, m/s^2, rad/s^2] added per integration step
        (:func:`rk4_mmg`), e.g. process noise.

    Returns
    -------
    DataFrame
        Columns ``t, x0, y0, psi, u, v, r, delta, n``; ``attrs["diverged_at"]``
        [s] when the run left the physical range.
    """
    k, a = mmg_inputs(vessel, modules)
    mode, cmd, params = manoeuvre.rudder_programme(YAW_SIGN)
    rate = np.full(cmd.shape[0], float(vessel.rps if rps is None else rps))
    states, diverged = rk4_mmg(hull_vector(model, values), k, a, _initial(vessel, initial),
                               manoeuvre.step, cmd, mode, params, rate, vessel.speed, external)
    record = _to_record(states, rate, manoeuvre.step, manoeuvre.substeps)
    record.attrs["name"] = manoeuvre.name
    if diverged >= 0:
        record.attrs["diverged_at"] = diverged * manoeuvre.step
    return record


def replay_mmg(model: ManoeuvringModel, values: dict, vessel: MMGVessel, record: pd.DataFrame,
               modules: MMGParameters | None = None, rps: float | None = None,
               external=None) -> pd.DataFrame:
    """Simulate a record's own rudder and propeller rate from its first state.

    The measured rudder is prescribed (no servo) and the measured ``n`` drives
    the propeller, both linear between samples (``rps`` replaces a record
    without ``n``, or overrides it); the integration step is the record's
    median sampling interval split so it is at most 0.1 s. The record and the
    vessel must be at the same scale. ``external``: accelerations per
    integration step (:func:`rk4_mmg`).
    """
    plan = MMGReplayPlan(model, vessel, record, modules, rps)
    states, diverged = plan.integrate(model.vector(values), external)
    out = _to_record(states, plan.rate, plan.step, plan.substeps)
    out["t"] = out["t"] + plan.t0
    out.attrs["name"] = record.attrs.get("name", "record")
    if diverged >= 0:
        out.attrs["diverged_at"] = diverged * plan.step
    return out


class MMGReplayPlan:
    """A record's MMG replay prepared once (rudder and propeller rate on the
    integration grid, the compiled constants) for many hull-coefficient
    vectors, external accelerations and initial states: the MMG counterpart
    of :class:`studies.simulate.simulator.ReplayPlan`, with the same
    :meth:`run_one` and :meth:`run` (states in the Abkowitz integrator's
    column order, ``u - U0`` first, so that both plans give the same arrays).

    Parameters
    ----------
    model : ManoeuvringModel
        The MMG hull terms (vectors in ``model.names`` order).
    vessel : MMGVessel
    record : DataFrame
        Data contract record with ``n`` [rps] (or pass ``rps``).
    modules : MMGParameters, optional
        Propeller and rudder parameters; default ``vessel.modules``.
    rps : float, optional
        Constant propeller rate replacing the record's.
    steer : bool
        A zig-zag record (:func:`~studies.simulate.manoeuvres.zigzag_of_record`)
        is replayed as it was run: the rudder reversed when the *replay's*
        heading reaches the test's angle, at the rudder rate of the vessel,
        from the execute on (``steered`` says whether it is). Any other
        record follows its measured rudder.
    """

    def __init__(self, model: ManoeuvringModel, vessel: MMGVessel, record: pd.DataFrame,
                 modules: MMGParameters | None = None, rps: float | None = None, steer: bool = False):
        t = record["t"].to_numpy(float)
        dt = float(np.median(np.diff(t)))
        man = Manoeuvre(str(record.attrs.get("name", "record")), "rudder", dt * (len(t) - 1), dt)
        zigzag = zigzag_of_record(record) if steer else None
        if zigzag is not None:
            man = zigzag
        grid = man.step_times()
        if rps is None and "n" not in record:
            raise ValueError("the record has no propeller rate 'n'; pass rps=")
        columns = ["delta"] + (["n"] if rps is None else [])
        inputs = resample(pd.DataFrame({"t": t - t[0], **{c: record[c].to_numpy(float) for c in columns}}),
                          grid, columns)
        self.model = model
        self.delta = np.ascontiguousarray(inputs["delta"].to_numpy(), float)
        self.steered = zigzag is not None
        if self.steered:
            self.mode, self.cmd, self.params = zigzag.rudder_programme(YAW_SIGN)
            self.cmd = np.ascontiguousarray(self.cmd, float)
        else:
            self.mode, self.cmd, self.params = 3, self.delta, np.zeros(4)
        self.rate = (np.ascontiguousarray(inputs["n"].to_numpy(), float) if rps is None
                     else np.full(grid.shape[0], float(rps)))
        first = record.iloc[0]
        self.first = {key: float(first[key]) for key in ("u", "v", "r", "x0", "y0", "psi")}
        self.x0 = _initial(vessel, self.first)
        self.x0[6] = self.delta[0]
        self.k, self.a = mmg_inputs(vessel, modules)
        self.speed0 = float(vessel.speed)
        self.limit_speed = max(float(vessel.speed), self.first["u"])
        self.step = float(man.step)
        self.substeps = int(man.substeps)
        self.t0 = float(t[0])

    @property
    def steps(self) -> int:
        """Integration steps of the replay (external accelerations need one row per step)."""
        return int(self.cmd.shape[0] - 1)

    @staticmethod
    def external_accelerations(accelerations: np.ndarray) -> np.ndarray:
        """What :meth:`run_one` takes as ``external`` for SI accelerations (steps, 3):
        the accelerations themselves (the MMG integrator adds them as they are)."""
        return np.asarray(accelerations, float)

    def integrate(self, vector: np.ndarray, external=None, initial: dict | None = None,
                  external_gain: float = 0.0):
        """``(states (steps + 1, 7), diverged_at)`` on the integration grid (MMG order, total ``u``)."""
        x0 = self.x0
        if initial:
            x0 = x0.copy()
            for key, idx in (("u", 0), ("v", 1), ("r", 2), ("x0", 3), ("y0", 4), ("psi", 5)):
                if key in initial:
                    x0[idx] = float(initial[key])
        hull = hull_vector(self.model, dict(zip(self.model.names, np.asarray(vector, float))))
        return rk4_mmg(hull, self.k, self.a, x0, self.step, self.cmd, self.mode, self.params, self.rate,
                       self.limit_speed, external, external_gain)

    def run_one(self, vector: np.ndarray, external=None, initial: dict | None = None,
                external_gain: float = 0.0):
        """One coefficient vector with its own external accelerations (one row per
        step, scaled by ``1 + external_gain |r'|``: :func:`rk4_mmg`) and initial
        ``u, v, r, x0, y0, psi`` (over ground as recorded); ``(states (n_samples,
        7), diverged_at)`` at the record's samples, ``u - U0`` in the first
        column as the Abkowitz plan gives it."""
        states, diverged = self.integrate(vector, external, initial, external_gain)
        states = states[:: self.substeps].copy()
        states[:, 0] -= self.speed0
        return states, int(diverged)

    def run(self, vectors: np.ndarray, initial: dict | None = None):
        """``(states (n_sets, n_samples, 7), diverged (n_sets,))`` of many vectors."""
        results = [self.run_one(v, None, initial) for v in np.atleast_2d(vectors)]
        return (np.asarray([s for s, _ in results]), np.asarray([d for _, d in results], dtype=np.int64))


def mmg_forces(model: ManoeuvringModel, values: dict, vessel: MMGVessel, u, v, r, delta, n,
               modules: MMGParameters | None = None) -> np.ndarray:
    """Total forces ``(X, Y, N)`` [N, N, N m] (n, 3) at states given as arrays:
    hull terms plus propeller and rudder (no inertial terms)."""
    u, v, r, delta, n = (np.asarray(x, float) for x in (u, v, r, delta, n))
    k = module_constants(vessel, modules or vessel.modules)
    speed = np.sqrt(u * u + v * v)
    primes = hull_primes(u, v, r, delta, n, vessel, modules or vessel.modules)
    xh, yh, nh = hull_forces(*primes.T, hull_vector(model, values))
    xm, ym, nm = module_forces(u, v, r, delta, n, k)
    scale = vessel.force_scale(speed)
    return np.column_stack([scale[..., 0] * xh + xm, scale[..., 1] * yh + ym,
                            scale[..., 2] * nh + nm])


def self_propulsion_rps(model: ManoeuvringModel, values: dict, vessel: MMGVessel,
                        speed: float | None = None, modules: MMGParameters | None = None) -> float:
    """Propeller rate [rps] at which the surge forces balance in straight motion.

    The root of ``X_H + X_P + X_R = 0`` at ``u = speed`` (default
    ``vessel.speed``), ``v = r = delta = 0``: the resistance ``R'_0 0.5 rho
    L d U^2`` equals the effective thrust ``(1 - t_P) T``. Searched between
    0.01 and 20 times the vessel's approach rate; ``ValueError`` when no
    rate balances.
    """
    u = float(vessel.speed if speed is None else speed)

    def surplus(n):
        return float(mmg_forces(model, values, vessel, [u], [0.0], [0.0], [0.0], [n], modules)[0, 0])

    low, high = 0.01 * vessel.rps, 20.0 * vessel.rps
    if surplus(low) * surplus(high) > 0:
        raise ValueError(f"no propeller rate in [{low:g}, {high:g}] rps holds {u:g} m/s")
    return float(brentq(surplus, low, high, xtol=1e-12 * vessel.rps))
