"""Roll-decay causes: what damping or restoring a linear roll model lacks.

The baseline is ``phi'' + b1 phi' + omega0^2 phi = 0`` (roll angle ``phi``
[rad], time [s]; :class:`studies.roll.model.RollModel`). Each cause adds one
or two terms to it: linear damping ``b1_added phi'`` (added to the
baseline's ``b1``: at forward speed the lift and skin-friction damping that
potential flow misses), ``b2 |phi'| phi'``, ``b3 phi'^3`` or ``c3 phi^3``, or
linear and quadratic damping together. A cause is a class with the contract
id (DESIGN.md's catalogue), its parameters with their units, the model terms
it extends the baseline to and its explanation; the fitting and naming are
:mod:`studies.roll.workflow.search`'s.
"""

from __future__ import annotations

__all__ = ["RollCause", "RollNone", "RollLinearDamping", "RollQuadraticDamping", "RollCubicDamping",
           "RollNonlinearRestoring", "RollLinearQuadraticDamping", "ROLL_CATALOGUE", "PARAMETER_UNITS"]

#: units of the roll causes' and the baseline's parameters (roll angle in radians, time in seconds)
PARAMETER_UNITS = {"omega0": "rad/s", "b1": "1/s", "b1_added": "1/s", "b2": "-", "b3": "s",
                   "c3": "1/s^2"}


class RollCause:
    """A named extension of the linear roll model.

    Attributes
    ----------
    id : str
        The contract id (``roll_quadratic_damping``; a pair joins its members' ids with ``+``).
    params : tuple of str
        The cause's own parameters (:data:`PARAMETER_UNITS`); ``b1_added`` adds to the baseline's ``b1``.
    explanation : str
        What the cause is physically, as the report prints it.
    needs_simulation : bool
        The cause exists only beside a baseline taken from another simulator's record
        (a baseline fitted to the measured decays already holds its own ``b1``).
    """

    id: str = ""
    params: tuple = ()
    explanation: str = ""
    needs_simulation: bool = False

    @property
    def members(self) -> list[str]:
        """The single causes a pair is made of (empty for a single cause)."""
        return self.id.split("+") if "+" in self.id else []

    def terms(self) -> list[str]:
        """Model terms of the baseline extended by the cause (``b1`` first)."""
        extra = [p if p != "b1_added" else "b1" for p in self.params]
        return ["b1"] + [t for t in extra if t != "b1"]

    @staticmethod
    def model_params(base: dict, added: dict) -> dict:
        """Parameters of the extended model: ``base`` (``omega0`` [rad/s], ``b1`` [1/s])
        with the cause's ``added`` parameters (``b1_added`` adds to ``b1``)."""
        out = dict(base)
        for name, value in added.items():
            if name == "b1_added":
                out["b1"] = float(base["b1"]) + float(value)
            else:
                out[name] = float(value)
        return out

    def units(self) -> dict:
        """``{parameter: unit}`` of the cause's parameters."""
        return {p: PARAMETER_UNITS[p] for p in self.params}


_LINEAR = ("Damping linear in the roll rate that the baseline lacks: at forward speed mostly the lift "
           "of the hull (Ikeda's lift component, growing with the speed) and skin friction; the "
           "baseline's radiation damping alone decays too slowly at every amplitude.")


class RollNone(RollCause):
    id = "none"
    explanation = "The linear roll model already explains the decay."


class RollLinearDamping(RollCause):
    id = "roll_linear_damping"
    params = ("b1_added",)
    explanation = _LINEAR
    needs_simulation = True


class RollQuadraticDamping(RollCause):
    id = "roll_quadratic_damping"
    params = ("b2",)
    explanation = ("Viscous roll damping grows with the square of the roll rate (eddy making, bilge keels, "
                   "hull skin friction): an inviscid or linear model decays too slowly at large angles.")


class RollCubicDamping(RollCause):
    id = "roll_cubic_damping"
    params = ("b3",)
    explanation = ("Damping that grows with the cube of the roll rate (strongly non-linear viscous damping "
                   "at large amplitudes).")


class RollNonlinearRestoring(RollCause):
    id = "roll_nonlinear_restoring"
    params = ("c3",)
    explanation = ("The righting arm is not linear in the heel angle (GZ curve curvature): the roll period "
                   "changes with the amplitude.")


class RollLinearQuadraticDamping(RollCause):
    id = "roll_linear_damping+roll_quadratic_damping"
    params = ("b1_added", "b2")
    explanation = ("Both a linear and a quadratic part of the damping are missing: damping linear in the "
                   "roll rate (at forward speed mostly the lift of the hull, Ikeda's lift component, and "
                   "skin friction) and viscous damping growing with the square of the roll rate (eddy "
                   "making, bilge keels).")
    needs_simulation = True


#: every roll-decay cause by its contract id, ``none`` first
ROLL_CATALOGUE = {c.id: c() for c in (RollNone, RollLinearDamping, RollQuadraticDamping, RollCubicDamping,
                                      RollNonlinearRestoring, RollLinearQuadraticDamping)}
