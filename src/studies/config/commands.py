"""The settings of each command: ``studies run`` (:class:`RunConfig`), ``studies discover``,
``studies report`` and ``studies simulate``.
"""

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Dict, Optional

from omegaconf import MISSING

from ..errors import ConfigError
from .values import DISCOVERY_JUDGES, DISCOVERY_METHODS, _number, _integer, _flag, _choice
from .conditions import Wind, Objective, Current, Noise, Disturbance
from .data import Train, Data, Identify, Kalman, Validate
from .models import Simplify, VesselConfig, ModelConfig
from .tracking import ReportOptions, TrackingStore, Tracking
from .methods import MethodConfig
from .manoeuvres import ManoeuvreConfig

__all__ = ["SimulationInput", "RunConfig", "DiscoverOptions", "DiscoverConfig", "ReportCommandConfig",
           "SimulateCommandConfig"]


@dataclass
class SimulationInput:
    """Another simulator's record (``simulation``).

    Attributes
    ----------
    path : str or None
        A record of another simulator (e.g. a potential-flow roll decay) to
        judge against the measurements of ``data.path``: by ``studies run
        model=roll`` and by ``studies discover``.
    """

    path: Optional[str] = None


@dataclass
class RunConfig:
    """``studies run`` / ``studies simplify`` (``conf/config.yaml``).

    Attributes
    ----------
    seed : int
        Seed of everything random, >= 0.
    verbose : bool
        Show tracebacks instead of one-line errors.
    resume : bool
        Skip jobs whose config already has a FINISHED run.
    run_name : str or None
        MLflow run name; None: built from method/manoeuvre/wind.
    preset : str or None
        Set by experiment presets.
    wind, current, noise, disturbance, objective, train, data, identify, kalman, validate, simplify, report,
    tracking, simulation
        The blocks of settings (see their classes).
    vessel, model, method, manoeuvre
        The chosen option of each config group.
    """

    seed: int = 0
    verbose: bool = False
    resume: bool = False
    run_name: Optional[str] = None
    preset: Optional[str] = None
    wind: Wind = field(default_factory=Wind)
    current: Current = field(default_factory=Current)
    noise: Noise = field(default_factory=Noise)
    disturbance: Disturbance = field(default_factory=Disturbance)
    objective: Objective = field(default_factory=Objective)
    train: Train = field(default_factory=Train)
    data: Data = field(default_factory=Data)
    identify: Identify = field(default_factory=Identify)
    kalman: Kalman = field(default_factory=Kalman)
    validate: Validate = field(default_factory=Validate)
    simplify: Simplify = field(default_factory=Simplify)
    report: ReportOptions = field(default_factory=ReportOptions)
    simulation: SimulationInput = field(default_factory=SimulationInput)
    tracking: Tracking = field(default_factory=Tracking)
    vessel: VesselConfig = MISSING
    model: ModelConfig = MISSING
    method: MethodConfig = MISSING
    manoeuvre: ManoeuvreConfig = MISSING

    def __post_init__(self):
        self.seed = _integer("seed", self.seed)
        if self.seed < 0:
            raise ConfigError(f"seed must be non-negative, got {self.seed}")
        self.verbose = _flag("verbose", self.verbose)
        self.resume = _flag("resume", self.resume)
        study = getattr(self.model, "study", "manoeuvring")
        if self.tracking.register and study != "manoeuvring":
            raise ConfigError(f"tracking.register: a {study} run logs no MLflow model to register "
                              "(only manoeuvring models are logged as MLflow models)")


