"""Keyword arguments of a Python call -> the command line's typed settings.

``studies.identify(model="mmg", method="ls", wind={"speed": 12}, noise__measurement=0.01)``
composes exactly what ``studies run model=mmg method=ls wind.speed=12
noise.measurement=0.01`` composes (Hydra's compose API on the same
``conf/``, the user's ``conf/`` folder included), checked by the same
dataclasses and pre-run checks, refused with the same one-line
:class:`~studies.errors.ConfigError`:

- a config group's option is a string (``model="mmg"``, ``vessel="kvlcc2"``,
  ``experiment="kvlcc2_cross_facility"``);
- a setting of a group is a dict (``wind={"speed": 12, "direction": 45}``) or
  a double underscore, scikit-learn's way (``wind__speed=12``);
- ``overrides=["wind.speed=12"]`` takes command-line overrides as written.

Values: numbers and booleans as they are, None as ``null``, lists as lists;
strings are quoted for Hydra when they hold anything but a plain name or path.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import ConfigError

__all__ = ["overrides_of", "compose", "hydra_value", "typed_settings"]

_PLAIN = re.compile(r"^[\w./\-:+~@]+$")


def hydra_value(value) -> str:
    """A Python value as a Hydra override's value (``[a,b]``, ``null``, ``'a b'``)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, Path):
        value = str(value)
    if isinstance(value, str):
        if _PLAIN.match(value) and value.lower() not in ("null", "true", "false"):
            return value
        return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(hydra_value(v) for v in value) + "]"
    try:                                   # numpy scalars
        return hydra_value(value.item())
    except AttributeError:
        raise ConfigError(f"cannot pass a {type(value).__name__} as a setting's value") from None


def _flat(key: str, value, out: list) -> None:
    if isinstance(value, dict):
        for sub, inner in value.items():
            _flat(f"{key}.{sub}", inner, out)
    else:
        out.append(f"{key}={hydra_value(value)}")


def overrides_of(settings: dict, overrides=()) -> list[str]:
    """Hydra overrides from keyword settings (see the module's docstring), then ``overrides``."""
    out: list[str] = []
    for key, value in settings.items():
        if value is None and "__" not in key and "." not in key:
            continue                        # an argument left at its default
        _flat(key.replace("__", "."), value, out)
    return out + [str(o) for o in overrides]


def compose(command: str, settings: dict, overrides=(), root: Path | None = None):
    """``(typed settings, params)`` of one job of ``command`` (``run`` or ``discover``)."""
    from ..config_check import compose_job

    name = {"run": "config", "discover": "discover"}[command]
    return compose_job(name, overrides_of(settings, overrides), Path.cwd() if root is None else Path(root))


def typed_settings(command: str = "run", overrides=(), **settings):
    """The typed settings (:class:`~studies.config.RunConfig`,
    :class:`~studies.config.DiscoverConfig`) the command line builds for these
    keywords: ``studies.settings(model="mmg", wind__speed=12)``."""
    if command not in ("run", "discover"):
        raise ConfigError(f"command: 'run' or 'discover', got {command!r}")
    return compose(command, settings, overrides)[0]
