"""PAWN sensitivity of a trajectory to the model's coefficients (Li et al. 2023, 3.5).

For one DOF at a time, its coefficients are sampled uniformly within
``(1 -/+ spread)`` of the identified values (the others stay fixed), the
manoeuvre is simulated for every sample in one compiled, parallel call, and
the output is the RMS distance [m] between each sampled trajectory and the
nominal one. PAWN (Pianosi & Wagener 2015) measures by the Kolmogorov-Smirnov
distance how much fixing a coefficient changes the output's distribution;
its median over the conditioning intervals is the index T_i in [0, 1].

References
----------
Pianosi, F., Wagener, T. (2015). A simple and efficient method for global
sensitivity analysis based on cumulative distribution functions.
Environmental Modelling & Software 67, 1-11. doi:10.1016/j.envsoft.2015.01.004

Li, S. et al. (2023). Ocean Engineering 280, 114540, section 3.5, Fig. 3.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from SALib.analyze import pawn

from ..identify.ga import gene_bounds
from ..simulate import simulate_many

__all__ = ["trajectory_pawn"]


def trajectory_pawn(model, values: dict, vessel, manoeuvre, dof: str, n_samples: int = 1000,
                    spread: float = 0.2, slices: int = 10, statistic: str = "median",
                    seed: int = 0) -> pd.DataFrame:
    """PAWN indices of one DOF's coefficients on the trajectory of ``manoeuvre``.

    Returns a DataFrame indexed by coefficient with columns ``pawn`` (the
    chosen statistic of the KS distances), ``minimum``, ``mean``,
    ``median``, ``maximum`` and the number of diverged samples ``diverged``
    (their output is the largest finite one, so they count as "far").
    """
    names = model.names_of(dof)
    base = model.vector(values)
    idx = np.array([model.names.index(n) for n in names])
    low, high = gene_bounds(base[idx], spread)
    rng = np.random.default_rng(seed)
    x = rng.uniform(low, high, size=(n_samples, len(idx)))
    vectors = np.repeat(base[None, :], n_samples + 1, axis=0)
    vectors[1:, idx] = x
    _, states, diverged = simulate_many(model, vectors, vessel, manoeuvre,
                                        yaw_sign=model.rudder_yaw_sign(values))
    ref = states[0, :, 3:5]
    dist = np.sqrt(np.nanmean(np.sum((states[1:, :, 3:5] - ref[None]) ** 2, axis=2), axis=1))
    bad = ~np.isfinite(dist) | (diverged[1:] >= 0)
    if bad.any():
        dist[bad] = np.nanmax(dist[~bad]) if (~bad).any() else 1.0
    problem = {"num_vars": len(names), "names": names,
               "bounds": [[lo, hi] for lo, hi in zip(low, high)]}
    res = pawn.analyze(problem, x, dist, S=slices, seed=seed)
    table = pd.DataFrame({k: np.asarray(res[k], float) for k in ("minimum", "mean", "median", "maximum")},
                         index=names)
    table["pawn"] = table[statistic]
    table["diverged"] = float(bad.sum())
    table.index.name = "name"
    return table
