"""MLflow tracking: with :mod:`~studies.runtime.model_logging` (the run's
MLflow model), the only module of `studies` that imports mlflow.

Default store (DESIGN.md): ``mlruns/mlflow.db`` (sqlite) with artifacts under
``mlruns/artifacts/`` at the project root (the directory `studies` is run
from). ``tracking.uri=`` selects any other MLflow URI, and without it the
``MLFLOW_TRACKING_URI`` environment variable does (:func:`resolve_uri`);
artifacts then go where that server or store puts them. A server that does
not answer is refused in one line within seconds (:func:`check_store`),
before any work.

Parallel sweep jobs share one sqlite file. MLflow creates a new store's
tables and runs its schema migrations in whichever process opens it first,
without a lock of its own: measured with MLflow 3.17 (2, 4 and 8 processes
logging 5 runs each into a fresh store, 3 trials each), processes that
opened the store together lost 20 of 30, 60 of 60 and 115 of 120 runs and
left the schema half-migrated (``table _alembic_tmp_... already exists``),
while with the lock no run was lost. Once the tables exist, sqlite's busy
timeout (20 s, set by MLflow) serialised the same writers without a loss,
but a writer kept waiting longer would fail. So every access to a sqlite
store goes through :func:`store_lock`, an exclusive ``flock`` on a file next
to the database, held only for short sections (create the run; log the
results and close it); the computation in between runs unlocked. A shared
server or a PostgreSQL URI needs no lock and gets none.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import logging
import math
import os
import subprocess
import uuid
import urllib.error
import urllib.request
from pathlib import Path

from .. import interrupt
from ..errors import ConfigError

# MLflow announces at INFO on stderr that it creates a new store's tables (alembic's
# migrations): bookkeeping of the library, not something a user acts on
for _name in ("mlflow.store.db.utils", "alembic.runtime.migration"):
    logging.getLogger(_name).setLevel(logging.WARNING)

__all__ = ["start_sweep", "end_sweep", "experiment_of", "sweep_tags", "select_sweep", "file_digest", "source_tags", "default_uri", "resolve_uri", "check_store", "configure", "start_run", "RunLogger", "store_lock", "flatten",
           "StoredRun", "read_experiment", "find_finished_run", "close_if_running", "load_model"]

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


def _sqlite_path(uri: str) -> Path | None:
    return Path(uri[len("sqlite:///"):]) if uri.startswith("sqlite:///") else None


@contextlib.contextmanager
def store_lock(uri: str):
    """Exclusive inter-process lock of a sqlite store (no-op for other URIs)."""
    db = _sqlite_path(uri)
    if db is None:
        yield
        return
    db.parent.mkdir(parents=True, exist_ok=True)
    # SIGINT/SIGTERM wait until the section is over (studies.interrupt)
    with interrupt.critical(), open(db.parent / f".{db.name}.lock", "a+") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def file_digest(path) -> str:
    """First 16 hex digits of the SHA-256 of a file's content."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()[:16]


def source_tags(root, command: str) -> dict:
    """MLflow's source tags of a run started from ``root`` by ``command``
    (``studies run``): the command and, when ``root`` or the installed
    package lies in a git work tree, its commit."""
    tags = {"mlflow.source.type": "LOCAL", "mlflow.source.name": command}
    for place in (Path(root), Path(__file__).resolve().parent):
        try:
            commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=place, capture_output=True,
                                    text=True, timeout=5)
        except (OSError, subprocess.SubprocessError):
            continue
        if commit.returncode == 0 and commit.stdout.strip():
            tags["mlflow.source.git.commit"] = commit.stdout.strip()
            break
    return tags


#: the environment variable MLflow users set to choose a store
ENV_URI = "MLFLOW_TRACKING_URI"


def resolve_uri(uri: str | None, root: str | os.PathLike) -> str:
    """The store a command uses: ``tracking.uri`` when given, else the
    ``MLFLOW_TRACKING_URI`` environment variable when set, else the default
    store under ``root`` (:func:`default_uri`)."""
    return uri or os.environ.get(ENV_URI) or default_uri(root)


