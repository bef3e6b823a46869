"""An independent Mariner simulator, written for the tests only.

A direct transcription of ``mariner.m`` of the Marine Systems Simulator
(Fossen & Perez 2004) with its own coefficient listing, integrated with
SciPy's adaptive Runge-Kutta (RK45, tight tolerances) and zig-zag switching
by integration events. It shares no code with `studies`, so records it writes
are "data some other program produced".
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

L = 160.93
U0 = 7.7175
DELTA_MAX = np.deg2rad(40.0)
RATE_MAX = np.deg2rad(5.0)

m = 798e-5
Iz = 39.2e-5
xG = -0.023
Xudot, Yvdot, Nvdot = -42e-5, -748e-5, 4.646e-5
Yrdot, Nrdot = -9.354e-5, -43.8e-5
Xu, Xuu, Xuuu, Xvv, Xrr = -184e-5, -110e-5, -215e-5, -899e-5, 18e-5
Xdd, Xudd, Xrv, Xvd, Xuvd = -95e-5, -190e-5, 798e-5, 93e-5, 93e-5
Yv, Yr, Yvvv, Yvvr, Yvu, Yru = -1160e-5, -499e-5, -8078e-5, 15356e-5, -1160e-5, -499e-5
Yd, Yddd, Yud, Yuud, Yvdd, Yvvd = 278e-5, -90e-5, 556e-5, 278e-5, -4e-5, 1190e-5
Y0, Y0u, Y0uu = -4e-5, -8e-5, -4e-5
Nv, Nr, Nvvv, Nvvr, Nvu, Nru = -264e-5, -166e-5, 1636e-5, -5483e-5, -264e-5, -166e-5
Nd, Nddd, Nud, Nuud, Nvdd, Nvvd = -139e-5, 45e-5, -278e-5, -139e-5, 13e-5, -489e-5
N0, N0u, N0uu = 3e-5, 6e-5, 3e-5

m11 = m - Xudot
m22 = m - Yvdot
m23 = m * xG - Yrdot
m32 = m * xG - Nvdot
m33 = Iz - Nrdot


def mariner(x, delta_c, extra=(0.0, 0.0, 0.0)):
    """mariner.m: x = [du v r x y psi delta] (du perturbation), delta_c commanded;
    ``extra``: nondimensional forces X', Y', N' added (a disturbance)."""
    U = np.sqrt((U0 + x[0]) ** 2 + x[1] ** 2)
    u, v, r, psi, delta = x[0] / U, x[1] / U, x[2] * L / U, x[5], x[6]
    delta_c = np.clip(delta_c, -DELTA_MAX, DELTA_MAX)
    delta_dot = np.clip(delta_c - delta, -RATE_MAX, RATE_MAX)
    X = (Xu * u + Xuu * u**2 + Xuuu * u**3 + Xvv * v**2 + Xrr * r**2 + Xrv * r * v
         + Xdd * delta**2 + Xudd * u * delta**2 + Xvd * v * delta + Xuvd * u * v * delta)
    Y = (Yv * v + Yr * r + Yvvv * v**3 + Yvvr * v**2 * r + Yvu * v * u + Yru * r * u
         + Yd * delta + Yddd * delta**3 + Yud * u * delta + Yuud * u**2 * delta
         + Yvdd * v * delta**2 + Yvvd * v**2 * delta + (Y0 + Y0u * u + Y0uu * u**2))
    N = (Nv * v + Nr * r + Nvvv * v**3 + Nvvr * v**2 * r + Nvu * v * u + Nru * r * u
         + Nd * delta + Nddd * delta**3 + Nud * u * delta + Nuud * u**2 * delta
         + Nvdd * v * delta**2 + Nvvd * v**2 * delta + (N0 + N0u * u + N0uu * u**2))
    X, Y, N = X + extra[0], Y + extra[1], N + extra[2]
    det = m22 * m33 - m23 * m32
    return np.array([
        X * (U**2 / L) / m11,
        -(-m33 * Y + m23 * N) * (U**2 / L) / det,
        (-m32 * Y + m22 * N) * (U**2 / L**2) / det,
        (np.cos(psi) * (U0 / U + u) - np.sin(psi) * v) * U,
        (np.sin(psi) * (U0 / U + u) + np.cos(psi) * v) * U,
        r * U / L,
        delta_dot,
    ])


