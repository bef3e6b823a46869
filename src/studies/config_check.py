"""Checking a command line before Hydra runs anything.

Hydra reports its own configuration errors (an unknown key, an unknown
option of a config group, an override it cannot parse) in several lines and
exits with status 1; impossible values (a negative wind speed) would only be
found inside each job of a sweep. :func:`check_arguments` composes the
configuration of every job first, with Hydra's compose API, and turns every
such error into one :class:`~studies.errors.ConfigError` line naming the key.
For a sweep (``-m``, or a preset that sets ``hydra.mode: MULTIRUN``) every
swept value is checked: all combinations when there are at most
:data:`MAX_VARIANTS`, otherwise each value of each swept key with the first
value of the others (composing takes about 0.1 s per job).

Command lines with other Hydra flags (``--cfg``, ``--help``, ``--info``, ...)
are left to Hydra unchecked.
"""

from __future__ import annotations

import difflib
import itertools
from dataclasses import dataclass
from pathlib import Path

from .errors import ConfigError, DataError

__all__ = ["Checked", "check_arguments", "verbose_requested", "MAX_VARIANTS"]

CHECKED_FLAGS = ("-m", "--multirun")
MAX_VARIANTS = 8
TRUE = ("true", "yes", "1", "on")


@dataclass
class Checked:
    """What the check learnt about the command line."""

    multirun: bool
    verbose: bool
    jobs: int | None
    #: ``tracking.uri`` of the first job (None: the environment's or the default store)
    tracking_uri: str | None = None
    #: ``tracking.experiment`` of the first job
    experiment: str | None = None
    #: ``preset`` of the first job (an experiment preset's name)
    preset: str | None = None


def verbose_requested(args: list[str]) -> bool:
    """``verbose=true`` among the overrides (the last one counts)."""
    value = None
    for arg in args:
        key, sep, rest = arg.lstrip("+").partition("=")
        if sep and key == "verbose":
            value = rest.strip().strip("'\"").lower()
    return value in TRUE


def _first_line(text) -> str:
    lines = [line.strip() for line in str(text).splitlines() if line.strip()]
    return lines[0] if lines else ""


def _keys(node, prefix: str = "") -> list[str]:
    from omegaconf import DictConfig

    out = []
    if isinstance(node, DictConfig):
        for key in node.keys():
            name = f"{prefix}{key}"
            out.append(name)
            try:
                child = node._get_node(key)
            except Exception:  # noqa: BLE001
                continue
            if isinstance(child, DictConfig):
                out.extend(_keys(child, name + "."))
    return out


class _Composer:
    """Hydra's compose API on the package's configs, with readable errors."""

    def __init__(self, config_name: str):
        self.config_name = config_name
        self._cache: dict = {}
        self._base = None

    def base(self):
        if self._base is None:
            self._base = self.compose(())
        return self._base

    def compose(self, overrides):
        from hydra import compose

        key = tuple(overrides)
        if key not in self._cache:
            try:
                self._cache[key] = compose(self.config_name, overrides=list(key),
                                           return_hydra_config=True)
            except Exception as error:  # noqa: BLE001 - turned into one line
                raise self.explain(error) from error
        return self._cache[key]

    def explain(self, error: Exception) -> ConfigError:
        """One line for a Hydra/OmegaConf composition error."""
        from hydra.errors import MissingConfigException, OverrideParseException

        from .config import explain_validation_error

        typed = explain_validation_error(error)
        if typed is not None:
            return typed
        cause = error.__cause__
        text = str(error)
        if isinstance(error, MissingConfigException):
            missing = str(getattr(error, "missing_cfg_file", "") or "")
            options = [o for o in (getattr(error, "options", None) or []) if not str(o).endswith("_schema")]
            group, _, option = missing.rpartition("/")
            if group and options:
                return ConfigError(f"{group}: unknown option '{option}'; known: {', '.join(options)}")
            return ConfigError(_first_line(text))
        if isinstance(error, OverrideParseException):
            return ConfigError(f"cannot parse the override: {_first_line(text)}")
        full_key = getattr(cause, "full_key", None)
        if cause is not None and full_key and ("not in struct" in str(cause)
                                               or "not in '" in str(cause)):
            return ConfigError(f"{full_key}: unknown key{self._suggest(full_key)}; the keys are listed "
                               "by studies <command> --help")
        if cause is not None and full_key:
            return ConfigError(f"{full_key}: {_first_line(cause)}")
        if "Ambiguous value for argument" in text:
            arg = text.split("'", 2)[1] if text.count("'") >= 2 else ""
            return ConfigError(f"{arg}: several values need -m (one job per value); "
                               "a list is written key=[a,b], a string with a comma is quoted")
        line = _first_line(text)
        if cause is not None and _first_line(cause) and _first_line(cause) not in line:
            line = f"{line} ({_first_line(cause)})"
        return ConfigError(line or type(error).__name__)

    def _suggest(self, key: str) -> str:
        try:
            known = _keys(self.base())
        except ConfigError:
            return ""
        close = difflib.get_close_matches(key, known, n=3, cutoff=0.6)
        return f" (did you mean {' or '.join(close)}?)" if close else ""


