"""The cause catalogue of ``studies discover`` (ids are the DESIGN.md contract).

Every cause is a parameterised extension of the baseline: given parameter
values it says how the training records must be read (what the
hydrodynamics really saw), which model to identify, and how to simulate the
extended model (environment, external forces, rudder). Fitting profiles the
hydrodynamic coefficients out by least squares for every trial of the cause's
own parameters (:mod:`studies.discover.fitting`).

Conventions: angles in radians; current direction is where it flows *to*,
wind direction where the wind comes *from* (earth-fixed, 0 = north); forces
are prime (thesis eq. 3.6); the rudder offset is the indicated angle at which
the rudder gives no force (the hydrodynamics see ``delta - delta0``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..environment.conditions import Environment
from ..models.abkowitz import ManoeuvringModel
from ..models.terms import candidate_terms
from ..simulate.simulator import record_environment

__all__ = ["Setup", "Cause", "CATALOGUE", "manoeuvring_causes", "compact_parameters"]


@dataclass
class Setup:
    """How to identify and simulate one candidate explanation.

    Attributes
    ----------
    model : ManoeuvringModel
        Model whose coefficients are identified by LS.
    fit_records : list of DataFrame
        Training records as the hydrodynamics saw them.
    fixed : dict
        Coefficients held at given values (the cause's own, for added terms).
    bias : ndarray (3,) or None
        Earth-fixed prime force bias (bx, by, bn) subtracted from the regression.
    """

    model: ManoeuvringModel
    fit_records: list
    fixed: dict = field(default_factory=dict)
    bias: np.ndarray | None = None
    cause: "Cause | None" = None
    theta: np.ndarray | None = None

    def sim_record(self, record: pd.DataFrame) -> pd.DataFrame:
        """The record to replay (its rudder as the hydrodynamics see it)."""
        return self.cause.sim_record(record, self.theta) if self.cause else record

    def environment(self, record: pd.DataFrame) -> Environment:
        return self.cause.environment(record, self.theta) if self.cause else record_environment(record)

    def external(self):
        if self.bias is None:
            return None
        return np.concatenate([self.bias, np.zeros(3)])


def compact_parameters(params: dict) -> str:
    """A cause's parameters (:meth:`Cause.parameters`) on one line, added terms by name."""
    flat = {}
    for key, value in params.items():
        flat.update(value if isinstance(value, dict) else {key: value})
    return ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}" for k, v in flat.items())


class Cause:
    """Base class: a named, parameterised extension of the baseline."""

    id = "none"
    params: tuple = ()
    explanation = "The identified model already explains the data: no extension gains on unseen data."

    def applicable(self, ctx) -> bool:
        return True

    def starts(self, ctx) -> list[np.ndarray]:
        """Initial guesses (a coarse grid where the fit is not convex)."""
        return [np.zeros(len(self.nl_params))]

    def bounds(self, ctx):
        return (np.full(len(self.nl_params), -np.inf), np.full(len(self.nl_params), np.inf))

    def transform(self, record: pd.DataFrame, theta) -> pd.DataFrame:
        return record

    def sim_record(self, record: pd.DataFrame, theta) -> pd.DataFrame:
        return record

    def environment(self, record: pd.DataFrame, theta) -> Environment:
        return record_environment(record)

    def model(self, ctx, theta) -> ManoeuvringModel:
        return ctx.model

    def setup(self, ctx, theta) -> Setup:
        theta = np.asarray(theta, float)
        return Setup(self.model(ctx, theta), [self.transform(r, theta) for r in ctx.train],
                     cause=self, theta=theta)

    @property
    def nl_params(self) -> tuple:
        """Parameters fitted by the outer (nonlinear) search; the others come out of LS."""
        return self.params

    def parameters(self, theta, fitted: dict | None = None) -> dict:
        """The cause's parameters for discovery.json (``fitted``: the LS coefficients)."""
        return {p: float(v) for p, v in zip(self.params, np.asarray(theta, float))}

    def n_params(self) -> int:
        """Number of parameters the cause adds (for the complexity penalty)."""
        return len(self.params)


class NoCause(Cause):
    pass


class RudderOffset(Cause):
    id = "rudder_offset"
    params = ("delta0",)
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


def _current_components(record, speed, direction):
    psi = record["psi"].to_numpy(float)
    return speed * np.cos(direction - psi), speed * np.sin(direction - psi)


class Current(Cause):
    id = "current"
    params = ("speed", "direction")
    explanation = ("A steady current carries the ship: the measured velocities and track are over "
                   "ground, while the hydrodynamic forces depend on the velocities through the water, "
                   "so a heading-dependent error appears and the track drifts downstream.")

    def starts(self, ctx):
        return [np.array([s, d]) for s in (0.3, 0.8) for d in np.linspace(-np.pi, np.pi, 8, endpoint=False)]

    def bounds(self, ctx):
        return (np.array([0.0, -4 * np.pi]), np.array([5.0, 4 * np.pi]))

    def transform(self, record, theta):
        out = record.copy()
        uc, vc = _current_components(record, theta[0], theta[1])
        out["u"] = record["u"] - uc
        out["v"] = record["v"] - vc
        return out

    def environment(self, record, theta):
        env = record_environment(record)
        return Environment(env.wind_speed, env.wind_direction, float(theta[0]), float(theta[1]))

    def parameters(self, theta, fitted=None):
        speed, direction = float(theta[0]), float(np.angle(np.exp(1j * theta[1])))
        return {"speed": speed, "direction": direction % (2 * np.pi)}