def _none(t):
    return (0.0, 0.0, 0.0)


def zigzag_record(amplitude_deg=20.0, heading_deg=20.0, duration=1500.0, dt=0.1, disturbance=_none):
    """Zig-zag (positive rudder first, the Mariner then turns to negative heading),
    sampled every ``dt``; columns of the studies data contract, SI units.
    ``disturbance(t)``: nondimensional forces X', Y', N' added at time t [s]."""
    amp, switch = np.deg2rad(amplitude_deg), np.deg2rad(heading_deg)
    t_out = np.arange(0.0, duration + dt / 2, dt)
    x = np.zeros(7)
    t0, sign = 0.0, 1.0
    pieces_t, pieces_x = [], []
    while t0 < duration:
        # positive rudder -> heading decreases; switch at psi = -switch, and back at +switch
        target = -sign * switch

        def event(t, y, target=target):
            return y[5] - target

        event.terminal = True
        sol = solve_ivp(lambda t, y, s=sign: mariner(y, s * amp, disturbance(t)), (t0, duration), x,
                        method="RK45", rtol=1e-10, atol=1e-12, max_step=0.5,
                        events=event, dense_output=True)
        mask = (t_out >= t0) & (t_out <= sol.t[-1])
        pieces_t.append(t_out[mask])
        pieces_x.append(sol.sol(t_out[mask]).T)
        t0, x = sol.t[-1], sol.y[:, -1]
        sign = -sign
        if sol.status == 0:
            break
    t = np.concatenate(pieces_t)
    states = np.concatenate(pieces_x)
    t, idx = np.unique(t, return_index=True)
    states = states[idx]
    return {"t": t, "x0": states[:, 3], "y0": states[:, 4], "psi": states[:, 5],
            "u": U0 + states[:, 0], "v": states[:, 1], "r": states[:, 2], "delta": states[:, 6]}


def turning_record(amplitude_deg=18.0, duration=1000.0, dt=0.5, execute=0.0, disturbance=_none):
    """Turning circle: the rudder commanded to ``amplitude_deg`` at t =
    ``execute`` (amidships before it) and held (the Mariner turns to negative
    heading), sampled every ``dt``; columns of the studies data contract, SI
    units. ``disturbance(t)``: nondimensional forces X', Y', N' added at time t [s]."""
    amp = np.deg2rad(amplitude_deg)
    t_out = np.arange(0.0, duration + dt / 2, dt)
    x, pieces = np.zeros(7), []
    for start, end, command in ((0.0, execute, 0.0), (execute, duration, amp)):
        if end <= start:
            continue
        sol = solve_ivp(lambda t, y, c=command: mariner(y, c, disturbance(t)), (start, end), x, method="RK45",
                        rtol=1e-9, atol=1e-10, max_step=1.0, dense_output=True)
        inside = (t_out >= start) & ((t_out < end) if end < duration else (t_out <= end))
        pieces.append(sol.sol(t_out[inside]).T)
        x = sol.y[:, -1]
    states = np.concatenate(pieces)
    return {"t": t_out, "x0": states[:, 3], "y0": states[:, 4], "psi": states[:, 5],
            "u": U0 + states[:, 0], "v": states[:, 1], "r": states[:, 2], "delta": states[:, 6]}


def write_csv(path, record):
    """Write a record with the csv module only (no pandas, no studies)."""
    import csv

    cols = list(record)
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(cols)
        for row in zip(*(record[c] for c in cols)):
            writer.writerow([repr(float(v)) for v in row])
