"""Loader for the MARIN free-running ``.dat`` files (SIMMAN 2008, KVLCC2).

File format (see ``../shared/data/README.md``): two title lines, then rows of
11 tab-separated numbers, no header, values at full scale::

    time [s]  x0 [m]  y0 [m]  phi [deg]  psi [deg]  u [m/s]  v [m/s]
    p [deg/s]  r [deg/s]  delta [deg]  rev [rpm]

``u``/``v`` in the file are earth-fixed velocities along ``x0``/``y0``, not
body-fixed. Every number is printed with three significant digits, the time
included: consecutive rows therefore share a time stamp (e.g. all rows between
99.95 s and 100.5 s read ``1.00E+02``), although the samples themselves are
uniform (about 0.1353 s at full scale, i.e. 0.02 s at model scale). The files
end with blank or tab-only lines.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from studies.data.contract import validate_manoeuvre
from studies.data.files import decode_text, number_rows, read_file_bytes, refuse_binary
from studies.data.scaling import froude_scale
from studies.data.ships import ship_named
from studies.errors import ConfigError, DataError

__all__ = ["read_marin", "MARIN_COLUMNS", "KVLCC2_SCALE"]

MARIN_COLUMNS = ("time", "x0", "y0", "phi", "psi", "u", "v", "p", "r", "delta",
                 "rev")
KVLCC2_SCALE = 45.7


def _parse(label: str, text: str) -> tuple[str, np.ndarray, np.ndarray]:
    """Title, numbers (one row per data line) and the file line of each row."""
    lines = text.splitlines()
    layout = ("a MARIN .dat file must start with two title lines followed by "
              "rows of 11 tab-separated numbers (time x0 y0 phi psi u v p r "
              "delta rev)")
    if len(lines) < 3:
        raise DataError(label, f"the file is too short: {layout}")
    for k in (0, 1):
        tokens = lines[k].split()
        if len(tokens) == len(MARIN_COLUMNS):
            try:
                [float(x) for x in tokens]
            except ValueError:
                continue
            raise DataError(label, f"line {k + 1} holds numbers, not a title; "
                            f"{layout}")
    numbers, line_numbers = number_rows(label, lines[2:], 3, MARIN_COLUMNS, layout)
    return lines[1].strip(), numbers, line_numbers


def _uniform_time(label: str, stamps: np.ndarray) -> np.ndarray:
    """Rebuild a uniform time axis from stamps rounded to a few digits."""
    n = len(stamps)
    if n < 2:
        return stamps.copy()
    index = np.arange(n, dtype=np.float64)
    slope, offset = np.polyfit(index, stamps, 1)
    t = offset + slope * index
    tolerance = 0.005 * np.abs(stamps) + 1.5 * abs(slope)
    bad = np.abs(t - stamps) > tolerance
    if slope <= 0 or bad.any():
        row = int(np.flatnonzero(bad)[0]) if bad.any() else None
        raise DataError(label, "the time stamps are not those of uniformly "
                        "sampled data; read it with uniform_time=False",
                        column="time", row=row)
    return t - t[0] + stamps[0]


def read_marin(path, model_scale: bool = False, scale: float = KVLCC2_SCALE, *,
               uniform_time: bool = False, min_samples: int = 10) -> pd.DataFrame:
    """Read a MARIN free-running ``.dat`` file into the data contract.

    Parameters
    ----------
    path : str or os.PathLike
        A ``MARIN_FREE_<ship>_<manoeuvre>_m.dat`` file (values at full scale).
    model_scale : bool, default False
        Return model-scale values (Froude scaling with ``scale``): lengths
        divided by ``scale``; times and velocities divided by
        ``sqrt(scale)``; yaw/roll rates and propeller rate multiplied by
        ``sqrt(scale)``; angles unchanged.
    scale : float, default 45.7
        Geometric scale of the model (KVLCC2 at MARIN: 1:45.7).
    uniform_time : bool, default False
        The time column is printed with three significant digits, so stamps
        repeat. By default the rows that repeat the previous time stamp are
        dropped (the first is kept), which leaves steps of 0.1-0.2 s below
        100 s, 1 s up to 1000 s and 10 s beyond, and stamps each kept sample
        up to half a step late (its true time is about 0.45 s earlier than
        its stamp between 100 and 1000 s, about 4.9 s earlier beyond 1000
        s). With ``uniform_time=True`` every row is
        kept and the time axis is rebuilt as uniform (least-squares fit of
        the stamps against the row index; refused if the stamps disagree).
    min_samples : int, default 10
        Fewest samples accepted (after dropping repeated time stamps).

    Returns
    -------
    pandas.DataFrame
        ``float64`` columns in the data contract: ``t`` [s], ``x0`` (north),
        ``y0`` (east) [m], ``psi`` [rad] (continuous, not wrapped), ``u``,
        ``v`` [m/s] body-fixed, ``r`` [rad/s], ``delta`` [rad], ``n`` [rps],
        plus the extra columns ``phi`` [rad] (roll) and ``p`` [rad/s] (roll
        rate). ``attrs`` holds ``name`` (file stem), ``source`` (path as
        given), ``title`` (the file's second title line), ``facility``
        ("MARIN"), ``vessel`` (the hull the title or file name names, lower
        case, when it names one), ``model_scale`` and ``scale``.

    Raises
    ------
    studies.errors.DataError
        The file is missing, empty, binary or malformed (wrong number of
        values, a non-number), or the result fails
        :func:`studies.data.validate_manoeuvre`; the row is the zero-based
        data row of the file (title and blank lines not counted) and the
        message gives the line number.
    studies.errors.ConfigError
        ``scale`` is not a positive finite number.

    Notes
    -----
    Conversions: degrees to radians for ``phi``, ``psi``, ``p``, ``r`` and
    ``delta``; rpm to rps (``n = rev / 60``); the earth-fixed velocities
    (``u_e`` along ``x0``, ``v_e`` along ``y0``) to body-fixed ones::

        u = u_e cos(psi) + v_e sin(psi)
        v = -u_e sin(psi) + v_e cos(psi)

    Rudder sign: in the MARIN files a positive rudder angle turns the ship
    towards negative heading (the 35 deg turning circle ends near
    psi = -738 deg). That is the data contract's convention (positive delta
    gives a negative yaw moment, Nd < 0, as for the Mariner coefficients),
    so ``delta`` keeps the file's sign.
    """
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ConfigError(f"scale must be a number, got {scale!r}") from None
    if not (math.isfinite(scale) and scale > 0):
        raise ConfigError(f"scale must be a positive number, got {scale}")

    label, p, data = read_file_bytes(path)
    refuse_binary(label, data, "a MARIN .dat text file")
    text = decode_text(data)
    title, a, line_numbers = _parse(label, text)

    stamps = a[:, 0]
    if uniform_time:
        kept = np.arange(len(a))
        t = _uniform_time(label, stamps)
    else:
        keep = np.ones(len(a), dtype=bool)
        keep[1:] = stamps[1:] != stamps[:-1]
        kept = np.flatnonzero(keep)
        t = stamps[kept]
    a = a[kept]

    psi = np.deg2rad(a[:, 4])
    u_e, v_e = a[:, 5], a[:, 6]
    columns = {
        "t": t,
        "x0": a[:, 1],
        "y0": a[:, 2],
        "psi": psi,
        "u": u_e * np.cos(psi) + v_e * np.sin(psi),
        "v": -u_e * np.sin(psi) + v_e * np.cos(psi),
        "r": np.deg2rad(a[:, 8]),
        "delta": np.deg2rad(a[:, 9]),
        "n": a[:, 10] / 60.0,
        "phi": np.deg2rad(a[:, 3]),
        "p": np.deg2rad(a[:, 7]),
    }
    df = pd.DataFrame(columns)
    try:
        df = validate_manoeuvre(df, label, min_samples=min_samples)
    except DataError as exc:
        if exc.row is None:
            raise
        original = int(kept[exc.row])
        raise DataError(label, f"{exc.message} (line {line_numbers[original]} "
                        "of the file)", column=exc.column, row=original) from None
    df.attrs.update({"name": p.stem, "source": label, "title": title, "facility": "MARIN",
                     "model_scale": False, "scale": scale})
    ship = ship_named(title) or ship_named(p.stem.replace("_", " "))
    if ship:
        df.attrs["vessel"] = ship
    return froude_scale(df, "model") if model_scale else df
