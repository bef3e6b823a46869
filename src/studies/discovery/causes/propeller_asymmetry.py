"""``propeller_asymmetry``: the side force and yaw moment of a single propeller."""

from __future__ import annotations

import numpy as np

from .base import Cause

__all__ = ["PropellerAsymmetry", "turning_sides", "STEADY_TURN"]

#: a stretch of a record is a steady turn when the speed has dropped below
#: ``speed`` times the approach speed and the prime yaw rate exceeds ``r_prime``
#: for at least ``seconds`` [s] on one side (a turning circle; a zig-zag loses
#: too little speed for the side force to differ from a rudder offset)
STEADY_TURN = {"speed": 0.85, "r_prime": 0.2, "seconds": 30.0}


def turning_sides(records, vessel) -> set:
    """The sides the records turn steadily to (:data:`STEADY_TURN`): a set of
    ``"starboard"`` (positive yaw rate: heading increasing) and ``"port"``."""
    sides = set()
    for rec in records:
        t = rec["t"].to_numpy(float)
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        u, v = rec["u"].to_numpy(float), rec["v"].to_numpy(float)
        speed = np.hypot(u, v)
        r_prime = rec["r"].to_numpy(float) * vessel.length / np.maximum(speed, 1e-9)
        slow = speed < STEADY_TURN["speed"] * vessel.speed
        for side, sign in (("starboard", 1.0), ("port", -1.0)):
            if np.sum(slow & (sign * r_prime > STEADY_TURN["r_prime"])) * dt >= STEADY_TURN["seconds"]:
                sides.add(side)
    return sides


class PropellerAsymmetry(Cause):
    """A single propeller's side force and yaw moment, of constant magnitude at constant rpm.

    A right- or left-handed propeller behind a hull works in a skewed wake
    and pushes the stern sideways; the force is proportional to the square
    of its rate, so at constant rpm it keeps its magnitude while the ship
    slows in a turn: in prime units (over ``0.5 rho L^2 U^2``) it grows as
    ``(U0 / U)^2``. A constant prime force (a rudder offset, a hull
    asymmetry) does not; this is what turning circles, where the speed drops
    to half, tell apart.

    Parameters (``theta``)
    ----------------------
    Yp0 : float
        Body-fixed prime side force at the approach speed ``U0`` [-]
        (over ``0.5 rho L^2 U0^2``, positive to starboard); no effect at 0.
    Np0 : float
        Prime yaw moment at ``U0`` [-] (over ``0.5 rho L^3 U0^2``, positive
        turning to starboard); no effect at 0. A force at the propeller,
        ``x_P`` about ``-0.5 L``, gives ``Np0`` about ``-0.5 Yp0``.

    Both are searched from 0, unbounded. Changes neither the records nor
    the model: :meth:`setup` carries the body force, which the regression
    subtracts (times ``(U0 / U)^2`` per row) and the replay adds
    (:func:`studies.simulate.simulate`'s body-fixed forces of given
    magnitude). Records with a varying propeller rate are read as at
    constant rpm.

    The asymmetry is told apart from the hull's symmetric terms only by
    turns to both sides: :meth:`undecidable` says which turning circle is
    missing when the training records turn steadily to one side only
    (:func:`turning_sides`), and the cause is then not named.
    """

    id = "propeller_asymmetry"
    params = ("Yp0", "Np0")
    no_effect = {"Yp0": 0.0, "Np0": 0.0}
    units = {"Yp0": "-, prime side force at the approach speed U0 (over 0.5 rho L^2 U0^2), positive to starboard",
             "Np0": "-, prime yaw moment at U0 (over 0.5 rho L^3 U0^2), positive turning to starboard"}
    #: a small side force: about a fifth of a degree of the Mariner's rudder at the approach speed
    typical = {"Yp0": 1e-5, "Np0": 5e-6}
    explanation = ("A single propeller pushes the stern sideways (its blades work in a skewed wake): a "
                   "side force and yaw moment of constant magnitude at constant rpm, which grows in prime "
                   "terms as the ship slows in a turn, so the ship turns tighter to one side than to the "
                   "other, more than a rudder offset would make it.")

    def setup(self, ctx, theta):
        s = super().setup(ctx, theta)
        theta = np.asarray(theta, float)
        s.body = np.array([0.0, theta[0], theta[1]])
        return s

    def undecidable(self, ctx) -> tuple[str, str] | None:
        sides = turning_sides(ctx.train, ctx.vessel)
        if len(sides) == 2:
            return None
        if not sides:
            return ("the training records hold no steady turn, where a propeller's side force differs "
                    "from a rudder offset or a hull asymmetry", "turning circles to both sides")
        side = sides.pop()
        other = "port" if side == "starboard" else "starboard"
        return (f"the training records turn steadily to {side} only, and a turn to one side cannot show "
                "that the ship turns differently to the other (the same records are explained by "
                "asymmetric hull terms such as Y0, Y0u, N0, N0u, or a rudder offset)",
                f"a turning circle to {other}")
