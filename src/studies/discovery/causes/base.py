"""The protocol every cause of ``studies discover`` follows: :class:`Cause`,
the :class:`Setup` it hands the fitting, and :func:`compact_parameters`.

Every cause is a parameterised extension of the baseline: given parameter
values it says how the training records must be read (what the
hydrodynamics really saw), which model to identify, and how to simulate the
extended model (environment, external forces, rudder). Fitting profiles the
hydrodynamic coefficients out by least squares for every trial of the cause's
own parameters (:mod:`studies.discovery.fitting`).

Conventions: angles in radians; current direction is where it flows *to*,
wind direction where the wind comes *from* (earth-fixed, 0 = north); forces
are prime (thesis eq. 3.6); the rudder offset is the indicated angle at which
the rudder gives no force (the hydrodynamics see ``delta - delta0``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ...environment.conditions import Environment
from ...formatting import compact_parameters
from ...models.abkowitz import ManoeuvringModel
from ...simulate.simulator import record_environment, replay

__all__ = ["Setup", "Cause", "compact_parameters"]


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
    cause : Cause or None
        The cause that made the setup (None: the baseline).
    theta : ndarray or None
        The cause's nonlinear parameters (:attr:`Cause.nl_params`).
    body : ndarray (3,) or None
        Body-fixed prime force and moment (fx, fy, fn) at the approach speed
        ``U0``: a force of constant magnitude (a propeller's side force at
        constant rpm), ``(U0 / U)^2`` times this in prime at the speed ``U``;
        subtracted from the regression and added to the replay.
    dynamics : object or None
        A cause that replaces the baseline's dynamics (``propulsion``: the
        MMG model) gives here how it is identified and replayed:
        ``regression_fit(ctx, setup) -> (params, residuals, problems)`` and
        ``replay(params, record) -> record``; None: the baseline's
        regression and simulator.
    """

    model: ManoeuvringModel
    fit_records: list
    fixed: dict = field(default_factory=dict)
    bias: np.ndarray | None = None
    cause: "Cause | None" = None
    theta: np.ndarray | None = None
    body: np.ndarray | None = None
    dynamics: object | None = None

    def replay(self, params: dict, vessel, record: pd.DataFrame) -> pd.DataFrame:
        """``record`` replayed by the identified model ``params`` (the cause's
        dynamics, or the baseline's simulator in the cause's environment)."""
        seen = self.sim_record(record)
        if self.dynamics is not None:
            return self.dynamics.replay(params, seen, self.environment(record), self.external(), self.model)
        return replay(self.model, params, vessel, seen, self.environment(record), self.external())

    def sim_record(self, record: pd.DataFrame) -> pd.DataFrame:
        """The record to replay (its rudder as the hydrodynamics see it)."""
        return self.cause.sim_record(record, self.theta) if self.cause else record

    def environment(self, record: pd.DataFrame) -> Environment:
        """The wind and current to replay ``record`` in (the cause's, else the record's own wind)."""
        return self.cause.environment(record, self.theta) if self.cause else record_environment(record)

    def external(self):
        """The external prime forces of the replay (:func:`studies.simulate.simulate`'s
        columns): ``(bx, by, bn, 0, 0, 0, fx, fy, fn)``, or None without a bias or a body force."""
        if self.bias is None and self.body is None:
            return None
        bias = np.zeros(3) if self.bias is None else self.bias
        body = np.zeros(3) if self.body is None else self.body
        return np.concatenate([bias, np.zeros(3), body])


