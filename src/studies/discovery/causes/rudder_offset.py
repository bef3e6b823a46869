"""``rudder_offset``: the rudder gives no force at an indicated angle delta0."""

from __future__ import annotations

import numpy as np

from .base import Cause

__all__ = ["RudderOffset"]


class RudderOffset(Cause):
    """The rudder's zero-force angle is ``delta0``, not zero.

    Parameters (``theta``)
    ----------------------
    delta0 : float
        Indicated rudder angle at which the rudder gives no force [rad];
        no effect at 0, searched within +-10 deg from 0.

    Changes the rudder angle both in the records the regression is built on
    (:meth:`transform`) and in the record replayed (:meth:`sim_record`): the
    hydrodynamics see ``delta - delta0``.
    """

    id = "rudder_offset"
    params = ("delta0",)
    no_effect = {"delta0": 0.0}
    units = {"delta0": "rad; the indicated rudder angle at which the rudder gives no force (the "
                       "hydrodynamics see delta - delta0; positive delta gives a negative yaw moment)"}
    explanation = ("The rudder gives no force at an indicated angle delta0, not at zero: a misaligned "
                   "rudder indicator, or the asymmetric inflow of a single propeller (the ship needs "
                   "a little rudder to go straight and turns differently to port and starboard).")

    def bounds(self, ctx):
        return (np.array([-np.deg2rad(10.0)]), np.array([np.deg2rad(10.0)]))

    def transform(self, record, theta):
        out = record.copy()
        out["delta"] = record["delta"] - theta[0]
        return out

    sim_record = transform
