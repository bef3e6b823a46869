"""Captive (PMM / static) model tests: reading a table of measured forces.

The table of the shared KVLCC2 data (``kvlcc2_mmg/captive.csv``) has one row
per test: ``Run No.``, ``beta(deg)``, ``delta(deg)``, ``r``, ``Speed(m/s)``,
``rps``, ``X'``, ``Y'``, ``N'`` (total forces on the model), ``RX'``, ``RY'``
(rudder), ``TX'`` (propeller thrust) and ``test type``. Read from the data
(checked against the MMG coefficients, see :mod:`studies.analysis.captive`):

- the primes are forces over ``0.5 rho L^2 U^2`` and the moment over
  ``0.5 rho L^3 U^2``;
- ``delta`` has the sign of the data contract (a positive rudder angle gives
  a positive side force and a negative yaw moment: it turns the ship to
  negative heading);
- ``beta`` is the drift angle of the MMG, ``v = -U sin(beta)`` (positive
  drift, positive side force).

:func:`read_captive` returns them with the columns ``beta`` [rad],
``delta`` [rad], ``r`` [rad/s], ``speed`` [m/s], ``n`` [rps], ``X``, ``Y``,
``N`` (the primes above) and ``test``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import DataError

__all__ = ["read_captive", "captive_motion", "CAPTIVE_COLUMNS"]

#: columns a captive table must have, by the name in the file
CAPTIVE_COLUMNS = {"beta(deg)": "beta", "delta(deg)": "delta", "r": "r", "Speed(m/s)": "speed",
                   "rps": "n", "X'": "X", "Y'": "Y", "N'": "N", "test type": "test"}


def read_captive(path) -> pd.DataFrame:
    """Read a captive-test table (see the module docstring); ``DataError`` names
    the file, the column and the row of what is wrong."""
    path = Path(path)
    if not path.is_file():
        raise DataError(str(path), "no captive-test table there")
    table = pd.read_csv(path)
    for col in CAPTIVE_COLUMNS:
        if col not in table:
            raise DataError(str(path), "a captive-test table needs this column", col)
    out = table[list(CAPTIVE_COLUMNS)].rename(columns=CAPTIVE_COLUMNS)
    for col in ("beta", "delta", "r", "speed", "n", "X", "Y", "N"):
        values = pd.to_numeric(out[col], errors="coerce")
        bad = np.flatnonzero(~np.isfinite(values.to_numpy(float)))
        if len(bad):
            name = [k for k, v in CAPTIVE_COLUMNS.items() if v == col][0]
            raise DataError(str(path), "not a finite number", name, int(bad[0]))
        out[col] = values.astype(float)
    if (out["speed"] <= 0).any():
        row = int(np.flatnonzero(out["speed"].to_numpy() <= 0)[0])
        raise DataError(str(path), "speed must be positive", "Speed(m/s)", row)
    out["beta"] = np.deg2rad(out["beta"])
    out["delta"] = np.deg2rad(out["delta"])
    out["test"] = out["test"].astype(str)
    out.attrs["name"] = path.stem
    return out.reset_index(drop=True)


def captive_motion(tests: pd.DataFrame) -> dict:
    """The tests' motion as the data contract has it: ``u, v`` [m/s] at
    midship (``v = -U sin(beta)``), ``r`` [rad/s], ``delta`` [rad], ``n``
    [rps] and the speed ``U`` [m/s], arrays of one value per test."""
    speed = tests["speed"].to_numpy(float)
    beta = tests["beta"].to_numpy(float)
    return {"u": speed * np.cos(beta), "v": -speed * np.sin(beta), "r": tests["r"].to_numpy(float),
            "delta": tests["delta"].to_numpy(float), "n": tests["n"].to_numpy(float), "U": speed}
