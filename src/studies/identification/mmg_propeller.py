"""The MMG propeller's wake fitted to measured thrust (records with a ``thrust`` column).

The MMG propeller (:mod:`studies.models.mmg`, eq. 11-17 of Yasukawa &
Yoshimura 2015) gives the thrust from the open-water curve ``K_T(J_P)`` at
the advance ratio ``J_P = u (1 - w_P) / (n D)``, with the wake fraction
changing with the drift at the propeller::

    1 - w_P = (1 - w_P0) (1 + (1 - exp(-C_1 |beta_P|)) (C_2 - 1)),   beta_P = beta - x'_P r'

Free-running tests that log the propeller thrust (HSVA's) measure it
directly. :func:`fit_wake` fits ``w_P0``, ``C_1`` and ``C_2`` (one for each
sign of ``beta_P``) by least squares on the measured thrust of every
training record that has it, so that the simulated thrust, and through it
the propeller's slipstream over the rudder, is the measured one. The
published values are the starting point; the fit is refused (published
values kept) when fewer than 200 samples carry a thrust.

Units: thrust [N], propeller rate ``n`` [rps], states of the data contract;
the records and the vessel at the same scale.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import least_squares

from ..models.mmg import MMGParameters, module_constants, thrust_normal_force

__all__ = ["WAKE_FACTORS", "fit_wake", "thrust_of"]

#: the propeller factors fitted to measured thrust, with their bounds
WAKE_FACTORS = {"wP0": (0.0, 0.8)}
#: fewest thrust samples for a fit
MIN_SAMPLES = 200


def thrust_of(record, vessel, modules: MMGParameters) -> np.ndarray:
    """The MMG propeller's thrust [N] along a record (its states and ``n``)."""
    u = record["u"].to_numpy(float)
    v = record["v"].to_numpy(float)
    r = record["r"].to_numpy(float)
    delta = record["delta"].to_numpy(float)
    speed = np.hypot(u, v)
    beta = np.arctan2(-v, u)
    rp = r * vessel.length / np.maximum(speed, 1e-9)
    k = module_constants(vessel, modules)
    thrust, _ = thrust_normal_force(u, speed, beta, rp, np.sin(delta), np.cos(delta),
                                    record["n"].to_numpy(float), k)
    return np.asarray(thrust, float)


def fit_wake(records, vessel, modules: MMGParameters) -> tuple[MMGParameters, dict]:
    """``(modules with the fitted wake, metrics)``; the modules unchanged without thrust.

    Metrics: ``propeller/<factor>`` fitted, ``propeller/thrust_rmse_pct``
    before and after (RMS of the thrust error over the mean measured
    thrust), ``propeller/thrust_samples``.
    """
    used = [r for r in records if "thrust" in r and "n" in r]
    samples = sum(len(r) for r in used)
    if samples < MIN_SAMPLES:
        return modules, {}
    measured = np.concatenate([r["thrust"].to_numpy(float) for r in used])
    finite = np.isfinite(measured)
    scale = float(np.mean(np.abs(measured[finite]))) or 1.0
    names = list(WAKE_FACTORS)
    lower = np.array([WAKE_FACTORS[n][0] for n in names])
    upper = np.array([WAKE_FACTORS[n][1] for n in names])

    def with_values(x) -> MMGParameters:
        return dataclasses.replace(modules, **dict(zip(names, (float(v) for v in x))))

    def residual(x) -> np.ndarray:
        model = np.concatenate([thrust_of(r, vessel, with_values(x)) for r in used])
        return (model - measured)[finite] / scale

    start = np.clip([getattr(modules, n) for n in names], lower + 1e-6, upper - 1e-6)
    before = float(np.sqrt(np.mean(residual(start) ** 2)))
    fit = least_squares(residual, start, bounds=(lower, upper), x_scale="jac")
    fitted = with_values(fit.x)
    metrics = {f"propeller/{n}": float(v) for n, v in zip(names, fit.x)}
    metrics.update({"propeller/thrust_rmse_pct_published": 100.0 * before,
                    "propeller/thrust_rmse_pct": 100.0 * float(np.sqrt(np.mean(fit.fun ** 2))),
                    "propeller/thrust_samples": float(finite.sum())})
    return fitted, metrics