def _parse(args: list[str]):
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import OverrideParseException

    parser = OverridesParser.create()
    parsed = []
    for arg in args:
        try:
            parsed.append(parser.parse_overrides([arg])[0])
        except OverrideParseException as error:
            raise ConfigError(f"cannot parse '{arg}': {_first_line(error)}") from error
    return parsed


def _values(override) -> list[str] | None:
    """The swept values as override strings (None: not enumerable here)."""
    try:
        values = list(override.sweep_string_iterator())
    except Exception:  # noqa: BLE001 - glob/interval sweeps: left to Hydra
        return None
    key = override.get_key_element()
    return [f"{key}={v}" for v in values]


def _variants(axes: list[list[str]]) -> list[tuple[str, ...]]:
    """Override lists that cover every value of every axis."""
    total = 1
    for axis in axes:
        total *= len(axis)
    if total <= MAX_VARIANTS:
        return [tuple(v) for v in itertools.product(*axes)]
    first = [axis[0] for axis in axes]
    out = [tuple(first)]
    for i, axis in enumerate(axes):
        for value in axis[1:]:
            row = list(first)
            row[i] = value
            out.append(tuple(row))
    return out


def _sweep_axes(args: list[str], parsed, multirun: bool, command: str) -> tuple[list, int]:
    axes, jobs = [], 1
    for arg, override in zip(args, parsed):
        if override.is_sweep_override():
            key = override.get_key_element()
            if not multirun:
                raise ConfigError(f"{arg}: several values need -m (studies {command} -m {arg}) "
                                  f"to run one job per value; a list is written {key}=[a,b]")
            values = _values(override)
            if values is None:
                continue
            axes.append(values)
            jobs *= len(values)
        else:
            axes.append([arg])
    return axes, jobs


def _preset_axes(cfg, args: list[str]) -> list[list[str]]:
    """Sweeps a preset declares in ``hydra.sweeper.params`` (not overridden on the command line)."""
    from omegaconf import OmegaConf

    params = OmegaConf.select(cfg, "hydra.sweeper.params") or {}
    given = {a.split("=")[0].lstrip("+~") for a in args}
    extra = [f"{k}={v}" for k, v in params.items() if k not in given]
    if not extra:
        return []
    axes = []
    for override, arg in zip(_parse(extra), extra):
        values = _values(override) if override.is_sweep_override() else [arg]
        if values:
            axes.append(values)
    return axes


