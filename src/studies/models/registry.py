"""Models by the names of the ``model=`` config group."""

from __future__ import annotations

from ..errors import ConfigError
from .abkowitz import ManoeuvringModel, abkowitz

__all__ = ["get_model"]

_REGISTRY = {"abkowitz": abkowitz}


def get_model(name: str) -> ManoeuvringModel:
    """Return the manoeuvring model registered as ``name``."""
    try:
        return _REGISTRY[name]()
    except KeyError:
        raise ConfigError(f"unknown model '{name}'; known: {', '.join(sorted(_REGISTRY))}") from None
