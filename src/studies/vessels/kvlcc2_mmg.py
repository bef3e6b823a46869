"""Particulars of a ship for the MMG model, and the KVLCC2 L7 read from the shared data.

:class:`MMGVessel` holds what the MMG standard method
(:mod:`studies.models.mmg`) takes as prior knowledge, dimensional (SI units)
at one scale: main dimensions, mass and yaw inertia, the MMG added masses,
propeller and rudder geometry, the open-water curve ``K_T(J)``, the
propeller/rudder parameters (:class:`~studies.models.mmg.MMGParameters`), the
approach speed and propeller rate, the steering gear and the published hull
coefficients. :meth:`MMGVessel.froude` scales it (Froude similarity: lengths
x lambda, speeds x sqrt(lambda), rates / sqrt(lambda), masses x lambda^3,
inertia x lambda^5, the density kept), which leaves every non-dimensional
force and so the simulated trajectory, scaled, unchanged.

:func:`kvlcc2_mmg` reads the KVLCC2 L7 model (Lpp = 7.0 m, scale 1:45.7 of
the MARIN free-running model) from ``kvlcc2_mmg/ship_data.yml`` and
``open_water_characteristics.csv`` of the shared data folder (by default
``../shared/data/kvlcc2_mmg`` next to the repository; the data are never
copied into the repository). Values that the files do not give:

- MMG added masses m'_x = 0.022, m'_y = 0.223, J'_z = 0.011 and the rudder
  and hull interaction factors t_R, a_H, x'_H, gamma_R, l'_R, epsilon,
  kappa, f_alpha: Yasukawa & Yoshimura (2015), the defaults of
  :class:`MMGParameters`; w_P0, C_1, C_2 and t_P are read from the file.
- ``K_T(J)``: least-squares quadratic of the open-water table
  (:func:`studies.models.mmg.fit_kt`), not the published polynomial.
- Approach speed 1.179 m/s and propeller rate 10.4 rps (model scale, the
  MMG standard simulations); a simulation of a measured record uses the
  record's own speed and rate.
- Steering gear: 35 deg, 2.32 deg/s and a 1 s servo time constant at full
  scale, as :mod:`studies.vessels.kvlcc2`, Froude-scaled to the model.

``ship_data.yml`` gives ``I_z`` with a radius of gyration of 0.25 L about
the centre of gravity: that is ``I_zG`` of the MMG equations. Its propeller
diameter, 0.204 m, is used as given (the full-scale 9.86 m of the SIMMAN
particulars would be 0.216 m at 1:45.7).

Self-propulsion: with these particulars and the published ``R'_0 = 0.022``
the surge forces balance at 1.179 m/s with the propeller at 12.1 rps (1.79
rps at full scale); at the 10.33 rps (1.528 rps full scale) of the MARIN
runs the effective thrust is 68 % of the resistance, so a simulation at the
measured rate slows down on a straight course (to about 1.01 m/s). The
captive tests point to the resistance rather than to a towing force: their
straight run (beta = delta = 0, 1.17 m/s, 9.9 rps) is nearly self-propelled
(total X' = -8e-5 with a thrust TX' = 1.22e-3, both over 0.5 rho L^2 U^2),
which with ``t_P`` = 0.22 is a hull resistance ``R'_0`` of about 0.016 in
the MMG's scaling, not 0.022, and a self-propulsion rate within 4 % of the
MARIN runs'. The hull regression identifies ``R0`` from the records (0.0136
from the MARIN zig-zags), so only the published reference simulator carries
the higher value; it is kept as published.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from ..errors import DataError
from ..models.mmg import KVLCC2_ADDED_MASS, KVLCC2_HULL, MMGParameters, fit_kt
from .kvlcc2 import KVLCC2_PARTICULARS

__all__ = ["MMGVessel", "kvlcc2_mmg", "DEFAULT_DATA_DIR", "KVLCC2_MODEL_SPEED", "KVLCC2_MODEL_RPS"]

#: the shared data folder next to the repository (``../shared/data/kvlcc2_mmg``)
DEFAULT_DATA_DIR = Path(__file__).resolve().parents[4] / "shared" / "data" / "kvlcc2_mmg"
#: approach speed [m/s] and propeller rate [rps] of the MMG standard simulations (model scale)
KVLCC2_MODEL_SPEED = 1.179
KVLCC2_MODEL_RPS = 10.4


@dataclass(frozen=True)
class MMGVessel:
    """Prior knowledge of a ship for the MMG model, SI units at one scale.

    Attributes
    ----------
    name : str
    length, draught, beam : float
        Lpp ``L``, draught ``d`` and beam [m].
    rho : float
        Water density [kg/m^3].
    mass : float
        Mass ``m`` [kg].
    iz : float
        Yaw moment of inertia about the centre of gravity ``I_zG`` [kg m^2].
    xg : float
        Centre of gravity forward of midship [m].
    mx, my, jz : float
        MMG added masses, ``m'_x``, ``m'_y`` over ``0.5 rho L^2 d`` and
        ``J'_z`` over ``0.5 rho L^4 d`` [-].
    propeller_diameter : float
        ``D`` [m].
    xp, xr : float
        Propeller and rudder positions forward of midship [m] (negative aft).
    rudder_area, rudder_height : float
        ``A_R`` [m^2] and ``H_R`` [m].
    kt : tuple of 3 float
        Open-water thrust coefficient ``K_T = k0 + k1 J + k2 J^2``.
    speed : float
        Approach speed ``U0`` [m/s].
    rps : float
        Propeller rate of the approach [rps].
    rudder_max : float
        Rudder limit [rad].
    rudder_rate : float
        Rudder rate limit [rad/s].
    rudder_time_constant : float
        Rudder servo time constant [s].
    modules : MMGParameters
        Propeller and rudder parameters.
    coefficients : dict
        Hull coefficients (names of :data:`studies.models.mmg.HULL_TERMS`).
    scale : float
        Geometric scale relative to the tested model (1: the model).
    reference : str
    captive : str
        Path of the vessel's captive-test table at ``scale`` 1 (empty: none).
    """

    name: str
    length: float
    draught: float
    beam: float
    rho: float
    mass: float
    iz: float
    xg: float
    mx: float
    my: float
    jz: float
    propeller_diameter: float
    xp: float
    xr: float
    rudder_area: float
    rudder_height: float
    kt: tuple
    speed: float
    rps: float
    rudder_max: float
    rudder_rate: float
    rudder_time_constant: float
    modules: MMGParameters = field(default_factory=MMGParameters)
    coefficients: dict = field(default_factory=dict)
    scale: float = 1.0
    reference: str = ""
    captive: str = ""

    def added_masses(self) -> tuple[float, float, float]:
        """Dimensional ``(m_x [kg], m_y [kg], J_z [kg m^2])``."""
        q = 0.5 * self.rho * self.length ** 2 * self.draught
        return self.mx * q, self.my * q, self.jz * q * self.length ** 2

    def force_scale(self, speed) -> np.ndarray:
        """``[0.5 rho L d U^2] * 2 + [0.5 rho L^2 d U^2]`` (..., 3): MMG prime -> N, N m."""
        q = 0.5 * self.rho * self.length * self.draught * np.asarray(speed, float) ** 2
        return np.stack([q, q, q * self.length], axis=-1)

    def froude(self, factor: float) -> "MMGVessel":
        """The same ship ``factor`` times larger (Froude similarity, same density)."""
        f = float(factor)
        if not (math.isfinite(f) and f > 0):
            raise ValueError(f"scale factor must be a positive number, got {factor!r}")
        root = math.sqrt(f)
        return replace(
            self, length=self.length * f, draught=self.draught * f, beam=self.beam * f,
            mass=self.mass * f ** 3, iz=self.iz * f ** 5, xg=self.xg * f,
            propeller_diameter=self.propeller_diameter * f, xp=self.xp * f, xr=self.xr * f,
            rudder_area=self.rudder_area * f ** 2, rudder_height=self.rudder_height * f,
            speed=self.speed * root, rps=self.rps / root, rudder_rate=self.rudder_rate / root,
            rudder_time_constant=self.rudder_time_constant * root, scale=self.scale * f)


def _read_yaml(path: Path) -> dict:
    if not path.is_file():
        raise DataError(str(path), "the KVLCC2 MMG ship data are not there (the shared data "
                        "folder is expected next to the repository, or pass data_dir=)")
    with path.open() as f:
        data = yaml.safe_load(f)
    if not isinstance(data, dict):
        raise DataError(str(path), "expected a mapping of particulars")
    need = ("L", "T", "B", "rho", "m", "I_z", "x_G", "x_p", "x_r", "D", "A_R", "H_R",
            "w_p0", "C_1", "C_2_beta_p_pos", "C_2_beta_p_neg", "tdf", "scale_factor")
    missing = [k for k in need if k not in data]
    if missing:
        raise DataError(str(path), f"missing particulars {missing}")
    return data


def _read_open_water(path: Path) -> tuple[float, float, float]:
    if not path.is_file():
        raise DataError(str(path), "the open-water table is not there")
    table = pd.read_csv(path)
    for col in ("J", "Kt"):
        if col not in table:
            raise DataError(str(path), "an open-water table needs columns J and Kt", col)
    return fit_kt(table["J"].to_numpy(float), table["Kt"].to_numpy(float))


def kvlcc2_mmg(full_scale: bool = False, data_dir=None) -> MMGVessel:
    """The KVLCC2 L7 model for the MMG model (see the module docstring).

    Parameters
    ----------
    full_scale : bool, default False
        Froude-scale by the file's ``scale_factor`` (45.7) to the full-scale
        values of the MARIN free-running records.
    data_dir : str or Path, optional
        Folder holding ``ship_data.yml`` and ``open_water_characteristics.csv``;
        default :data:`DEFAULT_DATA_DIR`.
    """
    folder = Path(data_dir) if data_dir is not None else DEFAULT_DATA_DIR
    d = _read_yaml(folder / "ship_data.yml")
    kt = _read_open_water(folder / "open_water_characteristics.csv")
    scale = float(d["scale_factor"])
    root = math.sqrt(scale)
    p = KVLCC2_PARTICULARS
    modules = MMGParameters(tP=float(d["tdf"]), wP0=float(d["w_p0"]), C1=float(d["C_1"]),
                            C2_plus=float(d["C_2_beta_p_pos"]),
                            C2_minus=float(d["C_2_beta_p_neg"]))
    model = MMGVessel(
        name="kvlcc2_mmg", length=float(d["L"]), draught=float(d["T"]), beam=float(d["B"]),
        rho=float(d["rho"]), mass=float(d["m"]), iz=float(d["I_z"]), xg=float(d["x_G"]),
        mx=KVLCC2_ADDED_MASS["mx"], my=KVLCC2_ADDED_MASS["my"], jz=KVLCC2_ADDED_MASS["jz"],
        propeller_diameter=float(d["D"]), xp=float(d["x_p"]), xr=float(d["x_r"]),
        rudder_area=float(d["A_R"]), rudder_height=float(d["H_R"]), kt=kt,
        speed=KVLCC2_MODEL_SPEED, rps=KVLCC2_MODEL_RPS,
        rudder_max=float(np.deg2rad(p["rudder_max_deg"])),
        rudder_rate=float(np.deg2rad(p["rudder_rate_deg_s"])) * root,
        rudder_time_constant=1.0 / root,
        modules=modules, coefficients=dict(KVLCC2_HULL), scale=1.0,
        reference="ship_data.yml and open_water_characteristics.csv (KVLCC2 L7); "
                  "Yasukawa & Yoshimura (2015)",
        captive=str(folder / "captive.csv") if (folder / "captive.csv").is_file() else "")
    return model.froude(scale) if full_scale else model
