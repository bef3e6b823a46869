"""The MMG standard method (Yasukawa & Yoshimura 2015): hull terms, propeller and rudder.

A modular manoeuvring model: the hull forces are named terms (a
:class:`~studies.models.abkowitz.ManoeuvringModel` that the regression,
SINDy, the GA and the tables read), the propeller and the rudder are force
modules with a few physical parameters (:class:`MMGParameters`).

Axes and signs
--------------
Body axes at midship (x forward, y to starboard), ``u`` surge and ``v`` sway
velocity at midship [m/s], ``r`` yaw rate [rad/s], ``U = sqrt(u^2 + v^2)``,
drift angle ``beta = atan2(-v, u)`` [rad]. The MMG's own rudder angle
``delta_M`` turns the ship to starboard (positive heading) when positive; the
data contract of `studies` (and the MARIN files) uses the opposite sign, so
``delta_M = -delta``: every function here takes the contract's ``delta``.

Equations of motion (Yasukawa & Yoshimura 2015, eq. 4)::

    (m + m_x) u_dot - (m + m_y) v r - x_G m r^2            = X_H + X_R + X_P
    (m + m_y) v_dot + (m + m_x) u r + x_G m r_dot          = Y_H + Y_R
    (I_zG + x_G^2 m + J_z) r_dot + x_G m (v_dot + u r)     = N_H + N_R

with ``m`` [kg] the mass, ``I_zG`` [kg m^2] the yaw inertia about the centre
of gravity, ``x_G`` [m] its position forward of midship, and the added masses
``m_x = m'_x (0.5 rho L^2 d)``, ``m_y = m'_y (0.5 rho L^2 d)``,
``J_z = J'_z (0.5 rho L^4 d)`` (``L`` = Lpp, ``d`` draught).

Hull (eq. 8-10), prime states ``v' = v / U``, ``r' = r L / U``::

    X_H = 0.5 rho L d U^2 (-R'_0 + X'_vv v'^2 + X'_vr v' r' + X'_rr r'^2 + X'_vvvv v'^4)
    Y_H = 0.5 rho L d U^2 (Y'_v v' + Y'_r r' + Y'_vvv v'^3 + Y'_vvr v'^2 r'
                           + Y'_vrr v' r'^2 + Y'_rrr r'^3)
    N_H = 0.5 rho L^2 d U^2 (N'_v v' + ... + N'_rrr r'^3)        (same monomials)

Note the ``L d`` (not ``L^2``) scaling of the forces: the Abkowitz models of
`studies` use ``0.5 rho L^2 U^2``.

Propeller (eq. 11-17)::

    X_P = (1 - t_P) T,   T = rho n^2 D^4 K_T(J_P),   K_T = k0 + k1 J + k2 J^2
    J_P = u (1 - w_P) / (n D)
    1 - w_P = (1 - w_P0) (1 + (1 - exp(-C_1 |beta_P|)) (C_2 - 1)),   beta_P = beta - x'_P r'
    C_2 = C_2+ for beta_P > 0, C_2- otherwise

(``n`` [rps] the propeller rate; a stopped propeller, ``n = 0``, gives no
thrust).

Rudder (eq. 18-32)::

    F_N = 0.5 rho A_R U_R^2 f_alpha sin(alpha_R),   alpha_R = delta_M - atan(v_R / u_R)
        [+ 0.5 rho A_R U_R^2 f_alpha_2 sin(alpha_R) |sin(alpha_R)|, see below]
    X_R = -(1 - t_R) F_N sin(delta_M)
    Y_R = -(1 + a_H) F_N cos(delta_M)
    N_R = -(x_R + a_H x_H) F_N cos(delta_M)
    u_R = epsilon u (1 - w_P) sqrt(eta {1 + kappa (sqrt(1 + 8 K_T / (pi J_P^2)) - 1)}^2 + 1 - eta)
    v_R = U gamma_R beta_R,   beta_R = beta - l'_R r',   eta = D / H_R
    gamma_R = gamma_R- for beta_R < 0, gamma_R+ otherwise

with ``x_R`` the rudder position and ``x_H = x'_H L``. The bracketed term
is not in the standard method (``f_alpha_2 = 0`` by default): the normal
force of a rudder of low aspect ratio grows faster than ``sin(alpha_R)`` at
large angles of attack (the cross-flow part of low-aspect-ratio wing
theory); :mod:`studies.identification.mmg_rudder` identifies ``f_alpha`` and
``f_alpha_2`` from free-running records.
:func:`thrust_normal_force` evaluates ``u_R`` in the equivalent form
``epsilon sqrt(eta (u_P + kappa (sqrt(u_P^2 + 8 T / (pi rho D^2)) - u_P))^2
+ (1 - eta) u_P^2)`` with ``u_P = u (1 - w_P)`` (no division by ``J_P``),
and ``sin(alpha_R) U_R = u_R sin(delta_M) - v_R cos(delta_M)`` (no
arctangent); :func:`module_gains` turns ``T`` and ``F_N`` into the forces.

The functions :func:`hull_forces`, :func:`module_forces` and the two it is
made of are written with NumPy ufuncs only, so they take scalars or arrays:
the regression evaluates them on a record's arrays, and
:mod:`studies.simulate.mmg` compiles :func:`hull_forces`,
:func:`thrust_normal_force` and :func:`module_gains` into its RK4
right-hand side (one definition of the physics).

References
----------
Yasukawa, H., Yoshimura, Y. (2015). Introduction of MMG standard method for
ship maneuvering predictions. J. Mar. Sci. Technol. 20, 37-52.
doi:10.1007/s00773-014-0293-y (KVLCC2 L7 model: Table 2-4).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from .abkowitz import ManoeuvringModel
from .terms import Term

__all__ = ["MMGTerm", "MMGParameters", "HULL_TERMS", "STANDARD_TERMS", "ASYMMETRY_TERMS",
           "THRUST_TERMS", "REDUCED_TERMS", "CROSSFLOW_TERMS", "HULL_FAMILIES", "RUDDER_TIES", "FAMILY_TIES",
           "rudder_lever", "family_ties", "crossflow_integrals",
           "crossflow_factors", "family_modules", "hull_primes", "KVLCC2_HULL", "KVLCC2_ADDED_MASS",
           "KVLCC2_KT_PUBLISHED", "mmg", "fit_kt", "hull_forces", "module_forces",
           "rudder_propeller", "thrust_normal_force", "module_gains", "module_constants",
           "MODULE_CONSTANTS"]


@dataclass(frozen=True)
class MMGTerm(Term):
    """A hull term of the MMG model: ``sign`` x monomial of ``(u', v', r', delta)``
    x ``T'^thrust``.

    The primes are those of the MMG hull, with the instantaneous speed
    ``U = sqrt(u^2 + v^2)``: ``u' = u / U = cos(beta)``, ``v' = v / U``,
    ``r' = r L / U``; ``delta`` [rad] in the data contract's sign and the
    thrust loading ``T' = T / (0.5 rho L d U^2)`` of the propeller module.
    ``sign`` is -1 for the resistance ``R0`` (``X'_H = -R'_0 + ...``, the
    published coefficient is positive) and +1 for every other term;
    ``thrust`` the exponent of ``T'`` (0 for the standard method's terms);
    ``crossflow``: the term is a drag coefficient times the cross-flow
    integral of its DOF (:func:`crossflow_integrals`).
    """

    sign: float = 1.0
    thrust: int = 0
    crossflow: bool = False

    def feature(self, primes: np.ndarray) -> np.ndarray:
        """The term on MMG primes (:func:`hull_primes`), shape (n, 7): columns ``u' = u / U``,
        ``v' = v / U``, ``r' = r L / U``, ``delta`` [rad, contract sign], the thrust
        loading ``T' = T / (0.5 rho L d U^2)`` (read by a term with ``thrust``) and the
        cross-flow drag integrals of sway and yaw (:func:`crossflow_integrals`, read by a
        ``crossflow`` term, whose exponents are zero)."""
        if self.crossflow:
            return self.sign * np.asarray(primes, float)[:, 5 if self.dof == "Y" else 6]
        out = self.sign * super().feature(primes)
        if self.thrust:
            out = out * np.asarray(primes, float)[:, 4] ** self.thrust
        return out


#: (name, dof, exponents of (u', v', r', delta), sign, exponent of T', cross-flow): the standard method's
#: terms in the order of eq. 8-10, the constants Y0, N0, then the terms of the other hull
#: families (:data:`HULL_FAMILIES`)
HULL_TERMS = (
    ("R0", "X", (0, 0, 0, 0), -1.0, 0, False), ("Xvv", "X", (0, 2, 0, 0), 1.0, 0, False),
    ("Xvr", "X", (0, 1, 1, 0), 1.0, 0, False), ("Xrr", "X", (0, 0, 2, 0), 1.0, 0, False),
    ("Xvvvv", "X", (0, 4, 0, 0), 1.0, 0, False),
    ("Yv", "Y", (0, 1, 0, 0), 1.0, 0, False), ("Yr", "Y", (0, 0, 1, 0), 1.0, 0, False),
    ("Yvvv", "Y", (0, 3, 0, 0), 1.0, 0, False), ("Yvvr", "Y", (0, 2, 1, 0), 1.0, 0, False),
    ("Yvrr", "Y", (0, 1, 2, 0), 1.0, 0, False), ("Yrrr", "Y", (0, 0, 3, 0), 1.0, 0, False),
    ("Nv", "N", (0, 1, 0, 0), 1.0, 0, False), ("Nr", "N", (0, 0, 1, 0), 1.0, 0, False),
    ("Nvvv", "N", (0, 3, 0, 0), 1.0, 0, False), ("Nvvr", "N", (0, 2, 1, 0), 1.0, 0, False),
    ("Nvrr", "N", (0, 1, 2, 0), 1.0, 0, False), ("Nrrr", "N", (0, 0, 3, 0), 1.0, 0, False),
    ("Y0", "Y", (0, 0, 0, 0), 1.0, 0, False), ("N0", "N", (0, 0, 0, 0), 1.0, 0, False),
    # surge in u' = cos(beta) and the rudder's drag
    ("Xu", "X", (1, 0, 0, 0), 1.0, 0, False), ("Xuu", "X", (2, 0, 0, 0), 1.0, 0, False),
    ("Xdd", "X", (0, 0, 0, 2), 1.0, 0, False),
    # sway, then yaw, the same monomials: u', u' r', the rudder (delta, v'^2 delta), the thrust
    # loading (T', T' delta)
    *((dof + name, dof, powers, 1.0, thrust, False) for dof in ("Y", "N")
      for name, powers, thrust in (("u", (1, 0, 0, 0), 0), ("ur", (1, 0, 1, 0), 0), ("d", (0, 0, 0, 1), 0),
                                   ("vvd", (0, 2, 0, 1), 0), ("T", (0, 0, 0, 0), 1), ("Td", (0, 0, 0, 1), 1))),
    # cross-flow drag of sway and yaw (Yoshimura's unified model): coefficient C_D each
    ("YCF", "Y", (0, 0, 0, 0), 1.0, 0, True), ("NCF", "N", (0, 0, 0, 0), 1.0, 0, True)
)
#: the terms of the MMG standard method (the first 17 of :data:`HULL_TERMS`)
STANDARD_TERMS = tuple(name for name, *_ in HULL_TERMS[:17])
#: constant side force and yaw moment (prime) of a ship that is not symmetric in calm
#: water: a single-screw propeller's side force and the asymmetric flow at its rudder
ASYMMETRY_TERMS = ("Y0", "N0")
#: side force and yaw moment proportional to the thrust loading ``T'`` (a single screw's
#: asymmetry grows as the propeller loads up: 7-10 times in a 35 deg turn), and the rudder's
#: force growing with it beyond the standard slipstream (``T' delta``)
THRUST_TERMS = ("YT", "NT", "YTd", "NTd")
#: the reduced model of Alexandersson et al. (2022) on the MMG primes: no cubic hull terms,
#: the rudder in the hull's terms (the rudder module off), the drift's nonlinearity carried by
#: ``u' = cos(beta)`` (``Yr r' + Yur u' r'``), a thrust-loaded rudder and asymmetry
REDUCED_TERMS = ("Xu", "Xuu", "Xrr", "Xvr", "Xdd",
                 "Yv", "Yr", "Yu", "Yur", "Yd", "YTd", "YT", "Yvvd",
                 "Nv", "Nr", "Nu", "Nur", "Nd", "NTd", "NT", "Nvvd")
#: a cross-flow hybrid (Yoshimura's unified model): the standard surge terms, linear sway and
#: yaw derivatives and the cross-flow drag of the hull's strips in place of the cubic terms
CROSSFLOW_TERMS = ("R0", "Xvv", "Xvr", "Xrr", "Xvvvv", "Yv", "Yr", "YCF", "Nv", "Nr", "NCF")
#: the hull families of ``model.hull``: their terms, and whether the rudder module acts
#: (False: the rudder's forces are hull terms)
HULL_FAMILIES = {
    "standard": (STANDARD_TERMS, True),
    "thrust": (STANDARD_TERMS + THRUST_TERMS, True),
    "reduced": (REDUCED_TERMS, False),
    "crossflow": (CROSSFLOW_TERMS, True),
}

#: the rudder's side force and its yaw moment as one force at one lever: pairs of (sway, yaw)
#: terms of the same monomial whose yaw coefficient is the sway one times :func:`rudder_lever`
#: (a family that carries the rudder in its hull terms regresses each pair as one coefficient:
#: the zig-zags alone cannot tell the rudder's moment from the hull's)
RUDDER_TIES = (("Yd", "Nd"), ("YTd", "NTd"), ("Yvvd", "Nvvd"))
#: the tied pairs of each hull family (:data:`HULL_FAMILIES`; ``model.tie_rudder``)
FAMILY_TIES = {"reduced": RUDDER_TIES}

#: Gauss-Legendre nodes and weights on x' in [-1/2, 1/2] (the hull's length from the stern
#: to the bow, midship at 0) of the cross-flow integrals
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
CROSSFLOW_NODES = tuple(float(x) for x in 0.5 * _GL_X)
CROSSFLOW_WEIGHTS = tuple(float(w) for w in 0.5 * _GL_W)


def crossflow_factors(vessel) -> tuple[float, float]:
    """Yoshimura's yaw-rate factors of the cross-flow ``(C_rY, C_rN)`` [-] from the
    vessel's ratios: ``C_rY = 0.52 L/B - 1.062``, ``C_rN = 0.0742 L/d - 0.297``
    (Yoshimura & Masumoto, MARSIM 2012: regressions over merchant hulls)."""
    return (0.52 * vessel.length / vessel.beam - 1.062, 0.0742 * vessel.length / vessel.draught - 0.297)


def crossflow_integrals(vp, rp, cry, crn):
    """Cross-flow drag integrals of sway and yaw (prime, per unit drag coefficient)::

        f_Y = -int |v' + C_rY r' x'| (v' + C_rY r' x') dx'
        f_N = -int x' |v' + C_rN r' x'| (v' + C_rN r' x') dx'

    over ``x'`` from -1/2 (stern) to 1/2 (bow), by 16-point Gauss-Legendre;
    ``YCF f_Y`` is then the side force over ``0.5 rho L d U^2`` of a drag
    coefficient ``YCF``, ``NCF f_N`` the yaw moment over ``0.5 rho L^2 d
    U^2``. Scalars or arrays."""
    fy = 0.0 * vp
    fn = 0.0 * vp
    for k in range(16):
        x = CROSSFLOW_NODES[k]
        w = CROSSFLOW_WEIGHTS[k]
        a = vp + cry * rp * x
        b = vp + crn * rp * x
        fy = fy - w * np.abs(a) * a
        fn = fn - w * x * np.abs(b) * b
    return fy, fn

#: published hull coefficients of the KVLCC2 L7 model (Yasukawa & Yoshimura
#: 2015, Table 4; forces over 0.5 rho L d U^2, moment over 0.5 rho L^2 d U^2)
KVLCC2_HULL = {
    "R0": 0.022, "Xvv": -0.040, "Xvr": 0.002, "Xrr": 0.011, "Xvvvv": 0.771,
    "Yv": -0.315, "Yr": 0.083, "Yvvv": -1.607, "Yvvr": 0.379, "Yvrr": -0.391, "Yrrr": 0.008,
    "Nv": -0.137, "Nr": -0.049, "Nvvv": -0.030, "Nvvr": -0.294, "Nvrr": 0.055, "Nrrr": -0.013,
}

#: MMG added masses m'_x, m'_y (over 0.5 rho L^2 d) and J'_z (over 0.5 rho L^4 d)
KVLCC2_ADDED_MASS = {"mx": 0.022, "my": 0.223, "jz": 0.011}

#: published open-water polynomial (k0, k1, k2); the vessel uses a fit of the
#: measured open-water table instead (k2 is quoted differently in the literature)
KVLCC2_KT_PUBLISHED = (0.2931, -0.2753, -0.1385)


@dataclass(frozen=True)
class MMGParameters:
    """Propeller and rudder parameters of the MMG standard method.

    Defaults are the published values of the KVLCC2 L7 model (Yasukawa &
    Yoshimura 2015, Table 3/4). Lengths are fractions of ``L``.

    Attributes
    ----------
    tP : float
        Thrust deduction factor t_P [-].
    wP0 : float
        Effective wake fraction at the propeller in straight motion [-].
    C1 : float
        Wake-change coefficient C_1 [-] (drift at the propeller).
    C2_plus, C2_minus : float
        Wake-change coefficient C_2 for ``beta_P > 0`` and ``beta_P <= 0`` [-].
    tR : float
        Steering resistance deduction factor t_R [-].
    aH : float
        Rudder force increase factor a_H [-].
    xH : float
        Position of the additional lateral force x'_H [-] (fraction of L).
    gammaR_minus, gammaR_plus : float
        Flow-straightening coefficient gamma_R for ``beta_R < 0`` and
        ``beta_R >= 0`` [-].
    lR : float
        Effective longitudinal rudder position l'_R [-] (fraction of L).
    epsilon : float
        Wake ratio at rudder and propeller epsilon [-].
    kappa : float
        Propeller slipstream correction kappa [-].
    f_alpha : float
        Rudder lift gradient coefficient f_alpha [1/rad].
    f_alpha_2 : float
        Coefficient of the rudder normal force's quadratic (cross-flow) part
        [-]: ``F_N = 0.5 rho A_R U_R^2 (f_alpha sin a_R + f_alpha_2 sin a_R
        |sin a_R|)``. 0 in the MMG standard method (a normal force linear in
        ``sin a_R``); a low-aspect-ratio rudder's force grows faster than that
        at large angles of attack.
    """

    tP: float = 0.220
    wP0: float = 0.40
    C1: float = 2.0
    C2_plus: float = 1.6
    C2_minus: float = 1.1
    tR: float = 0.387
    aH: float = 0.312
    xH: float = -0.464
    gammaR_minus: float = 0.395
    gammaR_plus: float = 0.640
    lR: float = -0.710
    epsilon: float = 1.09
    kappa: float = 0.50
    f_alpha: float = 2.747
    f_alpha_2: float = 0.0

    def as_dict(self) -> dict:
        return asdict(self)


def mmg(name: str = "mmg", asymmetry: bool = False, hull: str = "standard") -> ManoeuvringModel:
    """The hull terms of an MMG family (:data:`HULL_FAMILIES`).

    ``standard``: the 17 terms of the MMG standard method
    (:data:`STANDARD_TERMS`); ``thrust``: those and :data:`THRUST_TERMS`;
    ``reduced``: :data:`REDUCED_TERMS` (with the rudder module off, see
    :func:`family_modules`); ``crossflow``: :data:`CROSSFLOW_TERMS`. Forces of every term set are over ``0.5 rho L d
    U^2`` (moment over ``0.5 rho L^2 d U^2``); the propeller and, but for
    ``reduced``, the rudder are modules (:func:`module_forces`).
    ``asymmetry=True`` adds the constants ``Y0`` and ``N0``
    (:data:`ASYMMETRY_TERMS`) to ``standard`` and ``thrust``; ``reduced``
    carries a single screw's asymmetry in its own ``Yu u'``, ``Nu u'`` (``u'``
    is 1 going straight) and ``YT T'``, ``NT T'``, which the constants would
    only duplicate.
    """
    if hull not in HULL_FAMILIES:
        raise ValueError(f"unknown MMG hull '{hull}'; known: {', '.join(HULL_FAMILIES)}")
    names = HULL_FAMILIES[hull][0] + (ASYMMETRY_TERMS if asymmetry and hull != "reduced" else ())
    return ManoeuvringModel(name, tuple(MMGTerm(n, dof, p, s, t, cf) for n, dof, p, s, t, cf in HULL_TERMS
                                        if n in names))


def rudder_lever(vessel, modules: MMGParameters) -> float:
    """The rudder's yaw moment over its side force in prime units, ``N'_R / Y'_R =
    (x_R + a_H x_H) / ((1 + a_H) L)`` [-] (the rudder module's eq. 13-14: the force
    on the rudder at ``x_R`` and the hull's share ``a_H`` of it at ``x_H``; about -0.49
    for the KVLCC2, where Alexandersson et al. 2022 take -0.5)."""
    length = float(vessel.length)
    return float((float(vessel.xr) / length + modules.aH * modules.xH) / (1.0 + modules.aH))


def family_ties(hull: str, vessel, modules: MMGParameters) -> tuple:
    """``((sway term, yaw term, lever), ...)``: the family's tied rudder terms
    (:data:`FAMILY_TIES`) with the lever of :func:`rudder_lever`; empty for a family
    without ties."""
    pairs = FAMILY_TIES.get(hull, ())
    if not pairs:
        return ()
    lever = rudder_lever(vessel, modules)
    return tuple((y, n, lever) for y, n in pairs)


def family_modules(hull: str, modules: MMGParameters) -> MMGParameters:
    """The propeller and rudder parameters a hull family runs with: ``reduced``
    carries the rudder in its terms, so its rudder module gives no force
    (``f_alpha = f_alpha_2 = 0``); the others keep ``modules``."""
    if HULL_FAMILIES[hull][1]:
        return modules
    return replace(modules, f_alpha=0.0, f_alpha_2=0.0)


def fit_kt(j, kt) -> tuple[float, float, float]:
    """Least-squares quadratic ``K_T = k0 + k1 J + k2 J^2`` of an open-water table.

    Parameters
    ----------
    j, kt : array_like
        Advance ratio J [-] and thrust coefficient K_T [-].

    Returns
    -------
    tuple
        ``(k0, k1, k2)``.
    """
    k2, k1, k0 = np.polyfit(np.asarray(j, float), np.asarray(kt, float), 2)
    return float(k0), float(k1), float(k2)


#: names of :func:`module_constants`, in order
MODULE_CONSTANTS = ("L", "rho", "D", "k0", "k1", "k2", "xP", "xR", "q_rudder", "eta", "tP",
                    "wP0", "C1", "C2_plus", "C2_minus", "tR", "aH", "xH", "gammaR_minus",
                    "gammaR_plus", "lR", "epsilon", "kappa", "q_rudder_2")


def module_constants(vessel, params: MMGParameters) -> tuple:
    """Constants of :func:`module_forces` as a tuple of floats (:data:`MODULE_CONSTANTS`).

    ``vessel`` has the MMG particulars (``length``, ``rho``,
    ``propeller_diameter``, ``kt``, ``xp``, ``xr`` [m], ``rudder_area``,
    ``rudder_height``; see :class:`studies.vessels.kvlcc2_mmg.MMGVessel`).
    ``xR`` and ``xH`` come out in metres, ``xP`` and ``lR`` as fractions of
    ``L``, ``q_rudder = 0.5 rho A_R f_alpha``.
    """
    L = float(vessel.length)
    k0, k1, k2 = (float(x) for x in vessel.kt)
    p = params
    values = (L, vessel.rho, vessel.propeller_diameter, k0, k1, k2, vessel.xp / L, vessel.xr,
              0.5 * vessel.rho * vessel.rudder_area * p.f_alpha,
              vessel.propeller_diameter / vessel.rudder_height, p.tP, p.wP0, p.C1, p.C2_plus,
              p.C2_minus, p.tR, p.aH, p.xH * L, p.gammaR_minus, p.gammaR_plus, p.lR, p.epsilon,
              p.kappa, 0.5 * vessel.rho * vessel.rudder_area * p.f_alpha_2)
    return tuple(float(x) for x in values)


def hull_forces(up, vp, rp, delta, tp, fy, fn, c):
    """Prime hull forces ``(X'_H, Y'_H, N'_H)`` at ``u' = u/U``, ``v' = v/U``,
    ``r' = r L/U``, the rudder angle ``delta`` [rad, contract sign], the
    thrust loading ``T' = T / (0.5 rho L d U^2)`` and the cross-flow
    integrals ``fy``, ``fn`` (:func:`crossflow_integrals`).

    ``c`` holds the coefficients in the order of :data:`HULL_TERMS` (``R0``
    as published, positive), zero for a term the model does not have.
    Scalars or arrays.
    """
    vv = vp * vp
    rr = rp * rp
    vr = vp * rp
    ur = up * rp
    vvd = vv * delta
    td = tp * delta
    x = (-c[0] + c[1] * vv) + (c[2] * vr + c[3] * rr) + c[4] * vv * vv \
        + (c[19] * up + c[20] * up * up) + c[21] * delta * delta
    y = (c[5] * vp + c[6] * rp) + (c[7] * vv * vp + c[8] * vv * rp) + (c[9] * vp * rr + c[10] * rr * rp) \
        + c[17] + (c[22] * up + c[23] * ur) + (c[24] * delta + c[25] * vvd) + (c[26] * tp + c[27] * td) \
        + c[34] * fy
    n = (c[11] * vp + c[12] * rp) + (c[13] * vv * vp + c[14] * vv * rp) + (c[15] * vp * rr + c[16] * rr * rp) \
        + c[18] + (c[28] * up + c[29] * ur) + (c[30] * delta + c[31] * vvd) + (c[32] * tp + c[33] * td) \
        + c[35] * fn
    return x, y, n


def hull_primes(u, v, r, delta, n, vessel, modules: MMGParameters) -> np.ndarray:
    """MMG primes (k, 7) of states given as arrays (:meth:`MMGTerm.feature`):
    ``u / U``, ``v / U``, ``r L / U``, ``delta`` [rad, contract sign], the
    propeller module's thrust loading ``T / (0.5 rho L d U^2)`` at the rate
    ``n`` [rps] and the cross-flow integrals of sway and yaw with the
    vessel's factors (:func:`crossflow_integrals`, :func:`crossflow_factors`)
    (``vessel`` at the states' scale)."""
    u, v, r, delta, n = np.broadcast_arrays(*(np.asarray(x, float) for x in (u, v, r, delta, n)))
    speed = np.sqrt(u * u + v * v)
    k = module_constants(vessel, modules)
    rp = r * vessel.length / speed
    thrust, _ = thrust_normal_force(u, speed, np.arctan2(-v, u), rp, np.sin(delta), np.cos(delta), n, k)
    tp = thrust / (0.5 * vessel.rho * vessel.length * vessel.draught * speed * speed)
    fy, fn = crossflow_integrals(v / speed, rp, *crossflow_factors(vessel))
    return np.column_stack([u / speed, v / speed, rp, delta, tp, fy, fn])


def module_forces(u, v, r, delta, n, k):
    """Propeller and rudder forces ``(X_P + X_R, Y_R, N_R)`` [N, N, N m].

    Parameters
    ----------
    u, v : float or ndarray
        Surge and sway velocity at midship through the water [m/s].
    r : float or ndarray
        Yaw rate [rad/s].
    delta : float or ndarray
        Rudder angle [rad], contract sign (positive turns to negative heading).
    n : float or ndarray
        Propeller rate [rps], >= 0.
    k : tuple
        :func:`module_constants`.
    """
    return rudder_propeller(u, v, r, np.sin(delta), np.cos(delta), n, k)


def rudder_propeller(u, v, r, sin_delta, cos_delta, n, k):
    """:func:`module_forces` with the rudder angle given by its sine and cosine
    (contract sign): :func:`thrust_normal_force` at the drift angle
    ``atan2(-v, u)``, through :func:`module_gains`."""
    speed = np.sqrt(u * u + v * v)
    rp = r * k[0] * (1.0 / speed)
    beta = np.arctan2(-v, u)
    thrust, normal = thrust_normal_force(u, speed, beta, rp, sin_delta, cos_delta, n, k)
    g_thrust, g_surge, g_sway, g_yaw = module_gains(k)
    # MMG rudder sign is opposite to the contract's: sin(delta_M) = -sin(delta)
    return (g_thrust * thrust + g_surge * normal * -sin_delta, g_sway * normal * cos_delta,
            g_yaw * normal * cos_delta)


def module_gains(k) -> tuple[float, float, float, float]:
    """``(1 - t_P, -(1 - t_R), -(1 + a_H), -(x_R + a_H x_H))``: the module forces
    from the thrust and the rudder normal force (:func:`thrust_normal_force`)::

        X_P + X_R = (1 - t_P) T - (1 - t_R) F_N sin(delta_M)
        Y_R = -(1 + a_H) F_N cos(delta_M),   N_R = -(x_R + a_H x_H) F_N cos(delta_M)
    """
    tP, tR, aH, xH, xR = k[10], k[15], k[16], k[17], k[7]
    return 1.0 - tP, -(1.0 - tR), -(1.0 + aH), -(xR + aH * xH)


def thrust_normal_force(u, speed, beta, rp, sin_delta, cos_delta, n, k):
    """Propeller thrust ``T`` [N] and rudder normal force ``F_N`` [N].

    The state comes in as the caller has it: ``u`` [m/s] surge, ``speed``
    ``U`` [m/s], ``beta`` the drift angle ``atan2(-v, u)`` [rad] and ``rp``
    the prime yaw rate ``r L / U``; the rudder angle as its sine and cosine
    (contract sign), ``n`` [rps] and ``k`` as in :func:`module_forces`.
    :func:`module_gains` turns them into the forces. Scalars or arrays.

    The sums are arranged for the compiled simulator, where this is the
    longest chain of dependent operations of each RK4 stage: the terms of the
    propeller rate and the rudder's drift are ready before the wake's
    exponential, and after it each step is one product-sum or a square root
    (the slipstream's sum expanded in ``u_P`` instead of built from ``T``,
    ``U_R^2`` summed beside ``u_R^2`` instead of from it).
    """
    (L, rho, D, k0, k1, k2, xP, xR, q_rudder, eta, tP, wP0, C1, C2p, C2m, tR, aH, xH,
     gRm, gRp, lR, eps, kappa, q_rudder_2) = k
    # propeller inflow: the wake changes with the drift at the propeller,
    # u_P = u (1 - w_P) = u (1 - w_P0) (C_2 - (C_2 - 1) exp(-C_1 |beta_P|))
    beta_p = beta - xP * rp
    c2 = C2m + (C2p - C2m) * (beta_p > 0.0)
    u_0 = u * (1.0 - wP0)
    u_p = u_0 * c2 - u_0 * (c2 - 1.0) * np.exp(-C1 * abs(beta_p))
    # T = rho n^2 D^4 K_T(J_P) = rho D^2 p, p = k0 (nD)^2 + k1 nD u_P + k2 u_P^2 (none when stopped)
    on = n > 0.0
    nd = n * D * on
    p = k0 * nd * nd + u_p * (k1 * nd + k2 * on * u_p)
    # slipstream sqrt(u_P^2 + 8 T / (pi rho D^2)) = sqrt(u_P^2 + (8 / pi) p), the sum expanded in
    # u_P; the rudder's inflow in it, eps sqrt(eta) (u_P + kappa (slip - u_P))
    c8 = 8.0 / np.pi
    slip = np.sqrt(np.maximum(c8 * k0 * nd * nd + u_p * (c8 * k1 * nd + (1.0 + c8 * k2 * on) * u_p),
                              0.0))
    scale = eps * np.sqrt(eta)
    inflow = (scale * (1.0 - kappa)) * u_p + (scale * kappa) * slip
    # u_R^2 = inflow^2 + eps^2 (1 - eta) u_P^2 (the rudder's part outside the slipstream);
    # v_R with the flow straightening; U_R^2 = u_R^2 + v_R^2
    beta_r = beta - lR * rp
    v_r = speed * (gRm + (gRp - gRm) * (beta_r >= 0.0)) * beta_r
    outside = (eps * eps * (1.0 - eta)) * u_p * u_p
    u_r = np.sqrt(inflow * inflow + outside)
    speed_r = np.sqrt(inflow * inflow + (outside + v_r * v_r))
    # F_N = 0.5 rho A_R U_R^2 (f_alpha sin(alpha_R) + f_alpha_2 sin(alpha_R) |sin(alpha_R)|),
    # U_R sin(alpha_R) = u_R sin(dM) - v_R cos(dM), with the MMG's rudder sign opposite to the
    # contract's; the quadratic part, 0 in the standard method, adds exactly 0.0
    across = u_r * -sin_delta - v_r * cos_delta
    return rho * D * D * p, q_rudder * speed_r * across + q_rudder_2 * across * np.abs(across)
