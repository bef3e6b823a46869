"""Trajectory objective: how well coefficient sets reproduce the training records.

Thesis eq. 3.43, ``fitness = sum over k in (u, v, r) of mean((k - k_ref)^2)``
[SI units], evaluated by replaying each training record's own rudder from
its own initial state (so it needs nothing about how the record was made),
summed over records. Many coefficient sets are simulated in one compiled,
parallel call: this is what the GA and the trajectory-likelihood posterior
call. A set whose simulation leaves the physical range gets
:data:`~studies.simulate.simulator.DIVERGED_PENALTY` instead of NaN.

References
----------
Zhu, M. (2021). MSc thesis, NTNU, eq. 3.43.
"""

from __future__ import annotations

import numpy as np

from ..models.abkowitz import ManoeuvringModel
from ..simulate.simulator import DIVERGED_PENALTY, ReplayPlan
from ..vessels.base import Vessel

__all__ = ["TrajectoryObjective"]


class TrajectoryObjective:
    """Fitness (thesis eq. 3.43) of coefficient vectors on training records.

    Parameters
    ----------
    model, vessel
        The model whose term order the vectors follow, and the vessel.
    records : list of DataFrame
        Training records (data contract).
    max_samples : int, optional
        Use at most this many samples per record for the error (the
        simulation still runs over the whole record); default all.
    """

    def __init__(self, model: ManoeuvringModel, vessel: Vessel, records, max_samples: int | None = None):
        self.model = model
        self.vessel = vessel
        self.records = list(records)
        self.max_samples = max_samples
        self._targets = []
        self._plans = None
        for rec in self.records:
            target = np.column_stack([rec["u"].to_numpy(float) - vessel.speed,
                                      rec["v"].to_numpy(float), rec["r"].to_numpy(float)])
            self._targets.append(target)

    @property
    def names(self) -> list[str]:
        return self.model.names

    def residuals_many(self, vectors: np.ndarray) -> list[np.ndarray]:
        """Per record, simulated minus recorded (du, v, r): (n_sets, n_samples, 3)."""
        out = []
        if self._plans is None:       # each record's replay prepared once (rudder on the grid)
            self._plans = [ReplayPlan(self.model, self.vessel, rec) for rec in self.records]
        for plan, target in zip(self._plans, self._targets):
            states, _ = plan.run(vectors)
            n = min(states.shape[1], target.shape[0])
            out.append(states[:, :n, :3] - target[None, :n, :])
        return out

    def fitness_many(self, vectors: np.ndarray) -> np.ndarray:
        """Eq. 3.43 per coefficient vector (rows in model term order)."""
        vectors = np.atleast_2d(np.asarray(vectors, float))
        total = np.zeros(vectors.shape[0])
        for res in self.residuals_many(vectors):
            if self.max_samples and res.shape[1] > self.max_samples:
                idx = np.linspace(0, res.shape[1] - 1, self.max_samples).astype(int)
                res = res[:, idx]
            mse = np.mean(res ** 2, axis=1).sum(axis=1)
            total += mse
        total[~np.isfinite(total)] = DIVERGED_PENALTY
        return np.minimum(total, DIVERGED_PENALTY)

    def fitness(self, values: dict) -> float:
        return float(self.fitness_many(self.model.vector(values)[None, :])[0])
