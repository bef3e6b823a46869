"""Vessel particulars: everything about a ship that is prior knowledge.

A :class:`Vessel` holds main dimensions, the non-dimensional (prime) mass and
added-mass coefficients that the identification treats as known, the rudder
actuator limits, the wind-load particulars of Blendermann (1994) and, where
published, a reference set of hydrodynamic coefficients.

Conventions
-----------
Prime system of the Abkowitz model (Fossen & Perez 2004, thesis eq. 3.6 and
3.13): forces are scaled by ``0.5 rho L^2 U^2``, moments by
``0.5 rho L^3 U^2``, masses by ``0.5 rho L^3``, inertia by ``0.5 rho L^5``,
velocities by the instantaneous speed ``U`` and the yaw rate by ``U / L``.
Angles are radians. Rudder sign: positive ``delta`` gives a negative yaw
moment (``Nd < 0``) and turns the ship to negative heading.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..config import WIND_CONVENTIONS

__all__ = ["Vessel", "WindParticulars", "WIND_CONVENTIONS"]


@dataclass(frozen=True)
class WindParticulars:
    """Above-water particulars for the Blendermann (1994) wind loads.

    Attributes
    ----------
    area_frontal : float
        Frontal projected wind area A_Fw [m^2].
    area_lateral : float
        Lateral projected wind area A_Lw [m^2].
    s_l : float
        Horizontal distance from midship to the centre of the lateral
        projected area s_L [m], positive forward.
    length_overall : float
        L_oa [m].
    cd_t : float
        Transverse resistance coefficient CD_t [-].
    cd_l_af_bow, cd_l_af_stern : float
        Longitudinal resistance coefficient CD_l,AF for head (bow) and
        following (stern) wind [-].
    cross_force : float
        Cross-force parameter delta of Blendermann [-].
    rho_air : float
        Air density [kg/m^3].
    convention : str
        How the relative wind and the yaw moment are formed
        (:data:`WIND_CONVENTIONS`): ``downwind`` (default; a wind pushes the
        ship downwind, the moment coefficient antisymmetric in the relative
        angle) or ``zhu2021``, the thesis' eq. 3.17 as printed and as its
        code computes it (``v_rw = v - V_w sin(beta_w - psi)``, which mirrors
        the side force, and MSS ``blendermann94``'s moment
        ``C_N = (s_L/L_oa - 0.18 (gamma - pi/2)) C_Y`` for every angle); see
        :mod:`studies.environment.wind`.
    """

    area_frontal: float
    area_lateral: float
    s_l: float
    length_overall: float
    cd_t: float = 0.85
    cd_l_af_bow: float = 0.65
    cd_l_af_stern: float = 0.55
    cross_force: float = 0.40
    rho_air: float = 1.224
    convention: str = "downwind"

    def __post_init__(self):
        if self.convention not in WIND_CONVENTIONS:
            raise ValueError(f"wind convention must be one of {', '.join(WIND_CONVENTIONS)}, "
                             f"got {self.convention!r}")

    def as_array(self) -> np.ndarray:
        """Pack as the float array the compiled simulator takes (the
        convention as two flags: the sign of the wind's sway component in the
        relative wind, and 1.0 for the moment without the antisymmetric
        extension)."""
        thesis = self.convention == "zhu2021"
        return np.array([self.area_frontal, self.area_lateral, self.s_l,
                         self.length_overall, self.cd_t, self.cd_l_af_bow,
                         self.cd_l_af_stern, self.cross_force, self.rho_air,
                         -1.0 if thesis else 1.0, 1.0 if thesis else 0.0])


@dataclass(frozen=True)
class Vessel:
    """A ship's prior knowledge (see module docstring for the prime system).

    Attributes
    ----------
    name : str
    length : float
        Length between perpendiculars L [m], the reference length.
    speed : float
        Nominal (approach) speed U0 [m/s]; the Abkowitz ``u`` is the
        perturbation ``(u_total - U0) / U``.
    rho : float
        Water density [kg/m^3].
    m, iz, xg : float
        Prime mass, yaw inertia and longitudinal centre of gravity.
    x_udot, y_vdot, y_rdot, n_vdot, n_rdot : float
        Prime added-mass coefficients.
    rudder_max : float
        Rudder saturation [rad].
    rudder_rate : float
        Rudder rate limit [rad/s].
    rudder_time_constant : float
        Time constant of the rudder servo [s] (commanded -> actual).
    wind : WindParticulars or None
    coefficients : dict
        Reference hydrodynamic coefficients (prime), empty where none are
        published.
    reference : str
        Literature reference of the particulars and coefficients.
    """

    name: str
    length: float
    speed: float
    m: float
    iz: float
    xg: float
    x_udot: float
    y_vdot: float
    y_rdot: float
    n_vdot: float
    n_rdot: float
    rho: float = 1025.0
    rudder_max: float = np.deg2rad(40.0)
    rudder_rate: float = np.deg2rad(5.0)
    rudder_time_constant: float = 1.0
    wind: WindParticulars | None = None
    coefficients: dict = field(default_factory=dict)
    reference: str = ""

    def mass_matrix(self) -> np.ndarray:
        """Prime rigid-body plus added mass matrix M (3 x 3, thesis eq. 3.7).

        Rows are surge, sway, yaw: ``M @ [u'_dot, v'_dot, r'_dot] = [X', Y', N']``
        with ``u'_dot = u_dot L / U^2``, ``v'_dot = v_dot L / U^2`` and
        ``r'_dot = r_dot L^2 / U^2``.
        """
        m11 = self.m - self.x_udot
        m22 = self.m - self.y_vdot
        m23 = self.m * self.xg - self.y_rdot
        m32 = self.m * self.xg - self.n_vdot
        m33 = self.iz - self.n_rdot
        return np.array([[m11, 0.0, 0.0], [0.0, m22, m23], [0.0, m32, m33]])

    def force_scale(self, speed: np.ndarray | float) -> np.ndarray:
        """Dimensional scale of prime X, Y, N at ship speed ``speed`` [m/s].

        Returns an array ``[..., 3]``: ``0.5 rho L^2 U^2`` twice and
        ``0.5 rho L^3 U^2``, so that ``force = prime * scale``.
        """
        u2 = np.asarray(speed, dtype=float) ** 2
        q = 0.5 * self.rho * self.length**2 * u2
        return np.stack([q, q, q * self.length], axis=-1)
