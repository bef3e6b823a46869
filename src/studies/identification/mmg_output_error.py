"""Output-error identification for the MMG model: trajectories of the training records.

Two things live here:

:class:`MMGObjective`
    the trajectory fitness of thesis eq. 3.43 (``sum over (u, v, r) of
    mean squared error`` [SI], each training record replayed with its own
    rudder and propeller rate from its own initial state) for vectors of MMG
    hull coefficients, with the interface of
    :class:`~studies.identification.objective.TrajectoryObjective`, so the GA and
    the trajectory terms of ``method=bayes`` run on the MMG model.
:func:`refine_modules`
    the interaction factors of the propeller and rudder modules
    (:class:`~studies.models.mmg.MMGParameters`: ``epsilon``, ``kappa``,
    ``gammaR_*``, ``lR``, ``aH``, ...) enter the forces nonlinearly: they are
    fitted by output error with scipy's ``least_squares``, the hull
    coefficients re-identified by the (linear) inverse-dynamics regression
    for every trial set of factors (variable projection). The residuals are
    the replayed minus measured ``psi`` [rad], ``r L / U0``, ``(u - u_m) / U0``
    and ``v / U0`` every ``sample_s`` seconds, over the training records,
    plus a prior on the log of each factor's ratio to its prior value (a
    standard deviation of ``log_sd``).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from ..models.abkowitz import ManoeuvringModel
from ..models.mmg import MMGParameters
from ..simulate.mmg import replay_mmg
from .objective import TrajectoryObjective
from ..config import MMG_REFINABLE

__all__ = ["MMGObjective", "refine_modules", "REFINABLE"]

#: interaction factors :func:`refine_modules` may fit
REFINABLE = MMG_REFINABLE


class MMGObjective(TrajectoryObjective):
    """Trajectory fitness (thesis eq. 3.43) of MMG hull-coefficient vectors.

    :class:`~studies.identification.objective.TrajectoryObjective` with the MMG
    simulator: each record replayed with its rudder and propeller rate.

    Parameters
    ----------
    model : ManoeuvringModel
        The hull terms; vectors follow ``model.names``.
    vessel : MMGVessel
        Particulars at the records' scale.
    records : list of DataFrame
        Training records with ``n`` [rps].
    modules : MMGParameters
        Propeller and rudder parameters.
    """

    def __init__(self, model: ManoeuvringModel, vessel, records, modules: MMGParameters,
                 max_samples: int | None = None):
        super().__init__(model, vessel, records, max_samples)
        self.modules = modules

    def replay(self, values: dict, record):
        """``record`` replayed by the MMG model with its rudder and propeller rate
        (:func:`studies.simulate.mmg.replay_mmg`)."""
        return replay_mmg(self.model, values, self.vessel, record, self.modules)

    def residuals_many(self, vectors: np.ndarray) -> list[np.ndarray]:
        """Per record, replayed minus recorded ``(u, v, r)``: (n_sets, n_samples, 3); NaN
        from where a replay diverged."""
        vectors = np.atleast_2d(np.asarray(vectors, float))
        out = []
        for rec in self.records:
            target = rec[["u", "v", "r"]].to_numpy(float)
            block = np.full((vectors.shape[0], len(rec), 3), np.nan)
            for i, vec in enumerate(vectors):
                pred = self.replay(dict(zip(self.model.names, vec)), rec)
                n = min(len(pred), len(rec))
                block[i, :n] = pred[["u", "v", "r"]].to_numpy(float)[:n] - target[:n]
            out.append(block)
        return out


def _replay_residual(model, values, vessel, modules, record, sample_s: float) -> np.ndarray:
    t = record["t"].to_numpy(float)
    step = max(1, int(round(sample_s / float(np.median(np.diff(t))))))
    rows = slice(0, len(record), step)
    count = len(range(*rows.indices(len(record))))
    pred = replay_mmg(model, values, vessel, record, modules)
    if "diverged_at" in pred.attrs or len(pred) < len(record):
        return np.full(4 * count, 10.0)
    u0 = float(record["u"].iloc[0])
    scale = (1.0, vessel.length / u0, 1.0 / u0, 1.0 / u0)
    parts = [(pred[c].to_numpy(float) - record[c].to_numpy(float))[rows] * k
             for c, k in zip(("psi", "r", "u", "v"), scale)]
    return np.concatenate(parts)


def refine_modules(model: ManoeuvringModel, vessel, records, modules: MMGParameters, free,
                   fit_hull, sample_s: float = 5.0, log_sd: float = 0.3,
                   max_evaluations: int = 80) -> tuple[MMGParameters, dict, dict]:
    """Fit the interaction factors ``free`` by output error (see the module docstring).

    Parameters
    ----------
    fit_hull : callable
        ``fit_hull(modules) -> {name: value}``: the hull coefficients
        identified with those module parameters.
    free : sequence of str
        Names of :data:`REFINABLE` to fit (each as a factor on its prior value).

    Returns
    -------
    tuple
        ``(modules, hull coefficients, info)``; ``info`` has the metrics
        ``output_error/cost_before``, ``cost_after``, ``evaluations``,
        ``runtime_s`` and ``output_error/<factor>`` for each fitted factor.
    """
    free = list(free)
    unknown = [f for f in free if f not in REFINABLE]
    if unknown:
        raise ValueError(f"cannot refine {unknown}; refinable factors: {', '.join(REFINABLE)}")
    started = time.perf_counter()

    def trial(x):
        return replace(modules, **{f: getattr(modules, f) * float(np.exp(xi)) for f, xi in zip(free, x)})

    def residual(x):
        mods = trial(x)
        values = fit_hull(mods)
        parts = [_replay_residual(model, values, vessel, mods, rec, sample_s) for rec in records]
        e = np.concatenate(parts)
        return np.concatenate([e / np.sqrt(len(e)), np.asarray(x) / log_sd * 1e-2])

    x0 = np.zeros(len(free))
    before = 0.5 * float(np.sum(residual(x0) ** 2))
    if not free:
        return modules, fit_hull(modules), {}
    sol = least_squares(residual, x0, diff_step=1e-3, max_nfev=max_evaluations, x_scale=1.0)
    best = trial(sol.x) if sol.cost < before else modules
    info = {"output_error/cost_before": before, "output_error/cost_after": float(min(sol.cost, before)),
            "output_error/evaluations": float(sol.nfev),
            "output_error/runtime_s": time.perf_counter() - started}
    for f in free:
        info[f"output_error/{f}"] = float(getattr(best, f))
    return best, fit_hull(best), info
