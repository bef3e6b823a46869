"""The identified model of a run as an MLflow model (pyfunc), and back.

Every ``studies run`` of a manoeuvring model writes ``identified_model.json``
(:mod:`studies.workflows.identified_model`); :func:`log_identified_model`
logs it as the run's MLflow model ``model``, so that::

    import mlflow, pandas as pd
    model = mlflow.pyfunc.load_model("runs:/<run id>/model")      # or models:/<name>/<version>
    states = model.predict(pd.DataFrame({"manoeuvre": ["turning_35"]}))
    states = model.predict(pd.DataFrame({"t": t, "rudder": rudder}))   # [s], [rad]

simulates it wherever ``studies`` is installed, with the results of the run.
The MLflow model holds the JSON file as its artifact ``identified_model``, a
signature (:data:`SIGNATURE`: every input column optional, the output in the
data contract) and a three-line model file (MLflow's "models from code",
:data:`MODEL_CODE`) that builds :class:`IdentifiedModelPyfunc`; nothing is
pickled. Its requirements are given (:func:`requirements`), not inferred
(MLflow infers them by loading the model in another Python process). MLflow
still checks them against the installed packages, which scans every
installed distribution once per process: most of the 0.7 s CPU that logging
adds to a run (measured with MLflow 3.17). In MLflow 3 the model is a "logged
model" of the run's experiment, linked to the run as its output, and
``runs:/<run id>/model`` resolves to it. ``tracking.register=<name>``
registers it in the Model Registry (:func:`log_identified_model`).

With :mod:`studies.runtime.tracking`, one of the two modules that import MLflow.
"""

from __future__ import annotations

import contextlib
import logging
import math
import tempfile
import time
import warnings
from pathlib import Path

import mlflow
import mlflow.pyfunc
import pandas as pd

from ..errors import ConfigError, StudiesError
from ..workflows.identified_model import INPUT_COLUMNS, OPTIONAL_OUTPUT_COLUMNS, OUTPUT_COLUMNS, IdentifiedModel

__all__ = ["IdentifiedModelPyfunc", "SIGNATURE", "MODEL_NAME", "MODEL_CODE", "ARTIFACT",
           "log_identified_model", "load_identified_model", "requirements"]

#: the name of the run's model (``runs:/<run id>/model``)
MODEL_NAME = "model"
#: the key of the JSON description among the MLflow model's artifacts
ARTIFACT = "identified_model"

#: what MLflow runs to build the model when it is loaded (models from code)
MODEL_CODE = '''"""An identified manoeuvring model of `studies run` (studies.runtime.model_logging)."""
import mlflow.models

from studies.runtime.model_logging import IdentifiedModelPyfunc

mlflow.models.set_model(IdentifiedModelPyfunc())
'''


class IdentifiedModelPyfunc(mlflow.pyfunc.PythonModel):
    """The MLflow face of an :class:`~studies.workflows.identified_model.IdentifiedModel`.

    ``predict(table)`` simulates a named manoeuvre or a rudder time series
    (see :meth:`IdentifiedModel.predict` for the columns and units) and
    returns the simulated states in the data contract. ``identified`` is
    the model itself (``loaded.unwrap_python_model().identified``).
    """

    identified: IdentifiedModel | None = None

    def load_context(self, context) -> None:
        self.identified = IdentifiedModel.read(context.artifacts[ARTIFACT])

    def predict(self, context, model_input: pd.DataFrame, params=None) -> pd.DataFrame:
        return self.identified.predict(model_input)


def _signature():
    from mlflow.models import ModelSignature
    from mlflow.types.schema import ColSpec, Schema

    inputs = Schema([ColSpec(kind, name, required=False) for name, kind, _ in INPUT_COLUMNS])
    outputs = Schema([ColSpec("double", name) for name in OUTPUT_COLUMNS]
                     + [ColSpec("double", name, required=False) for name in OPTIONAL_OUTPUT_COLUMNS])
    return ModelSignature(inputs=inputs, outputs=outputs)


#: input: a named manoeuvre or a rudder time series (all columns optional); output: the states
SIGNATURE = _signature()


