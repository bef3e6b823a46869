"""What a study derives from its typed configuration before anything is written.

The values themselves are checked where they are declared
(:mod:`studies.config`); here they become the objects a study works with:
environments in radians, noise levels, the named manoeuvres of
``conf/manoeuvre/``, lists of record paths, and output paths that must lie
inside the project.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..config import RunConfig, manoeuvre_config
from ..environment.conditions import Environment
from ..environment.noise import noise_level
from ..config.paths import OUTPUT_KEYS, check_output_paths, output_path
from ..errors import ConfigError
from ..simulate.manoeuvres import Manoeuvre

__all__ = ["Settings", "read_settings", "named_manoeuvre", "as_path_list", "CONF_DIR",
           "output_path", "check_output_paths", "OUTPUT_KEYS"]

CONF_DIR = Path(__file__).resolve().parents[1] / "conf"


def as_path_list(value) -> list[str]:
    """``data.path``/``validate.path``: None, one path or a list -> list of str."""
    if value is None or value == "":
        return []
    if isinstance(value, (list, tuple)):
        return [str(v) for v in value]
    return [str(value)]


def named_manoeuvre(name: str, overrides: dict | None = None) -> Manoeuvre:
    """The manoeuvre defined in ``conf/manoeuvre/<name>.yaml`` (``overrides``
    replace its settings, e.g. ``{"duration": 600.0}`` [s])."""
    given = {k: v for k, v in asdict(manoeuvre_config(name)).items() if v is not None}
    given.update(overrides or {})
    return Manoeuvre.from_config(given)


@dataclass(frozen=True)
class Settings:
    """The checked, typed configuration of one ``studies run``."""

    environment: Environment
    validation_environment: Environment
    wind_speed_error: float
    measurement_noise: float
    bias_level: float
    process_level: float
    bias_scaling: str
    data_scheme: str
    seed: int
    data_paths: list
    validate_paths: list
    validate_manoeuvres: list


def read_settings(cfg: RunConfig) -> Settings:
    """The environments, noise levels and inputs of a ``studies run`` (angles in radians)."""
    env = Environment(cfg.wind.speed, np.deg2rad(cfg.wind.direction),
                      cfg.current.speed, np.deg2rad(cfg.current.direction))
    v_wind = cfg.validate.wind
    venv = Environment(env.wind_speed if v_wind.speed is None else float(v_wind.speed),
                       env.wind_direction if v_wind.direction is None else np.deg2rad(v_wind.direction),
                       env.current_speed, env.current_direction)
    return Settings(
        environment=env,
        validation_environment=venv,
        wind_speed_error=cfg.noise.wind_speed_error,
        measurement_noise=cfg.noise.measurement,
        bias_level=noise_level(cfg.disturbance.level or 0),
        process_level=noise_level(cfg.disturbance.process or 0),
        bias_scaling=str(cfg.disturbance.scaling),
        data_scheme=str(getattr(cfg.data, "scheme", "rk4")),
        seed=cfg.seed,
        data_paths=as_path_list(cfg.data.path),
        validate_paths=as_path_list(cfg.validate.path),
        validate_manoeuvres=[str(m) for m in cfg.validate.manoeuvres],
    )


