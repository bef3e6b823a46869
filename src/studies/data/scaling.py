"""Froude scaling of manoeuvre records between the model and the full-scale ship.

Records of one hull tested at different facilities (MARIN's files at full
scale, HSVA's at model scale) become one data set by Froude similarity with
the geometric scale ``lambda`` (KVLCC2: 45.7): lengths x lambda, times and
speeds x sqrt(lambda), yaw and roll rates and the propeller rate
/ sqrt(lambda), angles unchanged, forces x lambda^3 (the water's density
kept) and moments x lambda^4.

A record states its scale in ``attrs``: ``model_scale`` (True: the values
are those of the model) and ``scale`` (the geometric scale ``lambda`` of the
model). :func:`froude_scale` converts a record to model or full scale and
updates both; :func:`scale_label` names the scale for outputs.
"""

from __future__ import annotations

import math

import pandas as pd

from studies.errors import ConfigError

__all__ = ["LENGTH_COLUMNS", "TIME_COLUMNS", "SPEED_COLUMNS", "RATE_COLUMNS", "FORCE_COLUMNS",
           "MOMENT_COLUMNS", "froude_scale", "scale_label", "SCALES"]

#: columns in metres
LENGTH_COLUMNS = ("x0", "y0")
#: columns in seconds
TIME_COLUMNS = ("t",)
#: columns in m/s
SPEED_COLUMNS = ("u", "v", "wind_speed")
#: columns in rad/s or rps
RATE_COLUMNS = ("r", "p", "n")
#: columns in N
FORCE_COLUMNS = ("thrust",)
#: columns in N m
MOMENT_COLUMNS = ("torque",)
#: the scales a record can be converted to
SCALES = ("model", "full")


def froude_scale(record: pd.DataFrame, to: str) -> pd.DataFrame:
    """The record at model (``to="model"``) or full scale (``to="full"``).

    Parameters
    ----------
    record : pandas.DataFrame
        A record in the data contract whose ``attrs`` give ``model_scale``
        (bool) and ``scale`` (lambda > 0). A record without them is taken as
        it is and only accepted when nothing needs converting (it is
        returned unchanged).
    to : {"model", "full"}

    Returns
    -------
    pandas.DataFrame
        A copy, converted if needed, with ``attrs["model_scale"]`` updated;
        the other attributes are kept. Wind speed scales as a speed (the
        wind of the model test that corresponds to the full-scale wind).
    """
    if to not in SCALES:
        raise ConfigError(f"scale must be one of {', '.join(SCALES)}, got '{to}'")
    if "model_scale" not in record.attrs:
        return record
    is_model = bool(record.attrs["model_scale"])
    if is_model == (to == "model"):
        return record
    scale = float(record.attrs.get("scale", float("nan")))
    if not (math.isfinite(scale) and scale > 0):
        name = record.attrs.get("source", record.attrs.get("name", "record"))
        raise ConfigError(f"{name}: the record's geometric scale is unknown; it cannot be "
                          f"converted to {to} scale")
    factor = scale if to == "full" else 1.0 / scale
    root = math.sqrt(factor)
    out = record.copy()
    for columns, gain in ((LENGTH_COLUMNS, factor), (TIME_COLUMNS, root), (SPEED_COLUMNS, root),
                          (RATE_COLUMNS, 1.0 / root), (FORCE_COLUMNS, factor ** 3),
                          (MOMENT_COLUMNS, factor ** 4)):
        for name in columns:
            if name in out:
                out[name] = out[name] * gain
    out.attrs = dict(record.attrs)
    out.attrs["model_scale"] = to == "model"
    return out


def scale_label(record: pd.DataFrame) -> str:
    """``"model scale (1:45.7)"``, ``"full scale"`` or ``"as recorded"`` (scale not stated)."""
    if "model_scale" not in record.attrs:
        return "as recorded"
    if record.attrs["model_scale"]:
        return f"model scale (1:{float(record.attrs.get('scale', float('nan'))):g})"
    return "full scale"
