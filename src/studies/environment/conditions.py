"""Steady environmental conditions of one simulation: wind and current."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["Environment"]


@dataclass(frozen=True)
class Environment:
    """Steady wind and current.

    Attributes
    ----------
    wind_speed : float
        True wind speed V_w [m/s].
    wind_direction : float
        Direction the wind comes from, earth-fixed [rad] (0 = from north).
    current_speed : float
        Current speed [m/s].
    current_direction : float
        Direction the current flows to, earth-fixed [rad].
    """

    wind_speed: float = 0.0
    wind_direction: float = 0.0
    current_speed: float = 0.0
    current_direction: float = 0.0

    def __post_init__(self):
        for name in ("wind_speed", "current_speed"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ConfigError(f"{name.replace('_', '.', 1)} must be a finite non-negative speed in m/s, got {value}")
        for name in ("wind_direction", "current_direction"):
            if not np.isfinite(getattr(self, name)):
                raise ConfigError(f"{name.replace('_', '.', 1)} must be finite")

    def as_array(self) -> np.ndarray:
        return np.array([self.wind_speed, self.wind_direction,
                         self.current_speed, self.current_direction], dtype=float)
