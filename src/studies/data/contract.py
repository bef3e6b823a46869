"""The data contract for manoeuvring time series, and its validation.

A manoeuvre is a table with one row per sample, in SI units and radians
(see ``DESIGN.md``, section "Data contract"):

========== ======== =========================================================
column     unit     meaning
========== ======== =========================================================
``t``      s        time, strictly increasing
``x0``     m        earth-fixed position, north
``y0``     m        earth-fixed position, east
``psi``    rad      heading, continuous (not wrapped into [-pi, pi])
``u``      m/s      body-fixed surge velocity (total, not the perturbation)
``v``      m/s      body-fixed sway velocity
``r``      rad/s    yaw rate
``delta``  rad      actual rudder angle; positive delta gives a negative yaw
                    moment (Nd < 0, the Mariner convention)
========== ======== =========================================================

Optional: ``wind_speed`` [m/s] (>= 0), ``wind_direction`` [rad] (measured true
wind), ``n`` [rps] propeller rate. Any other numeric column (e.g. roll ``phi``
[rad] and roll rate ``p`` [rad/s]) is kept as it is.

:func:`validate_manoeuvre` either returns a clean ``float64`` copy of a table
or raises :class:`studies.errors.DataError` naming the file, the column and
the (zero-based, header not counted) row at fault.
"""

from __future__ import annotations

import difflib
import math
import re

import numpy as np
import pandas as pd

from studies.errors import DataError

__all__ = ["REQUIRED_COLUMNS", "OPTIONAL_COLUMNS", "COLUMN_DESCRIPTIONS",
           "validate_manoeuvre"]

REQUIRED_COLUMNS = ("t", "x0", "y0", "psi", "u", "v", "r", "delta")
OPTIONAL_COLUMNS = ("wind_speed", "wind_direction", "n")

COLUMN_DESCRIPTIONS = {
    "t": "time [s]",
    "x0": "earth-fixed position north [m]",
    "y0": "earth-fixed position east [m]",
    "psi": "heading [rad]",
    "u": "body-fixed surge velocity [m/s]",
    "v": "body-fixed sway velocity [m/s]",
    "r": "yaw rate [rad/s]",
    "delta": "rudder angle [rad]",
    "wind_speed": "true wind speed [m/s]",
    "wind_direction": "true wind direction [rad]",
    "n": "propeller rate [rps]",
}

# Largest plausible magnitudes in radians; beyond them the column is taken to
# be in degrees.
DELTA_MAX_RAD = 1.0          # 57 deg: no rudder turns that far
R_MAX_RAD_S = 1.5            # 86 deg/s: far beyond any ship's yaw rate
PHI_MAX_RAD = 1.0            # 57 deg of roll: the ship has capsized
WIND_DIRECTION_MAX_RAD = 2.0 * math.pi + 0.1
# Range of d(psi)/dt / r (or its inverse) that reveals a factor 180/pi = 57.3.
DEGREE_RATIO_RANGE = (30.0, 100.0)

# Common names of the contract's columns, to suggest a rename.
_SYNONYMS = {
    "t": ("time", "times", "timestamp", "time_s", "sec", "seconds"),
    "x0": ("x", "x_0", "xe", "x_earth", "north", "n_pos", "xpos", "x_pos"),
    "y0": ("y", "y_0", "ye", "y_earth", "east", "e_pos", "ypos", "y_pos"),
    "psi": ("heading", "yaw", "yaw_angle", "hdg", "course", "psi_rad"),
    "u": ("surge", "surge_velocity", "surge_speed", "u_b", "ub", "vx"),
    "v": ("sway", "sway_velocity", "sway_speed", "v_b", "vb", "vy"),
    "r": ("yaw_rate", "yawrate", "rot", "rate_of_turn", "r_rad_s", "psi_dot",
          "psidot", "dpsi"),
    "delta": ("rudder", "rudder_angle", "rudderangle", "delta_r", "dr",
              "rud", "rudder_rad", "d"),
    "wind_speed": ("windspeed", "v_w", "vw", "wind", "u_wind", "true_wind_speed"),
    "wind_direction": ("winddirection", "wind_dir", "beta_w", "betaw",
                       "true_wind_direction"),
    "n": ("rps", "rev", "revs", "propeller_rate", "rpm", "n_prop"),
}

