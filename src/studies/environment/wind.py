"""Wind loads after Blendermann (1994), thesis eq. 3.14-3.19.

Conventions
-----------
``wind_direction`` (beta_w) is the earth-fixed direction the wind comes
*from* [rad], measured like the heading (0 = from north / the x0 axis, pi/2 =
from east / the y0 axis). The relative wind seen by the ship (thesis eq.
3.15-3.18, written consistently for a "coming from" direction) is::

    u_rw = u + V_w cos(beta_w - psi)
    v_rw = v + V_w sin(beta_w - psi)
    gamma_rw = -atan2(v_rw, u_rw)

so ``gamma_rw = 0`` is a head wind, ``gamma_rw = -pi/2`` a wind on the
starboard beam (which pushes the ship to port: negative Y). The thesis
prints ``v_rw = v - v_w`` next to ``u_rw = u + u_w``; taken literally that
mirrors the side force, and the form above is the one consistent with the
wind pushing the ship downwind. Eq. 3.19's moment coefficient is written for
``0 <= gamma <= pi``; it is extended antisymmetrically (``|gamma|`` in the
bracket) so that port and starboard winds give opposite moments.

The thesis' own code (its appendix A.1-A.2) computes the relative wind as
printed, ``v_rw = v - V_w sin(beta_w - psi)``, in the data it identifies
from and in the regression, with the moment of MSS ``blendermann94`` (the
bracket without ``|gamma|``). ``WindParticulars(convention="zhu2021")``
(``wind.convention=zhu2021``) computes the loads that way: with it the
least-squares deviations of the thesis' Tables 4.6-4.14 are reproduced in
sign for about nine coefficients in ten, against one in three with the
default convention (``studies report report.compare=thesis``).

Loads are returned in the prime system: forces over ``0.5 rho L^2 U^2``,
moment over ``0.5 rho L^3 U^2`` (rho of water, U the ship's speed).

References
----------
Blendermann, W. (1994). Parameter identification of wind loads on ships.
Journal of Wind Engineering and Industrial Aerodynamics 51, 339-351.
doi:10.1016/0167-6105(94)90067-1

Zhu, M. (2021). MSc thesis, NTNU, eq. 3.14-3.21.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["wind_coefficients", "wind_load", "wind_load_prime", "wind_loads_prime"]


@njit(cache=True)
def wind_coefficients(gamma, cd_t, cd_l_af_bow, cd_l_af_stern, cross_force,
                      area_frontal, area_lateral, s_l, length_overall):
    """Blendermann coefficients (C_X, C_Y, C_N) at relative angle ``gamma`` [rad]."""
    cd_l_af = cd_l_af_bow if abs(gamma) <= 0.5 * math.pi else cd_l_af_stern
    cd_l = cd_l_af * area_frontal / area_lateral
    s2 = math.sin(2.0 * gamma)
    den = 1.0 - 0.5 * cross_force * (1.0 - cd_l / cd_t) * s2 * s2
    cx = -cd_l * area_lateral / area_frontal * math.cos(gamma) / den
    cy = cd_t * math.sin(gamma) / den
    cn = (s_l / length_overall - 0.18 * (abs(gamma) - 0.5 * math.pi)) * cy
    return cx, cy, cn


@njit(cache=True)
def wind_load(u, v, psi, wind_speed, wind_direction, wp):
    """Dimensional wind loads (X [N], Y [N], N [N m]) on a ship.

    Parameters
    ----------
    u, v : float
        Body-fixed velocities over ground [m/s] (u total, not perturbation).
    psi : float
        Heading [rad].
    wind_speed : float
        True wind speed V_w [m/s].
    wind_direction : float
        Direction the wind comes from, beta_w [rad].
    wp : ndarray
        :meth:`WindParticulars.as_array` of the vessel.
    """
    if wind_speed == 0.0:
        return 0.0, 0.0, 0.0
    u_rw = u + wind_speed * math.cos(wind_direction - psi)
    v_rw = v + wp[9] * wind_speed * math.sin(wind_direction - psi)
    gamma = -math.atan2(v_rw, u_rw)
    cx, cy, cn = wind_coefficients(gamma, wp[4], wp[5], wp[6], wp[7], wp[0], wp[1], wp[2], wp[3])
    if wp[10] > 0.5:            # zhu2021: MSS blendermann94's moment, not extended to port winds
        cn = (wp[2] / wp[3] - 0.18 * (gamma - 0.5 * math.pi)) * cy
    q = 0.5 * wp[8] * (u_rw * u_rw + v_rw * v_rw)
    return q * cx * wp[0], q * cy * wp[1], q * cn * wp[1] * wp[3]


@njit(cache=True)
def wind_load_prime(u, v, psi, wind_speed, wind_direction, wp, length, rho):
    """Prime wind loads: :func:`wind_load` over ``0.5 rho L^2 U^2`` (``L^3`` for N).

    ``length`` and ``rho`` are the reference length [m] and water density
    [kg/m^3]; ``U = sqrt(u^2 + v^2)``.
    """
    speed2 = u * u + v * v
    if wind_speed == 0.0 or speed2 == 0.0:
        return 0.0, 0.0, 0.0
    fx, fy, fn = wind_load(u, v, psi, wind_speed, wind_direction, wp)
    scale = 0.5 * rho * length * length * speed2
    return fx / scale, fy / scale, fn / (scale * length)


@njit(cache=True)
def _wind_loads_loop(u, v, psi, speed, direction, wp, length, rho, out):
    for i in range(u.shape[0]):
        tx, ty, tn = wind_load_prime(u[i], v[i], psi[i], speed[i], direction[i], wp, length, rho)
        out[i, 0] = tx
        out[i, 1] = ty
        out[i, 2] = tn


def wind_loads_prime(u, v, psi, wind_speed, wind_direction, vessel) -> np.ndarray:
    """Prime wind loads (n, 3) along a record; speeds/directions may be scalars.

    Returns zeros when the vessel has no wind particulars.
    """
    u = np.asarray(u, dtype=float)
    n = u.shape[0]
    out = np.zeros((n, 3))
    if vessel.wind is None:
        return out
    speed = np.broadcast_to(np.asarray(wind_speed, dtype=float), (n,)).copy()
    direction = np.broadcast_to(np.asarray(wind_direction, dtype=float), (n,)).copy()
    _wind_loads_loop(u, np.asarray(v, float), np.asarray(psi, float), speed, direction,
                     vessel.wind.as_array(), float(vessel.length), float(vessel.rho), out)
    return out
