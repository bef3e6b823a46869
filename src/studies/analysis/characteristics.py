"""Manoeuvre characteristics: zig-zag overshoot angles, turning-circle geometry.

Computed from a record alone (heading, position, rudder), so they apply to
simulated and measured manoeuvres, port or starboard (the sign of the turn is
read from the data).

Zig-zag: the rudder amplitude is the plateau of ``|delta|``; each reversal
starts where the rudder leaves a plateau; the execute heading is the heading
change at those instants (or given); overshoot ``k`` is the heading excursion
beyond it before the ship turns back [deg].

Turning circle: from the rudder execute (first ``|delta|`` above 1 deg),
advance is the distance travelled along the original course when the heading
has changed by 90 deg, transfer the distance perpendicular to it then, and
tactical diameter the perpendicular distance at 180 deg [m] (IMO MSC.137(76)).

References
----------
IMO (2002). Standards for ship manoeuvrability, Resolution MSC.137(76).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["zigzag_overshoots", "turning_geometry", "characteristics", "manoeuvre_kind"]


def _plateau(delta: np.ndarray) -> float:
    a = np.abs(delta)
    top = a.max()
    return float(np.median(a[a > 0.9 * top])) if top > 0 else 0.0


def manoeuvre_kind(record: pd.DataFrame) -> str:
    """``"zigzag"``, ``"turning"`` or ``"other"``, from the rudder and heading."""
    delta = record["delta"].to_numpy(float)
    amp = _plateau(delta)
    if amp < np.deg2rad(2.0):
        return "other"
    on = np.abs(delta) > 0.5 * amp
    signs = np.sign(delta[on])
    reversals = int(np.sum(signs[1:] != signs[:-1]))
    turned = np.abs(record["psi"].to_numpy(float) - record["psi"].iloc[0]).max()
    if reversals >= 2:
        return "zigzag"
    if reversals == 0 and turned > np.pi:
        return "turning"
    return "other"


def zigzag_overshoots(record: pd.DataFrame, heading: float | None = None, count: int = 2) -> dict:
    """First ``count`` overshoot angles [deg] of a zig-zag record.

    Parameters
    ----------
    heading : float, optional
        Execute heading change [rad] (e.g. 20 deg of a 20/20 zig-zag);
        inferred from the rudder reversals when absent.
    """
    psi = record["psi"].to_numpy(float)
    delta = record["delta"].to_numpy(float)
    change = psi - psi[0]
    amp = _plateau(delta)
    tol = max(np.deg2rad(0.5), 0.05 * amp)
    on_plateau = np.abs(np.abs(delta) - amp) <= tol
    starts = np.flatnonzero(on_plateau[:-1] & ~on_plateau[1:]
                            & (np.abs(delta[1:]) < np.abs(delta[:-1])))
    if heading is None:
        if len(starts) == 0:
            return {}
        heading = float(np.median(np.abs(change[starts])))
    out = {"execute_heading_deg": float(np.rad2deg(heading))}
    k = 0
    for s in starts:
        direction = np.sign(change[s])
        seg = change[s:] * direction
        # the heading keeps going past the execute angle until the ship turns back
        turn_back = np.flatnonzero(np.diff(seg) < 0)
        if len(turn_back) == 0:
            break
        peak = seg[turn_back[0]]
        k += 1
        out[f"overshoot{k}_deg"] = float(np.rad2deg(peak - heading))
        if k == count:
            break
    return out


def turning_geometry(record: pd.DataFrame) -> dict:
    """Advance, transfer and tactical diameter [m] of a turning record."""
    psi = record["psi"].to_numpy(float)
    delta = record["delta"].to_numpy(float)
    x = record["x0"].to_numpy(float)
    y = record["y0"].to_numpy(float)
    moved = np.flatnonzero(np.abs(delta) > np.deg2rad(1.0))
    if len(moved) == 0:
        return {}
    e = moved[0]
    course = psi[e]
    change = np.abs(psi[e:] - course)
    dx, dy = x[e:] - x[e], y[e:] - y[e]
    along = dx * np.cos(course) + dy * np.sin(course)
    across = -dx * np.sin(course) + dy * np.cos(course)
    out = {}
    for angle, keys in ((np.pi / 2, ("advance_m", "transfer_m")), (np.pi, (None, "tactical_diameter_m"))):
        idx = np.flatnonzero(change >= angle)
        if len(idx) == 0 or idx[0] == 0:
            continue
        i = idx[0]
        w = (angle - change[i - 1]) / (change[i] - change[i - 1])
        a = along[i - 1] + w * (along[i] - along[i - 1])
        c = across[i - 1] + w * (across[i] - across[i - 1])
        if keys[0]:
            out[keys[0]] = float(a)
        out[keys[1]] = float(abs(c))
    out["turn_direction"] = float(np.sign(psi[-1] - course))
    return out


def characteristics(record: pd.DataFrame, kind: str | None = None, heading: float | None = None) -> dict:
    """Characteristics of a record by its kind (detected when not given)."""
    kind = kind or manoeuvre_kind(record)
    if kind == "zigzag":
        return zigzag_overshoots(record, heading)
    if kind == "turning":
        return turning_geometry(record)
    return {}