_NAN_WORDS = {"", "nan", "na", "n/a", "null", "none", "<na>", "nat", "-nan"}


def _norm(name: str) -> str:
    return re.sub(r"[^0-9a-z]+", "_", name.strip().lower()).strip("_")


def _suggest(missing: str, available: list[str]) -> str | None:
    """Closest available column name for a missing contract column, if any."""
    candidates = [c for c in available
                  if c not in REQUIRED_COLUMNS and c not in OPTIONAL_COLUMNS]
    for c in candidates:                       # 'R' for 'r', ' U ' for 'u'
        if c.strip().lower() == missing:
            return c
    synonyms = _SYNONYMS.get(missing, ())
    for c in candidates:                       # 'yaw_rate' for 'r'
        if _norm(c) in synonyms:
            return c
    for c in candidates:                       # 'delta_deg', 'psi [rad]'
        head = re.split(r"[^0-9a-z]+", c.strip().lower())[0] if c.strip() else ""
        if head == missing:
            return c
    if len(missing) > 1:
        close = difflib.get_close_matches(
            missing, [c.lower() for c in candidates], n=1, cutoff=0.75)
        if close:
            return candidates[[c.lower() for c in candidates].index(close[0])]
    return None


def _looks_numeric(name: str) -> bool:
    try:
        float(name)
    except ValueError:
        return False
    return True


def _to_float(series: pd.Series, file: str, column: str) -> np.ndarray:
    """Convert one column to float64, refusing non-numeric cells by row."""
    dtype = series.dtype
    kind = getattr(dtype, "kind", "O")
    if kind == "b" or str(dtype) == "boolean":
        raise DataError(file, "values are True/False, not numbers; "
                        "store numbers in SI units", column=column, row=0)
    if kind in "mM":
        raise DataError(file, "values are dates or durations, not numbers; "
                        "store time as seconds (float)", column=column, row=0)
    if kind in "iuf" and not isinstance(dtype, pd.CategoricalDtype):
        try:
            return series.to_numpy(dtype=np.float64, na_value=np.nan)
        except (TypeError, ValueError, OverflowError):
            pass
    if kind == "c":
        raise DataError(file, "values are complex numbers; store real numbers",
                        column=column, row=0)
    values = series.astype(object).to_numpy()
    out = np.empty(len(values), dtype=np.float64)
    for i, value in enumerate(values):
        bad = False
        if value is None or value is pd.NA or value is pd.NaT:
            out[i] = np.nan
            continue
        if isinstance(value, (bool, np.bool_)):
            bad = True
        elif isinstance(value, (int, float, np.integer, np.floating)):
            try:
                out[i] = float(value)
            except (OverflowError, ValueError):
                out[i] = math.inf if value > 0 else -math.inf
            continue
        elif isinstance(value, str):
            text = value.strip()
            if text.lower() in _NAN_WORDS:
                out[i] = np.nan
                continue
            try:
                out[i] = float(text)
                continue
            except ValueError:
                bad = True
        else:
            bad = True
        if bad:
            shown = repr(value)
            if len(shown) > 40:
                shown = shown[:37] + "..."
            raise DataError(
                file, f"value {shown} is not a number; every cell must be a "
                "number (SI units, radians, '.' as the decimal point)",
                column=column, row=i)
    return out


def _first(mask: np.ndarray) -> int:
    return int(np.flatnonzero(mask)[0])


