"""Sobol selection of the coefficients a GA refines (thesis section 3.2.3).

The sensitivity model is the identified regression of one DOF (thesis eq.
3.5): ``f(x) = sum_i c_i x_i`` with each term's feature ``x_i`` an
independent input uniform on the unit hypercube (thesis: "range of input
variables [0, 1]", N = 5000). Constant terms (``Y0``, ``N0``) are not
inputs and get index 0. The first-order indices ``S1`` rank the
coefficients; the least sensitive ones are the least well determined by the
regression and are the GA's genes (thesis Table 4.2).

References
----------
Sobol', I.M. (2001). Global sensitivity indices for nonlinear mathematical
models and their Monte Carlo estimates. Mathematics and Computers in
Simulation 55, 271-280. doi:10.1016/S0378-4754(00)00270-6

Herman, J., Usher, W. (2017). SALib: an open-source Python library for
sensitivity analysis. JOSS 2(9). doi:10.21105/joss.00097

Zhu, M. (2021). MSc thesis, NTNU, section 3.2.3 and Table 4.2.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from SALib.analyze import sobol as sobol_analyze
from SALib.sample import sobol as sobol_sample

__all__ = ["sobol_indices", "least_sensitive"]


def _is_constant(problem, j: int) -> bool:
    col = problem.theta[:, j]
    return bool(np.all(col == col[0]))


def sobol_indices(problem, params: dict, n_samples: int = 5000, seed: int = 0) -> pd.DataFrame:
    """First- and total-order Sobol indices of one DOF's identified regression.

    Returns a DataFrame indexed by coefficient name with columns ``S1``,
    ``S1_conf``, ``ST``, ``ST_conf`` (constant terms: zeros).
    """
    names = list(problem.names)
    inputs = [j for j in range(len(names)) if not _is_constant(problem, j)]
    out = pd.DataFrame(0.0, index=names, columns=["S1", "S1_conf", "ST", "ST_conf"])
    if not inputs:
        return out
    spec = {"num_vars": len(inputs), "names": [names[j] for j in inputs],
            "bounds": [[0.0, 1.0]] * len(inputs)}
    coef = np.array([params[names[j]] for j in inputs])
    with warnings.catch_warnings():
        # SALib warns when N is not a power of two; the thesis uses N = 5000
        warnings.simplefilter("ignore")
        x = sobol_sample.sample(spec, int(n_samples), calc_second_order=False, seed=seed)
        y = x @ coef
        res = sobol_analyze.analyze(spec, y, calc_second_order=False, seed=seed)
    for k, j in enumerate(inputs):
        out.loc[names[j]] = [res["S1"][k], res["S1_conf"][k], res["ST"][k], res["ST_conf"][k]]
    return out


def least_sensitive(problems: dict, params: dict, per_dof: int = 5, n_samples: int = 5000,
                    seed: int = 0) -> tuple[list[str], pd.DataFrame]:
    """The ``per_dof`` coefficients with the lowest S1 in each DOF.

    Returns ``(names, table)``; ``table`` has one row per coefficient with
    its DOF, indices and whether it was selected.
    """
    rows = []
    selected = []
    for dof, problem in problems.items():
        table = sobol_indices(problem, params, n_samples, seed)
        table["dof"] = dof
        order = table["S1"].sort_values(kind="stable").index.tolist()
        pick = order[:per_dof]
        table["selected"] = table.index.isin(pick)
        selected += pick
        rows.append(table)
    full = pd.concat(rows)
    full.index.name = "name"
    return selected, full
