"""What the reproduction of Wang et al. (2021) computes: the paper's procedure run again.

The page (:mod:`studies.report.reproduction.svm_paper`) reads the runs of the
``svm_disturbance`` and ``svm_paper_clean`` presets from the store; what it
must simulate or identify beside them lives here:

- the reference model's 18 deg turning circle (:func:`reference_turn`), and
  run and read as MSS ``turncircle.m`` does (:func:`mss_reference`);
- the model averaged over a cell's trials and its turning-circle errors
  (:func:`averaged_model_errors`), with the scatter of that procedure over
  the paper's 100 trials (:func:`averaged_scatter`, a two-level bootstrap);
- the surge speed the turn and the training records reach
  (:func:`turn_speed_loss`, :func:`training_speed_loss`);
- which part of the disturbance makes an error systematic: LS re-identified
  on mirrored draws of the bias alone and of the process noise alone
  (:func:`source_errors`), and how large the bias is against the ship's own
  forces (:func:`bias_peaks`).

Errors are in per cent of the reference's characteristic; lengths in metres,
the Mariner's prime system for speeds (``u'``), rudder positive to port as
in the data contract.
"""

from __future__ import annotations

import ast
import dataclasses
from dataclasses import asdict

import numpy as np
import pandas as pd

from ...analysis.characteristics import TURNING_KEYS, mss_turncircle, steady_turn_rows, turning_geometry
from ...config import manoeuvre_config
from ...environment.noise import NOISE_LEVELS, disturbance_forces
from ...identification import build_problems
from ...identification.ls import LeastSquares
from ...identification.regression import prime_states
from ...models.abkowitz import abkowitz
from ...models.registry import get_model
from ...simulate import simulate, simulate_many
from ...simulate.manoeuvres import Manoeuvre
from ...vessels import get_vessel

__all__ = ["MANOEUVRE", "PAPER_TRIALS", "SCATTER_DRAWS", "MIN_SCATTER_TRIALS", "SCATTER_RANGE", "MSS_STEP",
           "MSS_FINAL", "MSS_EXECUTE", "SOURCE_SEEDS", "turn_manoeuvre", "reference_turn", "averaged_model_errors",
           "averaged_scatter", "mss_reference", "turn_speed_loss", "training_speed_loss", "source_errors",
           "clean_force_scale", "bias_peaks"]

#: the validation manoeuvre of Table 4
MANOEUVRE = "turning_18"
#: trials per case in the paper (section 4.3)
PAPER_TRIALS = 100
#: bootstrap draws of the averaged model, and the fewest trials a cell needs for them
SCATTER_DRAWS = 100
MIN_SCATTER_TRIALS = 5
#: the share of the draws inside the scatter range (5-95 %)
SCATTER_RANGE = (5.0, 95.0)


def turn_manoeuvre(duration: float | None = None) -> Manoeuvre:
    """Table 4's 18 deg turning circle (:data:`MANOEUVRE`), ``duration`` [s] when a run changed it."""
    given = {k: v for k, v in asdict(manoeuvre_config(MANOEUVRE)).items() if v is not None}
    if duration:
        given["duration"] = float(duration)
    return Manoeuvre.from_config(given)


def averaged_model_errors(coefficients: pd.DataFrame, model_name: str, vessel_name: str, manoeuvre: Manoeuvre,
                          reference, draws: int | None = None) -> tuple[dict, pd.DataFrame]:
    """The paper's procedure for one cell: the mean of each coefficient over
    the cell's trials (``coefficients``: one column per trial, indexed by the
    coefficient's name), the turning circle ``manoeuvre`` of that mean model
    and its errors [%] per characteristic against ``reference`` (the
    reference model's record of the same manoeuvre); with ``draws`` > 0 and
    at least :data:`MIN_SCATTER_TRIALS` trials the scatter of the procedure
    over :data:`PAPER_TRIALS` trials (:func:`averaged_scatter`). Returns
    ``(row, prediction)``: ``averaged`` (trials), ``diverged``, the errors,
    the scatter columns; the mean model's record."""
    draws = SCATTER_DRAWS if draws is None else draws
    mean = coefficients.mean(axis=1)
    model = get_model(model_name)
    vessel = get_vessel(vessel_name)
    prediction = simulate(model, {n: float(mean[n]) for n in model.names}, vessel, manoeuvre)
    row = {"averaged": coefficients.shape[1], "diverged": "diverged_at" in prediction.attrs}
    ref = turning_geometry(reference)
    if not row["diverged"]:
        found = turning_geometry(prediction)
        for key in TURNING_KEYS:
            row[key] = (100.0 * (found[key] - ref[key]) / ref[key]) if key in found else np.nan
    if draws and coefficients.shape[1] >= MIN_SCATTER_TRIALS:
        vectors = coefficients.reindex(list(model.names)).T.to_numpy(float)
        row.update(averaged_scatter(vectors, model, vessel, manoeuvre, ref, draws=draws))
    return row, prediction


