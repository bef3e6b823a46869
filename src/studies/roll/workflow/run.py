"""``studies run model=roll``: the roll-decay study behind the common command.

Inputs are checked (:func:`prepare_roll`) before the tracked run exists; the
study itself is :func:`studies.roll.workflow.pipeline.run_roll_study`.
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ...config import ROLL_TERMS, BayesMethod, RunConfig, settled_discrepancy
from ..records import find_particulars, load_roll_decay, record_vessel
from ..simulate import simulate_decay_record
from .pipeline import run_roll_study
from ...workflows.methods import check_method
from ...workflows.settings import as_path_list

logger = logging.getLogger(__name__)

__all__ = ["RollRun", "prepare_roll", "execute_roll", "ROLL_TERMS", "BAYES_SETTINGS"]

#: the ``method=bayes`` settings the roll posterior reads (the others, ``trajectory_*`` and
#: ``discrepancy_step``, belong to the manoeuvring posterior)
BAYES_SETTINGS = ("n_walkers", "n_samples", "burn_in", "thin", "seed", "init_scale", "moves",
                  "autocorr_correction", "discrepancy", "discrepancy_evaluations", "max_steps")


@dataclass
class RollRun:
    """A checked roll-decay configuration with its record paths.

    ``synthetic`` holds the decay to simulate when no record is given
    (``model.synthetic``: omega0 [rad/s], b1 [1/s], b2 [-], release angle
    ``phi0_deg`` [deg], ``duration``/``dt`` [s], ``noise`` as a fraction
    of the release angle).
    """

    cfg: RunConfig
    data_paths: list
    validate_paths: list
    simulation_path: str | None
    terms: list
    method: str
    synthetic: dict | None
    seed: int
    method_settings: dict | None = None
    #: every decay file read once by :func:`prepare_roll`: path -> record
    records: dict = field(default_factory=dict)


    @property
    def name(self) -> str:
        """The tracked run's name, e.g. ``nls_svm roll b1+b2 decay1 seed=0``."""
        if self.cfg.run_name:
            return str(self.cfg.run_name)
        records = ", ".join(Path(p).stem for p in self.data_paths) or "synthetic"
        return f"{self.method} roll {'+'.join(self.terms)} {records} seed={self.seed}"

    @property
    def tags(self) -> dict:
        """The tracked run's tags; for records, ``vessel`` (the ship the first
        record is of, ``unknown`` when no parameter file beside it names one)."""
        tags = {"method": self.method, "model": self.cfg.model.name, "manoeuvre": "roll_decay",
                "data": "measured" if self.data_paths else "simulated",
                "preset": self.cfg.preset or "none"}
        if self.data_paths:
            tags["vessel"] = record_vessel(find_particulars(self.data_paths[0]))[0] or "unknown"
        return tags

    @property
    def inputs(self) -> list:
        """``(path, record, context)`` of every decay file the run reads."""
        given = ([(p, "training") for p in self.data_paths] + [(p, "validation") for p in self.validate_paths]
                 + ([(self.simulation_path, "simulation")] if self.simulation_path else []))
        return [(p, self._record(p), context) for p, context in given]

    def _record(self, path) -> pd.DataFrame:
        """The record of ``path`` as :func:`prepare_roll` read it (read now when it did not)."""
        if path not in self.records:
            self.records[path] = load_roll_decay(path)
        return self.records[path]

    def execute(self, out_dir: Path) -> dict:
        """Identify and validate (:func:`execute_roll`); the metrics."""
        return execute_roll(self, out_dir)


def prepare_roll(cfg: RunConfig) -> RollRun:
    """Check the roll configuration and every input file (raises on bad input)."""
    method = str(cfg.method.name)
    check_method("roll_decay", method)
    terms = [str(t) for t in cfg.model.terms]
    data = as_path_list(cfg.data.path)
    validate = as_path_list(cfg.validate.path)
    simulation = cfg.simulation.path
    records = {path: load_roll_decay(path) for path in data + validate + ([str(simulation)] if simulation else [])}
    synthetic = None
    if not data:
        synthetic = asdict(cfg.model.synthetic)
    said = settled_discrepancy(cfg.method, bool(data))
    if said:
        logger.info(said)
    settings = ({key: getattr(cfg.method, key) for key in BAYES_SETTINGS}
                if isinstance(cfg.method, BayesMethod) else None)
    return RollRun(cfg, data, validate, str(simulation) if simulation else None, terms, method,
                     synthetic, cfg.seed, settings, records)


def execute_roll(study: RollRun, out_dir: Path) -> dict:
    """Run the roll study into ``out_dir``; returns its metrics."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data = [study._record(p) for p in study.data_paths]
    validate = [study._record(p) for p in study.validate_paths]
    simulation = study._record(study.simulation_path) if study.simulation_path else None
    truth = None
    if study.synthetic is not None:
        s = study.synthetic
        truth = {"omega0": s["omega0"], **{t: s[t] for t in study.terms}}
        params = {k: s[k] for k in ("omega0",) + ROLL_TERMS if k in s}
        sim_terms = [t for t in ROLL_TERMS if s.get(t)]
        train = out_dir / "synthetic_decay.csv"
        simulate_decay_record(params, sim_terms, s["duration"], s["dt"], np.deg2rad(s["phi0_deg"]),
                              s["noise"], study.seed, train)
        other = out_dir / "synthetic_decay_validation.csv"
        simulate_decay_record(params, sim_terms, s["duration"], s["dt"], 0.8 * np.deg2rad(s["phi0_deg"]),
                              s["noise"], study.seed + 1, other)
        data, validate = [str(train)], validate or [str(other)]
    corner_max = int(getattr(study.cfg.method, "corner_max", 8))
    _, metrics, _ = run_roll_study(data, study.method, str(out_dir), validate or None, study.terms,
                                   simulation, truth, study.seed, study.method_settings,
                                   study.cfg.validate.band_draws, study.cfg.model.holdout, corner_max)
    return metrics