def _resolve(cfg) -> None:
    """Every interpolation of the job's config resolves (``hydra:`` ones excepted)."""
    from hydra.core.hydra_config import HydraConfig
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    try:
        HydraConfig.instance().set_config(cfg)
    except Exception:  # noqa: BLE001
        pass
    for key in cfg.keys():
        if key == "hydra":
            continue
        try:
            node = cfg._get_node(key)
            if OmegaConf.is_config(node):
                OmegaConf.to_container(node, resolve=True)
            else:
                cfg[key]  # noqa: B018 - resolves a scalar
        except OmegaConfBaseException as error:
            if "hydra" in str(error):
                continue
            where = getattr(error, "full_key", None) or key
            raise ConfigError(f"{where}: {_first_line(error)}") from error


def _structure(cfg, base, parsed) -> None:
    """A group of settings (``wind``) replaced by a plain value (``wind=3``)."""
    from omegaconf import DictConfig, OmegaConf

    for override in parsed:
        key = override.key_or_group
        if override.is_sweep_override() or override.is_hydra_override() or override.is_delete():
            continue
        before = OmegaConf.select(base, key, throw_on_missing=False)
        if isinstance(before, DictConfig):
            after = OmegaConf.select(cfg, key, throw_on_missing=False)
            if not isinstance(after, DictConfig):
                keys = list(before.keys())
                example = f"{key}.{keys[0]}=..." if keys else f"{key}.<key>=..."
                raise ConfigError(f"{key}: is a group of settings ({', '.join(map(str, keys))}), "
                                  f"not a value; set one of them, e.g. {example}")


def _appended_keys(cfg, base, parsed, composer) -> None:
    """``+key=value`` for a key the schema does not know is refused like any unknown key
    (Hydra would add it, and the run would silently ignore it); ``+group=option`` for a
    config group (``+experiment=...``) is what ``+`` is for and passes."""
    from omegaconf import OmegaConf

    for override in parsed:
        if not override.input_line.startswith("+") or override.is_hydra_override():
            continue
        key = override.key_or_group
        if OmegaConf.select(base, key, throw_on_missing=False) is not None:
            continue
        if OmegaConf.select(cfg, key, throw_on_missing=False) is not None and "." not in key and \
                not isinstance(OmegaConf.select(cfg, key, throw_on_missing=False), (int, float, str, bool)):
            continue                                  # a config group appended (+experiment=...)
        if "." not in key and _is_group(key):
            continue
        raise ConfigError(f"{key}: unknown key{composer._suggest(key)}; the keys are listed by "
                          "studies <command> --help")


def _is_group(name: str) -> bool:
    """Whether ``name`` is a config group of the packaged ``conf/`` (a folder of options)."""
    return (Path(__file__).resolve().parent / "conf" / name).is_dir()


def _typed(cfg):
    """The job's typed settings (:mod:`studies.config`): converting runs the
    checks of every dataclass. Hydra's own node is left out."""
    from omegaconf import OmegaConf, open_dict

    cfg = cfg.copy()
    with open_dict(cfg):
        cfg.pop("hydra", None)
    return OmegaConf.to_object(cfg)


def _paths_exist(settings, root: Path) -> None:
    from .workflows.settings import as_path_list

    given = [settings.data.path, settings.validate.path, settings.simulation.path]
    for value in given:
        for path in as_path_list(value):
            p = Path(path).expanduser()
            if not (p if p.is_absolute() else root / p).exists():
                raise DataError(path, "the file does not exist; check the path (relative paths "
                                f"start at the working directory {root})")


def _check_run(cfg, root: Path) -> None:
    from .workflows.methods import check_method
    from .config.paths import check_output_paths
    from .workflows.vessel_choice import settle_vessel

    settings = _typed(cfg)
    check_method(settings.model.study, settings.method.name)
    check_output_paths(settings, root)
    _paths_exist(settings, root)
    settle_vessel(settings, root)


def _check_report(cfg, root: Path) -> None:
    from .config.paths import check_output_paths

    check_output_paths(_typed(cfg), root)


def _check_simulate(cfg, root: Path) -> None:
    _typed(cfg)