def requirements() -> list[str]:
    """The model's pip requirements: this ``studies`` and this MLflow (``studies``
    brings the scientific stack)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        own = f"studies=={version('studies')}"
    except PackageNotFoundError:
        own = "studies"
    return [own, f"mlflow=={mlflow.__version__}"]


@contextlib.contextmanager
def _own_requirements_only():
    """Let MLflow check the model's requirements without scanning the environment.

    The requirements are explicit (:func:`requirements`: this ``studies`` and
    this MLflow, both running), yet MLflow checks them against the
    environment by first mapping every installed distribution to its
    modules (``importlib.metadata.packages_distributions``: 0.5-1 s, once per
    process). For the call, its module map holds just the two packages
    named; the map is reset afterwards, so that MLflow builds the full one
    for anything else the process logs. When MLflow has already built the
    map, or no longer keeps it where this expects, nothing is changed.
    """
    try:
        from mlflow.utils import requirements_utils as known
    except ImportError:
        known = None
    if known is None or getattr(known, "_MODULES_TO_PACKAGES", False) is not None:
        yield
        return
    known._MODULES_TO_PACKAGES = {"studies": ["studies"], "mlflow": ["mlflow"]}
    try:
        yield
    finally:
        known._MODULES_TO_PACKAGES = None
        known._PACKAGES_TO_MODULES = None


@contextlib.contextmanager
def _quiet():
    """MLflow's notes while logging and loading (no input example, type hints,
    registration progress) are not the user's business: warnings off, its
    loggers at ERROR."""
    logger = logging.getLogger("mlflow")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        logger.setLevel(level)


def log_identified_model(client, run_id: str, path: str | Path, register: str | None = None,
                         metrics: dict | None = None) -> dict:
    """Log the ``identified_model.json`` at ``path`` as run ``run_id``'s MLflow model.

    ``client`` is an ``MlflowClient`` of the run's store (which must also be
    MLflow's current tracking URI, :func:`studies.runtime.tracking.configure`).
    The logged model (named :data:`MODEL_NAME`, in the run's experiment,
    type ``manoeuvring``) carries the model's name, vessel and method as
    params and ``metrics`` (a few summary numbers of the run, shown with the
    model and its registered versions); it is registered as ``register``
    when given (a new version of that registered model). Returns
    ``{"model_id", "uri", "registered"}`` (``registered``:
    ``models:/<name>/<version>`` or None).

    Logged before the run's own metrics: MLflow links every metric the run
    already has to a new model, one query each (0.3 s for a hundred).
    """
    from mlflow.entities import LoggedModelStatus, Metric
    from mlflow.models import Model

    identified = IdentifiedModel.read(path)
    experiment_id = client.get_run(run_id).info.experiment_id
    source = identified.source
    params = {"model": identified.model.name, "vessel": str(source.get("vessel", identified.vessel.name)),
              "method": str(source.get("method", "")), "simulator": "mmg" if identified.is_mmg else "abkowitz"}
    with _quiet(), _own_requirements_only(), tempfile.TemporaryDirectory() as tmp:
        code = Path(tmp) / "identified_model.py"
        code.write_text(MODEL_CODE)
        logged = client.create_logged_model(experiment_id, name=MODEL_NAME, source_run_id=run_id,
                                            params=params, model_type="manoeuvring")
        Model.log(None, name=MODEL_NAME, flavor=mlflow.pyfunc, run_id=run_id, model_id=logged.model_id,
                  python_model=str(code), artifacts={ARTIFACT: str(path)}, signature=SIGNATURE,
                  pip_requirements=requirements(), metadata={"studies": params})
        client.finalize_logged_model(logged.model_id, LoggedModelStatus.READY)
        stamp = int(time.time() * 1000)
        linked = [Metric(k, float(v), stamp, 0, model_id=logged.model_id, run_id=run_id)
                  for k, v in (metrics or {}).items() if math.isfinite(float(v))]
        if linked:
            client.log_batch(run_id, metrics=linked)
        registered = _register(client, register, logged.model_id, run_id) if register else None
    return {"model_id": logged.model_id, "uri": f"runs:/{run_id}/{MODEL_NAME}", "registered": registered}


def _register(client, name: str, model_id: str, run_id: str) -> str:
    """A new version of registered model ``name`` (created when new) from the
    logged model; ``models:/<name>/<version>``."""
    from mlflow.exceptions import MlflowException

    try:
        client.create_registered_model(name)
    except MlflowException as error:
        if error.error_code not in ("RESOURCE_ALREADY_EXISTS", "ALREADY_EXISTS"):
            raise
    version = client.create_model_version(name, source=f"models:/{model_id}", run_id=run_id,
                                          model_id=model_id)
    return f"models:/{name}/{version.version}"


def load_identified_model(model_uri: str) -> IdentifiedModel:
    """The identified model behind an MLflow model URI (``runs:/<run id>/model``,
    ``models:/<name>/<version>``, ``models:/<model id>`` or a local folder),
    loaded with ``mlflow.pyfunc.load_model`` from MLflow's current store.

    Raises :class:`~studies.errors.ConfigError` in one line when the URI
    names nothing loadable, or a model that ``studies run`` did not log.
    """
    uri = str(model_uri).strip()
    if not uri:
        raise ConfigError("model_uri: give runs:/<run id>/model or models:/<name>/<version>")
    try:
        with _quiet():
            loaded = mlflow.pyfunc.load_model(uri)
    except StudiesError as error:
        raise ConfigError(f"model_uri: {uri}: {error}") from None
    except Exception as error:  # noqa: BLE001 - MLflow's many ways of not finding a model
        reason = _first_line(error) or type(error).__name__
        raise ConfigError(f"model_uri: cannot load '{uri}' ({reason}); give runs:/<run id>/model "
                          "or models:/<name>/<version> of this store (tracking.uri=)") from None
    try:
        python_model = loaded.unwrap_python_model()
    except Exception:  # noqa: BLE001 - not a Python model
        python_model = None
    if not isinstance(python_model, IdentifiedModelPyfunc) or python_model.identified is None:
        raise ConfigError(f"model_uri: '{uri}' is not a model logged by studies run")
    return python_model.identified


def _first_line(error) -> str:
    lines = [line.strip() for line in str(error).strip().splitlines() if line.strip()]
    return lines[0][:300] if lines else ""
