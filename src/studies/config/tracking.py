"""Settings of where runs are logged (MLflow store and experiment) and of the comparison report.
"""

from dataclasses import dataclass
from typing import Optional

from ..errors import ConfigError

__all__ = ["ReportOptions", "TrackingStore", "Tracking"]


@dataclass
class ReportOptions:
    """``studies report``: comparison pages of one experiment (``report``).

    Attributes
    ----------
    dir : str
        Folder of the pages (project-relative); they go to ``<dir>/<experiment>/``.
    condition : str or None
        The swept config key that makes a table's column groups (several
        keys separated by commas).
    series : str
        The config key whose values are the columns within a group.
    experiment : str or None
        MLflow experiment to report; None: the one with the latest run.
    sweep : str or None
        Sweep id (tag ``sweep_id``) whose runs are reported; None: the
        experiment's latest sweep (all its runs when it has no sweep),
        ``all``: every run of the experiment.
    compare : str or None
        A paper (``thesis``, ...; :mod:`studies.papers`): instead of one
        experiment's page, the reproduction report of that paper, its
        published tables beside the runs of its presets
        (``<dir>/reproduce_<paper>/``).
    """

    dir: str = "reports"
    condition: Optional[str] = None
    series: str = "method.name"
    experiment: Optional[str] = None
    sweep: Optional[str] = None
    compare: Optional[str] = None


@dataclass
class TrackingStore:
    """The MLflow store a command reads (``tracking`` of ``studies simulate``).

    Attributes
    ----------
    uri : str or None
        Tracking URI (sqlite file, PostgreSQL database or MLflow server);
        None: the ``MLFLOW_TRACKING_URI`` environment variable when set,
        else the sqlite store ``mlruns/mlflow.db`` in the working directory.
    """

    uri: Optional[str] = None


@dataclass
class Tracking:
    """MLflow tracking (``tracking``).

    Attributes
    ----------
    uri : str or None
        Tracking URI (sqlite file, PostgreSQL database or MLflow server);
        None: the ``MLFLOW_TRACKING_URI`` environment variable when set,
        else the sqlite store ``mlruns/mlflow.db`` in the working directory.
    experiment : str
        MLflow experiment name (presets set their own).
    register : str or None
        Model Registry name: the run's identified model (its MLflow model
        ``runs:/<run id>/model``) becomes a new version of it,
        ``models:/<name>/<version>``; None: logged, not registered.
    """

    uri: Optional[str] = None
    experiment: str = "studies"
    register: Optional[str] = None

    def __post_init__(self):
        if self.register is None:
            return
        name = str(self.register).strip()
        if not name or name in (".", "..") or any(c in name for c in "/:"):
            raise ConfigError(f"tracking.register: '{self.register}' is not a model name (a name "
                              "without '/' or ':', e.g. mariner_ls)")
        self.register = name