#: seconds a tracking server has to answer before the command gives up
SERVER_TIMEOUT_S = 5.0


def check_store(uri: str | None, root: str | os.PathLike) -> None:
    """Refuse, in one line (:class:`~studies.errors.ConfigError`), a store the
    command could not write to: a tracking server that does not answer its
    health check within :data:`SERVER_TIMEOUT_S`, a PostgreSQL URI whose
    driver is not installed or whose database does not answer. sqlite
    files are created on first use and not checked."""
    uri = resolve_uri(uri, root)
    if uri.startswith(("http://", "https://")):
        _check_server(uri)
    elif uri.startswith("postgresql"):
        _check_postgres(uri)


def _check_server(uri: str) -> None:
    try:
        with urllib.request.urlopen(uri.rstrip("/") + "/health", timeout=SERVER_TIMEOUT_S) as answer:
            if answer.status < 400:
                return
            reason = f"HTTP {answer.status}"
    except urllib.error.HTTPError as error:
        reason = f"HTTP {error.code}"
    except (urllib.error.URLError, OSError, ValueError) as error:
        reason = str(getattr(error, "reason", error))
    raise ConfigError(f"tracking.uri: no MLflow server answers at {uri} ({reason}); start it "
                      "(mlflow server) or give another tracking.uri")


def _check_postgres(uri: str) -> None:
    import sqlalchemy

    try:
        engine = sqlalchemy.create_engine(uri, connect_args={"connect_timeout": int(SERVER_TIMEOUT_S)})
    except ModuleNotFoundError as error:     # the driver the URI's scheme names
        raise ConfigError(f"tracking.uri: a PostgreSQL store needs the {error.name} driver, which is not "
                          "installed: pip install 'studies[postgres]'") from None
    except (sqlalchemy.exc.ArgumentError, ValueError) as error:
        raise ConfigError(f"tracking.uri: not a database URI: {error}") from None
    try:
        with engine.connect():
            pass
    except sqlalchemy.exc.SQLAlchemyError as error:
        reason = str(getattr(error, "orig", error)).strip().splitlines()[0]
        raise ConfigError(f"tracking.uri: the PostgreSQL database does not answer ({reason})") from None
    finally:
        engine.dispose()


def configure(uri: str | None, root: str | os.PathLike) -> str:
    """Point mlflow at the store :func:`resolve_uri` chooses; that URI."""
    import mlflow

    uri = resolve_uri(uri, root)
    if uri.startswith("sqlite:///"):
        Path(uri[len("sqlite:///"):]).parent.mkdir(parents=True, exist_ok=True)
    before = os.environ.get(ENV_URI)
    mlflow.set_tracking_uri(uri)
    # MLflow also writes the URI into the environment, where it would pass for the
    # user's choice in later commands of this process and in every subprocess
    if before is None:
        os.environ.pop(ENV_URI, None)
    else:
        os.environ[ENV_URI] = before
    return uri


#: the MLflow UI opens an experiment of this kind in its model-training view
EXPERIMENT_KIND = {"mlflow.experimentKind": "custom_model_development"}


def _experiment_id(name: str, uri: str, root) -> str:
    """The experiment ``name`` (created when new, tagged as model training)."""
    import mlflow

    exp = mlflow.get_experiment_by_name(name)
    if exp is not None:
        if "mlflow.experimentKind" not in exp.tags:
            mlflow.MlflowClient().set_experiment_tag(exp.experiment_id, *next(iter(EXPERIMENT_KIND.items())))
        return exp.experiment_id
    location = _artifact_root(root, uri)
    if location:
        location = f"{location}/{name}"
    try:
        return mlflow.create_experiment(name, artifact_location=location, tags=EXPERIMENT_KIND)
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


