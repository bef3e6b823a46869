"""The StudyKind protocol: what every kind of study offers the command line.

A kind of study (manoeuvring records of a ship, roll decays) is chosen by the
``study`` setting of the model group (``model=abkowitz`` gives
``manoeuvring``, ``model=roll`` gives ``roll_decay``), never by the model's
name. Each kind implements :class:`StudyKind`:

``prepare(cfg, root, record)``
    check the settings that depend on files, load or simulate the training
    and validation records, and return a :class:`PreparedRun`; everything
    that can refuse the user's input happens here, before any tracked run
    exists;
``PreparedRun.execute(out_dir)``
    identify, simulate the validation records, compute the manoeuvre or
    decay characteristics, write the tables and figures into ``out_dir``
    and return the flat metrics;
``prepare_discovery(cfg, root, record)`` and ``discover(prepared, out_dir)``
    the same two steps for ``studies discover``: what the model gets wrong,
    the cause, the extension and its gain (``discovery.json``, report).

``record`` is a :data:`Recorder` handed down by the command line: a study
that must log an analysis of its own (the simplified model's derivation)
opens its run through it, without knowing the tracking store.
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol

from ..config import DiscoverConfig, RunConfig

__all__ = ["StudyKind", "PreparedRun", "RecordedRun", "Recorder", "PreparedDiscovery", "gain_pct"]


class RecordedRun(Protocol):
    """A tracked run being recorded (an MLflow run)."""

    run_id: str

    def log_outputs(self, metrics: dict, directory: Path) -> None:
        """Log the flat ``metrics`` and every file of ``directory``."""


#: ``record(experiment, run name, params, tags)`` opens a tracked run
Recorder = Callable[[str, str, dict, dict], AbstractContextManager[RecordedRun]]


class PreparedRun(Protocol):
    """A study with checked settings and loaded records, ready to run."""

    name: str
    tags: dict
    #: ``(path, record, context)`` of every record file read ("training",
    #: "validation" or "simulation"), logged as the run's dataset inputs
    inputs: list

    def execute(self, out_dir: Path) -> dict:
        """Fit, validate, write the outputs into ``out_dir``; the flat metrics."""


@dataclass
class PreparedDiscovery:
    """The inputs of one discovery, checked and loaded.

    Attributes
    ----------
    cfg : DiscoverConfig
        The settings.
    kind : StudyKind
        The kind of study that runs the discovery.
    vessel, model
        The vessel and the baseline model (manoeuvring); None for roll decays.
    train, validation : list of DataFrame
        Records the causes are fitted to, and held-out records they are judged on.
    simulation : DataFrame or None
        Another simulator's run (``simulation.path``).
    notes : list of str
        What was decided on the user's behalf (e.g. which part was held out).
    records : list of DataFrame
        Every whole record given (``data.path`` then ``validate.path``), for
        ``discover.splits``.
    inputs : list
        ``(path, record, context)`` of every record file read, logged as
        the run's dataset inputs.
    """

    cfg: DiscoverConfig
    kind: "StudyKind"
    vessel: object
    model: object
    train: list
    validation: list
    simulation: object = None
    notes: list = field(default_factory=list)
    records: list = field(default_factory=list)
    inputs: list = field(default_factory=list)


class StudyKind(Protocol):
    """One kind of study (see the module's docstring)."""

    #: the ``model.study`` value that selects it
    kind: str

    def prepare(self, cfg: RunConfig, root: Path, record: Recorder) -> PreparedRun:
        """Check the inputs and get the records of ``studies run``."""

    def prepare_discovery(self, cfg: DiscoverConfig, root: Path, record: Recorder) -> PreparedDiscovery:
        """Check the inputs and load the records of ``studies discover``."""

    def discover(self, study: PreparedDiscovery, out_dir: Path) -> tuple[dict, dict]:
        """Run the discovery into ``out_dir``; ``(discovery, metrics)``."""


def gain_pct(baseline_rmse: float, extended_rmse: float) -> float:
    """What the extension gains on the validation error [%] (0 for a zero baseline error)."""
    return 100.0 * (baseline_rmse - extended_rmse) / baseline_rmse if baseline_rmse > 0 else 0.0
