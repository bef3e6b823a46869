"""Which states a set of records covers, and where other records go beyond them.

A model identified from records can be trusted only where those records
went. The states that decide it for a manoeuvring model are the drift angle
``beta = atan2(-v, u)`` [deg] (the MMG convention: positive when the ship
slides to port, ``v < 0``), the yaw rate
in the prime system ``r' = r L / U`` [-], the speed over the approach speed
``U / U0`` [-], the rudder angle ``delta`` [deg] (the data contract's sign:
positive gives a negative yaw moment) and, where a record carries the
propeller rate and thrust, the thrust loading ``C_T = T / (0.5 rho U^2
L d)`` [-]. :func:`training_ranges` gives the envelope of the training
records (a low and high quantile of each state, so that a single spike does
not widen it); :func:`beyond` says, for another record, which states leave
that envelope, for what share of the record and how far. The discovery's
``outside_training_states`` verdict and the identifiability page of a
measured identification both read it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["STATES", "state_series", "training_ranges", "beyond", "Beyond", "RANGE_QUANTILES",
           "SIGNIFICANT_SHARE", "MARGIN"]

#: the states, with their unit and what they mean
STATES = {
    "drift_deg": ("deg", "drift angle beta = atan2(-v, u)"),
    "yaw_rate_prime": ("-", "yaw rate r' = r L / U"),
    "speed_ratio": ("-", "speed U / U0"),
    "rudder_deg": ("deg", "rudder angle delta"),
    "thrust_loading": ("-", "thrust loading T / (0.5 rho U^2 L d)"),
}

#: the envelope of the training records: these quantiles of each state over all their samples
RANGE_QUANTILES = (0.005, 0.995)
#: a record goes beyond the envelope when at least this share of its samples does
SIGNIFICANT_SHARE = 0.05
#: a sample is beyond the envelope when it lies outside it by more than this share of its
#: width (a rudder held at 35.01 deg is where training at 35 deg went)
MARGIN = 0.05


def state_series(record: pd.DataFrame, vessel) -> pd.DataFrame:
    """The states of :data:`STATES` per sample of ``record`` (data-contract columns;
    ``vessel``: length L [m], approach speed U0 [m/s], draught d [m], density rho)."""
    u = record["u"].to_numpy(float)
    v = record["v"].to_numpy(float)
    r = record["r"].to_numpy(float)
    speed = np.hypot(u, v)
    safe = np.where(speed > 1e-6, speed, np.nan)
    out = {"drift_deg": np.rad2deg(np.arctan2(-v, u)),
           "yaw_rate_prime": r * vessel.length / safe,
           "speed_ratio": speed / vessel.speed,
           "rudder_deg": np.rad2deg(record["delta"].to_numpy(float))}
    if "thrust" in record:
        rho = float(getattr(vessel, "rho", 1025.0))
        draught = float(getattr(vessel, "draught", np.nan) or np.nan)
        out["thrust_loading"] = record["thrust"].to_numpy(float) / (0.5 * rho * safe ** 2 * vessel.length * draught)
    return pd.DataFrame(out, index=record.index)


def training_ranges(records: list, vessel) -> dict:
    """``{state: (low, high)}`` over every sample of ``records``: the
    :data:`RANGE_QUANTILES` of each state (a state that some record lacks is
    left out)."""
    frames = [state_series(r, vessel) for r in records]
    common = set.intersection(*(set(f.columns) for f in frames)) if frames else set()
    out = {}
    for name in STATES:
        if name not in common:
            continue
        values = np.concatenate([f[name].to_numpy(float) for f in frames])
        values = values[np.isfinite(values)]
        if len(values):
            low, high = np.quantile(values, RANGE_QUANTILES)
            out[name] = (float(low), float(high))
    return out


@dataclass
class Beyond:
    """Where one record leaves the training envelope, per state.

    Attributes
    ----------
    record : str
        The record's name.
    states : dict
        ``{state: {"training": [low, high], "record": [low, high], "share": s, "excess": e}}``
        for every state the record takes beyond the envelope (by more than
        :data:`MARGIN` of its width) on at least :data:`SIGNIFICANT_SHARE` of its samples: its own range (the same
        quantiles), the share of its samples outside, and how far its range
        reaches beyond the envelope as a fraction of the envelope's width.
    outside : np.ndarray
        Per sample: True where any of those states is outside the envelope.
    """

    record: str
    states: dict
    outside: np.ndarray

    @property
    def share(self) -> float:
        """Share of the record's samples outside the envelope in some state."""
        return float(np.mean(self.outside)) if len(self.outside) else 0.0


def beyond(record: pd.DataFrame, ranges: dict, vessel) -> Beyond:
    """Which states of ``record`` leave the envelope ``ranges`` (:func:`training_ranges`)."""
    series = state_series(record, vessel)
    states, outside = {}, np.zeros(len(record), bool)
    for name, (low, high) in ranges.items():
        if name not in series:
            continue
        values = series[name].to_numpy(float)
        slack = MARGIN * (high - low)
        out = np.isfinite(values) & ((values < low - slack) | (values > high + slack))
        share = float(np.mean(out)) if len(out) else 0.0
        if share < SIGNIFICANT_SHARE:
            continue
        finite = values[np.isfinite(values)]
        own = np.quantile(finite, RANGE_QUANTILES)
        width = max(high - low, 1e-12)
        excess = max(float(own[1] - high), float(low - own[0]), 0.0) / width
        states[name] = {"training": [low, high], "record": [float(own[0]), float(own[1])],
                        "share": share, "excess": excess}
        outside |= out
    return Beyond(str(record.attrs.get("name", "record")), states, outside)
