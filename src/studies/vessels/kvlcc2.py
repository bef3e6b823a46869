"""The KVLCC2 tanker (MOERI design; SIMMAN 2008 free-running tests at MARIN).

Only prior knowledge is given here: main particulars, the prime mass, yaw
inertia and centre of gravity, added-mass estimates and the steering gear.
No hydrodynamic coefficients are published for the 3-DOF Abkowitz model of
`studies`, so :attr:`Vessel.coefficients` is empty: a KVLCC2 study always
identifies from measured records (``data.path=``), e.g. the MARIN files in
``../shared/data/kvlcc2_free_running/``.

Particulars (full scale, which is the scale of the MARIN files)
--------------------------------------------------------------
Lpp = 320 m, B = 58 m, T = 20.8 m, displacement 312 600 m^3, CB = 0.810,
xG = +11.2 m (forward of midship), kzz = 0.25 Lpp, approach speed 15.5 kn
(7.97 m/s, the measured approach speed of the three MARIN runs: 7.93-8.11
m/s at t = 0), sea water rho = 1025 kg/m^3.

Prime system of `studies` (:mod:`studies.vessels.base`): masses by
``0.5 rho L^3``, inertia by ``0.5 rho L^5``, lengths by ``L``::

    m'  = rho V / (0.5 rho L^3) = 312600 / (0.5 * 320^3)       = 0.019080
    x'G = 11.2 / 320                                          = 0.035
    I'z = m' (kzz'^2 + x'G^2) = m' (0.25^2 + 0.035^2)         = 0.0012159

``I'z`` is about the origin of the body axes (midship), as the mass matrix
of :meth:`Vessel.mass_matrix` expects (``m33 = Iz - Nrdot`` with the
``m xG`` coupling terms off the diagonal); kzz = 0.25 Lpp is the radius of
gyration about the centre of gravity, hence the parallel-axis term
``x'G^2`` (it adds 2 %).

Added masses: the MMG-standard estimates of Yasukawa & Yoshimura (2015)
m'x = 0.022, m'y = 0.223, J'z = 0.011 are made non-dimensional with
``0.5 rho Lpp^2 T`` (masses) and ``0.5 rho Lpp^4 T`` (inertia). In the
``L^3``/``L^5`` system of this code they are multiplied by ``T / L =
0.065``::

    X'udot = -0.022 * 0.065 = -0.00143
    Y'vdot = -0.223 * 0.065 = -0.014495
    N'rdot = -0.011 * 0.065 = -0.000715

(the same conversion gives m' = 0.2935 in the MMG system, which is the MMG
value for this displacement, a check of the factor). ``Yrdot`` and
``Nvdot`` are set to zero: the MMG standard neglects them, and slender-body
estimates for a tanker with xG close to midship are two orders below
``Yvdot``; the identification absorbs what remains in ``Yr``/``Nv``.

Steering gear: rudder limit 35 deg, rate 2.32 deg/s at full scale (SIMMAN
2008 KVLCC2 specification: 15.8 deg/s at model scale 1:45.7, divided by
sqrt(45.7)). The measured records prescribe the actual rudder angle, so the
rate limit only matters for simulated manoeuvres.

No wind particulars (the MARIN tests were made indoors).

References
----------
SIMMAN 2008 workshop, KVLCC2 particulars and free-running test conditions,
MARIN/FORCE, http://www.simman2008.dk.

Yasukawa, H., Yoshimura, Y. (2015). Introduction of MMG standard method for
ship maneuvering predictions. J. Mar. Sci. Technol. 20, 37-52.
doi:10.1007/s00773-014-0293-y

Alexandersson, M., Mao, W., Ringsberg, J.W. (2022). System identification
of vessel manoeuvring models. Ocean Engineering 266, 112940.
doi:10.1016/j.oceaneng.2022.112940
"""

from __future__ import annotations

import numpy as np

from .base import Vessel

__all__ = ["kvlcc2", "KVLCC2_PARTICULARS"]

#: main particulars at full scale (SI units), as in ``../shared/data/README.md``
KVLCC2_PARTICULARS = {
    "lpp": 320.0,
    "beam": 58.0,
    "draught": 20.8,
    "displacement": 312_600.0,      # m^3
    "cb": 0.810,
    "xg": 11.2,                     # m, forward of midship
    "kzz_over_lpp": 0.25,
    "approach_speed": 7.97,         # m/s (15.5 kn)
    "propeller_diameter": 9.86,
    "scale": 45.7,                  # MARIN model, 1:45.7
    "rho": 1025.0,
    # MMG added-mass estimates, non-dimensional with 0.5 rho L^2 T (masses)
    # and 0.5 rho L^4 T (inertia)
    "mx_mmg": 0.022,
    "my_mmg": 0.223,
    "jz_mmg": 0.011,
    "rudder_max_deg": 35.0,
    "rudder_rate_deg_s": 2.32,
}


def kvlcc2() -> Vessel:
    """The KVLCC2 at full scale (see the module docstring for every value)."""
    p = KVLCC2_PARTICULARS
    L = p["lpp"]
    m = p["displacement"] / (0.5 * L**3)          # rho cancels
    xg = p["xg"] / L
    iz = m * (p["kzz_over_lpp"] ** 2 + xg**2)
    t_over_l = p["draught"] / L
    return Vessel(
        name="kvlcc2",
        length=L,
        speed=p["approach_speed"],
        m=m,
        iz=iz,
        xg=xg,
        x_udot=-p["mx_mmg"] * t_over_l,
        y_vdot=-p["my_mmg"] * t_over_l,
        y_rdot=0.0,
        n_vdot=0.0,
        n_rdot=-p["jz_mmg"] * t_over_l,
        rho=p["rho"],
        rudder_max=float(np.deg2rad(p["rudder_max_deg"])),
        rudder_rate=float(np.deg2rad(p["rudder_rate_deg_s"])),
        rudder_time_constant=1.0,
        wind=None,
        coefficients={},
        reference="SIMMAN 2008 KVLCC2 particulars; Yasukawa & Yoshimura (2015) added masses; "
                  "Alexandersson et al. (2022)",
    )