def reference_turn(vessel_name: str, manoeuvre: Manoeuvre, vessel=None):
    vessel = vessel or get_vessel(vessel_name)
    full = abkowitz()
    return simulate(full, {n: vessel.coefficients[n] for n in full.names}, vessel, manoeuvre)


def averaged_scatter(vectors: np.ndarray, model, vessel, manoeuvre: Manoeuvre, reference: dict,
                     trials: int = PAPER_TRIALS, draws: int = SCATTER_DRAWS, seed: int = 0) -> dict:
    """The scatter of the paper's procedure as the cell's few trials can tell it: ``draws``
    times, the cell's identified models (``vectors``, one row per trial in the
    model's term order) are resampled with replacement (what the cell's own
    mean might have been: the uncertainty of a mean of few trials), then
    ``trials`` models are drawn from that resample, their coefficients
    averaged and the 18 deg turning circle of that mean model simulated (a
    two-level bootstrap: drawing the paper's 100 trials from the cell's 5
    alone would ignore the 5-trial mean's own uncertainty and come out about
    sqrt(1 + 100 / 5) = 4.6 times too narrow). Per characteristic the 5 and
    95 % quantiles of its error [%] against ``reference``
    (``<key>/scatter_lo``, ``/scatter_hi``), ``scatter_draws`` the draws
    whose mean model turned far enough and ``scatter_trials`` the trials
    averaged."""
    rng = np.random.default_rng(seed)
    n = len(vectors)
    outer = rng.integers(0, n, size=(draws, n))
    picks = np.take_along_axis(outer, rng.integers(0, n, size=(draws, trials)), axis=1)
    means = vectors[picks].mean(axis=1)
    sign = model.rudder_yaw_sign(dict(zip(model.names, vectors.mean(axis=0))))
    t, states, diverged = simulate_many(model, means, vessel, manoeuvre, yaw_sign=sign)
    found = []
    for k in range(draws):
        if diverged[k] >= 0:
            continue
        s = states[k]
        record = pd.DataFrame({"t": t, "x0": s[:, 3], "y0": s[:, 4], "psi": s[:, 5], "u": vessel.speed + s[:, 0],
                               "v": s[:, 1], "r": s[:, 2], "delta": s[:, 6]})
        g = turning_geometry(record)
        if all(key in g for key in TURNING_KEYS):
            found.append([100.0 * (g[key] - reference[key]) / reference[key] for key in TURNING_KEYS])
    out = {"scatter_draws": len(found), "scatter_trials": trials}
    for i, key in enumerate(TURNING_KEYS):
        values = np.array([f[i] for f in found])
        lo, hi = np.percentile(values, SCATTER_RANGE) if len(values) else (np.nan, np.nan)
        out[f"{key}/scatter_lo"], out[f"{key}/scatter_hi"] = float(lo), float(hi)
    return out


#: how MSS ``ExTurnCircle.m`` runs ``turncircle.m``: Euler steps [s] and run length [s]; the rudder
#: command time is the smallest ``t_rudderexecute`` [s] that leaves no straight run before the turn
MSS_STEP, MSS_FINAL, MSS_EXECUTE = 0.1, 700.0, 1.0


