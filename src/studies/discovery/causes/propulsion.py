"""``propulsion``: the baseline lacks thrust at constant rpm and the rudder's slipstream."""

from __future__ import annotations

import numpy as np

from ...identification.kalman import estimate_derivatives
from ...identification.mmg_filter import MMGFilterPlan
from ...identification.mmg_regression import mmg_problems
from ...models.abkowitz import ManoeuvringModel
from ...models.mmg import (ASYMMETRY_TERMS, HULL_FAMILIES, STANDARD_TERMS, MMGParameters, family_modules,
                           family_ties, mmg)
from ...simulate.mmg import MMGReplayPlan, replay_mmg
from ...vessels import has_mmg_particulars, mmg_vessel_at_speed
from .base import Cause, Setup

__all__ = ["Propulsion", "MMGDynamics", "PRIOR_SCALE"]

#: prior sd of the MMG hull coefficients as a fraction of the published values
#: (the ``model=mmg`` default, :class:`studies.config.MMGModelConfig`)
PRIOR_SCALE = 0.5
PRIOR_FLOOR = 0.005


def _through_the_water(record, environment) -> tuple:
    """``(speed [m/s], direction it flows to [rad], record)``: the current of
    ``environment`` (none: zero) and ``record`` with its over-ground ``u``,
    ``v`` turned into velocities through the water (the record itself
    without a current)."""
    speed, direction = ((float(environment.current_speed), float(environment.current_direction))
                        if environment is not None else (0.0, 0.0))
    if not speed:
        return speed, direction, record
    seen = record.copy()
    psi = record["psi"].to_numpy(float)
    seen["u"] = record["u"] - speed * np.cos(direction - psi)
    seen["v"] = record["v"] - speed * np.sin(direction - psi)
    return speed, direction, seen


