"""Comparing decays: prediction errors and the damping of a simulation against tests.

- :func:`mae`, :func:`rmse`: errors of a predicted roll time series against
  the measured one (Chen et al. 2019, eq. 17-18);
- :func:`replay_errors`: the one way every method's predicted decay is
  scored: the identified model simulated (RK4) over the whole record from a
  given initial state, MAE and RMSE against the record, and whether the
  replay diverged (then its errors are not numbers to average);
  :data:`STARTS` names the two initial states used, the record's own
  (``record_start``, the same for every method) and the method's own fitted
  one (``own_start``);
- :func:`compare_simulation_with_tests`: the equivalent linear damping of a
  simulated decay (e.g. potential flow) against measured decays of the same
  condition, from their decay curves (:mod:`studies.roll.decay`), and the
  damping the simulation misses.

References
----------
Chen, C., Tello Ruiz, M., Delefortrie, G., Mei, T., Vantorre, M., Lataire, E.
(2019). Parameter estimation for a ship's roll response model in shallow water
using an intelligent machine learning method. Ocean Engineering 191, 106479
(MAE and RMSE: eq. 17-18).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd

from studies.roll.decay import decay_curve, fit_decay_curve, zeta_from_curve
from studies.roll.figures import plot_simulation_vs_tests
from studies.roll.model import damping_ratio, equivalent_linear_damping
from studies.roll.simulate import predict_record

__all__ = ["mae", "rmse", "replay_errors", "ReplayErrors", "STARTS", "DIVERGED_ROLL_RAD",
           "compare_simulation_with_tests"]

#: the initial states a predicted decay is replayed from: the record's own
#: (:func:`studies.roll.records.initial_state`, the same for every method) and
#: the method's own estimate (``RollFit.meta["initial_states"]``)
STARTS = {"record_start": "from the record's initial state (angle and rate fitted to its first period), "
                          "the same for every method",
          "own_start": "from the method's own fitted initial state"}
#: [rad] a replay that leaves +-90 deg (the range a roll record may hold) has diverged
DIVERGED_ROLL_RAD = math.pi / 2


def mae(measured, predicted) -> float:
    """Mean absolute error (Chen et al. 2019, eq. 17), in the units of the input."""
    m = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    return float(np.mean(np.abs(m - p)))


def rmse(measured, predicted) -> float:
    """Root-mean-square error (Chen et al. 2019, eq. 18), in the units of the input."""
    m = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    return float(np.sqrt(np.mean((m - p) ** 2)))


@dataclass(frozen=True)
class ReplayErrors:
    """Errors of one replayed decay.

    Attributes
    ----------
    mae, rmse : float
        [rad] (eq. 17-18 of Chen et al. 2019), NaN when the replay diverged.
    diverged : bool
        The replay left +-90 deg or was not finite.
    start : (float, float)
        Initial angle [rad] and rate [rad/s] it was replayed from.
    predicted : ndarray
        The replayed roll angle [rad] at the record's times.
    """

    mae: float
    rmse: float
    diverged: bool
    start: tuple
    predicted: np.ndarray


def replay_errors(params, terms: Sequence[str], record: pd.DataFrame, start) -> ReplayErrors:
    """Replay a decay with identified coefficients from ``start`` and score it.

    The single definition of a method's prediction error: every method's
    MAE and RMSE (run metrics, :func:`studies.roll.workflow.pipeline.compare_methods`)
    come from here, so they differ only by the coefficients and the start.

    Parameters
    ----------
    params : mapping
        ``omega0`` [rad/s] and the coefficients of ``terms``.
    terms : sequence of str
        Model terms (:class:`studies.roll.model.RollModel`).
    record : DataFrame
        Prepared decay (``t`` [s] from the release, ``phi`` [rad]).
    start : (float, float)
        Initial angle [rad] and rate [rad/s] at ``record.t[0]``.

    Returns
    -------
    ReplayErrors
    """
    phi0, dphi0 = float(start[0]), float(start[1])
    pred = predict_record(params, terms, record, (phi0, dphi0))
    meas = record["phi"].to_numpy(float)
    diverged = not (np.all(np.isfinite(pred)) and np.max(np.abs(pred)) < DIVERGED_ROLL_RAD)
    if diverged:
        return ReplayErrors(float("nan"), float("nan"), True, (phi0, dphi0), pred)
    return ReplayErrors(mae(meas, pred), rmse(meas, pred), False, (phi0, dphi0), pred)


def compare_simulation_with_tests(simulation, tests: Sequence, reference_amplitude: float | None = None,
                                  terms: Sequence[str] = ("b1", "b2"),
                                  scale_note: str = "model scale",
                                  inertia: float | None = None,
                                  figure_path: str | None = None,
                                  labels: Sequence[str] | None = None) -> tuple[dict[str, float], dict]:
    """Compare the damping of a simulated decay with measured decays at one scale.

    Both must already be at the same scale (angles are scale-free; periods and
    damping coefficients with units are not, ``zeta`` is).

    Parameters
    ----------
    simulation : DataFrame
        Prepared simulated decay (``t`` [s], ``phi`` [rad]).
    tests : sequence of DataFrame
        Prepared measured decays of the same condition; their half-cycles are pooled.
    reference_amplitude : float, optional
        Amplitude [rad] at which the equivalent damping is compared. Default:
        the middle of the amplitude range covered by both.
    terms : sequence of str
        Damping terms of the decay-curve fits.
    scale_note : str
        Text for the figure saying at which scale the comparison is made.
    inertia : float, optional
        Total roll inertia [kg m^2] at the scale wanted for a dimensional
        missing damping ``missing_B44_eq`` [kg m^2/s] (= 2 omega0 I d zeta).
    figure_path : str, optional
        Where to write the PNG (decay curves and time series).
    labels : sequence of str, optional
        Names of the measured records (legend).

    Returns
    -------
    metrics : dict
        ``simulation/zeta_eq``, ``measured/zeta_eq`` (decay-curve fits at the
        reference amplitude), ``simulation/zeta_overlap``, ``measured/zeta_overlap``
        (linear fit of the half-cycles in the common amplitude range),
        ``simulation/b_eq_1_s``, ``measured/b_eq_1_s``, ``simulation/missing_zeta``
        (absolute), ``simulation/missing_damping_pct`` (of the measured),
        ``simulation/period_s``, ``measured/period_s``,
        ``reference_amplitude_deg``, and the decay-curve coefficients.
    details : dict
        Decay curves and fits, for reports.
    """
    c_sim = decay_curve(simulation)
    curves_m = [decay_curve(r) for r in tests]
    c_meas = pd.concat(curves_m, ignore_index=True)
    if len(c_sim) < 2 or len(c_meas) < 2:
        raise ValueError("too few half-cycles to compare decays")
    lo = max(c_sim["amplitude"].min(), c_meas["amplitude"].min())
    hi = min(c_sim["amplitude"].max(), c_meas["amplitude"].max())
    if reference_amplitude is None:
        reference_amplitude = 0.5 * (lo + hi) if hi > lo else float(c_meas["amplitude"].median())
    fit_sim = fit_decay_curve(c_sim, terms)
    fit_meas = fit_decay_curve(c_meas, terms)
    a = float(reference_amplitude)
    z_sim = damping_ratio(fit_sim, a)
    z_meas = damping_ratio(fit_meas, a)
    zo_sim = zeta_from_curve(c_sim, lo, hi) if hi > lo else float("nan")
    zo_meas = zeta_from_curve(c_meas, lo, hi) if hi > lo else float("nan")
    m = {
        "reference_amplitude_deg": math.degrees(a),
        "overlap_amplitude_min_deg": math.degrees(lo),
        "overlap_amplitude_max_deg": math.degrees(hi),
        "simulation/zeta_eq": z_sim,
        "measured/zeta_eq": z_meas,
        "simulation/zeta_overlap": zo_sim,
        "measured/zeta_overlap": zo_meas,
        "simulation/b_eq_1_s": equivalent_linear_damping(fit_sim, a),
        "measured/b_eq_1_s": equivalent_linear_damping(fit_meas, a),
        "simulation/period_s": 2 * math.pi / fit_sim["omega0"],
        "measured/period_s": 2 * math.pi / fit_meas["omega0"],
        "simulation/missing_zeta": z_meas - z_sim,
        "simulation/missing_damping_pct": 100.0 * (z_meas - z_sim) / z_meas,
        "simulation/missing_zeta_overlap": zo_meas - zo_sim,
        "simulation/missing_damping_overlap_pct": 100.0 * (zo_meas - zo_sim) / zo_meas,
    }
    for k, v in fit_sim.items():
        m[f"simulation/decay_curve_{k}"] = v
    for k, v in fit_meas.items():
        m[f"measured/decay_curve_{k}"] = v
    if inertia is not None:
        w0 = fit_meas["omega0"]
        m["simulation/missing_B44_eq_kgm2_s"] = 2.0 * w0 * float(inertia) * (z_meas - z_sim)
    details = {"curve_simulation": c_sim, "curves_measured": curves_m, "fit_simulation": fit_sim,
               "fit_measured": fit_meas, "reference_amplitude": a, "overlap": (lo, hi)}
    if figure_path is not None:
        plot_simulation_vs_tests(simulation, tests, details, figure_path, scale_note=scale_note,
                                 labels=labels)
    return m, details