def mss_reference(vessel, side: int = 1, scheme: str = "euler", execute: float = MSS_EXECUTE,
                  step: float = MSS_STEP, rudder_rate_deg: float | None = None) -> dict:
    """The reference model's 18 deg turning circle run and read as MSS
    ``turncircle.m`` does (:func:`~studies.analysis.characteristics.mss_turncircle`):
    ``scheme`` steps of ``step`` s for :data:`MSS_FINAL` s from a straight
    start, the rudder commanded to ``side`` (+1: a positive rudder, the
    Mariner turns to port, as ``ExTurnCircle.m``'s negative ``ui``) from the
    first step at which ``round(t)`` reaches ``execute``."""
    if rudder_rate_deg is not None:
        vessel = dataclasses.replace(vessel, rudder_rate=np.deg2rad(rudder_rate_deg))
    first = min(k * step for k in range(int(execute / step) + 2) if np.floor(k * step + 0.5 + 1e-9) >= execute)
    turn = Manoeuvre("turning_18_mss", "turning", MSS_FINAL, step, 18.0, 0.0, first_sign=side,
                     execute=float(first), max_step=step)
    full = abkowitz()
    record = simulate(full, {n: vessel.coefficients[n] for n in full.names}, vessel, turn, scheme=scheme)
    return mss_turncircle(record, execute)


def turn_speed_loss() -> float:
    """Prime surge velocity u' of the reference 18 deg turn's steady phase (median)."""
    if "turn" not in _SPEED_CACHE:
        turn = turn_manoeuvre()
        record = reference_turn("mariner", turn)
        rows = steady_turn_rows(record)
        primes = prime_states(record["u"], record["v"], record["r"], record["delta"], get_vessel("mariner"))
        _SPEED_CACHE["turn"] = float(np.median(primes[rows, 0]))
    return _SPEED_CACHE["turn"]


def training_speed_loss(setup: tuple) -> float:
    """The lowest prime surge velocity u' of the set-up's clean training records."""
    try:
        names = ast.literal_eval(setup[2]) if setup[2] else []
    except (ValueError, SyntaxError):
        names = []
    lows = []
    for name in names:
        if str(name) not in _SPEED_CACHE:
            manoeuvre, _ = clean_force_scale(str(name))
            vessel = get_vessel("mariner")
            full = abkowitz()
            clean = simulate(full, {n: vessel.coefficients[n] for n in full.names}, vessel, manoeuvre)
            _SPEED_CACHE[str(name)] = float(prime_states(clean["u"], clean["v"], clean["r"], clean["delta"],
                                                         vessel)[:, 0].min())
        lows.append(_SPEED_CACHE[str(name)])
    return min(lows) if lows else np.nan


_SPEED_CACHE: dict = {}


#: pairs of mirrored draws of the bias-only and process-noise-only trials that find what makes an error
#: systematic (each pair identifies with a disturbance and with its mirror image)
SOURCE_SEEDS = 10


_SOURCE_CACHE: dict = {}


def _one_trial(setup: tuple, bias_level: int, process_level: int, seed: int, turn: Manoeuvre,
               reference: dict, sign: float = 1.0) -> dict | None:
    """Errors [%] of the 18 deg turning circle of LS identified on the
    set-up's training manoeuvres, each simulated with the given bias and
    process noise levels (eq. 12-14, the set-up's scaling) multiplied by
    ``sign`` (-1: the mirror image of the same draw), against the
    reference's; None when a simulation diverged or the turn fell short."""
    names = ast.literal_eval(setup[2]) if setup[2] else []
    vessel = get_vessel("mariner")
    full = abkowitz()
    truth = {n: vessel.coefficients[n] for n in full.names}
    rng = np.random.default_rng(seed)
    records = []
    for name in names:
        manoeuvre, scale = clean_force_scale(str(name))
        n_steps = len(manoeuvre.step_times()) - 1
        ext = sign * disturbance_forces(n_steps, manoeuvre.step, scale, NOISE_LEVELS[bias_level],
                                        NOISE_LEVELS[process_level], rng, setup[0])
        record = simulate(full, truth, vessel, manoeuvre, None, ext)
        if "diverged_at" in record.attrs:
            return None
        record.attrs["name"] = str(name)
        records.append(record)
    derivative = setup[3] if setup[3] and setup[3] != "auto" else "savgol"
    params = LeastSquares().fit(build_problems(full, vessel, records, derivative)).params
    prediction = simulate(full, params, vessel, turn)
    if "diverged_at" in prediction.attrs:
        return None
    found = turning_geometry(prediction)
    if not all(key in found for key in TURNING_KEYS):
        return None
    return {key: 100.0 * (found[key] - reference[key]) / reference[key] for key in TURNING_KEYS}