class MMGDynamics:
    """How the ``propulsion`` extension is identified and simulated: the MMG model.

    Hull terms by the inverse-dynamics regression with the propeller and
    rudder forces known and a Gaussian prior on the vessel's published
    coefficients (:func:`studies.identification.mmg_regression.mmg_problems`), on
    the same state and acceleration estimates as the baseline (so the rows
    are the same); replays with the measured rudder and propeller rate
    (:func:`studies.simulate.mmg.replay_mmg`).

    Residuals are handed to the scoring in the baseline's prime units:
    the MMG divides forces by ``0.5 rho L d U^2`` (moment ``0.5 rho L^2 d
    U^2``), the Abkowitz models by ``0.5 rho L^2 U^2`` (``0.5 rho L^3 U^2``),
    so MMG residuals are multiplied by ``d / L``.
    """

    def __init__(self, vessel, modules: MMGParameters | None = None, asymmetry: bool = False,
                 hull: str = "standard", tie_rudder: bool = True):
        self.vessel = vessel
        self.hull = hull
        self.modules = family_modules(hull, modules or vessel.modules)
        # the family's tied rudder terms (model.tie_rudder), known in the problems
        self.ties = family_ties(hull, vessel, self.modules) if tie_rudder else ()
        # with Y0, N0: the single-screw ship's asymmetry; the hull family of model.hull
        self.model = mmg(asymmetry=asymmetry, hull=hull)
        # the published values are the standard hull's (a family that shares the rudder's
        # forces out differently is regressed without them)
        self.prior = vessel.coefficients if HULL_FAMILIES[hull][1] else None
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
        # the setup's hull terms: the MMG hull, with a missing term's added terms (a cause on an MMG baseline)
        model = setup.model if setup.model is not None and setup.cause is not None else self.model
        problems = mmg_problems(model, self.vessel, self.modules, setup.fit_records, estimates,
                                self.prior, PRIOR_SCALE, PRIOR_FLOOR, ties=self.ties)
        return problems, self.vessel.draught / self.vessel.length

    def replay(self, params: dict, record, environment=None, external=None, model=None):
        """The MMG model's replay of ``record`` (its rudder and propeller rate).

        ``model``: the hull terms (default the MMG hull; a missing term's cause adds terms).
        ``environment``: a uniform current (speed, direction it flows to) in
        which the record was measured over ground: the ship is replayed through
        the water from its initial state less the current, and the current's
        drift added to the track and velocities (the exact effect of a uniform
        current). ``external``: prime forces as :func:`studies.simulate.simulate`
        takes them (earth-fixed bias ``bx, by, bn``, then body-fixed forces at
        the approach speed in columns 6-8, Abkowitz prime units); they are
        turned into accelerations along the record's own speed and heading
        (an approximation: the replay's speed and heading differ from the
        record's where the replay departs from it).
        """
        speed, direction, seen = _through_the_water(record, environment)
        model = model or self.model
        # the baseline's own hull terms and the standard method's (with Y0, N0) go to the compiled
        # simulator; a missing term's terms are added as accelerations
        hull = set(self.model.names) | set(STANDARD_TERMS) | set(ASYMMETRY_TERMS)
        extra = [t for t in model.terms if t.name not in hull]
        if extra:                       # a missing term's terms, outside the MMG simulator's hull
            model = ManoeuvringModel(model.name, tuple(t for t in model.terms if t.name in hull))
        accelerations = None
        if extra or (external is not None and np.any(external)):
            plan = MMGReplayPlan(model, self.vessel, seen, self.modules)
            parts = []
            if external is not None and np.any(external):
                parts.append(self._accelerations(np.asarray(external, float), seen, plan))
            if extra:
                parts.append(self._term_accelerations(extra, params, seen, plan))
            accelerations = sum(parts[1:], parts[0])
        out = replay_mmg(model, params, self.vessel, seen, self.modules, external=accelerations)
        if speed:
            t = out["t"].to_numpy(float)
            t = t - t[0]
            psi = out["psi"].to_numpy(float)
            out["x0"] = out["x0"] + speed * np.cos(direction) * t
            out["y0"] = out["y0"] + speed * np.sin(direction) * t
            out["u"] = out["u"] + speed * np.cos(direction - psi)
            out["v"] = out["v"] + speed * np.sin(direction - psi)
        return out

    def _term_accelerations(self, terms, params: dict, record, plan) -> np.ndarray:
        """SI accelerations per integration step of hull terms the MMG simulator does not hold.

        The terms' MMG prime forces (over ``0.5 rho L d U^2``, moment over
        ``0.5 rho L^2 d U^2``, features of ``(0, v', r', delta)``) are
        evaluated along the record's own states, as the external forces of
        :meth:`_accelerations` are (the same approximation where the replay
        departs from the record).
        """
        return self.term_accelerations_at(terms, params, record, plan.t0 + plan.step * np.arange(plan.steps))

    def term_accelerations_at(self, terms, params: dict, record, times: np.ndarray) -> np.ndarray:
        """:meth:`_term_accelerations` at ``times`` [s] of the record (rows)."""
        vessel = self.vessel
        t = record["t"].to_numpy(float)
        u, v, r, delta = (np.interp(times, t, record[c].to_numpy(float)) for c in ("u", "v", "r", "delta"))
        speed = np.sqrt(u * u + v * v)
        primes = np.column_stack([np.zeros_like(u), v / speed, r * vessel.length / speed, delta])
        prime = {dof: np.zeros_like(u) for dof in ("X", "Y", "N")}
        for term in terms:
            prime[term.dof] = prime[term.dof] + float(params.get(term.name, 0.0)) * term.feature(primes)
        q = 0.5 * vessel.rho * vessel.length * vessel.draught * speed * speed
        forces = q * np.array([prime["X"], prime["Y"], prime["N"] * vessel.length])
        return self._through_mass(forces)

    def _through_mass(self, forces: np.ndarray) -> np.ndarray:
        """Accelerations (steps, 3) of forces (3, steps) [N, N, N m] through the MMG mass matrix."""
        vessel = self.vessel
        mx, my, jz = vessel.added_masses()
        m, xgm = vessel.mass, vessel.xg * vessel.mass
        mass = np.array([[m + mx, 0.0, 0.0], [0.0, m + my, xgm],
                         [0.0, xgm, vessel.iz + vessel.xg ** 2 * m + jz]])
        return np.linalg.solve(mass, forces).T

    def _accelerations(self, external: np.ndarray, record, plan) -> np.ndarray:
        """SI accelerations per integration step of prime external forces (see :meth:`replay`)."""
        return self.accelerations_at(external, record, plan.t0 + plan.step * np.arange(plan.steps))

    def accelerations_at(self, external: np.ndarray, record, times: np.ndarray) -> np.ndarray:
        """:meth:`_accelerations` at ``times`` [s] of the record (rows)."""
        vessel = self.vessel
        t = record["t"].to_numpy(float)
        u = np.interp(times, t, record["u"].to_numpy(float))
        v = np.interp(times, t, record["v"].to_numpy(float))
        psi = np.interp(times, t, record["psi"].to_numpy(float))
        speed2 = u * u + v * v
        q = 0.5 * vessel.rho * vessel.length ** 2
        bx, by, bn = external[:3]
        fx, fy, fn = external[6:9] if len(external) >= 9 else (0.0, 0.0, 0.0)
        body = speed2 * np.array([np.cos(psi) * bx + np.sin(psi) * by,
                                  -np.sin(psi) * bx + np.cos(psi) * by,
                                  np.full_like(psi, bn) * vessel.length])
        body += vessel.speed ** 2 * np.array([[fx], [fy], [fn * vessel.length]])
        return self._through_mass(q * body)

    def filter_plan(self, model, record, environment=None, external=None) -> MMGFilterPlan:
        """``record`` (uniformly sampled, as the model sees it: a rudder offset
        applied) in the prediction-error filter with the MMG model
        (:class:`studies.identification.mmg_filter.MMGFilterPlan`): the current of
        ``environment``, the prime ``external`` forces (:meth:`replay`) and
        the terms of ``model`` outside the MMG hull as accelerations along the
        record's states at the start of each step."""
        # velocities through the water along the record (what the forces act on)
        speed, direction, seen = _through_the_water(record, environment)
        current = (speed * np.cos(direction), speed * np.sin(direction))
        times = record["t"].to_numpy(float)[:-1]
        acc = None
        if external is not None and np.any(external):
            acc = self.accelerations_at(np.asarray(external, float), seen, times)

        def unit(terms):
            return {term.name: self.term_accelerations_at([term], {term.name: 1.0}, seen, times) for term in terms}
        return MMGFilterPlan(model, self.vessel, record, current, acc, unit, self.modules)


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

    def at_effect(self, parameters, factor):
        """None: the extension is another model, with no size to scale."""
        return None

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
        """The fitted parameter: the hull's resistance coefficient ``R0`` (the
        interaction factors are the vessel's published ones,
        :meth:`fixed_parameters`)."""
        out = {}
        if fitted and "R0" in fitted:
            out["R0"] = float(fitted["R0"])
        return out

    def fixed_parameters(self) -> dict:
        """The vessel's published propeller and rudder factors the extension uses, not fitted."""
        modules = self._dynamics.modules if self._dynamics else MMGParameters()
        return {k: float(v) for k, v in modules.as_dict().items()}

    units = {"R0": "-, the hull's resistance coefficient (MMG prime, over 0.5 rho L d U^2)"}

    def n_params(self) -> int:
        return self._extra