@dataclass
class DiscoverOptions:
    """Options of ``studies discover`` (``discover``).

    Attributes
    ----------
    holdout : float
        Share of a single training record held out when ``validate.path``
        is empty (manoeuvres: its last samples; roll decays: its last
        half-cycles, time-blocked), in [0.05, 0.8].
    horizon : float or None
        Prediction windows of the validation error [s]; None: whole records.
    second_cause : bool
        Try a second cause on top of the best one.
    splits : bool
        Also hold out every record of data.path + validate.path in turn: the
        baseline and the named model identified on the others and judged on
        it (does the gain hold on every manoeuvre).
    method : str
        ``inference``: every cause and pair of the catalogue judged at once
        by one criterion (:mod:`studies.discovery.track_inference` and
        :mod:`studies.discovery.inference`), on any baseline, the MMG model
        included.
    injected : dict
        An effect whose truth is known (injected into the records, or hidden
        in a simulation): ``{cause id: {parameter: value}}``, one or two
        causes, the catalogue's parameters in its units (prime coefficients,
        m/s, rad; a missing term by its coefficient, ``{missing_term: {Nrrr:
        -0.002}}``). Scored on the tracks at those values by the verdict's
        own criterion (:mod:`studies.discovery.stated_effect`): whether the
        records can show it at all, written as ``injected`` in
        ``discovery.json`` and the report. It changes nothing of the verdict.
        Empty (the default): nothing stated.
    judge : str
        What ``method=inference`` judges the causes on: ``tracks`` (the
        baseline's prediction-error filter over the measured records, every
        cause by its gain in the one-step-ahead predictions:
        :mod:`studies.discovery.track_inference`), ``blocks`` (held-out time
        blocks of the smoothed records' accelerations:
        :mod:`studies.discovery.inference`) or ``auto`` (tracks for a
        polynomial baseline, blocks for the MMG model: on the measured
        KVLCC2 records the tracks name the MMG model's own errors as a
        current, docs/discovery.md).
    """

    holdout: float = 0.3
    horizon: Optional[float] = 120.0
    second_cause: bool = True
    splits: bool = False
    method: str = "inference"
    judge: str = "auto"
    injected: Dict[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        if str(self.method) == "search":
            raise ConfigError("discover.method=search: the rule-based search was retired; the inference (the "
                              "default, discover.method=inference) judges the whole catalogue, propulsion "
                              "included, and keeps discover.splits and simulation.path")
        self.method = _choice("discover.method", self.method, DISCOVERY_METHODS)
        self.judge = _choice("discover.judge", self.judge, DISCOVERY_JUDGES)
        share = _number("discover.holdout", self.holdout)
        if not 0.05 <= share <= 0.8:
            raise ConfigError(f"discover.holdout must be in [0.05, 0.8], got {share}")
        self.holdout = share
        self.splits = _flag("discover.splits", self.splits)
        self.injected = _injected(self.injected) if self.injected else {}


def _injected(value) -> dict:
    """``discover.injected`` checked: one or two causes, each with finite
    numbers by parameter name (the causes and their parameters are checked
    against the catalogue, the baseline and the records once they are known,
    before anything runs: :func:`studies.discovery.stated_effect.stated_causes`)."""
    stated = {}
    for cid, values in dict(value).items():
        if values is not None and not isinstance(values, Mapping):
            raise ConfigError(f"discover.injected.{cid}: expected {{parameter: value}}, got {values!r}")
        stated[str(cid)] = {str(k): v for k, v in dict(values or {}).items()}
    if not 1 <= len(stated) <= 2:
        raise ConfigError(f"discover.injected: one or two causes, got {len(stated)}")
    for cid, values in stated.items():
        for name, x in values.items():
            values[name] = _number(f"discover.injected.{cid}.{name}", x)
    return stated


@dataclass
class DiscoverConfig(RunConfig):
    """``studies discover`` (``conf/discover.yaml``): the run configuration plus
    the discovery's options.

    Attributes
    ----------
    discover : DiscoverOptions
        The discovery's own options.
    """

    tracking: Tracking = field(default_factory=lambda: Tracking(experiment="discover"))
    discover: DiscoverOptions = field(default_factory=DiscoverOptions)

    def __post_init__(self):
        super().__post_init__()
        if self.tracking.register:
            raise ConfigError("tracking.register: studies discover logs no model to register; "
                              "a studies run of the extended model does")


@dataclass
class ReportCommandConfig:
    """``studies report`` (``conf/report.yaml``).

    Attributes
    ----------
    verbose : bool
        Show tracebacks instead of one-line errors.
    report : ReportOptions
        Which experiment, and where the pages go.
    tracking : Tracking
        Where the runs are.
    """

    verbose: bool = False
    report: ReportOptions = field(default_factory=ReportOptions)
    tracking: Tracking = field(default_factory=Tracking)

    def __post_init__(self):
        self.verbose = _flag("verbose", self.verbose)


@dataclass
class SimulateCommandConfig:
    """``studies simulate`` (``conf/simulate.yaml``).

    Attributes
    ----------
    verbose : bool
        Show tracebacks instead of one-line errors.
    model_uri : str or None
        The model to simulate: ``runs:/<run id>/model`` (logged by ``studies
        run``), ``models:/<name>/<version>`` (registered with
        ``tracking.register``) or a local MLflow model folder; None: the
        published model of ``vessel`` (its Abkowitz coefficients, or its MMG
        model when it has none).
    tracking : TrackingStore
        The store the URI is looked up in (``tracking.uri``).
    vessel, manoeuvre
        The vessel of the published model (without ``model_uri``), and the
        manoeuvre to simulate (``manoeuvre.duration=`` and
        ``manoeuvre.dt=`` [s] replace its own).
    """

    verbose: bool = False
    model_uri: Optional[str] = None
    tracking: TrackingStore = field(default_factory=TrackingStore)
    vessel: VesselConfig = MISSING
    manoeuvre: ManoeuvreConfig = MISSING

    def __post_init__(self):
        self.verbose = _flag("verbose", self.verbose)
        if self.manoeuvre.kind == "decay":
            raise ConfigError(f"manoeuvre: '{self.manoeuvre.name}' is a roll decay; studies simulate "
                              "simulates manoeuvring models (zig-zag, turning, course, rudder)")