def _log_params(client, run_id: str, params: dict) -> None:
    """Log flat ``params`` (name -> text) to a run in batches of 100 (MLflow's limit per call)."""
    import mlflow

    items = list(params.items())
    for i in range(0, len(items), 100):
        client.log_batch(run_id, params=[mlflow.entities.Param(k, v) for k, v in items[i:i + 100]])


@contextlib.contextmanager
def start_run(experiment: str, run_name: str, uri: str | None, root, params: dict,
              tags: dict | None = None, on_create=None):
    """Open one MLflow run and yield its :class:`RunLogger`.

    The run is created (status RUNNING, params and tags logged) under the
    store lock; ``on_create(run_id, uri)`` is called once it exists; the body
    runs unlocked; :meth:`RunLogger.log_outputs` logs the results under the lock.
    An exception in the body marks the run FAILED with the error as a tag;
    KeyboardInterrupt/SystemExit (SIGINT and SIGTERM arrive as
    :class:`studies.interrupt.Interrupted`) mark it KILLED.
    """
    import mlflow
    from mlflow.tracking import MlflowClient

    uri = configure(uri, root)
    logger = None
    try:
        with store_lock(uri):
            exp_id = _experiment_id(experiment, uri, root)
            client = MlflowClient(tracking_uri=uri)
            run = client.create_run(exp_id, run_name=run_name,
                                    tags={k: str(v) for k, v in (tags or {}).items()})
            logger = RunLogger(client, run.info.run_id, uri)
            if on_create is not None:
                on_create(logger.run_id, uri)
            _log_params(client, logger.run_id, flatten(params))
        yield logger
    except Exception as error:
        interrupt.acknowledge()         # the run is closed as FAILED, not interrupted again
        if logger is not None and not logger.ended:
            import traceback

            logger.end("FAILED", _one_line(f"{type(error).__name__}: {error}"),
                       traceback.format_exc()[-5000:])
        raise
    except BaseException as error:
        interrupt.acknowledge()         # the run is being closed as KILLED
        if logger is not None and not logger.ended:
            reason = f"interrupted by {error}" if isinstance(error, interrupt.Interrupted) \
                else type(error).__name__
            logger.end("KILLED", reason)
        raise
    else:
        if not logger.ended:
            logger.end("FINISHED")


def _one_line(text: str, limit: int = 5000) -> str:
    """The error as one line: its first line, and its last if they differ."""
    lines = [line.strip() for line in str(text).strip().splitlines() if line.strip()]
    if not lines:
        return ""
    out = lines[0] if len(lines) == 1 or lines[-1] == lines[0] else f"{lines[0]} ... {lines[-1]}"
    return out[:limit]


#: a run directory's step metrics: ``{name: [[step, value], ...]}`` (GA generations, emcee iterations)
METRIC_HISTORY = "metric_history.json"


def history_metrics(path: str | os.PathLike) -> list:
    """The finite step metrics of a ``metric_history.json`` file as MLflow
    metrics (none when the file does not exist)."""
    import json

    import mlflow

    path = Path(path)
    if not path.is_file():
        return []
    return [mlflow.entities.Metric(key, float(value), 0, int(step))
            for key, points in json.loads(path.read_text()).items()
            for step, value in points if math.isfinite(float(value))]


#: output folders logged as artifacts under their own names (beside the files and ``.hydra/``):
#: a discovery's members' predictions of the manoeuvre that would settle its class
LOGGED_FOLDERS = ("settling",)

