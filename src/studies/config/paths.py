"""Where `studies` may write: output paths named in the settings stay inside the project.

Kept apart from :mod:`studies.workflows.settings` so that a command checks its
output paths before (and without) importing the numerical code.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError

__all__ = ["OUTPUT_KEYS", "output_path", "check_output_paths"]

#: config values naming files or directories that `studies` writes (project-relative).
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
    """Refuse every :data:`OUTPUT_KEYS` value of ``cfg`` (typed settings)
    outside the project (or run) directory."""
    for key in OUTPUT_KEYS:
        group, _, name = key.partition(".")
        value = getattr(getattr(cfg, group, None), name, None)
        if value is not None:
            output_path(value, key, root, *allowed)
