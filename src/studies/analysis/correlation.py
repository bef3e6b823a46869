"""Correlation of identified coefficients over noisy realisations (Li et al. 2023, 3.4).

The full model is identified on many realisations of the same manoeuvre that
differ only in their sensor noise; coefficients whose estimates move
together (|Spearman rho| > 0.7) cannot be told apart by the data and form a
group. Groups are cliques: every pair inside a group exceeds the threshold
(complete-linkage clustering on ``1 - |rho|``). :func:`co_membership` says
how often two coefficients share a group over bootstrap draws.

References
----------
Li, S., Wang, T., Li, G., Skulstad, R., Zhang, H. (2023). Ship maneuvering
model optimization for improved identification with less excitation. Ocean
Engineering 280, 114540, section 3.4 and Table 2.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import squareform
from scipy.stats import spearmanr

__all__ = ["spearman_matrix", "correlated_groups", "co_membership"]


def spearman_matrix(estimates: pd.DataFrame) -> pd.DataFrame:
    """Spearman rank correlation between columns (coefficients) over rows (realisations)."""
    if estimates.shape[1] == 1:
        return pd.DataFrame([[1.0]], index=estimates.columns, columns=estimates.columns)
    rho, _ = spearmanr(estimates.to_numpy(), axis=0)
    rho = np.nan_to_num(np.atleast_2d(rho), nan=0.0)
    np.fill_diagonal(rho, 1.0)
    return pd.DataFrame(rho, index=estimates.columns, columns=estimates.columns)


def correlated_groups(rho: pd.DataFrame, threshold: float = 0.7) -> list[list[str]]:
    """Groups in which every pair has ``|rho| > threshold`` (singletons included).

    Returned in the order of the matrix's columns.
    """
    names = list(rho.columns)
    if len(names) == 1:
        return [names]
    dist = 1.0 - np.abs(rho.to_numpy())
    np.fill_diagonal(dist, 0.0)
    dist = np.clip((dist + dist.T) / 2.0, 0.0, None)
    tree = linkage(squareform(dist, checks=False), method="complete")
    labels = fcluster(tree, t=1.0 - threshold - 1e-12, criterion="distance")
    groups = {}
    for name, label in zip(names, labels):
        groups.setdefault(label, []).append(name)
    return sorted(groups.values(), key=lambda g: names.index(g[0]))


def co_membership(partitions, names) -> pd.DataFrame:
    """Fraction of ``partitions`` (lists of groups, e.g. one per bootstrap
    draw) in which each pair of ``names`` shares a group [-]."""
    index = {n: i for i, n in enumerate(names)}
    together = np.zeros((len(names), len(names)))
    for groups in partitions:
        for group in groups:
            idx = [index[n] for n in group]
            together[np.ix_(idx, idx)] += 1.0
    together /= max(1, len(partitions))
    return pd.DataFrame(together, index=list(names), columns=list(names))