class RunLogger:
    """Writes one run's results to the store under the store lock."""

    def __init__(self, client, run_id: str, uri: str):
        self.client = client
        self.run_id = run_id
        self.uri = uri
        self.ended = False

    def log_outputs(self, metrics: dict, directory: str | os.PathLike) -> None:
        """Log finite metrics (non-finite ones stay in metrics.json only) and
        every file of ``directory`` (plus its ``.hydra/`` config) as artifacts;
        an empty log file (Hydra's job log when nothing was logged) is left out.
        ``coefficients.csv`` is also logged as an MLflow table
        (``coefficients_table.json``), and the step metrics of
        ``metric_history.json`` (:func:`history_metrics`) with their steps: a
        metric with a history is logged at each of its steps instead of once
        at step 0 (its last step holds the value of ``metrics``)."""
        import mlflow

        directory = Path(directory)
        stepped = history_metrics(directory / METRIC_HISTORY)
        named = {m.key for m in stepped}
        finite = [mlflow.entities.Metric(k, float(v), 0, 0) for k, v in metrics.items()
                  if isinstance(v, (int, float)) and math.isfinite(float(v)) and k not in named]
        finite += stepped
        with store_lock(self.uri):
            for i in range(0, len(finite), 200):
                self.client.log_batch(self.run_id, metrics=finite[i:i + 200])
            for path in sorted(directory.iterdir()):
                if path.is_file() and not (path.suffix == ".log" and path.stat().st_size == 0):
                    self.client.log_artifact(self.run_id, str(path))
                elif path.is_dir() and path.name == ".hydra":
                    self.client.log_artifacts(self.run_id, str(path), artifact_path="hydra")
                elif path.is_dir() and path.name in LOGGED_FOLDERS:
                    self.client.log_artifacts(self.run_id, str(path), artifact_path=path.name)
            table = directory / "coefficients.csv"
            if table.is_file():                 # also as a table the UI can show and compare
                import pandas as pd

                self.client.log_table(self.run_id, pd.read_csv(table), "coefficients_table.json")

    def log_records(self, inputs) -> None:
        """Log the records a run used as MLflow dataset inputs.

        ``inputs`` holds ``(path, frame, context)`` per record: the file
        (its content digest and location are the dataset's source), the
        loaded table (its columns and row count are the dataset's schema and
        profile) and how it was used (``training``, ``validation`` or
        ``simulation``, the ``mlflow.data.context`` tag).
        """
        import mlflow
        from mlflow.entities import DatasetInput, InputTag

        from mlflow.data.dataset_source_registry import get_registered_sources

        # MLflow registers the local-file source twice, and resolving a file URI
        # then warns that it is ambiguous: take the class itself
        local = next(s for s in get_registered_sources() if s.__name__ == "LocalArtifactDatasetSource")
        datasets = []
        for path, frame, context in inputs:
            path = Path(path).expanduser().resolve()
            dataset = mlflow.data.from_pandas(frame.reset_index(drop=True), source=local(path.as_uri()),
                                              name=path.name, digest=file_digest(path))
            datasets.append(DatasetInput(dataset._to_mlflow_entity(),
                                         tags=[InputTag("mlflow.data.context", context)]))
        if datasets:
            with store_lock(self.uri):
                self.client.log_inputs(self.run_id, datasets=datasets)

    def log_model(self, path: str | os.PathLike, register: str | None = None,
                  metrics: dict | None = None) -> dict:
        """Log the run's ``identified_model.json`` (``path``) as its MLflow model
        ``model`` with a few summary ``metrics`` and, with ``register``,
        register it under that name
        (:func:`studies.runtime.model_logging.log_identified_model`; call it
        before :meth:`log_outputs`); returns ``{"model_id", "uri", "registered"}``."""
        from .model_logging import log_identified_model

        with store_lock(self.uri):
            return log_identified_model(self.client, self.run_id, path, register, metrics)

    def set_tags(self, tags: dict) -> None:
        """Add tags to the run (e.g. the cause a discovery named)."""
        with store_lock(self.uri):
            for key, value in tags.items():
                self.client.set_tag(self.run_id, key, str(value))

    def end(self, status: str, error: str | None = None, detail: str | None = None) -> None:
        """Close the run with ``FINISHED``, ``FAILED`` or ``KILLED``; ``error``
        (one line) and ``detail`` (the traceback) become tags."""
        with store_lock(self.uri):
            if error:
                self.client.set_tag(self.run_id, "error", error[:5000])
            if detail:
                self.client.set_tag(self.run_id, "error_traceback", detail[-5000:])
            self.client.set_terminated(self.run_id, status=status)
        self.ended = True


