"""The Mariner class cargo vessel (3-DOF Abkowitz model).

Coefficients of Chislett & Strom-Tejsen (1965) as listed in the Marine
Systems Simulator ``mariner.m`` (Fossen & Perez 2004) and in the thesis'
Tables 4.1 and 4.3-4.5 (Zhu 2021). The thesis prints Yvvr = 1.54e-1; the
MSS listing has 15356e-5, used here. Wind particulars of a similar cargo
vessel (Fujiwara & Nimura 2005) and Blendermann's coefficients for a loaded
cargo vessel, as in the thesis.

References
----------
Chislett, M.S., Strom-Tejsen, J. (1965). Planar motion mechanism tests and
full-scale steering and manoeuvring predictions for a Mariner class vessel.
Hydro- and Aerodynamics Laboratory, Lyngby, Report Hy-6.

Fossen, T.I., Perez, T. (2004). Marine Systems Simulator (MSS).

Zhu, M. (2021). Genetic-algorithm-based parameter identification for ship
manoeuvring model under wind disturbance. MSc thesis, NTNU.
"""

from __future__ import annotations

from .base import Vessel, WindParticulars

__all__ = ["MARINER_COEFFICIENTS", "mariner"]

MARINER_COEFFICIENTS = {
    # surge
    "Xu": -184e-5, "Xuu": -110e-5, "Xuuu": -215e-5, "Xvv": -899e-5,
    "Xrr": 18e-5, "Xrv": 798e-5, "Xdd": -95e-5, "Xudd": -190e-5,
    "Xvd": 93e-5, "Xuvd": 93e-5,
    # sway
    "Yv": -1160e-5, "Yr": -499e-5, "Yvvv": -8078e-5, "Yvvr": 15356e-5,
    "Yvu": -1160e-5, "Yru": -499e-5, "Yd": 278e-5, "Yddd": -90e-5,
    "Yud": 556e-5, "Yuud": 278e-5, "Yvdd": -4e-5, "Yvvd": 1190e-5,
    "Y0": -4e-5, "Y0u": -8e-5, "Y0uu": -4e-5,
    # yaw
    "Nv": -264e-5, "Nr": -166e-5, "Nvvv": 1636e-5, "Nvvr": -5483e-5,
    "Nvu": -264e-5, "Nru": -166e-5, "Nd": -139e-5, "Nddd": 45e-5,
    "Nud": -278e-5, "Nuud": -139e-5, "Nvdd": 13e-5, "Nvvd": -489e-5,
    "N0": 3e-5, "N0u": 6e-5, "N0uu": 3e-5,
}


def mariner() -> Vessel:
    """The Mariner vessel of the thesis (Table 4.1), U0 = 15 kn."""
    return Vessel(
        name="mariner",
        length=160.93,
        speed=7.7175,
        m=798e-5,
        iz=39.2e-5,
        xg=-0.023,
        x_udot=-42e-5,
        y_vdot=-748e-5,
        y_rdot=-9.354e-5,
        n_vdot=4.646e-5,
        n_rdot=-43.8e-5,
        wind=WindParticulars(area_frontal=469.0, area_lateral=1874.0, s_l=7.2,
                             length_overall=160.93),
        coefficients=dict(MARINER_COEFFICIENTS),
        reference="Chislett & Strom-Tejsen (1965); Fossen & Perez (2004) MSS mariner.m; Zhu (2021) Table 4.1",
    )
