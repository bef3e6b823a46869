"""One job of ``studies run`` or ``studies discover``, shared by the command line and Python.

The command line and :mod:`studies.api` run the same code from typed settings
to metrics: the kind of study prepares (checks the inputs, reads or simulates
the records), a run is opened, the study executes into a folder, and the
model, metrics and files are logged. Only the run differs: the command line
always opens one in the store of ``tracking.uri``; a Python call logs to the
caller's active MLflow run, opens one when asked, or logs nothing
(:mod:`studies.api.where`). ``open_run(name, params, tags)`` is that choice:
a context manager yielding a logger with ``run_id``, ``log_records``,
``log_model``, ``log_outputs`` and ``set_tags``
(:class:`studies.runtime.tracking.RunLogger`, or ``Untracked``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

__all__ = ["IdentificationJob", "DiscoveryJob", "run_identification", "run_discovery", "run_summary", "recorder"]


@dataclass
class IdentificationJob:
    """What one identification job gave."""

    #: the prepared run (settings, vessel, model, records)
    prepared: object
    #: the flat metrics the run logged (``metrics.json``)
    metrics: dict
    #: the run's name
    name: str
    #: the MLflow run id, None when nothing was tracked
    run_id: str | None
    #: the logged model (``uri``, ``registered``), None when nothing was tracked
    logged: dict | None


@dataclass
class DiscoveryJob:
    """What one discovery job gave."""

    prepared: object
    #: the discovery as ``discovery.json`` holds it
    discovery: dict
    metrics: dict
    name: str
    run_id: str | None


def recorder(settings, root: Path):
    """``record(experiment, name, params, tags)``: a tracked run in the job's store
    (the simplified model's derivation opens its own)."""
    from ..runtime import tracking

    def record(experiment: str, name: str, params: dict, tags: dict):
        return tracking.start_run(experiment, name, settings.tracking.uri, root, params, tags)

    return record


def run_summary(metrics: dict) -> dict:
    """The metrics a run's logged model carries (validation, deviations, fitness, CPU)."""
    return {k: v for k, v in metrics.items()
            if k.startswith(("deviation/", "runtime/", "validation/", "simulation/"))
            or k.endswith(("/fitness", "/rmse_deg_record_start", "/rmse_deg_own_start", "cpu_s"))}


def run_identification(settings, params: dict, root: Path, out_dir: Path, open_run: Callable,
                       command: str = "studies run", digest: str | None = None,
                       tracked: bool = True) -> IdentificationJob:
    """Prepare, open the run, execute into ``out_dir``, log (figures finished before the files).

    ``settings`` is the typed :class:`~studies.config.RunConfig`, ``params``
    the same configuration as plain containers, ``digest`` its
    ``config_hash`` tag (``resume``). Untracked (``tracked=False``), an
    analysis the study derives first (the simplified model's) is not logged
    either.
    """
    from ..plotting import DRAWER
    from ..runtime import tracking
    from ..workflows.identified_model import IDENTIFIED_MODEL_FILE
    from ..workflows.kinds import kind_for, logged_params

    prepared = kind_for(settings).prepare(settings, root, recorder(settings, root) if tracked else None)
    name, tags = prepared.name, dict(prepared.tags)
    if digest is not None:
        tags["config_hash"] = digest
    tags.update(tracking.source_tags(root, command))
    tags.update(tracking.sweep_tags())
    with open_run(name, logged_params(settings, params), tags) as run:
        run.log_records(prepared.inputs)
        metrics = prepared.execute(Path(out_dir))
        summary = run_summary(metrics)
        model = Path(out_dir) / IDENTIFIED_MODEL_FILE        # manoeuvring models; not roll decays
        linked = {k: v for k, v in summary.items() if not k.startswith("runtime/")}
        logged = run.log_model(model, settings.tracking.register, linked) if model.is_file() else None
        DRAWER.finish()
        run.log_outputs(metrics, Path(out_dir))
    return IdentificationJob(prepared, metrics, name, run.run_id, logged)


def run_discovery(settings, params: dict, root: Path, out_dir: Path, open_run: Callable,
                  command: str = "studies discover", tracked: bool = True) -> DiscoveryJob:
    """Load and check the records, then the discovery in its run (figures finished before the files)."""
    from ..plotting import DRAWER
    from ..runtime import tracking
    from ..workflows.kinds import execute_discover, logged_params, prepare_discover
    from ..workflows.settings import as_path_list

    study = prepare_discover(settings, root, recorder(settings, root) if tracked else None)
    stems = ", ".join(Path(p).stem for p in as_path_list(settings.data.path))
    name = settings.run_name or f"discover {settings.model.name} {stems}"
    vessel = settings.vessel.name if study.vessel is not None else "unknown"
    tags = {"kind": "discovery", "model": settings.model.name, "vessel": vessel,
            "data": "measured", **tracking.source_tags(root, command), **tracking.sweep_tags()}
    with open_run(name, logged_params(settings, params), tags) as run:
        run.log_records(study.inputs)
        discovery, metrics = execute_discover(study, Path(out_dir))
        DRAWER.finish()
        run.log_outputs(metrics, Path(out_dir))
        named = discovery.get("vessel")            # a roll discovery names the ship from its records
        run.set_tags({"cause": discovery["cause"],
                      **({"vessel": named.get("name") or "unknown"} if isinstance(named, dict) else {})})
    return DiscoveryJob(study, discovery, metrics, name, run.run_id)