#: where ``studies ui`` serves a local store (its default host and port)
LOCAL_UI = "http://127.0.0.1:5000"


def ui_address(uri: str) -> str:
    """The MLflow UI of store ``uri``: the tracking server itself for an
    ``http(s)`` URI, else where ``studies ui`` serves it by default."""
    return uri.rstrip("/") if uri.startswith(("http://", "https://")) else LOCAL_UI


class StoredRun:
    """One run as read back from the store (plain Python values); ``url`` is
    its page in the MLflow UI at ``ui`` (:func:`ui_address`)."""

    def __init__(self, run, client, ui: str = LOCAL_UI):
        self._client = client
        self.run_id = run.info.run_id
        self.experiment_id = run.info.experiment_id
        self.url = f"{ui}/#/experiments/{self.experiment_id}/runs/{self.run_id}"
        self.name = run.info.run_name or run.data.tags.get("mlflow.runName", self.run_id)
        self.status = run.info.status
        self.start_time = run.info.start_time or 0
        self.params = dict(run.data.params)
        self.metrics = dict(run.data.metrics)
        self.tags = dict(run.data.tags)
        self.artifact_uri = run.info.artifact_uri or ""

    def artifact(self, path: str, destination: str | os.PathLike) -> Path | None:
        """One artifact as a local file to read; None when it does not exist.

        An artifact of a local store (a ``file:`` artifact location) is its
        file where the store keeps it (read it, do not change it); others are
        downloaded into ``destination``. MLflow's download costs about 0.1 s
        a file even for a local store: a report reads hundreds."""
        local = _local_artifact(self.artifact_uri, path)
        if local is not None:
            return local if local.is_file() else None
        try:
            local = self._client.download_artifacts(self.run_id, path, str(destination))
        except Exception:
            return None
        return Path(local)

    def artifact_names(self) -> list[str]:
        try:
            return [f.path for f in self._client.list_artifacts(self.run_id)]
        except Exception:
            return []


def _local_artifact(artifact_uri: str, path: str) -> Path | None:
    """The file of artifact ``path`` under a local (``file:``) artifact location, else None."""
    if not artifact_uri.startswith("file:"):
        return None
    from urllib.parse import unquote, urlparse

    root = Path(unquote(urlparse(artifact_uri).path))
    target = (root / path).resolve()
    return target if target.is_relative_to(root.resolve()) else None


#: environment variables that tell a sweep's jobs (in worker processes) their sweep
SWEEP_ID_ENV, PARENT_RUN_ENV = "STUDIES_SWEEP_ID", "STUDIES_PARENT_RUN_ID"


def start_sweep(experiment: str, uri: str | None, root, name: str, tags: dict | None = None) -> dict:
    """Open the parent run of a sweep; the environment tells its jobs.

    Returns ``{"sweep_id": ..., "run_id": ..., "uri": ...}``. Every run
    started afterwards in this process or its workers (:func:`sweep_tags`)
    becomes a child run tagged with the sweep id.
    """
    from mlflow.tracking import MlflowClient

    uri = configure(uri, root)
    sweep_id = uuid.uuid4().hex[:12]
    with store_lock(uri):
        exp_id = _experiment_id(experiment, uri, root)
        client = MlflowClient(tracking_uri=uri)
        run = client.create_run(exp_id, run_name=name,
                                tags={"kind": "sweep", "sweep_id": sweep_id,
                                      **{k: str(v) for k, v in (tags or {}).items()}})
    os.environ[SWEEP_ID_ENV] = sweep_id
    os.environ[PARENT_RUN_ENV] = run.info.run_id
    return {"sweep_id": sweep_id, "run_id": run.info.run_id, "uri": uri}


