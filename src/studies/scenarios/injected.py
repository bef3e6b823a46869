"""Effects whose truth is exact, injected into measured records.

A model-basin test has a calibrated rudder and no current. Two effects of
the cause catalogue can be added to such a record exactly, without any
simulator, so that ``studies discover`` can be judged on records no code of
the project produced:

Rudder-angle sensor offset ``b`` [rad]
    The recorded rudder reads ``b`` more than the rudder the water sees:
    ``delta_recorded = delta + b``. The cause ``rudder_offset`` must then
    report ``delta0 = b`` (the indicated angle of zero force).
Uniform current of ``speed`` [m/s] towards ``direction`` [rad] (earth-fixed,
0 = north, pi/2 = east: where the water flows *to*)
    A uniform current moves the water, not the hull's physics: the same test
    in that current, measured over ground, is the record with
    ``speed (cos direction, sin direction) (t - t0)`` added to ``(x0, y0)``
    and the current's body-fixed components added to the over-ground
    velocities ``u, v``::

        u += speed cos(direction - psi)
        v += speed sin(direction - psi)

The record's scale is kept: a current given at full scale is converted to
a model-scale record by Froude scaling (``speed / sqrt(scale)``) when the
record says it is at model scale (``attrs["model_scale"]``); the returned
record's ``attrs["injected"]`` holds the truth at the scale of the record
and at full scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..errors import ConfigError

__all__ = ["Injection", "inject", "injection_grid"]


@dataclass(frozen=True)
class Injection:
    """An exact effect to add to a measured record (full-scale values).

    Attributes
    ----------
    rudder_offset : float
        Rudder-angle sensor offset ``b`` [rad]: the record reads ``b`` more than
        the rudder the water sees (0: none).
    current_speed : float
        Uniform current speed [m/s] at full scale (0: none).
    current_direction : float
        Earth-fixed direction the current flows *to* [rad] (0 = north, pi/2 = east).
    """

    rudder_offset: float = 0.0
    current_speed: float = 0.0
    current_direction: float = 0.0

    def __post_init__(self):
        for name in ("rudder_offset", "current_speed", "current_direction"):
            if not np.isfinite(getattr(self, name)):
                raise ConfigError(f"injection: {name} must be a finite number")
        if self.current_speed < 0:
            raise ConfigError("injection: current_speed must be >= 0 (give the direction it flows to)")

    @property
    def causes(self) -> tuple:
        """The catalogue ids of what is injected, in the catalogue's order."""
        out = []
        if self.rudder_offset:
            out.append("rudder_offset")
        if self.current_speed:
            out.append("current")
        return tuple(out)

    @property
    def label(self) -> str:
        """``offset+1.5deg``, ``current0.4@90deg``, both joined by ``_`` or ``nothing``."""
        parts = []
        if self.rudder_offset:
            parts.append(f"offset{np.rad2deg(self.rudder_offset):+.2g}deg")
        if self.current_speed:
            parts.append(f"current{self.current_speed:.2g}@{np.rad2deg(self.current_direction) % 360:.0f}deg")
        return "_".join(parts) or "nothing"

    def truth(self) -> dict:
        """``{cause id: parameters}`` as ``discovery.json`` writes them (full scale)."""
        out = {}
        if self.rudder_offset:
            out["rudder_offset"] = {"delta0": float(self.rudder_offset)}
        if self.current_speed:
            out["current"] = {"speed": float(self.current_speed),
                              "direction": float(self.current_direction % (2 * np.pi))}
        return out


def _speed_at_record_scale(record: pd.DataFrame, speed: float) -> float:
    if record.attrs.get("model_scale"):
        scale = float(record.attrs.get("scale", 1.0))
        return speed / np.sqrt(scale)
    return speed


def inject(record: pd.DataFrame, injection: Injection) -> pd.DataFrame:
    """``record`` as it would have been measured with ``injection`` acting.

    Parameters
    ----------
    record : DataFrame
        A data-contract record (``t, x0, y0, psi, u, v, delta`` at least).
    injection : Injection
        What to add (full-scale values; see the module docstring).

    Returns
    -------
    DataFrame
        A copy; ``attrs`` as the record's plus ``injected`` (the truth, full
        scale) and a name with the injection's label appended.
    """
    missing = [c for c in ("t", "x0", "y0", "psi", "u", "v", "delta") if c not in record]
    if missing:
        raise ConfigError(f"injection: record {record.attrs.get('name', '?')} lacks the columns {missing}")
    out = record.copy()
    if injection.rudder_offset:
        out["delta"] = record["delta"].to_numpy(float) + injection.rudder_offset
    if injection.current_speed:
        c = _speed_at_record_scale(record, injection.current_speed)
        beta = injection.current_direction
        t = record["t"].to_numpy(float)
        psi = record["psi"].to_numpy(float)
        out["x0"] = record["x0"].to_numpy(float) + c * np.cos(beta) * (t - t[0])
        out["y0"] = record["y0"].to_numpy(float) + c * np.sin(beta) * (t - t[0])
        out["u"] = record["u"].to_numpy(float) + c * np.cos(beta - psi)
        out["v"] = record["v"].to_numpy(float) + c * np.sin(beta - psi)
    out.attrs = dict(record.attrs)
    out.attrs["injected"] = injection.truth()
    if injection.causes:
        out.attrs["name"] = f"{record.attrs.get('name', 'record')}_{injection.label}"
    return out


def injection_grid(offsets_deg=(0.5, 1.0, 2.0), speeds=(0.2, 0.5, 0.8),
                   directions_deg=(0.0, 90.0, 180.0, 270.0), both: bool = True) -> list[Injection]:
    """The grid of exact effects judged on real records: each offset (both
    signs), each current at each direction, and (``both``) offset and current
    together (the middle offset with each current direction at the middle
    speed). Full-scale values."""
    grid = [Injection(rudder_offset=np.deg2rad(s * o)) for o in offsets_deg for s in (1.0, -1.0)]
    grid += [Injection(current_speed=c, current_direction=np.deg2rad(d)) for c in speeds for d in directions_deg]
    if both:
        o = np.deg2rad(offsets_deg[len(offsets_deg) // 2])
        c = speeds[len(speeds) // 2]
        grid += [Injection(rudder_offset=o * (1 if k % 2 == 0 else -1), current_speed=c,
                           current_direction=np.deg2rad(d)) for k, d in enumerate(directions_deg)]
    return grid
