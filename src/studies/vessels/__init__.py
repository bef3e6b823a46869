"""Vessels known to `studies`, by the names of the ``vessel=`` config group."""

from __future__ import annotations

import math

from ..errors import ConfigError
from .base import Vessel, WindParticulars
from .kvlcc2 import kvlcc2
from .kvlcc2_mmg import MMGVessel, kvlcc2_mmg
from .mariner import MARINER_COEFFICIENTS, mariner

__all__ = ["Vessel", "WindParticulars", "MARINER_COEFFICIENTS", "MMGVessel", "get_vessel", "get_mmg_vessel",
           "has_mmg_particulars", "mmg_vessel_at_speed", "known_vessels", "vessel_with_particulars",
           "PARTICULARS_TOLERANCE"]

_REGISTRY = {"mariner": mariner, "kvlcc2": kvlcc2}


def get_vessel(name: str) -> Vessel:
    """Return the vessel registered under ``name`` (e.g. ``"mariner"``)."""
    try:
        return _REGISTRY[name]()
    except KeyError:
        raise ConfigError(f"unknown vessel '{name}'; known: {', '.join(sorted(_REGISTRY))}") from None


def known_vessels() -> tuple[str, ...]:
    """Names of the registered vessels (the options of ``vessel=``)."""
    return tuple(sorted(_REGISTRY))


#: relative tolerance on length and displaced volume when particulars name a vessel
PARTICULARS_TOLERANCE = {"length": 0.02, "volume": 0.05}


def vessel_with_particulars(particulars: dict) -> str | None:
    """The registered vessel whose main dimensions are those given, or None.

    ``particulars`` holds full-scale ``length`` [m] and optionally
    ``volume`` [m^3] (e.g. from :func:`studies.data.ship_evidence`). A
    vessel matches when its length is within 2 % and, if a volume is
    given, its displaced volume (``m' 0.5 L^3``, the prime mass) within 5 %;
    None unless exactly one vessel matches.
    """
    length = particulars.get("length")
    if not length:
        return None
    matches = []
    for name in _REGISTRY:
        vessel = get_vessel(name)
        if abs(length / vessel.length - 1.0) > PARTICULARS_TOLERANCE["length"]:
            continue
        volume = particulars.get("volume")
        if volume and abs(volume / (vessel.m * 0.5 * vessel.length ** 3) - 1.0) > PARTICULARS_TOLERANCE["volume"]:
            continue
        matches.append(name)
    return matches[0] if len(matches) == 1 else None


_MMG_REGISTRY = {"kvlcc2": kvlcc2_mmg}


def get_mmg_vessel(name: str, full_scale: bool = False) -> MMGVessel:
    """The MMG particulars of vessel ``name`` at model scale, or Froude scaled
    to full scale; ``ConfigError`` when the vessel has none."""
    try:
        make = _MMG_REGISTRY[name]
    except KeyError:
        raise ConfigError(f"vessel '{name}' has no MMG particulars (propeller, rudder, interaction "
                          f"factors); model=mmg knows: {', '.join(sorted(_MMG_REGISTRY))}") from None
    return make(full_scale=full_scale)


def has_mmg_particulars(name: str) -> bool:
    """Whether vessel ``name`` has MMG particulars (:func:`get_mmg_vessel`)."""
    return name in _MMG_REGISTRY


def mmg_vessel_at_speed(name: str, speed: float) -> MMGVessel:
    """The MMG particulars at model or full scale, whichever approach speed is
    nearer ``speed`` [m/s] on a log scale (records do not say their scale)."""
    model = get_mmg_vessel(name)
    full = get_mmg_vessel(name, full_scale=True)
    return min((model, full), key=lambda v: abs(math.log(max(float(speed), 1e-9) / v.speed)))
