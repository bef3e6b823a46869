"""``propulsion``: the baseline lacks thrust at constant rpm and the rudder's slipstream."""

from __future__ import annotations

import numpy as np

from ...identify.kalman import estimate_derivatives
from ...identify.mmg_regression import mmg_problems
from ...models.mmg import MMGParameters, mmg
from ...simulate.mmg import replay_mmg
from ...vessels import has_mmg_particulars, mmg_vessel_at_speed
from .base import Cause, Setup

__all__ = ["Propulsion", "MMGDynamics", "PRIOR_SCALE"]

#: prior sd of the MMG hull coefficients as a fraction of the published values
#: (the ``model=mmg`` default, :class:`studies.config.MMGModelConfig`)
PRIOR_SCALE = 0.5
PRIOR_FLOOR = 0.005


class MMGDynamics:
    """How the ``propulsion`` extension is identified and simulated: the MMG model.

    Hull terms by the inverse-dynamics regression with the propeller and
    rudder forces known and a Gaussian prior on the vessel's published
    coefficients (:func:`studies.identify.mmg_regression.mmg_problems`), on
    the same state and acceleration estimates as the baseline (so the rows
    are the same); replays with the measured rudder and propeller rate
    (:func:`studies.simulate.mmg.replay_mmg`).

    Residuals are handed to the scoring in the baseline's prime units:
    the MMG divides forces by ``0.5 rho L d U^2`` (moment ``0.5 rho L^2 d
    U^2``), the Abkowitz models by ``0.5 rho L^2 U^2`` (``0.5 rho L^3 U^2``),
    so MMG residuals are multiplied by ``d / L``.
    """

    def __init__(self, vessel, modules: MMGParameters | None = None):
        self.vessel = vessel
        self.modules = modules or vessel.modules
        self.model = mmg()
        self._estimates = {}

    def estimates(self, records, derivative: str) -> list:
        out = []
        for rec in records:
            key = (id(rec), derivative)
            if key not in self._estimates:
                self._estimates[key] = (rec, estimate_derivatives(rec, derivative))
            out.append(self._estimates[key][1])
        return out

    def problems(self, ctx, setup: Setup) -> tuple[dict, float]:
        """``({dof: RegressionProblem}, d / L)``: the MMG hull regression of the
        setup's records (data rows, then the prior's rows), and the factor that
        turns its prime units into the baseline's."""
        estimates = self.estimates(setup.fit_records, ctx.derivative)
        problems = mmg_problems(self.model, self.vessel, self.modules, setup.fit_records, estimates,
                                self.vessel.coefficients, PRIOR_SCALE, PRIOR_FLOOR)
        return problems, self.vessel.draught / self.vessel.length

    def replay(self, params: dict, record):
        return replay_mmg(self.model, params, self.vessel, record, self.modules)


class Propulsion(Cause):
    """The ship's propeller and rudder, missing from a polynomial hull model.

    The baseline's surge force is a polynomial in ``u'`` fitted over the
    speeds of the training records; with the propeller at constant rpm the
    thrust grows as the ship slows (the propeller loading rises) and the
    rudder sits in a stronger slipstream, which such a polynomial cannot
    extrapolate to (a tight turn at 40 % of the approach speed). The
    extension replaces the baseline by the MMG model (Yasukawa & Yoshimura
    2015): the hull as MMG terms, thrust from the measured propeller rate
    ``n`` with ``K_T(J)`` and the wake, the rudder force in the slipstream.

    Parameters
    ----------
    None are searched: the interaction factors are the vessel's published
    ones (written in ``discovery.json``), the hull coefficients come out of
    the regression. The complexity of the extension is its number of
    coefficients against the baseline's (:meth:`n_params`, negative when the
    MMG hull has fewer terms).

    Applies when the vessel has MMG particulars (propeller, rudder,
    open-water curve) and every training and validation record carries the
    propeller rate ``n``.
    """

    id = "propulsion"
    params = ()
    #: no parameter value turns the MMG model into the baseline: the extension replaces it
    no_effect = None
    explanation = ("The model has no propeller: at constant rpm the thrust rises as the ship slows "
                   "(the propeller loading grows) and the rudder works in the propeller's slipstream, "
                   "which a polynomial in the surge speed fitted at service speed cannot extrapolate "
                   "to. The extension is the MMG model: hull, propeller thrust from the measured rpm "
                   "and the rudder in the slipstream.")
    #: the extension replaces the baseline's dynamics (not an added term or force)
    replaces_dynamics = True

    def __init__(self):
        self._extra = 0
        self._dynamics = None

    def applicable(self, ctx) -> bool:
        name = str(getattr(ctx.vessel, "name", ""))
        records = list(ctx.train) + list(ctx.validation)
        if not has_mmg_particulars(name) or not records:
            return False
        if not all("n" in r and np.all(np.asarray(r["n"], float) > 0) for r in records):
            return False
        first = ctx.train[0]
        self._dynamics = MMGDynamics(mmg_vessel_at_speed(name, float(np.hypot(first["u"].iloc[0],
                                                                               first["v"].iloc[0]))))
        self._extra = len(self._dynamics.model.terms) - len(ctx.model.terms)
        return True

    def setup(self, ctx, theta) -> Setup:
        if self._dynamics is None and not self.applicable(ctx):
            raise ValueError("propulsion needs a vessel with MMG particulars and records with n")
        return Setup(self._dynamics.model, list(ctx.train), cause=self,
                     theta=np.asarray(theta, float), dynamics=self._dynamics)

    def parameters(self, theta, fitted=None) -> dict:
        modules = self._dynamics.modules if self._dynamics else MMGParameters()
        out = {k: float(v) for k, v in modules.as_dict().items()}
        if fitted and "R0" in fitted:
            out["R0"] = float(fitted["R0"])
        return out

    def n_params(self) -> int:
        return self._extra
