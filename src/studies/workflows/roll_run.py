"""``studies run model=roll``: the roll-decay study behind the common command.

Inputs are checked (:func:`prepare_roll`) before the MLflow run exists; the
study itself is :func:`studies.workflows.roll.run_roll_study`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from omegaconf import OmegaConf

from ..roll.records import load_roll_decay
from ..errors import ConfigError
from ..roll.estimators import ESTIMATORS
from .settings import as_path_list

__all__ = ["RollStudy", "prepare_roll", "execute_roll", "ROLL_TERMS"]

ROLL_TERMS = ("b1", "b2", "b3", "c3")


@dataclass
class RollStudy:
    cfg: object
    data_paths: list
    validate_paths: list
    simulation_path: str | None
    terms: list
    method: str
    synthetic: dict | None
    seed: int


def prepare_roll(cfg) -> RollStudy:
    """Check the roll configuration and every input file (raises on bad input)."""
    method = str(cfg.method.name)
    if method not in ESTIMATORS:
        raise ConfigError(f"method '{method}' is not a roll-decay method; use one of "
                          f"{', '.join(sorted(ESTIMATORS))}")
    terms = [str(t) for t in cfg.model.terms]
    unknown = set(terms) - set(ROLL_TERMS)
    if unknown:
        raise ConfigError(f"model.terms: unknown roll terms {sorted(unknown)}; known: {', '.join(ROLL_TERMS)}")
    data = as_path_list(OmegaConf.select(cfg, "data.path"))
    validate = as_path_list(OmegaConf.select(cfg, "validate.path"))
    simulation = OmegaConf.select(cfg, "model.simulation_path")
    for path in data + validate + ([str(simulation)] if simulation else []):
        load_roll_decay(path)
    synthetic = None
    if not data:
        synthetic = OmegaConf.to_container(cfg.model.synthetic, resolve=True)
        if not (synthetic["omega0"] > 0 and synthetic["duration"] > 0 and 0 < synthetic["dt"] < synthetic["duration"]):
            raise ConfigError("model.synthetic: omega0, duration and dt must be positive (dt < duration)")
        if not (0 <= synthetic["noise"] < 1):
            raise ConfigError(f"model.synthetic.noise is a fraction in [0, 1), got {synthetic['noise']}")
    return RollStudy(cfg, data, validate, str(simulation) if simulation else None, terms, method,
                     synthetic, int(cfg.seed))


def execute_roll(study: RollStudy, out_dir: Path) -> dict:
    """Run the roll study into ``out_dir``; returns its metrics."""
    import numpy as np

    from .roll import run_roll_study, simulate_decay_record

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data, validate, truth = study.data_paths, study.validate_paths, None
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
    _, metrics, _ = run_roll_study(data, study.method, str(out_dir), validate or None, study.terms,
                                   study.simulation_path, truth, study.seed)
    return metrics
