"""PAWN sensitivity of a trajectory to the model's coefficients (Li et al. 2023, 3.5).

For one DOF at a time, its coefficients are sampled uniformly within
``(1 -/+ spread)`` of the identified values (the others stay fixed), the
manoeuvre is simulated for every sample in one compiled, parallel call, and
the output is the RMS distance [m] between each sampled trajectory and the
nominal one. PAWN (Pianosi & Wagener 2015) measures by the Kolmogorov-Smirnov
distance how much fixing a coefficient changes the output's distribution;
its median over the conditioning intervals is the index T_i in [0, 1]
(:func:`slice_ks` computes the distances as SALib's ``pawn.analyze`` does,
vectorised, so that bootstrap draws are cheap).
:func:`subsample_pawn` recomputes the indices on a random subset of the
samples, for the stability selection of :mod:`studies.workflows.simplify`.

References
----------
Pianosi, F., Wagener, T. (2015). A simple and efficient method for global
sensitivity analysis based on cumulative distribution functions.
Environmental Modelling & Software 67, 1-11. doi:10.1016/j.envsoft.2015.01.004

Li, S. et al. (2023). Ocean Engineering 280, 114540, section 3.5, Fig. 3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..identification.ga import gene_bounds
from ..simulate import simulate_many

__all__ = ["trajectory_pawn", "PawnSamples", "pawn_samples", "pawn_indices", "subsample_pawn", "slice_ks"]


@dataclass(frozen=True)
class PawnSamples:
    """The sampled coefficients of one DOF and the output of each sample.

    Attributes
    ----------
    names : list of str
        The DOF's coefficients (model order).
    bounds : list of [low, high]
        Sampling interval of each coefficient (prime).
    x : ndarray (n_samples, n_names)
        The sampled coefficient values.
    y : ndarray (n_samples,)
        RMS distance [m] of each sampled trajectory from the nominal one;
        diverged samples carry the largest finite distance.
    diverged : int
        Number of diverged samples.
    """

    names: list
    bounds: list
    x: np.ndarray
    y: np.ndarray
    diverged: int


def pawn_samples(model, values: dict, vessel, manoeuvre, dof: str, n_samples: int = 1000,
                 spread: float = 0.2, seed: int = 0) -> PawnSamples:
    """Sample one DOF's coefficients within ``(1 -/+ spread)`` of ``values``
    and simulate ``manoeuvre`` for every sample (one compiled, parallel call)."""
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
    return PawnSamples(list(names), [[lo, hi] for lo, hi in zip(low, high)], x, dist, int(bad.sum()))


def slice_ks(x: np.ndarray, y: np.ndarray, slices: int = 10) -> np.ndarray:
    """Kolmogorov-Smirnov distances between the conditional and the
    unconditional output, shape ``(slices, n_inputs)``.

    Input ``i`` is cut into ``slices`` equal-count intervals at the
    quantiles of ``x[:, i]`` (each closed below, open above, as in SALib's
    ``pawn.analyze``); NaN for an empty slice. The two-sample KS statistic
    is evaluated at every output value, as ``scipy.stats.ks_2samp`` does.
    """
    y = np.asarray(y, float)
    order = np.sort(y)
    f_all = np.searchsorted(order, order, side="right") / len(order)
    edges = np.nanquantile(x, np.arange(0, 1 + 1.0 / slices, 1.0 / slices)[: slices + 1], axis=0)
    out = np.full((slices, x.shape[1]), np.nan)
    for i in range(x.shape[1]):
        for k in range(slices):
            part = np.sort(y[(x[:, i] >= edges[k, i]) & (x[:, i] < edges[k + 1, i])])
            if len(part):
                f_part = np.searchsorted(part, order, side="right") / len(part)
                out[k, i] = np.max(np.abs(f_part - f_all))
    return out


def pawn_indices(samples: PawnSamples, rows=None, slices: int = 10,
                 statistic: str = "median") -> pd.DataFrame:
    """PAWN indices of ``samples`` (or of its ``rows``, e.g. a bootstrap draw).

    Returns a DataFrame indexed by coefficient with columns ``minimum``,
    ``mean``, ``median``, ``maximum`` (of the KS distances over the
    conditioning slices), ``pawn`` (the chosen ``statistic``) and
    ``diverged`` (diverged samples of the whole set).
    """
    x, y = (samples.x, samples.y) if rows is None else (samples.x[rows], samples.y[rows])
    ks = slice_ks(x, y, slices)
    with np.errstate(all="ignore"):
        res = {"minimum": np.nanmin(ks, axis=0), "mean": np.nanmean(ks, axis=0),
               "median": np.nanmedian(ks, axis=0), "maximum": np.nanmax(ks, axis=0)}
    table = pd.DataFrame(res, index=samples.names)
    table["pawn"] = table[statistic]
    table["diverged"] = float(samples.diverged)
    table.index.name = "name"
    return table


def subsample_pawn(samples: PawnSamples, rng: np.random.Generator, size: int, slices: int = 10,
                   statistic: str = "median") -> pd.Series:
    """PAWN indices of ``size`` of the samples drawn without replacement:
    one draw of a stability selection."""
    n = len(samples.y)
    rows = rng.choice(n, min(n, max(slices, int(size))), replace=False)
    return pawn_indices(samples, rows, slices, statistic)["pawn"]


def trajectory_pawn(model, values: dict, vessel, manoeuvre, dof: str, n_samples: int = 1000,
                    spread: float = 0.2, slices: int = 10, statistic: str = "median",
                    seed: int = 0) -> pd.DataFrame:
    """PAWN indices of one DOF's coefficients on the trajectory of ``manoeuvre``.

    Returns a DataFrame indexed by coefficient with columns ``pawn`` (the
    chosen statistic of the KS distances), ``minimum``, ``mean``,
    ``median``, ``maximum`` and the number of diverged samples ``diverged``
    (their output is the largest finite one, so they count as "far").
    """
    samples = pawn_samples(model, values, vessel, manoeuvre, dof, n_samples, spread, seed)
    return pawn_indices(samples, None, slices, statistic)
