"""``studies discover`` on manoeuvring records: loading them, and what the
report compares besides the verdict.

:func:`prepare_discovery` checks the options and loads every record before
any tracked run exists; the discovery itself is
:func:`studies.workflows.discover_inference.execute_inference` (one
inference over the cause catalogue). :func:`departures` and
:func:`on_record_time` give the report where the replays, and another
simulator's run of a held-out manoeuvre (``simulation.path``), depart from
the measured records. Roll decays have their own discovery
(:mod:`studies.roll.workflow.discover`); the command line reaches both
through :mod:`studies.workflows.kinds`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..config import DiscoverConfig
from ..data.resample import resample
from ..discovery import diagnostics as dg
from ..discovery.fitting import kinematic_smoothing
from ..errors import ConfigError
from ..vessels import get_vessel
from .manoeuvring import get_study_model
from .measured import load_measured, load_study_records
from .settings import as_path_list
from .protocol import PreparedDiscovery, Recorder, StudyKind, gain_pct
from .vessel_choice import settle_vessel

__all__ = ["prepare_discovery", "holdout", "gain_pct", "smooth_measured", "departures", "on_record_time",
           "DEPARTURES"]



def smooth_measured(record: pd.DataFrame) -> pd.DataFrame:
    """Velocities and heading of a measured record replaced by their EKF/RTS
    estimates (kinematic pass; positions and rudder kept): discovery then
    fits every cause on consistent states, estimated once
    (:func:`studies.discovery.fitting.kinematic_smoothing`)."""
    return kinematic_smoothing(record)


def holdout(records: list, share: float) -> tuple[list, list, str]:
    """Training and validation records when no validation record is given.

    Two or more records: the last whole record is held out. One record: its
    last ``share`` is held out (replayed from its own state at the cut).
    """
    if len(records) >= 2:
        return records[:-1], records[-1:], f"held out the whole record {records[-1].attrs.get('name')}"
    rec = records[0]
    cut = int(len(rec) * (1.0 - share))
    train, val = rec.iloc[:cut].copy(), rec.iloc[cut:].copy()
    for part, suffix in ((train, "first"), (val, "last")):
        part.attrs = dict(rec.attrs)
        part.attrs["name"] = f"{rec.attrs.get('name', 'record')}_{suffix}"
    return [train], [val], f"held out the last {100 * share:.0f} % of {rec.attrs.get('name')}"


def prepare_discovery(cfg: DiscoverConfig, root: Path, kind: StudyKind,
                      record: Recorder | None = None) -> PreparedDiscovery:
    """Check the options and load every manoeuvring record (raises ConfigError/DataError)."""
    data = as_path_list(cfg.data.path)
    if not data:
        raise ConfigError("discover needs measured records: data.path=FILE or data.path=[a,b]")
    validate = as_path_list(cfg.validate.path)
    simulation = cfg.simulation.path
    vessel = get_vessel(settle_vessel(cfg, root))
    model = get_study_model(cfg, root, record)
    records, val = load_study_records(data, validate, min_samples=60, scale=cfg.data.scale)
    sim = load_measured([str(simulation)])[0] if simulation else None
    if cfg.data.derivative in ("ekf", "ekf_kinematic"):
        records = [smooth_measured(r) for r in records]
    prepared = PreparedDiscovery(cfg, kind, vessel, model, records, val, sim, records=records + val)
    if cfg.discover.splits and len(prepared.records) < 2:
        raise ConfigError("discover.splits=true needs two or more records (data.path + validate.path) "
                          "to hold out in turn")
    if not val:
        prepared.train, prepared.validation, note = holdout(records, cfg.discover.holdout)
        prepared.notes.append(note)
    return prepared


#: the baseline's largest departures kept in ``discovery.json`` and the verdict
DEPARTURES = 3

def departures(records: list, models: dict, vessel) -> pd.DataFrame:
    """Departures of every model's replays (``models``: label -> one prediction
    per record, None where there is none) from the validation records, largest
    first per model (:func:`studies.discovery.diagnostics.departures`)."""

    tables = [dg.departures(rec, pred, str(rec.attrs.get("name", "record")), vessel).assign(model=label)
              for label, predictions in models.items() for rec, pred in zip(records, predictions)
              if pred is not None]
    tables = [t for t in tables if not t.empty]
    if not tables:
        return pd.DataFrame()
    out = pd.concat(tables, ignore_index=True)
    return out.sort_values(["model", "rmse_prime"], ascending=[True, False], ignore_index=True,
                           key=lambda c: c.map(list(models).index) if c.name == "model" else c)


def on_record_time(simulation: pd.DataFrame, record: pd.DataFrame) -> pd.DataFrame | None:
    """Another simulator's run interpolated onto a measured record's time axis
    (``t``, ``x0``, ``y0``, ``psi``, ``u``, ``v``, ``r``, ``delta``); None when
    it is not a run of that manoeuvre: its time span does not cover the
    record's (to within one sample), or its largest port or starboard rudder
    angle differs from the measured one by more than 2 deg or 20 % (the
    time history may differ: a zig-zag's rudder switches when the simulated
    heading says so)."""
    ts, t = simulation["t"].to_numpy(float), record["t"].to_numpy(float)
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if ts[0] > t[0] + step or ts[-1] < t[-1] - step:
        return None
    out = resample(simulation, t, [c for c in ("x0", "y0", "psi", "u", "v", "r", "delta") if c in simulation])
    out.attrs = {}
    if "delta" in out:
        measured, run = record["delta"].to_numpy(float), out["delta"].to_numpy()
        tolerance = max(np.deg2rad(2.0), 0.2 * float(np.max(np.abs(measured))))
        if (abs(run.max() - measured.max()) > tolerance or abs(run.min() - measured.min()) > tolerance):
            return None
    return out


