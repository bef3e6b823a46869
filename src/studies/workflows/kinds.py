"""The kinds of study, chosen by the model group's ``study`` setting.

=============  =================================  ==========================================
``study``      models                             pipeline
=============  =================================  ==========================================
manoeuvring    abkowitz, symmetric, simplified,   :mod:`studies.workflows.manoeuvring`,
               simplified_li2023, mmg             :mod:`studies.workflows.mmg` (``model=mmg``),
                                                  :mod:`studies.workflows.discover`
roll_decay     roll                               :mod:`studies.roll.workflow.run`,   
                                                  :mod:`studies.roll.workflow.discover`
=============  =================================  ==========================================

Each kind imports its pipeline when it is used (a manoeuvring run does not load
the roll or discovery code, nor what they import).

A new kind is a class with the methods of
:class:`studies.workflows.protocol.StudyKind` and one entry in :data:`KINDS`,
and names the settings its runs depend on in :data:`PARAM_GROUPS` (the
run's MLflow params, :func:`logged_params`).
"""

from __future__ import annotations

from pathlib import Path

from ..config import DiscoverConfig, RunConfig
from ..errors import ConfigError
from .settings import as_path_list
from .protocol import PreparedDiscovery, PreparedRun, Recorder, StudyKind
from .vessel_choice import simulated_vessel

__all__ = ["ManoeuvringKind", "RollDecayKind", "KINDS", "kind_for", "prepare_discover",
           "execute_discover", "PARAM_GROUPS", "logged_params"]


class ManoeuvringKind:
    """Manoeuvring records of a ship (3-DOF surge, sway, yaw models)."""

    kind = "manoeuvring"

    def prepare(self, cfg: RunConfig, root: Path, record: Recorder | None = None) -> PreparedRun:
        from . import mmg as _mmg
        if _mmg.is_mmg(cfg):
            return _mmg.prepare_mmg(cfg, root, record)
        from . import manoeuvring as _manoeuvring
        return _manoeuvring.prepare(cfg, root, record)

    def prepare_discovery(self, cfg: DiscoverConfig, root: Path,
                          record: Recorder | None = None) -> PreparedDiscovery:
        from . import discover as _discover
        from . import discover_inference as _inference
        prepared = _discover.prepare_discovery(cfg, root, self, record)
        paths = as_path_list(cfg.data.path) + as_path_list(cfg.validate.path)
        contexts = ["training"] * len(as_path_list(cfg.data.path)) + ["validation"] * len(paths)
        prepared.inputs = [(p, r, c) for p, r, c in zip(paths, prepared.records, contexts)]
        if prepared.simulation is not None:
            prepared.inputs.append((cfg.simulation.path, prepared.simulation, "simulation"))
        if cfg.discover.injected:
            # the stated effect's causes and parameters checked against the baseline before anything runs
            _inference.check_injected(prepared)
        return prepared

    def discover(self, prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
        from . import discover_inference as _inference
        return _inference.execute_inference(prepared, out_dir)


class RollDecayKind:
    """Free roll decays (1-DOF roll model, Chen et al. 2019)."""

    kind = "roll_decay"

    def prepare(self, cfg: RunConfig, root: Path, record: Recorder | None = None) -> PreparedRun:
        from ..roll.workflow import run as _roll_run
        return _roll_run.prepare_roll(cfg)

    def prepare_discovery(self, cfg: DiscoverConfig, root: Path,
                          record: Recorder | None = None) -> PreparedDiscovery:
        from ..roll.records import load_roll_decay
        from ..roll.workflow import discover as _roll_discover
        prepared = _roll_discover.prepare_roll_discovery(cfg, root, self, record)
        given = ([(p, "training") for p in as_path_list(cfg.data.path)]
                 + [(p, "validation") for p in as_path_list(cfg.validate.path)]
                 + ([(cfg.simulation.path, "simulation")] if cfg.simulation.path else []))
        prepared.inputs = [(p, load_roll_decay(p), c) for p, c in given]
        return prepared

    def discover(self, prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
        from ..roll.workflow import discover as _roll_discover
        return _roll_discover.execute_roll_discovery(prepared, out_dir)


#: the kinds of study by the ``model.study`` setting
KINDS: dict[str, StudyKind] = {s.kind: s for s in (ManoeuvringKind(), RollDecayKind())}


def kind_for(cfg: RunConfig) -> StudyKind:
    """The kind of study the configuration's model belongs to."""
    try:
        return KINDS[cfg.model.study]
    except KeyError:
        raise ConfigError(f"model.study: unknown kind of study '{cfg.model.study}'; "
                          f"known: {', '.join(sorted(KINDS))}") from None


#: the top-level settings that decide what a run of each kind computes (its MLflow params)
PARAM_GROUPS = {
    "manoeuvring": ("seed", "preset", "vessel", "model", "method", "manoeuvre", "train", "wind",
                    "current", "noise", "disturbance", "objective", "data", "validate"),
    "roll_decay": ("seed", "preset", "model", "method", "data", "validate", "simulation"),
}
#: settings used only with records given in ``data.path`` (the measured-data pipeline)
MEASURED_GROUPS = ("identify", "kalman")
#: a discovery's own settings, besides those of its kind
DISCOVER_GROUPS = ("discover", "simulation")
#: report settings a run carries for ``studies report`` (presets set them) and
#: their defaults: logged only when a preset or the user changed them
REPORT_DEFAULTS = {"condition": None, "series": "method.name"}


def logged_params(cfg: RunConfig, params: dict) -> dict:
    """The part of a job's resolved configuration that its run logs as params.

    Parameters
    ----------
    cfg : RunConfig or DiscoverConfig
        The job's typed settings.
    params : dict
        The same configuration as nested plain containers.

    Returns
    -------
    dict
        The groups of :data:`PARAM_GROUPS` for the kind of prepared, plus
        :data:`MEASURED_GROUPS` when ``data.path`` is given, ``simplify``
        for ``model=simplified`` (its definition is derived with those
        settings), :data:`DISCOVER_GROUPS` for a discovery, and
        ``report.condition``/``report.series`` when they differ from their
        defaults. Bookkeeping (``verbose``, ``resume``, ``run_name``,
        ``tracking``) and the settings of other commands are left out.
    """
    groups = list(PARAM_GROUPS.get(cfg.model.study, PARAM_GROUPS["manoeuvring"]))
    if cfg.data.path:
        groups += MEASURED_GROUPS
    if str(cfg.model.name) == "simplified":
        groups.append("simplify")
    if isinstance(cfg, DiscoverConfig):
        groups += DISCOVER_GROUPS
    out = {key: params[key] for key in dict.fromkeys(groups) if key in params}
    if isinstance(out.get("vessel"), dict):
        # vessel=auto as resolved by prepare (a simulated study: the vessel it simulates)
        name = str(cfg.vessel.name) if cfg.data.path else simulated_vessel(cfg)
        out["vessel"] = {**out["vessel"], "name": name}
    report = {k: v for k, v in (params.get("report") or {}).items()
              if k in REPORT_DEFAULTS and v != REPORT_DEFAULTS[k]}
    if report:
        out["report"] = report
    return out


def prepare_discover(cfg: DiscoverConfig, root: Path, record: Recorder | None = None) -> PreparedDiscovery:
    """Check the options and load every record of a discovery (before any tracked run)."""
    return kind_for(cfg).prepare_discovery(cfg, Path(root), record)


def execute_discover(prepared: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
    """Run a prepared discovery into ``out_dir``; ``(discovery, metrics)``."""
    return prepared.kind.discover(prepared, Path(out_dir))
