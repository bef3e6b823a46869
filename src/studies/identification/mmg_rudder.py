"""The MMG rudder's lift identified from free-running records, beside the hull.

The MMG standard method (:mod:`studies.models.mmg`) takes the rudder's normal
force as linear in the sine of its angle of attack, with the lift gradient
``f_alpha`` of an open-water formula or a captive test::

    F_N = 0.5 rho A_R U_R^2 (f_alpha sin(alpha_R) + f_alpha_2 sin(alpha_R) |sin(alpha_R)|)

with ``f_alpha_2 = 0``. A rudder of low aspect ratio has a normal force that
grows faster than that at large angles of attack (the cross-flow part of
low-aspect-ratio wing theory). A zig-zag shows it where the rudder is put
over from amidships: the ship is still going straight, so the first yaw and
sway accelerations are the rudder's forces over the inertia, and the
records with 25-35 deg of rudder show the large angles.

:func:`fit_rudder_lift` identifies ``f_alpha`` and ``f_alpha_2`` by
least squares together with the hull terms, in the hull regression of
:mod:`studies.identification.mmg_regression`: the rudder's part of the sway force
and yaw moment is linear in the two coefficients, through the published
gains ``-(1 + a_H)`` and ``-(x_R + a_H x_H)``. Sway and yaw share the two
coefficients; each DOF's rows (records and prior rows alike) are divided by
that DOF's residual RMS of the unregularised fit, so the two are weighed by
their own noise. The captive tests' rows, when the regression has them, are
left out of this fit (their hull forces were taken with the starting
rudder). The hull coefficients of this joint fit are not kept: the run
regresses the hull again, captive rows included, with the identified rudder.

Units: forces prime (over ``0.5 rho L d U^2``, moment ``0.5 rho L^2 d
U^2``), ``f_alpha`` [1/rad] as in the MMG, ``f_alpha_2`` [-]; the records
and the vessel at the same scale; rudder angle in radians, contract sign.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import block_diag

from ..models.mmg import MMGParameters, module_constants, module_forces
from .mmg_regression import MMG_CAPTIVE_RECORD

__all__ = ["rudder_lift_columns", "fit_rudder_lift", "RUDDER_LIFT_FACTORS"]

#: the rudder factors this fit identifies
RUDDER_LIFT_FACTORS = ("f_alpha", "f_alpha_2")
#: the two sway/yaw DOFs that carry the rudder's lift
_DOFS = ("Y", "N")


def rudder_lift_columns(vessel, modules: MMGParameters, records, estimates) -> dict:
    """``{dof: (k, 2)}``: the prime sway force and yaw moment of a unit ``f_alpha``
    and of a unit ``f_alpha_2``, on the hull regression's rows.

    Parameters
    ----------
    vessel : MMGVessel
        Particulars at the records' scale.
    modules : MMGParameters
        Propeller and rudder parameters (their ``f_alpha``, ``f_alpha_2`` are
        replaced by the unit values).
    records : list of DataFrame
        Records with the propeller rate ``n`` [rps].
    estimates : list of DerivativeEstimate
        The smoothed states of each record, as the hull regression uses them.
    """
    linear = module_constants(vessel, dataclasses.replace(modules, f_alpha=1.0, f_alpha_2=0.0))
    quadratic = module_constants(vessel, dataclasses.replace(modules, f_alpha=0.0, f_alpha_2=1.0))
    out = {dof: [] for dof in _DOFS}
    for rec, est in zip(records, estimates):
        s = est.states
        u, v, r, delta = (np.asarray(s[k], float) for k in ("u", "v", "r", "delta"))
        n = rec["n"].to_numpy(float)[est.index]
        scale = vessel.force_scale(np.hypot(u, v))
        _, y1, n1 = module_forces(u, v, r, delta, n, linear)
        _, y2, n2 = module_forces(u, v, r, delta, n, quadratic)
        out["Y"].append(np.column_stack([y1, y2]) / scale[:, 1:2])
        out["N"].append(np.column_stack([n1, n2]) / scale[:, 2:3])
    return {dof: np.vstack(parts) for dof, parts in out.items()}


def fit_rudder_lift(problems: dict, columns: dict, modules: MMGParameters) -> tuple[MMGParameters, dict]:
    """``(modules with the identified f_alpha, f_alpha_2, metrics)``.

    Parameters
    ----------
    problems : dict
        ``{dof: RegressionProblem}`` of the hull regression
        (:func:`studies.identification.mmg_regression.mmg_problems`), built with
        ``modules``: its forces are what is left once ``modules``' rudder is
        taken away, so the fit finds the change of the rudder's coefficients.
        The records' rows come first (``problem.n_data``), prior rows after.
    columns : dict
        :func:`rudder_lift_columns` on the same rows.
    modules : MMGParameters
        The rudder the problems were built with.

    Returns
    -------
    modules : MMGParameters
        ``modules`` with ``f_alpha`` and ``f_alpha_2`` identified.
    metrics : dict
        ``rudder/f_alpha``, ``rudder/f_alpha_2`` and their standard errors
        ``rudder/f_alpha_se``, ``rudder/f_alpha_2_se`` (from the joint fit's
        residuals, rows taken as independent: a lower bound, the rows of a
        record are correlated).
    """
    blocks = []
    for dof in _DOFS:
        problem = problems[dof]
        n_data = int(getattr(problem, "n_data", problem.theta.shape[0]))
        extra = np.zeros((problem.theta.shape[0], 2))
        extra[:n_data] = columns[dof]
        keep = np.ones(problem.theta.shape[0], bool)
        if problem.record is not None:
            keep = np.asarray(problem.record) != MMG_CAPTIVE_RECORD
        records_theta, records_y = problem.theta[:n_data], problem.y[:n_data]
        fitted = np.linalg.lstsq(records_theta, records_y, rcond=None)[0]
        sigma = float(np.sqrt(np.mean((records_y - records_theta @ fitted) ** 2)))
        blocks.append((problem.theta[keep] / sigma, extra[keep] / sigma, problem.y[keep] / sigma))
    a = np.hstack([block_diag(*[blk[0] for blk in blocks]), np.vstack([blk[1] for blk in blocks])])
    b = np.concatenate([blk[2] for blk in blocks])
    coef, *_ = np.linalg.lstsq(a, b, rcond=None)
    residual = b - a @ coef
    dof_free = max(len(b) - a.shape[1], 1)
    covariance = np.linalg.pinv(a.T @ a) * float(residual @ residual) / dof_free
    change = coef[-2:]
    se = np.sqrt(np.diag(covariance)[-2:])
    fitted = dataclasses.replace(modules, f_alpha=float(modules.f_alpha + change[0]),
                                 f_alpha_2=float(modules.f_alpha_2 + change[1]))
    metrics = {"rudder/f_alpha": fitted.f_alpha, "rudder/f_alpha_2": fitted.f_alpha_2,
               "rudder/f_alpha_se": float(se[0]), "rudder/f_alpha_2_se": float(se[1])}
    return fitted, metrics