def _check_degrees(data: dict[str, np.ndarray], file: str) -> None:
    """Refuse angles that are evidently in degrees."""
    fix = "angles must be in radians (convert with numpy.deg2rad)"
    delta = data["delta"]
    if np.max(np.abs(delta)) > DELTA_MAX_RAD:
        i = _first(np.abs(delta) > DELTA_MAX_RAD)
        raise DataError(
            file, f"rudder angle {delta[i]:.6g} exceeds {DELTA_MAX_RAD} rad "
            f"(57 deg), so it looks like degrees; {fix}", column="delta", row=i)
    r = data["r"]
    if np.max(np.abs(r)) > R_MAX_RAD_S:
        i = _first(np.abs(r) > R_MAX_RAD_S)
        raise DataError(
            file, f"yaw rate {r[i]:.6g} exceeds {R_MAX_RAD_S} rad/s (86 deg/s), "
            f"so it looks like degrees per second; yaw rate must be in rad/s "
            f"and {fix}", column="r", row=i)
    if "wind_direction" in data:
        wd = data["wind_direction"]
        if np.max(np.abs(wd)) > WIND_DIRECTION_MAX_RAD:
            i = _first(np.abs(wd) > WIND_DIRECTION_MAX_RAD)
            raise DataError(
                file, f"wind direction {wd[i]:.6g} is beyond 2 pi, so it looks "
                f"like degrees; {fix}", column="wind_direction", row=i)
    if "phi" in data:
        phi = data["phi"]
        if np.max(np.abs(phi)) > PHI_MAX_RAD:
            i = _first(np.abs(phi) > PHI_MAX_RAD)
            raise DataError(
                file, f"roll angle {phi[i]:.6g} exceeds {PHI_MAX_RAD} rad "
                f"(57 deg), so it looks like degrees; {fix}", column="phi", row=i)
    _check_heading_consistency(data, file, fix)


def _check_heading_consistency(data: dict[str, np.ndarray], file: str,
                               fix: str) -> None:
    """Compare d(psi)/dt with r: a ratio near 180/pi reveals degrees.

    The heading is continuous (a turning circle legitimately reaches -13 rad),
    so its range says nothing; its consistency with the yaw rate does.
    """
    t, psi, r = data["t"], data["psi"], data["r"]
    if len(t) < 3:
        return
    with np.errstate(all="ignore"):
        dpsi = np.gradient(psi, t)
        r_max = np.max(np.abs(r))
        dpsi_max = np.max(np.abs(dpsi[np.isfinite(dpsi)]), initial=0.0)
        low, high = DEGREE_RATIO_RANGE
        # psi in degrees, r in rad/s: d(psi)/dt = 57.3 r
        significant = np.abs(r) >= max(0.25 * r_max, 1e-5)
        if np.count_nonzero(significant) >= 5:
            ratio = dpsi[significant] / r[significant]
            ratio = ratio[np.isfinite(ratio)]
            if ratio.size >= 5 and low <= np.median(ratio) <= high:
                hits = significant & (dpsi / r >= low) & (dpsi / r <= high)
                i = _first(hits) if hits.any() else None
                raise DataError(
                    file, f"the heading changes {np.median(ratio):.1f} times "
                    "faster than the yaw rate 'r' says (180/pi = 57.3), so "
                    f"heading looks like degrees; {fix}", column="psi", row=i)
        # psi in rad, r in deg/s: r = 57.3 d(psi)/dt
        significant = np.isfinite(dpsi) & (np.abs(dpsi) >= max(0.25 * dpsi_max, 1e-5))
        if np.count_nonzero(significant) >= 5:
            ratio = r[significant] / dpsi[significant]
            ratio = ratio[np.isfinite(ratio)]
            if ratio.size >= 5 and low <= np.median(ratio) <= high:
                hits = significant & (r / dpsi >= low) & (r / dpsi <= high)
                i = _first(hits) if hits.any() else None
                raise DataError(
                    file, f"the yaw rate is {np.median(ratio):.1f} times the "
                    "rate of change of the heading 'psi' (180/pi = 57.3), so "
                    "it looks like degrees per second; yaw rate must be in "
                    f"rad/s and {fix}", column="r", row=i)


