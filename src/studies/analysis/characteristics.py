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
The maximum advance and maximum transfer are the largest distances along and
perpendicular to the original course on the first circle (until the heading
has changed by 360 deg or the rudder leaves its turning angle); they are
reached a drift angle after 90 and 180 deg of heading, since the ship's track
turns later than its bow. The steady turning radius is ``U / |r|`` (median
over the steady phase: the rudder still on its plateau after 360 deg of
heading change, at least 90 deg of it, :func:`steady_turn_rows`): the radius of
curvature of the origin's path in the steady turn, from the speed and yaw
rate, which a drift of the circle's centre (current, a slowly varying
external force) does not enter, as it would a circle fitted to the
positions; in calm water both agree to 0.01 %. These six are the turning
characteristics of Wang et al. (2021), Table 4. :func:`mss_turncircle` reads
them as the Marine Systems Simulator's ``turncircle.m`` does, as that
table's model reference was read (at 89.5 deg of heading, not interpolated to
90 deg; the radius of the last sample).

References
----------
Fossen, T.I. (2001-2020). ``turncircle.m`` and ``ExTurnCircle.m``, Marine
Systems Simulator (MSS), NTNU. https://github.com/cybergalactic/MSS

IMO (2002). Standards for ship manoeuvrability, Resolution MSC.137(76).

Wang, T., Li, G., Wu, B., Aesoy, V., Zhang, H. (2021). Parameter
identification of ship manoeuvring model under disturbance using support
vector machine method. Ships and Offshore Structures 16(S1), 13-21, Table 4.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["zigzag_overshoots", "turning_geometry", "characteristics", "manoeuvre_kind",
           "steady_turn_rows", "mss_turncircle", "TURNING_KEYS"]

#: the turning characteristics of :func:`turning_geometry` [m] (Wang et al. 2021, Table 4)
TURNING_KEYS = ("steady_radius_m", "max_transfer_m", "max_advance_m", "transfer_m", "advance_m",
                "tactical_diameter_m")


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


def _rudder_plateau(delta: np.ndarray) -> np.ndarray | None:
    """Samples with the rudder on its turning angle (within 0.5 deg or 5 %);
    None when the rudder never leaves zero by 2 deg."""
    a = np.abs(delta)
    top = a.max()
    if top < np.deg2rad(2.0):
        return None
    return np.abs(a - np.median(a[a > 0.9 * top])) <= max(np.deg2rad(0.5), 0.05 * top)


def steady_turn_rows(record: pd.DataFrame) -> np.ndarray | None:
    """Rows of the steady phase of a turning record, or None.

    The samples with the rudder on its plateau after the heading has changed
    by 360 deg from the execute (the speed has settled by then), up to the
    first sample where the rudder leaves the plateau (the pull-out); None
    when that phase spans fewer than 10 samples or less than 90 deg of
    heading change.
    """
    delta = record["delta"].to_numpy(float)
    psi = record["psi"].to_numpy(float)
    plateau = _rudder_plateau(delta)
    moved = np.flatnonzero(np.abs(delta) > np.deg2rad(1.0))
    if plateau is None or len(moved) == 0:
        return None
    change = np.abs(psi - psi[moved[0]])
    rows = plateau & (change >= 2 * np.pi)
    rows[: moved[0]] = False
    if not rows.any():
        return None
    first = np.flatnonzero(rows)[0]
    leave = np.flatnonzero(~plateau[first:])
    if len(leave):
        rows[first + leave[0]:] = False
    if rows.sum() < 10 or change[rows].max() - change[rows].min() < np.pi / 2:
        return None
    return rows


