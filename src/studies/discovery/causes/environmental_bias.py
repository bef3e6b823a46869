"""``environmental_bias``: a slowly varying earth-fixed force and moment."""

from __future__ import annotations

import numpy as np

from .base import Cause

__all__ = ["EnvironmentalBias"]


class EnvironmentalBias(Cause):
    """A constant earth-fixed prime force and moment (Wang et al. 2021 eq. 12).

    Parameters (``theta``)
    ----------------------
    bx, by : float
        Earth-fixed prime force towards north and east [-] (thesis eq. 3.6);
        no effect at 0, searched from 0, unbounded.
    bn : float
        Prime yaw moment [-]; no effect at 0. Not fitted (written as None)
        when the baseline has its own constant yaw term N0, the same column
        of the regression.

    Changes neither the records nor the model: :meth:`setup` carries the
    bias, which the regression subtracts (turned to body axes with the
    heading) and the replay adds as an external force.
    """

    id = "environmental_bias"
    params = ("bx", "by", "bn")
    no_effect = {"bx": 0.0, "by": 0.0, "bn": 0.0}
    units = {"bx": "-, prime force towards north (over 0.5 rho L^2 U^2)",
             "by": "-, prime force towards east (over 0.5 rho L^2 U^2)",
             "bn": "-, prime yaw moment (over 0.5 rho L^3 U^2); null when the baseline's N0 holds it"}
    #: a small bias: a prime force about that of a fifth of a degree of the Mariner's rudder
    typical = {"bx": 1e-5, "by": 1e-5, "bn": 5e-6}
    explanation = ("A slowly varying earth-fixed force and moment (waves' drift, wind or current loads "
                   "lumped together; Wang et al. 2021 eq. 12) pushes the ship the same way whatever its "
                   "heading, so its body-fixed effect turns with the heading.")

    def __init__(self, fit_moment: bool = True):
        # a constant earth-fixed yaw moment is the same column as the model's own constant
        # yaw term (N0): then bn cannot be told apart and is not fitted
        self.fit_moment = fit_moment

    @property
    def nl_params(self):
        return ("bx", "by", "bn") if self.fit_moment else ("bx", "by")

    def setup(self, ctx, theta):
        s = super().setup(ctx, theta)
        theta = np.asarray(theta, float)
        s.bias = np.array([theta[0], theta[1], theta[2] if self.fit_moment else 0.0])
        return s

    def parameters(self, theta, fitted=None):
        theta = np.asarray(theta, float)
        return {"bx": float(theta[0]), "by": float(theta[1]),
                "bn": float(theta[2]) if self.fit_moment else None}

    def n_params(self):
        return len(self.nl_params)
