"""Settings of a manoeuvre (``manoeuvre=``) and the packaged manoeuvres' names.
"""

import math
from dataclasses import dataclass
from typing import List, Optional

from omegaconf import MISSING, OmegaConf, flag_override

from ..errors import ConfigError
from .values import CONF_DIR, MANOEUVRE_KINDS, user_conf_dir

__all__ = ["known_manoeuvres", "ManoeuvreConfig", "manoeuvre_config"]


def _manoeuvre_files() -> dict:
    """``{name: YAML file}`` of the named manoeuvres: the packaged ones, and
    the user's (:func:`user_conf_dir`), which replace a packaged namesake."""
    folders = [CONF_DIR / "manoeuvre"]
    user = user_conf_dir()
    if user is not None:
        folders.append(user / "manoeuvre")
    return {p.stem: p for folder in folders for p in sorted(folder.glob("*.yaml"))}


def known_manoeuvres() -> list:
    """Names of the named manoeuvres (packaged and the user's), sorted."""
    return sorted(_manoeuvre_files())


def _check_manoeuvre_names(key: str, names) -> None:
    known = known_manoeuvres()
    for name in names:
        if str(name) not in known:
            raise ConfigError(f"{key}: unknown manoeuvre '{name}'; known: {', '.join(known)}")


@dataclass
class ManoeuvreConfig:
    """An option of the ``manoeuvre`` group: the simulated training manoeuvre.

    Attributes
    ----------
    name : str
        Record name (``zigzag_20_20``, ...).
    kind : str
        One of :data:`MANOEUVRE_KINDS`.
    amplitude : float or None
        Rudder amplitude [deg], in (0, 90] (zigzag, turning).
    heading : float or None
        Heading change that reverses the rudder (zigzag, > 0) or starts the
        pull-out (turning) [deg].
    duration : float or None
        Length of the record [s], > 0.
    dt : float or None
        Sampling step [s], in (0, duration].
    schedule : list of [t_start, t_end, value_deg] or None
        Heading reference (course) or commanded rudder (rudder) segments.
    first_sign : int or None
        Sign of the first rudder deflection (zigzag, turning): 1 (the
        default) lays a positive rudder first, which turns the Mariner to
        port (``Nd < 0``); -1 turns it to starboard first, as the Marine
        Systems Simulator's ``zigzag.m`` does (its ``mariner.m`` takes the
        command with the opposite sign).
    execute : float or None
        Time [s] the first rudder command is given (zigzag, turning), in
        [0, duration); before it the rudder is held amidships. MSS
        ``zigzag.m`` lays it when ``round(t)`` reaches its
        ``t_rudderexecute``: 9.5 s for the 10 s of the thesis' call.

    None leaves the simulator's default.
    """

    name: str = MISSING
    kind: str = MISSING
    amplitude: Optional[float] = None
    heading: Optional[float] = None
    duration: Optional[float] = None
    dt: Optional[float] = None
    schedule: Optional[List[List[float]]] = None
    first_sign: Optional[int] = None
    execute: Optional[float] = None

    def __post_init__(self):
        where = f"(manoeuvre '{self.name}')"
        if self.kind not in MANOEUVRE_KINDS:
            raise ConfigError(f"manoeuvre.kind: unknown kind '{self.kind}' {where} "
                              f"(known: {', '.join(MANOEUVRE_KINDS)})")
        if self.duration is not None and not self.duration > 0:
            raise ConfigError(f"manoeuvre.duration must be positive, got {self.duration} {where}")
        if self.dt is not None and not (0 < self.dt <= (self.duration or math.inf)):
            raise ConfigError(f"manoeuvre.dt must be in (0, duration], got {self.dt} {where}")
        if self.kind in ("zigzag", "turning") and self.amplitude is not None \
                and not (0 < abs(self.amplitude) <= 90):
            raise ConfigError(f"manoeuvre.amplitude: rudder amplitude must be in (0, 90] deg, "
                              f"got {self.amplitude} {where}")
        if self.kind == "zigzag" and self.heading is not None and not self.heading > 0:
            raise ConfigError(f"manoeuvre.heading: zig-zag heading must be positive, "
                              f"got {self.heading} {where}")
        if self.first_sign is not None and self.first_sign not in (1, -1):
            raise ConfigError(f"manoeuvre.first_sign must be 1 or -1, got {self.first_sign} {where}")
        if self.execute is not None and not (0 <= self.execute < (self.duration or math.inf)):
            raise ConfigError(f"manoeuvre.execute must be in [0, duration), got {self.execute} {where}")


def manoeuvre_config(name: str) -> ManoeuvreConfig:
    """The named manoeuvre ``manoeuvre/<name>.yaml`` (the user's, else the packaged one), checked.

    Raises :class:`ConfigError` for an unknown name (listing the known ones)
    or a file whose values are impossible.
    """
    path = _manoeuvre_files().get(name)
    if path is None:
        raise ConfigError(f"unknown manoeuvre '{name}'; known: {', '.join(known_manoeuvres())}")
    node = OmegaConf.load(path)
    with flag_override(node, "struct", False):
        node.pop("defaults", None)
    return OmegaConf.to_object(OmegaConf.merge(ManoeuvreConfig, node))