def turning_geometry(record: pd.DataFrame) -> dict:
    """Turning characteristics [m] of a turning record (the module's docstring).

    ``advance_m``, ``transfer_m`` (at 90 deg of heading change),
    ``tactical_diameter_m`` (transfer at 180 deg), ``max_advance_m`` (when
    the first circle reaches 180 deg), ``max_transfer_m`` (when it reaches
    270 deg), ``steady_radius_m`` (when the record has a steady phase) and
    ``turn_direction`` (+1 starboard, -1 port); a key is absent when the
    record does not reach its heading.
    """
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
    # the first circle: up to 360 deg of heading change or the pull-out
    end = len(change)
    full = np.flatnonzero(change >= 2 * np.pi)
    if len(full):
        end = full[0] + 1
    plateau = _rudder_plateau(delta[e:])
    if plateau is not None and plateau.any():
        reached = np.flatnonzero(plateau)[0]
        left = np.flatnonzero(~plateau[reached:])
        if len(left):
            end = min(end, reached + left[0] + 1)
    turned = change[:end].max()
    if turned >= np.pi:
        out["max_advance_m"] = float(along[:end].max())
    if turned >= 1.5 * np.pi:
        out["max_transfer_m"] = float(np.abs(across[:end]).max())
    rows = steady_turn_rows(record)
    if rows is not None:
        speed = np.hypot(record["u"].to_numpy(float)[rows], record["v"].to_numpy(float)[rows])
        rate = np.abs(record["r"].to_numpy(float)[rows])
        out["steady_radius_m"] = float(np.median(speed / np.maximum(rate, 1e-12)))
    out["turn_direction"] = float(np.sign(psi[-1] - course))
    return out


def mss_turncircle(record: pd.DataFrame, t_rudderexecute: float) -> dict:
    """The six characteristics as the Marine Systems Simulator's ``turncircle.m`` prints them [m].

    Wang et al. (2021) Table 4 names its rows as ``turncircle.m`` prints
    them ("Steady turning radius", ..., "Tactical diameter at 180 (deg)
    heading"). That function reads them off its own Euler run of ``t_final``
    seconds from a straight start at the origin, rudder commanded from the
    first step at which ``round(t)`` reaches ``t_rudderexecute``, and:

    - transfer and advance at 90 deg (tactical diameter at 180 deg) from the
      first sample whose heading, rounded to whole degrees, reaches 90 (180)
      deg, i.e. at 89.5 (179.5) deg, not interpolated to 90 (180) deg;
    - advances from ``x(Nrudder)``, the sample at ``t_rudderexecute - h``
      (``h`` the step), which is 0.5 - h s after the rudder command;
    - the maxima over the whole run, ``max|y|`` and ``max|x| - x(Nrudder)``;
    - the steady radius ``U / |r|`` of the last sample.

    Heading and position are taken from the record's first sample, along
    and across its course (``turncircle.m`` starts at the origin on course
    0, where these are its ``x``, ``y`` and ``psi``). The record is the run
    (``t_final`` its length, ``h`` its step), without a pull-out.
    """
    t = record["t"].to_numpy(float)
    h = float(np.median(np.diff(t)))
    psi = record["psi"].to_numpy(float)
    dx = record["x0"].to_numpy(float) - float(record["x0"].iloc[0])
    dy = record["y0"].to_numpy(float) - float(record["y0"].iloc[0])
    x = dx * np.cos(psi[0]) + dy * np.sin(psi[0])
    y = -dx * np.sin(psi[0]) + dy * np.cos(psi[0])
    turned = np.rad2deg(np.abs(psi - psi[0]))
    whole = np.floor(turned + 0.5)                     # MATLAB round of a non-negative number
    origin = int(round(t_rudderexecute / h)) - 1       # x(Nrudder), MATLAB's 1-based index
    out = {}
    for angle, keys in ((90.0, ("advance_m", "transfer_m")), (180.0, (None, "tactical_diameter_m"))):
        reached = np.flatnonzero(whole >= angle)
        if len(reached):
            i = reached[0]
            if keys[0]:
                out[keys[0]] = float(abs(x[i] - x[origin]))
            out[keys[1]] = float(abs(y[i]))
    speed = np.hypot(record["u"].to_numpy(float)[-1], record["v"].to_numpy(float)[-1])
    out["steady_radius_m"] = float(speed / max(abs(float(record["r"].iloc[-1])), 1e-12))
    out["max_transfer_m"] = float(np.max(np.abs(y)))
    out["max_advance_m"] = float(abs(np.max(np.abs(x)) - x[origin]))
    return out


def characteristics(record: pd.DataFrame, kind: str | None = None, heading: float | None = None) -> dict:
    """Characteristics of a record by its kind (detected when not given)."""
    kind = kind or manoeuvre_kind(record)
    if kind == "zigzag":
        return zigzag_overshoots(record, heading)
    if kind == "turning":
        return turning_geometry(record)
    return {}
