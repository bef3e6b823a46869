"""Trajectory objective: how well coefficient sets reproduce the training records.

Thesis eq. 3.43, ``fitness = sum over k in (u, v, r) of mean((k - k_ref)^2)``
[SI units], summed over records. Each training record is simulated in one
of two ways (``objective.simulation``):

``replay`` (:class:`TrajectoryObjective`, the default)
    the record's own rudder replayed from its own initial state: the
    simulation sees the measured rudder, so an error of the model shows as
    the states it produces under that rudder;
``closed_loop`` (:class:`ClosedLoopObjective`)
    the record's zig-zag steered again by the model
    (:func:`~studies.simulate.manoeuvres.zigzag_of_record`: the rudder
    reversed when the simulated heading reaches the execute angle), as the
    thesis' GA code simulates it (its appendix A.4: the 20/20 zig-zag run
    by the candidate model for 4000 s): a model that turns a little faster
    reverses the rudder earlier, so small errors add up over the cycles.

Both need nothing about how the record was made. Many coefficient sets are
simulated in one compiled, parallel call: this is what the GA and the
trajectory-likelihood posterior call. A set whose simulation leaves the
physical range gets :data:`~studies.simulate.simulator.DIVERGED_PENALTY`
instead of NaN.

References
----------
Zhu, M. (2021). MSc thesis, NTNU, eq. 3.43 and appendix A.4.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from ..models.abkowitz import ManoeuvringModel
from ..simulate.manoeuvres import zigzag_of_record
from ..simulate.simulator import DIVERGED_PENALTY, ReplayPlan, record_environment, replay, simulate_many
from ..vessels.base import Vessel

__all__ = ["TrajectoryObjective", "ClosedLoopObjective", "trajectory_objective", "SIMULATIONS"]


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

    def replay(self, values: dict, record):
        """``record`` replayed with ``values`` (prime coefficients by name) from its first
        state with its own rudder (:func:`studies.simulate.simulator.replay`)."""
        return replay(self.model, values, self.vessel, record)

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


class ClosedLoopObjective(TrajectoryObjective):
    """Eq. 3.43 with each training zig-zag steered again by the model.

    Each record's zig-zag is read from the record
    (:func:`~studies.simulate.manoeuvres.zigzag_of_record`) and simulated by
    every coefficient set from the record's first state in the wind the
    record carries, the rudder reversed when the *simulated* heading
    reaches the execute angle; the velocities are compared with the record
    sample by sample (see the module docstring).

    Raises
    ------
    ConfigError
        A training record that is not a zig-zag.
    """

    def __init__(self, model: ManoeuvringModel, vessel: Vessel, records, max_samples: int | None = None):
        super().__init__(model, vessel, records, max_samples)
        self._runs = []
        for rec in self.records:
            manoeuvre = zigzag_of_record(rec)
            if manoeuvre is None:
                raise ConfigError(f"objective.simulation=closed_loop steers zig-zags again; training record "
                                  f"'{rec.attrs.get('name', 'record')}' is not a zig-zag (use replay)")
            first = rec.iloc[0]
            initial = {k: float(first[k]) for k in ("u", "v", "r", "x0", "y0", "psi", "delta")}
            self._runs.append((manoeuvre, record_environment(rec), initial))

    def residuals_many(self, vectors: np.ndarray) -> list[np.ndarray]:
        """Per record, simulated minus recorded (du, v, r): (n_sets, n_samples, 3)."""
        vectors = np.atleast_2d(np.asarray(vectors, float))
        yaw_sign = self.model.rudder_yaw_sign(self.model.as_dict(vectors[0]))
        out = []
        for (manoeuvre, environment, initial), target in zip(self._runs, self._targets):
            _, states, _ = simulate_many(self.model, vectors, self.vessel, manoeuvre, environment,
                                         yaw_sign=yaw_sign, initial=initial)
            n = min(states.shape[1], target.shape[0])
            out.append(states[:, :n, :3] - target[None, :n, :])
        return out


#: ``objective.simulation`` values and their objectives
SIMULATIONS = {"replay": TrajectoryObjective, "closed_loop": ClosedLoopObjective}


def trajectory_objective(model: ManoeuvringModel, vessel: Vessel, records,
                         simulation: str = "replay") -> TrajectoryObjective:
    """The trajectory objective of ``records`` simulated as ``simulation`` says
    (:data:`SIMULATIONS`)."""
    try:
        cls = SIMULATIONS[simulation]
    except KeyError:
        raise ConfigError(f"objective.simulation must be one of {', '.join(SIMULATIONS)}, "
                          f"got '{simulation}'") from None
    return cls(model, vessel, records)
