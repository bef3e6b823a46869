"""``current``: a steady current the measured velocities are over ground in."""

from __future__ import annotations

import numpy as np

from ...environment.conditions import Environment
from ...simulate.simulator import record_environment
from .base import Cause

__all__ = ["Current"]


def _current_components(record, speed, direction):
    """Body-fixed current velocities (uc, vc) [m/s] along a record's heading."""
    psi = record["psi"].to_numpy(float)
    return speed * np.cos(direction - psi), speed * np.sin(direction - psi)


class Current(Cause):
    """A steady, uniform current.

    Parameters (``theta``)
    ----------------------
    speed : float
        Current speed [m/s]; no effect at 0, searched in [0, 5] from 0.3 and 0.8.
    direction : float
        Earth-fixed direction the current flows *to* [rad]; written in
        [0, 2 pi). Searched from eight directions around the compass.

    Changes the records the regression is built on (:meth:`transform`: the
    velocities through the water, measured minus current) and the replay's
    environment (:meth:`environment`: the record's wind and the current).
    """

    id = "current"
    params = ("speed", "direction")
    #: the track drifts in proportion to the speed; the direction sets no size
    effect_power = {"speed": 1.0, "direction": 0.0}
    no_effect = {"speed": 0.0, "direction": 0.0}
    units = {"speed": "m/s, at the records' scale",
             "direction": "rad, earth-fixed, where the current flows to (0 = north, pi/2 = east)"}
    explanation = ("A steady current carries the ship: the measured velocities and track are over "
                   "ground, while the hydrodynamic forces depend on the velocities through the water, "
                   "so a heading-dependent error appears and the track drifts downstream.")

    def bounds(self, ctx):
        return (np.array([0.0, -4 * np.pi]), np.array([5.0, 4 * np.pi]))

    def transform(self, record, theta):
        out = record.copy()
        uc, vc = _current_components(record, theta[0], theta[1])
        out["u"] = record["u"] - uc
        out["v"] = record["v"] - vc
        if "u_dot" in record and "v_dot" in record:
            # the current's body-fixed components turn with the heading: d(uc)/dt = r vc, d(vc)/dt = -r uc
            r = record["r"].to_numpy(float)
            out["u_dot"] = record["u_dot"] - r * vc
            out["v_dot"] = record["v_dot"] + r * uc
        return out

    def environment(self, record, theta):
        env = record_environment(record)
        return Environment(env.wind_speed, env.wind_direction, float(theta[0]), float(theta[1]))

    def parameters(self, theta, fitted=None):
        speed, direction = float(theta[0]), float(np.angle(np.exp(1j * theta[1])))
        return {"speed": speed, "direction": direction % (2 * np.pi)}
