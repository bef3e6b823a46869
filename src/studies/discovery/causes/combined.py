"""Two causes at once: :class:`Combined`, the second cause tried on top of the best."""

from __future__ import annotations

import numpy as np

from ...environment.conditions import Environment
from .base import Cause, Setup
from .missing_term import MissingTerm

__all__ = ["Combined"]


class Combined(Cause):
    """Two causes at once (their nonlinear parameters concatenated).

    The id is ``first+second``; the records pass through the first cause's
    hooks, then the second's; the environment takes the wind of whichever
    cause has one and the current likewise; a second :class:`MissingTerm`
    adds its terms to the first cause's model. Parameters, no-effect values
    and the explanation are the two causes', by id.
    """

    def __init__(self, first: Cause, second: Cause):
        self.first, self.second = first, second
        self.id = f"{first.id}+{second.id}"
        self.params = tuple(first.params) + tuple(second.params)
        self.no_effect = {first.id: first.no_effect, second.id: second.no_effect}
        self.explanation = first.explanation + " " + second.explanation
        self.units = {first.id: dict(first.units), second.id: dict(second.units)}
        self._n = len(first.nl_params)

    def acts(self, theta):
        a, b = self._split(theta)
        return self.first.acts(a) and self.second.acts(b)

    @property
    def nl_params(self):
        return tuple(self.first.nl_params) + tuple(self.second.nl_params)

    def _split(self, theta):
        theta = np.asarray(theta, float)
        return theta[: self._n], theta[self._n:]

    def bounds(self, ctx):
        (l1, h1), (l2, h2) = self.first.bounds(ctx), self.second.bounds(ctx)
        return np.concatenate([l1, l2])[: len(self.nl_params)], np.concatenate([h1, h2])[: len(self.nl_params)]

    def scales(self, ctx):
        return np.concatenate([self.first.scales(ctx), self.second.scales(ctx)])[: len(self.nl_params)]

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
                     cause=self, theta=np.asarray(theta, float),
                     body=s1.body if s1.body is not None else s2.body)

    def undecidable(self, ctx):
        return self.first.undecidable(ctx) or self.second.undecidable(ctx)

    def parameters(self, theta, fitted=None):
        a, b = self._split(theta)
        return {self.first.id: self.first.parameters(a, fitted),
                self.second.id: self.second.parameters(b, fitted)}

    def n_params(self):
        return self.first.n_params() + self.second.n_params()

    def fixed_parameters(self):
        fixed = {self.first.id: self.first.fixed_parameters(), self.second.id: self.second.fixed_parameters()}
        return {k: v for k, v in fixed.items() if v}
