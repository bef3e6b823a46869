"""The wind causes: ``wind_unmodelled`` (a wind the records do not carry) and
``wind_speed_bias`` (the anemometer reads the wind speed off by a factor)."""

from __future__ import annotations

import numpy as np

from ...environment.conditions import Environment
from ...simulate.simulator import record_environment
from .base import Cause

__all__ = ["WindUnmodelled", "WindSpeedBias"]


#: true wind speed [m/s] below which a fitted wind is calm air (a cup anemometer's starting speed)
CALM = 0.5


class WindUnmodelled(Cause):
    """A steady wind on a vessel whose records carry no wind.

    Parameters (``theta``)
    ----------------------
    speed : float
        True wind speed [m/s]; no effect at 0, searched in [0, 40] from 8 and 16.
    direction : float
        Earth-fixed direction the wind comes *from* [rad]; written in
        [0, 2 pi). Searched from eight directions around the compass.

    Applicable to a vessel with wind coefficients and records without wind
    columns. Changes the records the regression is built on
    (:meth:`transform`: the wind columns, whose load the regression
    removes) and the replay's environment (:meth:`environment`).
    """

    id = "wind_unmodelled"
    params = ("speed", "direction")
    #: wind loads grow as the square of the speed; the direction sets no size
    effect_power = {"speed": 2.0, "direction": 0.0}
    no_effect = {"speed": 0.0, "direction": 0.0}
    units = {"speed": "m/s, true wind speed",
             "direction": "rad, earth-fixed, where the wind comes from (0 = north, pi/2 = east)"}
    explanation = ("Wind loads act on the superstructure but the model has none: a steady wind gives "
                   "a force and moment that depend on the heading relative to the wind (Blendermann 1994).")

    def applicable(self, ctx):
        return ctx.vessel.wind is not None and not any("wind_speed" in r for r in ctx.train)

    def bounds(self, ctx):
        return (np.array([0.0, -4 * np.pi]), np.array([40.0, 4 * np.pi]))

    def transform(self, record, theta):
        out = record.copy()
        out["wind_speed"] = float(theta[0])
        out["wind_direction"] = float(theta[1])
        return out

    def environment(self, record, theta):
        return Environment(float(theta[0]), float(theta[1]))

    def parameters(self, theta, fitted=None):
        return {"speed": float(theta[0]), "direction": float(np.angle(np.exp(1j * theta[1])) % (2 * np.pi))}

    def acts(self, theta):
        """A true wind of at least :data:`CALM` m/s. The wind load model
        (:func:`studies.environment.wind.wind_load`) is off in calm air and
        on at any true wind, where the ship's own speed through the air
        loads it too: a fit at nearly no wind would be credited with that
        air resistance, which the baseline's coefficients already hold."""
        return bool(theta[0] >= CALM)


class WindSpeedBias(Cause):
    """The measured wind speed is ``(1 + k)`` times the true one (thesis eq. 4.1).

    Parameters (``theta``)
    ----------------------
    k : float
        Relative error of the anemometer [-]; no effect at 0, searched in
        [-0.8, 3] from 0.

    Applicable to a vessel with wind coefficients and records with wind
    columns. Changes the wind speed of the records the regression is built
    on (:meth:`transform`) and of the replay's environment
    (:meth:`environment`): both are divided by ``1 + k``.
    """

    id = "wind_speed_bias"
    params = ("k",)
    no_effect = {"k": 0.0}
    units = {"k": "-, the anemometer reads (1 + k) times the true wind speed"}
    explanation = ("The anemometer reads the wind speed off by a factor (1 + k) (thesis eq. 4.1): the "
                   "wind load removed from the data is wrong in proportion to the wind load itself.")

    def applicable(self, ctx):
        return ctx.vessel.wind is not None and all("wind_speed" in r for r in ctx.train)

    def bounds(self, ctx):
        return (np.array([-0.8]), np.array([3.0]))

    def transform(self, record, theta):
        out = record.copy()
        out["wind_speed"] = record["wind_speed"] / (1.0 + theta[0])
        return out

    def environment(self, record, theta):
        env = record_environment(record)
        return Environment(env.wind_speed / (1.0 + float(theta[0])), env.wind_direction)
