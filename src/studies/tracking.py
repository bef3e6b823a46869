"""MLflow tracking: the only module of `studies` that imports mlflow.

Default store (DESIGN.md): ``mlruns/mlflow.db`` (sqlite) with artifacts under
``mlruns/artifacts/`` at the project root (the directory `studies` is run
from). ``tracking.uri=`` selects any other MLflow URI; artifacts then go where
that server or store puts them.
"""

from __future__ import annotations

import contextlib
import math
import os
from pathlib import Path

__all__ = ["default_uri", "configure", "start_run", "log_outputs", "flatten"]

os.environ.setdefault("MLFLOW_DISABLE_TELEMETRY", "true")

MAX_PARAM_LENGTH = 6000


def default_uri(root: str | os.PathLike) -> str:
    """``sqlite:///<root>/mlruns/mlflow.db``."""
    return f"sqlite:///{Path(root).resolve() / 'mlruns' / 'mlflow.db'}"


def _artifact_root(root, uri: str) -> str | None:
    if uri.startswith("sqlite:///"):
        db = Path(uri[len("sqlite:///"):])
        return (db.parent / "artifacts").resolve().as_uri()
    return None


def configure(uri: str | None, root: str | os.PathLike) -> str:
    """Point mlflow at ``uri`` (default store under ``root`` when None)."""
    import mlflow

    uri = uri or default_uri(root)
    if uri.startswith("sqlite:///"):
        Path(uri[len("sqlite:///"):]).parent.mkdir(parents=True, exist_ok=True)
    mlflow.set_tracking_uri(uri)
    return uri


def _experiment_id(name: str, uri: str, root) -> str:
    import mlflow

    exp = mlflow.get_experiment_by_name(name)
    if exp is not None:
        return exp.experiment_id
    location = _artifact_root(root, uri)
    if location:
        location = f"{location}/{name}"
    try:
        return mlflow.create_experiment(name, artifact_location=location)
    except Exception:
        # another job created it in the meantime
        exp = mlflow.get_experiment_by_name(name)
        if exp is None:
            raise
        return exp.experiment_id


def flatten(cfg: dict, prefix: str = "") -> dict:
    """Nested mapping -> ``{"a.b.c": value}`` with values as strings."""
    out = {}
    for key, value in cfg.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        else:
            text = "null" if value is None else str(value)
            out[name] = text[:MAX_PARAM_LENGTH]
    return out


@contextlib.contextmanager
def start_run(experiment: str, run_name: str, uri: str | None, root, params: dict,
              tags: dict | None = None):
    """Open one MLflow run; yields the run id. A failure marks it FAILED."""
    import mlflow

    uri = configure(uri, root)
    exp_id = _experiment_id(experiment, uri, root)
    with mlflow.start_run(experiment_id=exp_id, run_name=run_name) as run:
        mlflow.set_tags({k: str(v) for k, v in (tags or {}).items()})
        items = list(flatten(params).items())
        for i in range(0, len(items), 100):
            mlflow.log_params(dict(items[i:i + 100]))
        yield run.info.run_id


def log_outputs(metrics: dict, directory: str | os.PathLike) -> None:
    """Log finite metrics (non-finite ones are skipped: they stay in metrics.json)
    and every file of ``directory`` as artifacts of the active run."""
    import mlflow

    finite = {k: float(v) for k, v in metrics.items()
              if isinstance(v, (int, float)) and math.isfinite(float(v))}
    items = list(finite.items())
    for i in range(0, len(items), 200):
        mlflow.log_metrics(dict(items[i:i + 200]))
    directory = Path(directory)
    for path in sorted(directory.iterdir()):
        if path.is_file():
            mlflow.log_artifact(str(path))
        elif path.is_dir() and path.name == ".hydra":
            mlflow.log_artifacts(str(path), artifact_path="hydra")
