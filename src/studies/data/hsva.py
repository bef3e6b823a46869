"""Loader for the HSVA free-running ``.dat`` files (SIMMAN 2008, KVLCC2, model scale).

File format (see ``../shared/data/README.md``): four title lines in cp1252
(the second names the ship, the third the test, e.g. ``Z20°/10° starting to
starboard``), then rows of twelve space-separated numbers, no header, values
at model scale (1:45.7, Lpp = 7.0 m), sampled every 0.05 s:

=== ============================================ ========= ====================
#   holds                                        unit      read as
=== ============================================ ========= ====================
1   time                                         s         ``t``
2   x0, earth-fixed position north               m         ``x0``
3   y0, earth-fixed position east                m         ``y0``
4   heading                                      deg       ``psi`` [rad]
5   EARTH-fixed velocity along x0                m/s       ``u`` (body-fixed)
6   EARTH-fixed velocity along y0                m/s       ``v`` (body-fixed)
7   yaw rate                                     deg/s     ``r`` [rad/s]
8   a small signal (about +-0.45, not the yaw)   ?         not read
9   actual rudder angle                          deg       ``delta`` [rad]
10  propeller revolutions                        rps       ``n``
11  propeller thrust                             N         ``thrust``
12  propeller torque                             N m       ``torque``
=== ============================================ ========= ====================

The source names columns 7 and 8 ``p`` and ``r``: measured on every file,
the integral of column 7 follows the heading to 0.01-0.05 deg, so column 7
is the yaw rate; column 8 is left out because what it measures is not
known. Columns 5 and 6 equal the differenced track to 0.0006 m/s: they are
earth-fixed and are turned to body axes. Rudder sign as in the MARIN files
and the data contract: a positive rudder angle turns the ship towards
negative heading.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from studies.data.contract import validate_manoeuvre
from studies.data.files import number_rows, read_file_bytes, refuse_binary
from studies.data.scaling import froude_scale
from studies.data.ships import ship_named
from studies.errors import ConfigError, DataError

__all__ = ["read_hsva", "HSVA_COLUMNS", "HSVA_TITLE_LINES", "is_hsva_text"]

HSVA_COLUMNS = ("time", "x0", "y0", "psi", "u", "v", "r", "column_8", "delta", "rev", "thrust",
                "torque")
HSVA_TITLE_LINES = 4
#: geometric scale of the HSVA KVLCC2 model (Lpp 7.0 m of 320 m)
HSVA_SCALE = 45.7

_LAYOUT = ("an HSVA .dat file starts with four title lines followed by rows of 12 space-separated "
           "numbers (time x0 y0 psi u v r - delta rev thrust torque)")


def is_hsva_text(text: str) -> bool:
    """Whether a ``.dat`` file's text is in HSVA's layout (its first line names HSVA,
    or four title lines are followed by rows of twelve numbers)."""
    lines = text.splitlines()
    if lines and "HSVA" in lines[0].upper():
        return True
    if len(lines) <= HSVA_TITLE_LINES:
        return False
    tokens = lines[HSVA_TITLE_LINES].split()
    if len(tokens) != len(HSVA_COLUMNS):
        return False
    try:
        [float(x) for x in tokens]
    except ValueError:
        return False
    return True


def _parse(label: str, text: str) -> tuple[list[str], np.ndarray, np.ndarray]:
    lines = text.splitlines()
    if len(lines) <= HSVA_TITLE_LINES:
        raise DataError(label, f"the file is too short: {_LAYOUT}")
    numbers, line_numbers = number_rows(label, lines[HSVA_TITLE_LINES:], HSVA_TITLE_LINES + 1, HSVA_COLUMNS,
                                        _LAYOUT)
    titles = [line.strip() for line in lines[:HSVA_TITLE_LINES]]
    return titles, numbers, line_numbers


def read_hsva(path, full_scale: bool = False, scale: float = HSVA_SCALE, *,
              min_samples: int = 10) -> pd.DataFrame:
    """Read an HSVA free-running ``.dat`` file into the data contract.

    Parameters
    ----------
    path : str or os.PathLike
        An ``HSVA_CPMC_<ship>_Z_<rudder>_<check>[_P|_S].dat`` file (model scale).
    full_scale : bool, default False
        Return full-scale values (Froude scaling with ``scale``, see
        :mod:`studies.data.scaling`).
    scale : float, default 45.7
        Geometric scale of the model.
    min_samples : int, default 10
        Fewest samples accepted.

    Returns
    -------
    pandas.DataFrame
        ``float64`` columns ``t`` [s], ``x0`` (north), ``y0`` (east) [m],
        ``psi`` [rad] (continuous), ``u``, ``v`` [m/s] body-fixed, ``r``
        [rad/s], ``delta`` [rad] (positive turns the ship to negative
        heading), ``n`` [rps], ``thrust`` [N] and ``torque`` [N m].
        ``attrs``: ``name`` (file stem), ``source`` (path as given),
        ``title`` (the test, third title line), ``facility`` ("HSVA"),
        ``vessel`` (the ship named in the second title line, lower case, or
        absent), ``model_scale`` and ``scale``.

    Raises
    ------
    studies.errors.DataError
        The file is missing, empty, binary or malformed, or the result fails
        :func:`studies.data.validate_manoeuvre`; the message gives the line
        of the file, the row is the zero-based data row.
    """
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ConfigError(f"scale must be a number, got {scale!r}") from None
    if not (math.isfinite(scale) and scale > 0):
        raise ConfigError(f"scale must be a positive number, got {scale}")
    label, p, data = read_file_bytes(path)
    refuse_binary(label, data, "an HSVA .dat text file")
    text = data.decode("cp1252", errors="replace")
    titles, a, line_numbers = _parse(label, text)
    psi = np.deg2rad(a[:, 3])
    u_e, v_e = a[:, 4], a[:, 5]
    df = pd.DataFrame({
        "t": a[:, 0],
        "x0": a[:, 1],
        "y0": a[:, 2],
        "psi": psi,
        "u": u_e * np.cos(psi) + v_e * np.sin(psi),
        "v": -u_e * np.sin(psi) + v_e * np.cos(psi),
        "r": np.deg2rad(a[:, 6]),
        "delta": np.deg2rad(a[:, 8]),
        "n": a[:, 9],
        "thrust": a[:, 10],
        "torque": a[:, 11],
    })
    try:
        df = validate_manoeuvre(df, label, min_samples=min_samples)
    except DataError as exc:
        if exc.row is None:
            raise
        raise DataError(label, f"{exc.message} (line {line_numbers[exc.row]} of the file)",
                        column=exc.column, row=exc.row) from None
    df.attrs.update({"name": p.stem, "source": label, "title": titles[2], "facility": "HSVA",
                     "model_scale": True, "scale": scale})
    ship = ship_named(titles[1]) or ship_named(p.stem)
    if ship:
        df.attrs["vessel"] = ship
    return froude_scale(df, "full") if full_scale else df
