"""The per-phase errors of a replay: a replay that stopped short (NaN rows) is no error and no warning."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from studies.discovery.diagnostics import phase_errors


def _record(n=200):
    t = np.arange(n) * 0.5
    delta = np.where(t < 50, 0.0, np.deg2rad(20.0))
    return pd.DataFrame({"t": t, "u": 7.0 + 0.01 * t, "v": 0.1 * np.sin(t / 10), "r": 0.01 * np.cos(t / 10),
                         "delta": delta})


def test_phase_errors_of_a_replay_that_stopped_short_are_nan_without_warning():
    record = _record()
    prediction = record.copy()
    prediction.loc[:, ["u", "v", "r"]] += 0.1
    prediction.loc[record["t"] >= 50, ["u", "v", "r"]] = np.nan     # diverged when the rudder went over
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        table = phase_errors(record, prediction, "rec").set_index("phase")
    assert np.isnan(table.loc["steady helm", "rmse_u"])
    assert abs(table.loc["straight", "rmse_u"] - 0.1) < 1e-9
    assert abs(table.loc["all", "rmse_v"] - 0.1) < 1e-9       # the finite rows only