def validate_manoeuvre(df: pd.DataFrame, file: str, min_samples: int = 10
                       ) -> pd.DataFrame:
    """Check a manoeuvre table against the data contract.

    Parameters
    ----------
    df : pandas.DataFrame
        One row per sample. Required columns ``t`` [s], ``x0``, ``y0`` [m],
        ``psi`` [rad], ``u``, ``v`` [m/s] (body-fixed), ``r`` [rad/s],
        ``delta`` [rad] (positive gives a negative yaw moment); optional
        ``wind_speed`` [m/s], ``wind_direction`` [rad], ``n`` [rps]; any other
        numeric column is kept.
    file : str
        Name of the file the table came from, used in error messages.
    min_samples : int, default 10
        Fewest rows accepted.

    Returns
    -------
    pandas.DataFrame
        A new ``float64`` table with a fresh ``RangeIndex``: the required
        columns first (contract order), then the optional ones present, then
        any other columns in their original order. ``df.attrs`` is copied.

    Raises
    ------
    studies.errors.DataError
        On the first problem found, naming ``file``, the column and the
        zero-based row (header not counted): a missing or duplicated column,
        a non-numeric cell, NaN or infinity, time not strictly increasing
        (duplicated or decreasing), fewer than ``min_samples`` rows, angles
        in degrees (``delta`` beyond 1 rad, ``r`` beyond 1.5 rad/s,
        ``wind_direction`` beyond 2 pi, ``phi`` beyond 1 rad, or ``psi``/``r``
        inconsistent by a factor near 180/pi), negative ``wind_speed``.
    """
    file = str(file)
    if not isinstance(df, pd.DataFrame):
        raise DataError(file, f"expected a table (pandas.DataFrame), got "
                        f"{type(df).__name__}")
    names = [str(c).strip() for c in df.columns]
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise DataError(file, "the column appears more than once; every "
                            "column name must be unique", column=name)
        seen.add(name)
    # Columns that are entirely empty and unnamed are CSV artefacts (a
    # trailing comma on every line): drop them.
    keep = []
    for j, name in enumerate(names):
        col = df.iloc[:, j]
        if (name.startswith("Unnamed:") or name == "") and len(col) and \
                bool(col.isna().all()):
            continue
        keep.append(j)

    missing = [c for c in REQUIRED_COLUMNS if c not in names]
    if missing:
        c = missing[0]
        available = [n for n in names if n]
        msg = f"required column '{c}' ({COLUMN_DESCRIPTIONS[c]}) is missing"
        if len(missing) > 1:
            msg += " (also missing: " + ", ".join(repr(m) for m in missing[1:]) + ")"
        guess = _suggest(c, available)
        if guess is not None:
            msg += f"; found '{guess}': rename it to '{c}'"
        elif available and all(_looks_numeric(n) for n in available):
            msg += ("; the first line looks like data, not a header: the first "
                    "line must name the columns")
        else:
            shown = ", ".join(repr(n) for n in available[:12])
            msg += f"; the columns found are {shown or 'none'}"
        msg += ". Required columns: " + ", ".join(REQUIRED_COLUMNS)
        raise DataError(file, msg, column=c)

    data: dict[str, np.ndarray] = {}
    for j in keep:
        name = names[j]
        data[name] = _to_float(df.iloc[:, j], file, name)

    order = list(REQUIRED_COLUMNS) + [c for c in OPTIONAL_COLUMNS if c in data]
    order += [n for n in data if n not in order]

    for name in order:
        values = data[name]
        bad = ~np.isfinite(values)
        if bad.any():
            i = _first(bad)
            what = "missing (NaN)" if np.isnan(values[i]) else "infinite"
            raise DataError(file, f"value is {what}; every cell must hold a "
                            "finite number (fill or cut the gap)",
                            column=name, row=i)

    t = data["t"]
    if len(t) > 1:
        not_increasing = ~(t[1:] > t[:-1])
        if not_increasing.any():
            i = _first(not_increasing) + 1
            if t[i] == t[i - 1]:
                msg = (f"time {t[i]:.9g} is duplicated (same as row {i - 1}); "
                       "time must be strictly increasing: drop repeated samples")
            else:
                msg = (f"time decreases from {t[i - 1]:.9g} to {t[i]:.9g}; time "
                       "must be strictly increasing: sort the rows or split "
                       "the record")
            raise DataError(file, msg, column="t", row=i)

    if len(t) < min_samples:
        raise DataError(file, f"only {len(t)} samples; at least {min_samples} "
                        "are needed")

    _check_degrees(data, file)

    if "wind_speed" in data:
        ws = data["wind_speed"]
        if (ws < 0).any():
            i = _first(ws < 0)
            raise DataError(file, f"wind speed {ws[i]:.6g} is negative; wind "
                            "speed must be >= 0 m/s (give the direction in "
                            "'wind_direction')", column="wind_speed", row=i)

    out = pd.DataFrame({name: data[name] for name in order})
    out.attrs.update(dict(df.attrs))
    return out
