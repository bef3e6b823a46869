"""Reading and checking the run configuration before anything is written.

Every impossible value is refused here with a :class:`ConfigError` naming the
key, so that a bad override never creates an MLflow run.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from ..environment.conditions import Environment
from ..environment.noise import noise_level
from ..errors import ConfigError
from ..simulate.manoeuvres import Manoeuvre

__all__ = ["Settings", "read_settings", "named_manoeuvre", "as_path_list", "CONF_DIR",
           "output_path", "check_output_paths", "OUTPUT_KEYS"]

CONF_DIR = Path(__file__).resolve().parents[1] / "conf"


def _number(cfg, key: str, low: float | None = None, high: float | None = None) -> float:
    node = OmegaConf.select(cfg, key)
    if node is None:
        return 0.0
    try:
        value = float(node)
    except (TypeError, ValueError):
        raise ConfigError(f"{key} must be a number, got {node!r}") from None
    if not np.isfinite(value):
        raise ConfigError(f"{key} must be finite, got {value}")
    if low is not None and value < low:
        raise ConfigError(f"{key} must be >= {low}, got {value}")
    if high is not None and value > high:
        raise ConfigError(f"{key} must be <= {high}, got {value}")
    return value


def as_path_list(value) -> list[str]:
    """``data.path``/``validate.path``: None, one path or a list -> list of str."""
    if value is None or value == "":
        return []
    if isinstance(value, (list, tuple)) or OmegaConf.is_list(value):
        return [str(v) for v in value]
    return [str(value)]


def named_manoeuvre(name: str, overrides: dict | None = None) -> Manoeuvre:
    """The manoeuvre defined in ``conf/manoeuvre/<name>.yaml``."""
    path = CONF_DIR / "manoeuvre" / f"{name}.yaml"
    if not path.is_file():
        known = sorted(p.stem for p in (CONF_DIR / "manoeuvre").glob("*.yaml"))
        raise ConfigError(f"unknown manoeuvre '{name}'; known: {', '.join(known)}")
    cfg = OmegaConf.to_container(OmegaConf.load(path), resolve=True)
    cfg.update(overrides or {})
    return Manoeuvre.from_config(cfg)


@dataclass(frozen=True)
class Settings:
    """The checked, typed configuration of one ``studies run``."""

    environment: Environment
    validation_environment: Environment
    wind_speed_error: float
    measurement_noise: float
    bias_level: float
    process_level: float
    seed: int
    data_paths: list
    validate_paths: list
    validate_manoeuvres: list


def read_settings(cfg) -> Settings:
    """Check a composed Hydra config of ``studies run``."""
    wind_speed = _number(cfg, "wind.speed", 0.0, 100.0)
    wind_dir = np.deg2rad(_number(cfg, "wind.direction"))
    current_speed = _number(cfg, "current.speed", 0.0, 10.0)
    current_dir = np.deg2rad(_number(cfg, "current.direction"))
    env = Environment(wind_speed, wind_dir, current_speed, current_dir)
    v_speed = OmegaConf.select(cfg, "validate.wind.speed")
    v_dir = OmegaConf.select(cfg, "validate.wind.direction")
    venv = Environment(
        wind_speed if v_speed is None else _number(cfg, "validate.wind.speed", 0.0, 100.0),
        wind_dir if v_dir is None else np.deg2rad(_number(cfg, "validate.wind.direction")),
        current_speed, current_dir)
    seed = OmegaConf.select(cfg, "seed")
    try:
        seed = int(seed)
    except (TypeError, ValueError):
        raise ConfigError(f"seed must be an integer, got {seed!r}") from None
    if seed < 0:
        raise ConfigError(f"seed must be non-negative, got {seed}")
    manoeuvres = OmegaConf.select(cfg, "validate.manoeuvres") or []
    if isinstance(manoeuvres, str) or not (OmegaConf.is_list(manoeuvres) or isinstance(manoeuvres, list)):
        manoeuvres = [manoeuvres]
    if OmegaConf.select(cfg, "validate.duration", default=None) is not None:
        duration = _number(cfg, "validate.duration")
        if duration <= 0:
            raise ConfigError(f"validate.duration must be positive [s], got {duration:g}")
    known = sorted(p.stem for p in (CONF_DIR / "manoeuvre").glob("*.yaml"))
    for name in manoeuvres:
        if str(name) not in known:
            raise ConfigError(f"validate.manoeuvres: unknown manoeuvre '{name}'; known: {', '.join(known)}")
    return Settings(
        environment=env,
        validation_environment=venv,
        wind_speed_error=_number(cfg, "noise.wind_speed_error", -0.99, 0.99),
        measurement_noise=_number(cfg, "noise.measurement", 0.0, 1.0),
        bias_level=noise_level(OmegaConf.select(cfg, "disturbance.level") or 0),
        process_level=noise_level(OmegaConf.select(cfg, "disturbance.process") or 0),
        seed=seed,
        data_paths=as_path_list(OmegaConf.select(cfg, "data.path")),
        validate_paths=as_path_list(OmegaConf.select(cfg, "validate.path")),
        validate_manoeuvres=[str(m) for m in manoeuvres],
    )


# Config values naming files or directories that `studies` writes (project-relative).
OUTPUT_KEYS = ("report.dir", "simplify.output")


def output_path(value, key: str, root, *allowed) -> Path:
    """``value`` (relative to ``root``) as an absolute path, refused unless it
    lies inside ``root`` (the project directory) or one of ``allowed`` (the run
    directory): config values must not make `studies` write elsewhere."""
    text = str(value).strip()
    if not text or "\x00" in text:
        raise ConfigError(f"{key}: an empty path is not allowed")
    base = Path(root).resolve()
    path = Path(text).expanduser()
    path = (path if path.is_absolute() else base / path).resolve()
    for place in (base, *(Path(a).resolve() for a in allowed if a)):
        if path == place or place in path.parents:
            return path
    raise ConfigError(f"{key}: '{text}' is outside the project directory {base}; "
                      "give a path inside it (e.g. a relative path without '..')")


def check_output_paths(cfg, root, *allowed) -> None:
    """Refuse every :data:`OUTPUT_KEYS` value outside the project (or run) directory."""
    for key in OUTPUT_KEYS:
        value = OmegaConf.select(cfg, key, default=None)
        if value is not None:
            output_path(value, key, root, *allowed)
