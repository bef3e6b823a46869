"""Simulated roll decays: a record predicted from its initial state, synthetic records.

Both go through the one integrator of the roll equation,
:meth:`studies.roll.model.RollModel.simulate` (fixed-step RK4):

- :func:`predict_record`: the decay a model predicts for a prepared record,
  started from the record's initial state (validation, prediction errors,
  the roll causes of ``studies discover``);
- :func:`simulate_decay_record`: a synthetic free decay with optional
  measurement noise, as a data-contract CSV (``t`` [s], ``phi`` [rad]) or a
  ``DataFrame`` (tests, demos, ``studies run model=roll`` with
  ``model.synthetic``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from studies.roll.model import RollModel
from studies.roll.records import initial_state

__all__ = ["predict_record", "simulate_decay_record"]


def predict_record(params: Mapping[str, float], terms: Sequence[str], record: pd.DataFrame,
                   initial: tuple[float, float] | None = None) -> np.ndarray:
    """Simulate a record from its initial state with the identified model (RK4).

    Parameters
    ----------
    params : mapping
        Identified coefficients: ``omega0`` [rad/s] and those of ``terms``.
    terms : sequence of str
        Terms of the model (see :class:`studies.roll.model.RollModel`).
    record : DataFrame
        Prepared decay (``t`` [s] from the release, ``phi`` [rad]).
    initial : (phi0, dphi0), optional
        Initial state [rad, rad/s] at ``record.t[0]``; default from the
        record's first period (:func:`studies.roll.records.initial_state`).

    Returns
    -------
    ndarray
        Predicted roll angle [rad] at ``record.t``.
    """
    if initial is None:
        initial = initial_state(record)
    phi, _ = RollModel(tuple(terms)).simulate(params, initial[0], initial[1], record["t"].to_numpy(float))
    return phi


def simulate_decay_record(params: Mapping[str, float], terms: Sequence[str] = ("b1", "b2"),
                          duration: float = 60.0, dt: float = 0.01, phi0: float = math.radians(10.0),
                          noise: float = 0.0, seed: int = 0, path: str | None = None,
                          dphi0: float = 0.0) -> str | pd.DataFrame:
    """Simulate a free roll decay (RK4) and write it as a data-contract CSV (``t``, ``phi``).

    Parameters
    ----------
    params : mapping
        ``omega0`` [rad/s] and the coefficients of ``terms``.
    terms : sequence of str
        Model terms (see :class:`studies.roll.model.RollModel`).
    duration : float
        Record length [s].
    dt : float
        Sampling step [s].
    phi0 : float
        Release angle [rad] (the model is released from rest unless ``dphi0``).
    noise : float
        Standard deviation of additive white Gaussian measurement noise as a
        fraction of ``|phi0|`` (0.01 = "1 % noise").
    seed : int
        Seed of the noise generator.
    path : str, optional
        CSV file to write. Without it the record is returned as a DataFrame.
    dphi0 : float
        Initial roll rate [rad/s].

    Returns
    -------
    str or DataFrame
        The path written, or the record.
    """
    model = RollModel(tuple(terms))
    t = np.arange(int(round(duration / dt)) + 1) * dt
    phi, _ = model.simulate(params, phi0, dphi0, t)
    if noise:
        phi = phi + float(noise) * abs(phi0) * np.random.default_rng(seed).standard_normal(t.size)
    df = pd.DataFrame({"t": t, "phi": phi})
    if path is None:
        return df
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(path, index=False, float_format="%.10g")
    return str(path)