def _pair_means(setup: tuple, bias: int, noise: int, seeds: int, turn: Manoeuvre, reference: dict) -> list:
    """Per seed, the mean of the errors of a draw and of its mirror image
    (both bounded): the part of the error that does not change sign with
    the disturbance, which is what averaging over trials keeps."""
    key = (setup, bias, noise, seeds)
    if key not in _SOURCE_CACHE:
        means = []
        for s in range(seeds):
            plus = _one_trial(setup, bias, noise, 1000 + s, turn, reference)
            minus = _one_trial(setup, bias, noise, 1000 + s, turn, reference, -1.0) if plus else None
            if plus and minus:
                means.append({k: 0.5 * (plus[k] + minus[k]) for k in TURNING_KEYS})
        _SOURCE_CACHE[key] = means
    return _SOURCE_CACHE[key]


def source_errors(setup: tuple, level: int, turn: Manoeuvre | None = None, seeds: int = SOURCE_SEEDS,
                  key: str = "steady_radius_m") -> tuple:
    """Errors [%] of ``key`` (default the steady turning radius) of LS
    trials on the set-up's training manoeuvres with the NL``level`` bias
    alone and with the set-up's process noise alone: per seed the mean of
    the draw and its mirror image (:func:`_pair_means`; ``seeds`` pairs each,
    pairs with a diverged trial left out)."""
    process = int(float(setup[1] or 0))
    turn = turn if turn is not None else turn_manoeuvre()
    reference = turning_geometry(reference_turn("mariner", turn))
    return (np.array([p[key] for p in _pair_means(setup, level, 0, seeds, turn, reference)]),
            np.array([p[key] for p in _pair_means(setup, 0, process, seeds, turn, reference)]))


_BIAS_CACHE: dict = {}


def clean_force_scale(name: str) -> tuple[Manoeuvre, np.ndarray]:
    """The named training manoeuvre and ``max |clean prime force|`` per DOF of
    its simulation with the Mariner's reference model (eq. 14's scale)."""
    if name not in _SCALE_CACHE:
        given = {k: v for k, v in asdict(manoeuvre_config(name)).items() if v is not None}
        manoeuvre = Manoeuvre.from_config(given)
        vessel = get_vessel("mariner")
        full = abkowitz()
        truth = {n: vessel.coefficients[n] for n in full.names}
        clean = simulate(full, truth, vessel, manoeuvre)
        primes = prime_states(clean["u"], clean["v"], clean["r"], clean["delta"], vessel)
        _SCALE_CACHE[name] = (manoeuvre, np.max(np.abs(full.forces(primes, truth)), axis=0))
    return _SCALE_CACHE[name]


_SCALE_CACHE: dict = {}


def bias_peaks(setup: tuple, level: int, draws: int = 20) -> dict:
    """``{record: peak |bias| / max|clean force|}`` (largest of sway and yaw,
    median over ``draws`` seeds) of the set-up's training manoeuvres."""
    key = (setup, level, draws)
    if key in _BIAS_CACHE:
        return _BIAS_CACHE[key]
    try:
        names = ast.literal_eval(setup[2]) if setup[2] else []
    except (ValueError, SyntaxError):
        names = []
    out = {}
    for name in names:
        manoeuvre, scale = clean_force_scale(str(name))
        n_steps = len(manoeuvre.step_times()) - 1
        peaks = []
        for seed in range(draws):
            ext = disturbance_forces(n_steps, manoeuvre.step, scale, NOISE_LEVELS[level], 0.0,
                                     np.random.default_rng(seed), setup[0])
            peaks.append(np.max(np.abs(ext[:, 1:3]), axis=0) / scale[1:3])
        out[str(name)] = float(np.max(np.median(peaks, axis=0)))
    _BIAS_CACHE[key] = out
    return out