class Cause:
    """Base class: a named, parameterised extension of the baseline.

    A cause is one subclass in a module of its own under
    :mod:`studies.discovery.causes`, entered in ``CATALOGUE``. It declares
    the class attributes below and overrides only the hooks that concern
    what it changes; every hook of the base class leaves the baseline as it
    is.

    Attributes
    ----------
    id : str
        The contract id of the cause (DESIGN.md's catalogue): its name in
        ``discovery.json`` and the report.
    params : tuple of str
        Names of the cause's parameters, in the order of ``theta``.
    no_effect : dict or None
        The parameters, as :meth:`parameters` writes them, at which the
        cause changes nothing: the extended model is then the baseline
        (``{}`` for a cause without parameters). ``tests/test_discover_causes.py``
        checks that the hooks leave a record unchanged there. None for a
        cause that replaces the baseline's dynamics (``replaces_dynamics``,
        its :class:`Setup` carries ``dynamics``): no value of its parameters
        is the baseline.
    replaces_dynamics : bool
        The extension is another model, not the baseline extended
        (``propulsion``); on the tracks it is judged as another process
        model in the filter
        (:func:`studies.discovery.track_inference.propulsion_on_tracks`).
    explanation : str
        What the cause is physically, in words the report prints when the
        cause is named.

    Notes
    -----
    The hooks, in the order a discovery uses them:

    Applicability
        :meth:`applicable` says whether the cause can be fitted to the
        training records of ``ctx`` (:class:`studies.discovery.fitting.Context`),
        e.g. a wind cause needs the vessel's wind coefficients;
        :meth:`undecidable` whether those records can tell it from the
        baseline at all (``propeller_asymmetry`` needs turns to both sides),
        and if not, which manoeuvre would.
    What it changes in the baseline (at parameters ``theta``)
        - :meth:`transform`: the training record as the hydrodynamics saw it
          (the regression is built on it), e.g. velocities through the water.
        - :meth:`sim_record`: the record replayed to validate the model (its
          rudder as the hydrodynamics see it).
        - :meth:`environment`: the wind and current of the replay.
        - :meth:`model`: the model whose coefficients are identified (added
          terms).
        - :meth:`setup`: all of it in one :class:`Setup`, which also carries
          external forces (an earth-fixed bias, a body-fixed force) and fixed
          coefficients.
    Its parameters
        :attr:`nl_params` are searched by the outer nonlinear fit; the
        others (added terms' coefficients) come out of the LS.
        :meth:`parameters` writes them for ``discovery.json`` (units in the
        cause's docstring) and :meth:`n_params` counts them for the
        complexity penalty of the score.
    How it is fitted
        :func:`studies.discovery.inference.refine` profiles the baseline's
        hydrodynamic coefficients out by LS for every trial ``theta``
        within :meth:`bounds`, from the linear solution of its signature;
        on the tracks, :func:`studies.discovery.track_inference.refine_on_tracks`
        fits them to the filter's innovations.
    """

    id: str
    no_effect: dict | None
    explanation: str
    params: tuple = ()
    replaces_dynamics: bool = False

    def applicable(self, ctx) -> bool:
        """Whether the cause can be fitted to the training records of ``ctx``."""
        return True

    def undecidable(self, ctx) -> tuple[str, str] | None:
        """``(why, manoeuvre)`` when the training records of ``ctx`` cannot
        decide for this cause: why not, and which manoeuvre would (e.g. "a
        turning circle to starboard"); None when they can. An undecidable
        cause is fitted and reported, but not named."""
        return None

    def bounds(self, ctx):
        """Lower and upper bounds of :attr:`nl_params` (arrays; unbounded by default)."""
        return (np.full(len(self.nl_params), -np.inf), np.full(len(self.nl_params), np.inf))

    #: the size of a small effect of an unbounded parameter, by name (units of the parameter)
    typical: dict = {}
    #: each parameter's unit and convention, by name, as ``discovery.json`` states them
    units: dict = {}

    def fixed_parameters(self) -> dict:
        """Values the extension uses but does not fit (published ones), by name; none by default."""
        return {}

    def scales(self, ctx) -> np.ndarray:
        """The unit in which the output-error and filter-error refinements move
        each of :attr:`nl_params` when its start is near no effect (and the
        step of their finite differences, a ten-thousandth of it): a thousandth
        of its bounded range, or :attr:`typical` for an unbounded parameter.
        Without it a parameter started at zero would move in steps of 1e-9
        and its finite-difference derivative would be rounding noise: the fit
        would stay at no effect."""
        low, high = self.bounds(ctx)
        span = np.where(np.isfinite(high - low), high - low, 0.0)
        typical = np.array([float(self.typical.get(n, 0.0)) for n in self.nl_params])
        return np.maximum(np.maximum(1e-3 * span, typical), 1e-9)

    def transform(self, record: pd.DataFrame, theta) -> pd.DataFrame:
        """The training record as the hydrodynamics saw it (the record itself by default)."""
        return record

    def sim_record(self, record: pd.DataFrame, theta) -> pd.DataFrame:
        """The record to replay (the record itself by default)."""
        return record

    def environment(self, record: pd.DataFrame, theta) -> Environment:
        """The wind and current to replay ``record`` in (the record's own wind by default)."""
        return record_environment(record)

    def model(self, ctx, theta) -> ManoeuvringModel:
        """The model to identify (the baseline's by default)."""
        return ctx.model

    def setup(self, ctx, theta) -> Setup:
        """How to identify and simulate the extended model at ``theta``."""
        theta = np.asarray(theta, float)
        return Setup(self.model(ctx, theta), [self.transform(r, theta) for r in ctx.train],
                     cause=self, theta=theta)

    def acts(self, theta) -> bool:
        """Whether the cause at ``theta`` is an effect at all (a cause whose
        fit lies where it is no effect is not named: its evidence is none)."""
        return True

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

    #: how the effect grows with each parameter, by name: the effect is proportional to the
    #: parameter to this power (1 by default; 0: a direction, which sets no size)
    effect_power: dict = {}

    def at_effect(self, parameters: dict, factor: float) -> dict | None:
        """``parameters`` (as :meth:`parameters` writes them) with the effect's size
        scaled by ``factor`` and its direction kept: each parameter times
        ``factor ** (1 / power)`` (:attr:`effect_power`); a nested mapping
        (a missing term's ``terms``) scaled value by value; None when a
        parameter is not a number (the size is not defined)."""
        out = {}
        for name, value in parameters.items():
            power = float(self.effect_power.get(name, 1.0))
            scale = 1.0 if power == 0.0 else float(factor) ** (1.0 / power)
            if value is None:
                out[name] = None
            elif isinstance(value, dict):
                out[name] = {k: float(v) * scale for k, v in value.items()}
            elif isinstance(value, (int, float)) and not isinstance(value, bool):
                out[name] = float(value) * scale
            else:
                return None
        return out
