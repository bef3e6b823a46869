"""``studies run --help`` (and ``discover``, ``simplify``, ``report``, ``simulate``): the
command's own options with their default, unit and meaning (``--help-all``: every
option in full), read from the typed settings of :mod:`studies.config`.

The text of each option is the ``Attributes`` entry of its dataclass's
docstring, so the help cannot drift from the schema; the options of each
config group (``method=``, ``model=``, ...) are the packaged YAML files.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import MISSING, fields, is_dataclass

from . import config

__all__ = ["command_help"]

#: what each command does, first line of its help
PURPOSE = {
    "run": "identify a manoeuvring (or roll-decay) model from simulated or measured data, "
           "validate it and log it to MLflow",
    "discover": "show what a model gets wrong on measured data, name the cause from the "
                "catalogue, extend the model and measure the gain",
    "simplify": "derive the simplified model (correlation + PAWN, Li et al. 2023) and log its derivation",
    "report": "write reports/<experiment>/index.md and index.html from the MLflow runs",
    "simulate": "simulate a manoeuvre with a logged or registered model (model_uri=runs:/<run id>/model "
                "or models:/<name>/<version>) or a vessel's published model, and write the files "
                "and figures of a run's validation",
}

SCHEMAS = {"run": config.RunConfig, "simplify": config.RunConfig,
           "discover": config.DiscoverConfig, "report": config.ReportCommandConfig,
           "simulate": config.SimulateCommandConfig}

#: config groups chosen by name, and where their options are packaged
GROUPS = ("vessel", "model", "method", "manoeuvre", "experiment")
#: the groups of a command, where not all of :data:`GROUPS`
COMMAND_GROUPS = {"report": (), "simulate": ("vessel", "manoeuvre")}


def _attributes(cls) -> dict:
    """``{field name: description}`` from a NumPy-style ``Attributes`` section."""
    doc = cls.__doc__ or ""
    if "Attributes" not in doc:
        return {}
    body = doc.split("Attributes", 1)[1]
    body = re.sub(r"^\s*-+\s*\n", "", body, count=1)
    out, names, text = {}, [], []
    for line in textwrap.dedent(body).splitlines():
        if line and not line.startswith(" "):
            more = [n.strip() for n in line.split(":")[0].split(",") if n.strip()]
            if names and not text:         # the list of names goes on
                names += more
                continue
            for name in names:
                out[name] = " ".join(text)
            names, text = more, []
        elif line.strip():
            text.append(line.strip())
    for name in names:
        out[name] = " ".join(text)
    return out


def _plain(text: str) -> str:
    """Docstring markup as plain text: ``x`` -> x, :data:`NAME` -> its values."""
    def role(match):
        kind, name = match.group(1), match.group(2).split(".")[-1].lstrip("~")
        value = getattr(config, name, None) if kind == "data" else None
        if isinstance(value, (tuple, list)):
            return " | ".join(str(v) for v in value)
        return name
    text = re.sub(r":(\w+):`([^`]+)`", role, text)
    return text.replace("``", "")


def _default(field):
    if field.default is not MISSING:
        return field.default
    if field.default_factory is not MISSING:
        return field.default_factory()
    return None


def _options(cls, prefix: str = "") -> list[tuple[str, object, str]]:
    """``(key, default, description)`` of every leaf setting of ``cls``."""
    docs = _attributes(cls)
    out = []
    for field in fields(cls):
        key = f"{prefix}{field.name}"
        if not prefix and field.name in GROUPS:
            continue
        value = _default(field)
        if is_dataclass(value):
            out += _options(type(value), key + ".")
        else:
            out.append((key, value, _plain(docs.get(field.name, ""))))
    return out


def _group_options(groups=GROUPS) -> dict:
    return {group: sorted(p.stem for p in (config.CONF_DIR / group).glob("*.yaml"))
            for group in groups if (config.CONF_DIR / group).is_dir()}


#: each command's own settings (key prefixes), listed first and alone by ``--help``
OWN = {
    "run": ("vessel", "model", "method", "manoeuvre", "experiment", "data.path", "validate.path",
            "validate.manoeuvres", "manoeuvre.duration", "wind.speed", "wind.direction",
            "noise.", "seed", "tracking.experiment", "tracking.register"),
    "discover": ("vessel", "model", "data.path", "validate.path", "simulation.path", "data.scale",
                 "discover.", "tracking.experiment"),
    "simplify": ("simplify.",),
    "report": ("report.", "tracking."),
    "simulate": ("model_uri", "vessel", "manoeuvre", "manoeuvre.duration", "tracking.uri"),
}


def _own(command: str, key: str) -> bool:
    return any(key == p or (p.endswith(".") and key.startswith(p)) for p in OWN.get(command, ()))


def _first_sentence(text: str) -> str:
    """The first sentence of a setting's description (the whole text is in --help-all)."""
    match = re.search(r"(?<!e\.g)(?<!i\.e)\.(\s+[A-Z]|$)", text)
    return text[:match.start() + 1] if match else text