CHECKS = {"config": _check_run, "discover": _check_run, "report": _check_report,
          "simulate": _check_simulate}


def check_arguments(config_name: str, args: list[str], root: Path, command: str = "run"):
    """Compose the config of every job of ``args``; :class:`Checked` or None (not checked).

    Raises :class:`ConfigError` (or :class:`DataError` for a data file that
    does not exist) with one line naming the key.
    """
    from hydra import initialize_config_module
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf

    flags = [a for a in args if a.startswith("-")]
    if any(f not in CHECKED_FLAGS for f in flags):
        return None
    overrides = [a for a in args if not a.startswith("-")]
    multirun = bool(flags)
    parsed = _parse(overrides)
    root = Path(root)
    check = CHECKS.get(config_name)
    GlobalHydra.instance().clear()
    try:
        with initialize_config_module("studies.conf", version_base="1.3"):
            from hydra.types import RunMode

            composer = _Composer(config_name)
            base = composer.base()
            axes, jobs = _sweep_axes(overrides, parsed, multirun, command)
            first = composer.compose([axis[0] for axis in axes])
            multirun = multirun or OmegaConf.select(first, "hydra.mode", default=None) == RunMode.MULTIRUN
            verbose = OmegaConf.select(first, "verbose", default=False) is True
            tracking_uri = OmegaConf.select(first, "tracking.uri", default=None)
            experiment = OmegaConf.select(first, "tracking.experiment", default=None)
            preset = OmegaConf.select(first, "preset", default=None)
            done = set()
            for n, variant in enumerate(_variants(axes)):
                cfg = first if n == 0 else composer.compose(variant)
                extra = _preset_axes(cfg, overrides) if multirun else []
                if n == 0:
                    for axis in extra:
                        jobs *= len(axis)
                for row in (_variants([[v] for v in variant] + extra) if extra else [variant]):
                    if row in done:
                        continue
                    done.add(row)
                    job_cfg = composer.compose(row)
                    _structure(job_cfg, base, parsed)
                    _appended_keys(job_cfg, base, parsed, composer)
                    _resolve(job_cfg)
                    if check is not None:
                        check(job_cfg, root)
    finally:
        GlobalHydra.instance().clear()
    return Checked(multirun=multirun, verbose=verbose, jobs=jobs if multirun else 1,
                   tracking_uri=tracking_uri, experiment=experiment, preset=preset)


def compose_job(config_name: str, overrides: list[str], root: Path):
    """One job's settings composed and checked as the command line does: ``(typed, params)``.

    ``config_name`` is ``config`` (``studies run``) or ``discover``;
    ``overrides`` are Hydra overrides of one job (no sweep). ``typed`` is the
    command's dataclass (every value checked), ``params`` the resolved
    configuration as plain containers (what a run logs). Refusals are the
    command line's own one-line :class:`ConfigError` or :class:`DataError`.
    """
    from hydra import initialize_config_module
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf, open_dict

    overrides = list(overrides)
    parsed = _parse(overrides)
    for arg, override in zip(overrides, parsed):
        if override.is_sweep_override():
            raise ConfigError(f"{arg}: one value per setting here; several values are a sweep "
                              "(studies.sweep, or studies run -m)")
    GlobalHydra.instance().clear()
    try:
        with initialize_config_module("studies.conf", version_base="1.3"):
            composer = _Composer(config_name)
            base = composer.base()
            cfg = composer.compose(overrides)
            _structure(cfg, base, parsed)
            _appended_keys(cfg, base, parsed, composer)
            _resolve(cfg)
            check = CHECKS.get(config_name)
            if check is not None:
                check(cfg, Path(root))
            job = cfg.copy()
            with open_dict(job):
                job.pop("hydra", None)
            typed = OmegaConf.to_object(job)
            params = OmegaConf.to_container(job, resolve=True)
    finally:
        GlobalHydra.instance().clear()
    return typed, params
