"""Hydra's side: the schemas stored in its ConfigStore, the user's config folder in its search path,
the one-line explanation of a value of the wrong type, and composing settings as the command line does.
"""

from dataclasses import dataclass, field, fields, is_dataclass
from typing import List, Optional, Union, get_args, get_origin, get_type_hints

from hydra.core.config_search_path import ConfigSearchPath
from hydra.core.config_store import ConfigStore
from hydra.core.plugins import Plugins
from hydra.plugins.search_path_plugin import SearchPathPlugin
from omegaconf import OmegaConf, flag_override
from omegaconf.errors import OmegaConfBaseException

from ..errors import ConfigError
from .values import user_conf_dir
from .models import VesselConfig, ModelConfig, SimplifiedModelConfig, RollModelConfig, MMGModelConfig
from .methods import MethodConfig, SvmMethod, GaMethod, BayesMethod, SindyMethod
from .manoeuvres import ManoeuvreConfig
from .commands import RunConfig, DiscoverConfig, ReportCommandConfig, SimulateCommandConfig

__all__ = ["SCHEMAS", "UserConfigSearchPath", "register", "explain_validation_error", "compose_settings"]


def _extension(schema: type, base: type):
    """``schema`` (a subclass of ``base``) without the fields it inherits.

    Merged after a config of type ``base`` it changes that config's type to
    ``schema`` and adds (and type-checks) the new fields, leaving every node
    composed before it as it is (the chosen ``model``, ``method``, ... keep
    their own types).
    """
    node = OmegaConf.structured(schema)
    with flag_override(node, ["struct", "readonly"], [False, False]):
        for item in fields(base):
            del node[item.name]
    for key in OPEN_MAPPINGS.get(schema.__name__, ()):
        # a mapping whose keys the user names (discover.injected={current: {speed: 0.3}}): open to new keys
        OmegaConf.set_struct(OmegaConf.select(node, key), False)
    return node


#: per schema, its settings that are mappings with keys of the user's choosing
OPEN_MAPPINGS = {"DiscoverConfig": ("discover.injected",)}


#: (group, name, schema) stored by :func:`register`; a YAML extends one by
#: naming it in its ``defaults:`` list: first (before ``_self_``), except
#: ``discover_schema``, which comes after ``config`` (see :func:`_extension`)
SCHEMAS = (
    (None, "run_schema", RunConfig),
    (None, "discover_schema", lambda: _extension(DiscoverConfig, RunConfig)),
    (None, "report_schema", ReportCommandConfig),
    (None, "simulate_schema", SimulateCommandConfig),
    ("vessel", "vessel_schema", VesselConfig),
    ("model", "model_schema", ModelConfig),
    ("model", "simplified_schema", SimplifiedModelConfig),
    ("model", "roll_schema", RollModelConfig),
    ("model", "mmg_schema", MMGModelConfig),
    ("method", "method_schema", MethodConfig),
    ("method", "svm_schema", SvmMethod),
    ("method", "ga_schema", GaMethod),
    ("method", "bayes_schema", BayesMethod),
    ("method", "sindy_schema", SindyMethod),
    ("manoeuvre", "manoeuvre_schema", ManoeuvreConfig),
)


class UserConfigSearchPath(SearchPathPlugin):
    """Hydra searches the user's config folder (:func:`user_conf_dir`) before
    the packaged ``studies/conf``: a preset, vessel or manoeuvre there is
    found by name, and one with a packaged name replaces it."""

    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        folder = user_conf_dir()
        if folder is not None:
            search_path.prepend(provider="studies-user", path=folder.as_uri())


def register() -> None:
    """Store every schema of :data:`SCHEMAS` in Hydra's ConfigStore and the
    user's config folder in its search path (idempotent)."""
    store = ConfigStore.instance()
    for group, name, node in SCHEMAS:
        store.store(group=group, name=name, node=node if is_dataclass(node) else node())
    Plugins.instance().register(UserConfigSearchPath)


_KINDS = {float: "a number", int: "an integer", bool: "true or false", str: "a string"}


def _declared_type(owner, key):
    """The type declared for field ``key`` of dataclass ``owner`` (Optional removed), or None."""
    if not (isinstance(owner, type) and is_dataclass(owner)):
        return None
    try:
        declared = get_type_hints(owner).get(key)
    except (NameError, TypeError):
        return None
    if get_origin(declared) is Union:
        members = [a for a in get_args(declared) if a is not type(None)]
        declared = members[0] if len(members) == 1 else None
    return declared


def explain_validation_error(error: BaseException) -> Optional[ConfigError]:
    """One line for a value of the wrong type refused while composing.

    ``error`` is an OmegaConf ``ValidationError`` or a Hydra error caused by
    one (its ``__cause__``). Returns e.g. ``ConfigError("wind.speed must be a
    number, got 'fast'")``, or None when the error is not about the type of
    a declared setting.
    """
    for candidate in (error, error.__cause__, getattr(error.__cause__, "__cause__", None)):
        if not isinstance(candidate, OmegaConfBaseException):
            continue
        key = getattr(candidate, "full_key", None)
        if not key:
            continue
        value = getattr(candidate, "value", None)
        if "is not Optional" in str(candidate):
            return ConfigError(f"{key} must not be null")
        declared = _declared_type(getattr(candidate, "object_type", None), getattr(candidate, "key", None))
        if declared in _KINDS:
            return ConfigError(f"{key} must be {_KINDS[declared]}, got {value!r}")
        if get_origin(declared) in (list, List):
            return ConfigError(f"{key} must be a list (written {key}=[a,b]), got {value!r}")
        if is_dataclass(declared):
            names = [item.name for item in fields(declared)]
            return ConfigError(f"{key}: is a group of settings ({', '.join(names)}), not a value; "
                               f"set one of them, e.g. {key}.{names[0]}=...")
    return None


def compose_settings(config_name: str = "config", overrides=()) -> "RunConfig":
    """The typed settings of a command, composed as the command line would.

    ``config_name`` is ``config`` (``studies run``), ``discover``,
    ``report`` or ``simulate``; ``overrides`` are Hydra overrides (``["wind.speed=12",
    "method=svm"]``). For scripts and tests; works inside an initialised
    Hydra context or alone. Raises Hydra's composition errors, or
    :class:`ConfigError` from the dataclasses' checks.
    """
    from hydra import compose, initialize_config_module
    from hydra.core.global_hydra import GlobalHydra

    if GlobalHydra.instance().is_initialized():
        cfg = compose(config_name, overrides=list(overrides))
    else:
        with initialize_config_module("studies.conf", version_base="1.3"):
            cfg = compose(config_name, overrides=list(overrides))
    return OmegaConf.to_object(cfg)