class WindUnmodelled(Cause):
    id = "wind_unmodelled"
    params = ("speed", "direction")
    explanation = ("Wind loads act on the superstructure but the model has none: a steady wind gives "
                   "a force and moment that depend on the heading relative to the wind (Blendermann 1994).")

    def applicable(self, ctx):
        return ctx.vessel.wind is not None and not any("wind_speed" in r for r in ctx.train)

    def starts(self, ctx):
        return [np.array([s, d]) for s in (8.0, 16.0) for d in np.linspace(-np.pi, np.pi, 8, endpoint=False)]

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


class WindSpeedBias(Cause):
    id = "wind_speed_bias"
    params = ("k",)
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


class EnvironmentalBias(Cause):
    id = "environmental_bias"
    params = ("bx", "by", "bn")
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

    def starts(self, ctx):
        return [np.zeros(len(self.nl_params))]

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


class MissingTerm(Cause):
    """Terms of the extended candidate library that the baseline lacks.

    The terms are chosen by sparse regression (:func:`studies.discover.search.select_missing_terms`)
    before the fit; the extended model is then identified by LS, so the
    terms' coefficients come out of the regression (no outer search).
    """

    id = "missing_term"
    explanation = ("A hydrodynamic effect the model's polynomial does not contain (e.g. a cubic yaw "
                   "damping Nrrr in tight turns): the monomials of u', v', r', delta up to third order "
                   "are searched for the terms the records need (sparse regression on the force "
                   "residual; on noisy records, score tests on the replayed records).")

    def __init__(self, terms=()):
        self.terms = list(terms)
        self.params = tuple(t.name for t in self.terms)

    @property
    def nl_params(self):
        return ()

    def applicable(self, ctx):
        return bool(self.terms)

    def model(self, ctx, theta):
        return ctx.model.extended(self.terms, f"{ctx.model.name}+" + "+".join(self.params))

    def parameters(self, theta, fitted=None):
        fitted = fitted or {}
        return {"terms": {name: float(fitted.get(name, np.nan)) for name in self.params}}


CATALOGUE = {c.id: c for c in (NoCause, RudderOffset, Current, WindUnmodelled, WindSpeedBias,
                               EnvironmentalBias, MissingTerm)}


def manoeuvring_causes(ctx, missing_terms=()) -> list[Cause]:
    """The applicable manoeuvring causes, ``none`` first."""
    has_n0 = any(t.powers == (0, 0, 0, 0) for t in ctx.model.terms_of("N"))
    causes = [NoCause(), RudderOffset(), Current(), WindUnmodelled(), WindSpeedBias(),
              EnvironmentalBias(fit_moment=not has_n0), MissingTerm(missing_terms)]
    return [c for c in causes if c.applicable(ctx)]


def extended_library(model: ManoeuvringModel, max_order: int = 3) -> list:
    """Candidate terms (monomials up to ``max_order``) the model does not have."""
    have = {(t.dof, t.powers) for t in model.terms}
    return [t for dof in ("X", "Y", "N") for t in candidate_terms(dof, max_order)
            if (t.dof, t.powers) not in have]


class Combined(Cause):
    """Two causes at once (their nonlinear parameters concatenated)."""

    def __init__(self, first: Cause, second: Cause, starts=None):
        self.first, self.second = first, second
        self.id = f"{first.id}+{second.id}"
        self.params = tuple(first.params) + tuple(second.params)
        self.explanation = first.explanation + " " + second.explanation
        self._n = len(first.nl_params)
        self._starts = starts

    @property
    def nl_params(self):
        return tuple(self.first.nl_params) + tuple(self.second.nl_params)

    def _split(self, theta):
        theta = np.asarray(theta, float)
        return theta[: self._n], theta[self._n:]

    def starts(self, ctx):
        if self._starts is not None:
            return self._starts
        return [np.concatenate([a, b]) for a in self.first.starts(ctx)[:4] for b in self.second.starts(ctx)[:4]]

    def bounds(self, ctx):
        (l1, h1), (l2, h2) = self.first.bounds(ctx), self.second.bounds(ctx)
        return np.concatenate([l1, l2])[: len(self.nl_params)], np.concatenate([h1, h2])[: len(self.nl_params)]

    def transform(self, record, theta):
        a, b = self._split(theta)
        return self.second.transform(self.first.transform(record, a), b)

    def sim_record(self, record, theta):
        a, b = self._split(theta)
        return self.second.sim_record(self.first.sim_record(record, a), b)

    def environment(self, record, theta):
        a, b = self._split(theta)
        e1, e2 = self.first.environment(record, a), self.second.environment(record, b)
        wind = e1 if e1.wind_speed else e2
        current = e1 if e1.current_speed else e2
        return Environment(wind.wind_speed, wind.wind_direction, current.current_speed,
                           current.current_direction)

    def model(self, ctx, theta):
        a, b = self._split(theta)
        m = self.first.model(ctx, a)
        if isinstance(self.second, MissingTerm):
            m = m.extended(self.second.terms, m.name + "+" + "+".join(self.second.params))
        return m

    def setup(self, ctx, theta):
        a, b = self._split(theta)
        s1, s2 = self.first.setup(ctx, a), self.second.setup(ctx, b)
        return Setup(self.model(ctx, theta), [self.transform(r, theta) for r in ctx.train],
                     {**s1.fixed, **s2.fixed}, s1.bias if s1.bias is not None else s2.bias,
                     cause=self, theta=np.asarray(theta, float))

    def parameters(self, theta, fitted=None):
        a, b = self._split(theta)
        return {self.first.id: self.first.parameters(a, fitted),
                self.second.id: self.second.parameters(b, fitted)}

    def n_params(self):
        return self.first.n_params() + self.second.n_params()
