"""Vessels known to `studies`, by the names of the ``vessel=`` config group."""

from __future__ import annotations

from ..errors import ConfigError
from .base import Vessel, WindParticulars
from .kvlcc2 import kvlcc2
from .mariner import MARINER_COEFFICIENTS, mariner

__all__ = ["Vessel", "WindParticulars", "MARINER_COEFFICIENTS", "get_vessel"]

_REGISTRY = {"mariner": mariner, "kvlcc2": kvlcc2}


def get_vessel(name: str) -> Vessel:
    """Return the vessel registered under ``name`` (e.g. ``"mariner"``)."""
    try:
        return _REGISTRY[name]()
    except KeyError:
        raise ConfigError(f"unknown vessel '{name}'; known: {', '.join(sorted(_REGISTRY))}") from None
