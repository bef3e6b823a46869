"""Roll damping against forward speed, and a decay at an untested speed.

At forward speed the hull acts as a lifting body as it rolls: the lift
component of Ikeda's damping is linear in the roll rate and grows about
linearly with the speed ``U``, so from decays at several speeds

    b1(U) = b1_0 + b1_U U,

with ``b2`` (quadratic damping) fitted at each speed and interpolated
linearly in ``U`` between them (held constant outside). ``omega0`` is one
value for all speeds. Speeds and coefficients are at the records' scale
(``U`` [m/s], ``b1`` [1/s], ``b2`` [-]).

:func:`fit_speed_dependence` fits it to prepared records that know their
speed (``attrs["speed"]``, see :func:`studies.roll.records.record_speed`);
:meth:`SpeedDependence.simulate` simulates a decay at any speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from studies.roll.simulate import predict_record, simulate_decay_record

__all__ = ["SpeedDependence", "fit_speed_dependence", "speeds_of"]


def speeds_of(records: Sequence[pd.DataFrame], digits: int = 3) -> list[float | None]:
    """Forward speed [m/s] of each record (``attrs["speed"]``, rounded), None where unknown."""
    out = []
    for rec in records:
        u = rec.attrs.get("speed")
        out.append(None if u is None or not np.isfinite(u) else round(float(u), digits))
    return out


@dataclass
class SpeedDependence:
    """Roll damping as a function of forward speed.

    Attributes
    ----------
    omega0 : float
        Natural frequency [rad/s] (all speeds).
    b1_0 : float
        Linear damping at zero speed [1/s].
    b1_U : float
        Its growth with speed [1/m] (``b1`` in 1/s per m/s).
    speeds : list of float
        The tested speeds [m/s].
    b1, b2 : list of float
        Linear [1/s] and quadratic [-] damping fitted at each tested speed.
    rmse_deg : list of float
        RMSE [deg] of each speed's fit over its records.
    """

    omega0: float
    b1_0: float
    b1_U: float
    speeds: list = field(default_factory=list)
    b1: list = field(default_factory=list)
    b2: list = field(default_factory=list)
    rmse_deg: list = field(default_factory=list)

    def params(self, speed: float) -> dict[str, float]:
        """Model parameters (``omega0``, ``b1``, ``b2``) at ``speed`` [m/s]."""
        order = np.argsort(self.speeds)
        b2 = float(np.interp(float(speed), np.asarray(self.speeds)[order], np.asarray(self.b2)[order]))
        return {"omega0": float(self.omega0), "b1": float(self.b1_0 + self.b1_U * float(speed)), "b2": b2}

    def simulate(self, speed: float, phi0: float = math.radians(10.0), duration: float = 60.0,
                 dt: float = 0.01) -> pd.DataFrame:
        """A free decay at ``speed`` [m/s] released from ``phi0`` [rad] at rest:
        ``t`` [s], ``phi`` [rad] every ``dt`` [s] for ``duration`` [s]."""
        rec = simulate_decay_record(self.params(speed), ("b1", "b2"), duration, dt, phi0)
        rec.attrs["speed"] = float(speed)
        return rec

    def as_dict(self) -> dict:
        """For ``discovery.json``: the fit, its units and the per-speed table."""
        return {"omega0": self.omega0, "b1_0": self.b1_0, "b1_U": self.b1_U,
                "units": {"omega0": "rad/s", "b1_0": "1/s", "b1_U": "1/m (1/s per m/s)", "speed": "m/s",
                          "b1": "1/s", "b2": "-"},
                "per_speed": [{"speed": u, "b1": b1, "b2": b2, "rmse_deg": e}
                              for u, b1, b2, e in zip(self.speeds, self.b1, self.b2, self.rmse_deg)]}


def _fit_group(records, omega0, start):
    """``(omega0, b1, b2)`` and the RMSE [deg] of one speed's records (output error)."""
    def resid(x):
        params = {"omega0": x[0], "b1": x[1], "b2": x[2]}
        return np.concatenate([np.nan_to_num(predict_record(params, ("b1", "b2"), r) - r["phi"].to_numpy(float),
                                              nan=1.0) for r in records])

    x0 = [omega0, *start]
    res = least_squares(resid, x0, x_scale="jac", max_nfev=200)
    return res.x, float(np.degrees(np.sqrt(np.mean(res.fun ** 2))))


def fit_speed_dependence(records: Sequence[pd.DataFrame]) -> SpeedDependence | None:
    """Fit ``b1(U) = b1_0 + b1_U U`` and ``b2`` per speed to decays at two or more speeds.

    Each speed's records are fitted by simulation least squares with
    ``omega0``, ``b1`` and ``b2`` free; ``omega0`` is then the mean over the
    speeds and ``b1_0``, ``b1_U`` the least-squares line through the
    per-speed ``b1``.

    Parameters
    ----------
    records : sequence of DataFrame
        Prepared decays with ``attrs["speed"]`` [m/s]; records without a
        speed are left out.

    Returns
    -------
    SpeedDependence or None
        None when fewer than two distinct speeds are known.
    """
    groups: dict[float, list] = {}
    for rec, u in zip(records, speeds_of(records)):
        if u is not None:
            groups.setdefault(u, []).append(rec)
    if len(groups) < 2:
        return None
    speeds, fits, errors = [], [], []
    for u in sorted(groups):
        recs = groups[u]
        period = float(recs[0].attrs.get("period") or 2 * math.pi)
        x, err = _fit_group(recs, 2 * math.pi / period, [0.02, 0.0])
        speeds.append(u)
        fits.append(x)
        errors.append(err)
    fits = np.asarray(fits)
    slope, intercept = np.polyfit(speeds, fits[:, 1], 1)
    return SpeedDependence(float(np.mean(fits[:, 0])), float(intercept), float(slope), speeds,
                           [float(v) for v in fits[:, 1]], [float(v) for v in fits[:, 2]], errors)