def end_sweep(sweep: dict, status: str, metrics: dict | None = None, tags: dict | None = None) -> None:
    """Close a sweep's parent run (``FINISHED``, ``FAILED`` or ``KILLED``) with
    its summary ``metrics`` (jobs finished, failed, ...) and ``tags``."""
    import mlflow
    from mlflow.tracking import MlflowClient

    os.environ.pop(SWEEP_ID_ENV, None)
    os.environ.pop(PARENT_RUN_ENV, None)
    with store_lock(sweep["uri"]):
        client = MlflowClient(tracking_uri=sweep["uri"])
        batch = [mlflow.entities.Metric(k, float(v), 0, 0) for k, v in (metrics or {}).items()]
        if batch:
            client.log_batch(sweep["run_id"], metrics=batch)
        for key, value in (tags or {}).items():
            client.set_tag(sweep["run_id"], key, str(value))
        client.set_terminated(sweep["run_id"], status)


def experiment_of(sweep: dict) -> str:
    """The experiment name of a sweep's parent run."""
    from mlflow.tracking import MlflowClient

    client = MlflowClient(tracking_uri=sweep["uri"])
    with store_lock(sweep["uri"]):
        run = client.get_run(sweep["run_id"])
        return client.get_experiment(run.info.experiment_id).name


def sweep_tags() -> dict:
    """Tags that make a run a child of the sweep it belongs to ({} outside a sweep)."""
    sweep_id, parent = os.environ.get(SWEEP_ID_ENV), os.environ.get(PARENT_RUN_ENV)
    return {"sweep_id": sweep_id, "mlflow.parentRunId": parent} if sweep_id and parent else {}


def select_sweep(runs: list, sweep: str | None) -> list:
    """The runs a report is about: those of sweep ``sweep`` (``None``: the
    latest sweep, or every run when there is none; ``"all"``: every run),
    never the sweeps' parent runs. Raises ``LookupError`` for an unknown id."""
    jobs = [r for r in runs if r.tags.get("kind") != "sweep"]
    if sweep == "all":
        return jobs
    swept = [r for r in jobs if r.tags.get("sweep_id")]
    if sweep is None:
        if not swept:
            return jobs
        sweep = max(swept, key=lambda r: r.start_time).tags["sweep_id"]
    chosen = [r for r in jobs if r.tags.get("sweep_id") == sweep]
    if not chosen:
        known = sorted({r.tags["sweep_id"] for r in swept})
        raise LookupError(f"report.sweep: no runs of sweep '{sweep}' (known: {', '.join(known) or 'none'})")
    return chosen


def read_experiment(uri: str | None, root, name: str | None = None):
    """``(experiment name, [StoredRun, ...])`` of experiment ``name``.

    With ``name=None`` the experiment holding the most recent run is taken.
    Raises ``LookupError`` when there is no such experiment or no run.
    """
    from mlflow.tracking import MlflowClient

    uri = configure(uri, root)
    with store_lock(uri):
        client = MlflowClient(tracking_uri=uri)
        experiments = client.search_experiments()
        if name is not None:
            chosen = [e for e in experiments if e.name == name]
            if not chosen:
                known = ", ".join(sorted(e.name for e in experiments)) or "none"
                raise LookupError(f"no MLflow experiment named '{name}' in {uri} (known: {known})")
        else:
            chosen = experiments
        runs = client.search_runs([e.experiment_id for e in chosen], max_results=50000,
                                  order_by=["attributes.start_time DESC"]) if chosen else []
        if not runs:
            raise LookupError(f"no runs in {'experiment ' + repr(name) if name else 'the store'} ({uri})")
        if name is None:
            exp_id = runs[0].info.experiment_id
            name = next(e.name for e in chosen if e.experiment_id == exp_id)
            runs = [r for r in runs if r.info.experiment_id == exp_id]
        return name, [StoredRun(r, client, ui_address(uri)) for r in runs]


def load_model(model_uri: str, uri: str | None, root):
    """The identified model an MLflow model URI names in the store
    (``runs:/<run id>/model``, ``models:/<name>/<version>``), as
    :class:`~studies.workflows.identified_model.IdentifiedModel`; a URI that
    names nothing loadable is a :class:`~studies.errors.ConfigError`."""
    from .model_logging import load_identified_model

    uri = configure(uri, root)
    with store_lock(uri):
        return load_identified_model(model_uri)