def _setting_lines(options, width: int, short: bool) -> list[str]:
    lines = []
    for key, value, doc in options:
        shown = "null" if value is None else str(value)
        head = f"  {key} [{shown}]"
        text = _first_sentence(doc) if short else doc
        if text and len(head) + 2 + len(text) <= width:
            lines.append(f"{head}  {text}")
            continue
        lines.append(head)
        lines += ["        " + part for part in (textwrap.wrap(text, width - 8) if text else [])]
    return lines


def _composed_defaults(command: str) -> dict:
    """``{key: value}`` of the command's configuration composed with no override (the
    YAML's defaults, which a command's schema may set apart from the shared one)."""
    from hydra import compose, initialize_config_module
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf

    name = {"run": "config", "simplify": "config"}.get(command, command)
    GlobalHydra.instance().clear()
    try:
        with initialize_config_module("studies.conf", version_base="1.3"):
            cfg = OmegaConf.to_container(compose(name), resolve=False)
    except Exception:  # noqa: BLE001 - the schema's defaults then
        return {}
    finally:
        GlobalHydra.instance().clear()
    flat = {}

    def walk(node, prefix):
        for key, value in node.items():
            if isinstance(value, dict) and value:
                walk(value, f"{prefix}{key}.")
            else:
                flat[f"{prefix}{key}"] = value
    walk(cfg, "")
    return flat


def command_help(command: str, every: bool = False) -> str:
    """The help text of ``studies <command> --help``: the command's own settings
    (their first sentence, default in brackets); ``every``: ``--help-all``, every
    setting in full, the command's own first."""
    lines = [f"usage: studies {command} [-m] [key=value ...]", "", PURPOSE.get(command, ""), ""]
    groups = COMMAND_GROUPS.get(command, GROUPS)
    own_groups = [g for g in groups if _own(command, g)] if not every else list(groups)
    if own_groups:
        lines.append("config groups (key=option):")
        for group, names in _group_options(own_groups).items():
            lines.append(f"  {group + '=':12s}{', '.join(names)}")
        lines.append("")
    defaults = _composed_defaults(command)
    options = [(key, defaults.get(key, value), doc) for key, value, doc in _options(SCHEMAS[command])]
    own = [o for o in options if _own(command, o[0])]
    rest = [o for o in options if not _own(command, o[0])]
    lines.append(f"{command}'s own settings (key=value; default in brackets):")
    lines += _setting_lines(own, 110, short=not every)
    if every and rest:
        lines += ["", "the other settings (shared with the other commands):"]
        lines += _setting_lines(rest, 100, short=False)
    lines.append("")
    if not every and (rest or len(own_groups) < len(groups)):
        prefixes = sorted({key.split(".")[0] for key, _, _ in rest})
        lines.append(f"{len(rest)} more settings ({', '.join(prefixes)}) and every setting in full: "
                     f"studies {command} --help-all")
    lines += ["-m runs a sweep (one job per combination); every key is a Hydra override.",
              "Angles in settings are degrees; in data and inside, radians."]
    return "\n".join(lines)
