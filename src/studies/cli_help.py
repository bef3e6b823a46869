"""``studies run --help`` (and ``discover``, ``report``, ``simulate``): every option with its
default, unit and meaning, read from the typed settings of :mod:`studies.config`.

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
    "simplify": "derive the simplified model (correlation + PAWN, Li et al. 2023) and log how",
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


def command_help(command: str) -> str:
    """The help text of ``studies <command>``."""
    lines = [f"usage: studies {command} [-m] [key=value ...]", "", PURPOSE.get(command, ""), ""]
    groups = COMMAND_GROUPS.get(command, GROUPS)
    if groups:
        lines.append("config groups (key=option):")
        for group, names in _group_options(groups).items():
            lines.append(f"  {group + '=':12s}{', '.join(names)}")
        lines += ["  each option's own settings are listed by `studies " + command +
                  " <group>=<option> --cfg job`", ""]
    lines.append("settings (key=value; default in brackets):")
    width = 100
    for key, value, doc in _options(SCHEMAS[command]):
        shown = "null" if value is None else str(value)
        head = f"  {key} [{shown}]"
        body = textwrap.wrap(doc, width - 8) or [""]
        lines.append(head)
        lines += ["        " + part for part in body if part]
    lines += ["", "-m runs a sweep (one job per combination); every key is a Hydra override.",
              "Angles in settings are degrees; in data and inside, radians."]
    return "\n".join(lines)