def find_finished_run(uri: str | None, root, experiment: str, config_hash: str) -> str | None:
    """Id of a FINISHED run of ``experiment`` tagged ``config_hash`` (None if there is none)."""
    from mlflow.tracking import MlflowClient

    uri = configure(uri, root)
    with store_lock(uri):
        client = MlflowClient(tracking_uri=uri)
        exp = client.get_experiment_by_name(experiment)
        if exp is None:
            return None
        runs = client.search_runs([exp.experiment_id], max_results=1,
                                  filter_string=f"tags.config_hash = '{config_hash}' "
                                                "and attributes.status = 'FINISHED'",
                                  order_by=["attributes.start_time DESC"])
    return runs[0].info.run_id if runs else None


def close_if_running(uri: str, root, run_id: str, status: str = "KILLED",
                     error: str | None = None) -> bool:
    """End run ``run_id`` with ``status`` if it is still RUNNING (its process
    died before closing it); True when it was closed here."""
    from mlflow.tracking import MlflowClient

    uri = configure(uri, root)
    with store_lock(uri):
        client = MlflowClient(tracking_uri=uri)
        try:
            run = client.get_run(run_id)
        except Exception:
            return False
        if run.info.status != "RUNNING":
            return False
        if error:
            client.set_tag(run_id, "error", error[:5000])
        client.set_terminated(run_id, status=status)
    return True


class Untracked:
    """What a run logger does when nothing is tracked (a Python call with no
    active MLflow run and ``track`` not asked): nothing; ``run_id`` is None."""

    run_id = None
    uri = None
    ended = True

    def log_outputs(self, metrics: dict, directory) -> None:
        """Nothing is logged."""

    def log_records(self, inputs) -> None:
        """Nothing is logged."""

    def log_model(self, path, register: str | None = None, metrics: dict | None = None) -> None:
        """Nothing is logged (None: no model URI)."""
        return None

    def set_tags(self, tags: dict) -> None:
        """Nothing is logged."""


def active_run():
    """The MLflow run a Python caller has open (``mlflow.start_run()``), or None.

    MLflow is not imported for the question: a caller with an open run has
    imported it already."""
    import sys

    mlflow = sys.modules.get("mlflow")
    return mlflow.active_run() if mlflow is not None else None


@contextlib.contextmanager
def into_active_run(params: dict, tags: dict | None = None):
    """Yield a :class:`RunLogger` on the caller's active MLflow run.

    The run's params and tags are added to it; the run is neither ended nor
    marked on error (the caller's ``with mlflow.start_run()`` does that, by
    MLflow's convention). A param the run already holds with another value
    is refused with one line (MLflow params cannot change): a second study
    goes in a run of its own (``mlflow.start_run(nested=True)``).
    """
    import mlflow
    from mlflow.tracking import MlflowClient

    from ..errors import ConfigError

    run = mlflow.active_run()
    if run is None:
        raise ConfigError("no active MLflow run to log to (mlflow.start_run() first, or track=True)")
    uri = mlflow.get_tracking_uri()
    client = MlflowClient(tracking_uri=uri)
    run_id = run.info.run_id
    held = client.get_run(run_id).data.params
    new = {}
    for key, value in flatten(params).items():
        if key in held and held[key] != value:
            raise ConfigError(f"{key}: the active MLflow run {run_id} already holds {held[key]!r}, this "
                              f"study has {value!r}; open a run for it (mlflow.start_run(nested=True))")
        if key not in held:
            new[key] = value
    with store_lock(uri):
        _log_params(client, run_id, new)
        for key, value in (tags or {}).items():
            if not key.startswith("mlflow.source"):      # the caller's own source stays
                client.set_tag(run_id, key, str(value))
    logger = RunLogger(client, run_id, uri)
    yield logger
