"""The typed configuration of the command line: one dataclass per block of settings.

The YAML files under ``studies/conf/`` hold the values; the dataclasses here
are their schema. :func:`register` stores them in Hydra's ``ConfigStore``
(called at import of this module), and every YAML names its schema first in
its ``defaults:`` list (``- run_schema``, ``- bayes_schema``, ...), so that
Hydra type-checks every composed configuration: a key that is not declared
here, or a value of the wrong type, is refused while composing.

``OmegaConf.to_object(cfg)`` on a composed configuration (without its
``hydra`` node) then builds a :class:`RunConfig`, :class:`DiscoverConfig` or
:class:`ReportCommandConfig` whose ``method``, ``model`` and ``manoeuvre``
are instances of the dataclass of the chosen option. Every dataclass checks
its own values in ``__post_init__`` and raises
:class:`~studies.errors.ConfigError` naming the key in full (``wind.speed
must be >= 0.0, got -3.0``). Checks that depend on the working directory
(input files that must exist, output paths that must stay inside the
project) are left to the command line.

Units follow the YAML comments: speeds in m/s, angles in degrees, times in
seconds; fractions are plain numbers (0.05 = 5 %).
"""

import math
import os
from dataclasses import dataclass, field, fields, is_dataclass
from pathlib import Path
from typing import Any, List, Optional, Union, get_args, get_origin, get_type_hints

from hydra.core.config_search_path import ConfigSearchPath
from hydra.core.config_store import ConfigStore
from hydra.core.plugins import Plugins
from hydra.plugins.search_path_plugin import SearchPathPlugin
from omegaconf import II, MISSING, OmegaConf, flag_override
from omegaconf.errors import OmegaConfBaseException

from .errors import ConfigError

__all__ = [
    "Wind", "Current", "Noise", "Disturbance", "Train", "Data", "Identify", "Kalman",
    "ValidationWind", "Validate", "Simplify", "ReportOptions", "Tracking", "TrackingStore",
    "VesselConfig", "ModelConfig", "SimplifiedModelConfig", "RollSynthetic", "RollModelConfig",
    "MethodConfig", "SvmMethod", "GaMethod", "BayesMethod", "SindyMethod", "ManoeuvreConfig",
    "RunConfig", "DiscoverOptions", "SimulationInput", "DiscoverConfig", "ReportCommandConfig",
    "SimulateCommandConfig",
    "register", "settled_discrepancy", "SCHEMAS", "known_manoeuvres", "manoeuvre_config", "explain_validation_error",
    "CONF_DIR", "compose_settings", "DERIVATIVES", "DISCOVERY_METHODS", "WEIGHTINGS", "STUDIES", "ROLL_TERMS", "ROLL_DAMPING_TERMS",
    "MANOEUVRE_KINDS",
    "SVM_LOSSES", "SINDY_LIBRARIES", "BAYES_MOVES", "BAYES_DISCREPANCIES", "DISTURBANCE_SCALINGS",
    "DATA_SCHEMES",
]

#: the packaged config folder (``studies/conf``)
CONF_DIR = Path(__file__).resolve().parent / "conf"

#: ``data.derivative``: state/acceleration estimators
DERIVATIVES = ("auto", "central", "savgol", "forward", "ekf", "ekf_kinematic")
#: ``discover.method`` values
DISCOVERY_METHODS = ("inference", "search")
#: ``data.scheme``: how the training records of a simulated study are integrated
#: (:data:`studies.simulate.integrator.SCHEMES`)
DATA_SCHEMES = ("rk4", "euler")
#: ``identify.weights``: row weightings of the measured regression
WEIGHTINGS = ("none", "speed", "record", "speed_record")
#: ``model.study``: the study that runs a model
STUDIES = ("manoeuvring", "roll_decay")
#: ``model.terms`` of the roll model (omega0 is always identified)
ROLL_TERMS = ("b1", "b2", "b3", "c3")
#: roll damping terms, at least one of which the roll model needs
ROLL_DAMPING_TERMS = ("b1", "b2", "b3")
#: ``manoeuvre.kind``: the simulated kinds, and ``decay`` (roll decay, not simulated)
MANOEUVRE_KINDS = ("zigzag", "turning", "course", "rudder", "decay")
#: ``method.loss`` of the SVM
SVM_LOSSES = ("squared_epsilon_insensitive", "epsilon_insensitive")
#: ``method.library`` of SINDy
SINDY_LIBRARIES = ("model", "extended")
#: ``method.moves`` of the Bayesian regression
BAYES_MOVES = ("de", "stretch")
#: ``method.discrepancy`` of the Bayesian regression (:mod:`studies.identify.discrepancy`)
BAYES_DISCREPANCIES = ("auto", "none", "process_noise")
#: ``wind.convention``: the relative wind and moment of the Blendermann loads
#: (:class:`studies.vessels.base.WindParticulars`)
WIND_CONVENTIONS = ("downwind", "zhu2021")
#: ``objective.simulation``: how a trajectory objective simulates a training record
OBJECTIVE_SIMULATIONS = ("replay", "closed_loop")
#: ``disturbance.scaling``: how Wang et al. (2021) eq. 14 sizes the Wiener bias
#: (:mod:`studies.environment.noise`)
DISTURBANCE_SCALINGS = ("record", "per_second")


# ------------------------------------------------------------------ value checks

def _number(key: str, value, low: Optional[float] = None, high: Optional[float] = None) -> float:
    """``value`` as a finite float within ``[low, high]`` (ConfigError naming ``key``)."""
    if isinstance(value, bool):
        raise ConfigError(f"{key} must be a number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{key} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ConfigError(f"{key} must be finite, got {number}")
    if low is not None and number < low:
        raise ConfigError(f"{key} must be >= {low}, got {number}")
    if high is not None and number > high:
        raise ConfigError(f"{key} must be <= {high}, got {number}")
    return number


def _optional_number(key: str, value, low: Optional[float] = None,
                     high: Optional[float] = None) -> Optional[float]:
    return None if value is None else _number(key, value, low, high)


def _integer(key: str, value) -> int:
    """``value`` as an int (ConfigError naming ``key`` unless it is a whole number)."""
    if isinstance(value, bool):
        raise ConfigError(f"{key} must be an integer, got {value!r}")
    try:
        number = int(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{key} must be an integer, got {value!r}") from None
    if number != value and not isinstance(value, str):
        raise ConfigError(f"{key} must be an integer, got {value!r}")
    return number


def _flag(key: str, value) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{key} must be true or false, got {value!r}")
    return value


def _choice(key: str, value, allowed) -> str:
    if str(value) not in allowed:
        raise ConfigError(f"{key} must be one of {', '.join(allowed)}, got '{value}'")
    return str(value)


def _names(value) -> list:
    """A name or a list of names as a list of str."""
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    return [str(v) for v in value]


def _manoeuvre_files() -> dict:
    """``{name: YAML file}`` of the named manoeuvres: the packaged ones, and
    the user's (:func:`user_conf_dir`), which replace a packaged namesake."""
    folders = [CONF_DIR / "manoeuvre"]
    user = user_conf_dir()
    if user is not None:
        folders.append(user / "manoeuvre")
    return {p.stem: p for folder in folders for p in sorted(folder.glob("*.yaml"))}


def known_manoeuvres() -> list:
    """Names of the named manoeuvres (packaged and the user's), sorted."""
    return sorted(_manoeuvre_files())


def _check_manoeuvre_names(key: str, names) -> None:
    known = known_manoeuvres()
    for name in names:
        if str(name) not in known:
            raise ConfigError(f"{key}: unknown manoeuvre '{name}'; known: {', '.join(known)}")


# ------------------------------------------------------------------ environment and data

@dataclass
class Wind:
    """True wind during the training manoeuvres (``wind``).

    Attributes
    ----------
    speed : float
        True wind speed V_w [m/s], in [0, 100].
    direction : float
        Direction the wind comes from [deg], 0 = north; any finite value.
    convention : str
        How the wind loads form the relative wind (:data:`WIND_CONVENTIONS`):
        ``downwind`` (a wind pushes the ship downwind) or ``zhu2021`` (the
        thesis' eq. 3.17 as printed and coded, which mirrors the side force;
        for reproducing its tables). Used in the simulation of the training
        and validation manoeuvres and in the identification alike.
    """

    speed: float = 0.0
    direction: float = 45.0
    convention: str = "downwind"

    def __post_init__(self):
        self.speed = _number("wind.speed", self.speed, 0.0, 100.0)
        self.direction = _number("wind.direction", self.direction)
        self.convention = _choice("wind.convention", self.convention, WIND_CONVENTIONS)


@dataclass
class Objective:
    """How the trajectory objective simulates the training records (``objective``).

    The objective is thesis eq. 3.43 (the GA's fitness of ``method=ls_ga|svm_ga``,
    and the trajectory posterior of ``method=bayes``).

    Attributes
    ----------
    simulation : str
        ``replay`` (:data:`OBJECTIVE_SIMULATIONS`): each record's own rudder
        replayed from its first state; ``closed_loop``: each record's zig-zag
        steered again by the model, the rudder reversed when the simulated
        heading reaches the execute angle (the thesis' GA code, its appendix
        A.4); zig-zag records only.
    """

    simulation: str = "replay"

    def __post_init__(self):
        self.simulation = _choice("objective.simulation", self.simulation, OBJECTIVE_SIMULATIONS)


@dataclass
class Current:
    """Uniform current (``current``).

    Attributes
    ----------
    speed : float
        Current speed [m/s], in [0, 10].
    direction : float
        Direction the current flows to [deg]; any finite value.
    """

    speed: float = 0.0
    direction: float = 0.0

    def __post_init__(self):
        self.speed = _number("current.speed", self.speed, 0.0, 10.0)
        self.direction = _number("current.direction", self.direction)


@dataclass
class Noise:
    """Sensor errors of the simulated records (``noise``).

    Attributes
    ----------
    wind_speed_error : float
        Anemometer accuracy as a fraction, in [-0.99, 0.99]: the record
        carries ``V_p = V_w (1 + error)`` (thesis eq. 4.1).
    measurement : float
        Degree of measurement noise k0 of Sutulo & Guedes Soares, a
        fraction in [0, 1] (0.05 = 5 %).
    """

    wind_speed_error: float = 0.0
    measurement: float = 0.0

    def __post_init__(self):
        self.wind_speed_error = _number("noise.wind_speed_error", self.wind_speed_error, -0.99, 0.99)
        self.measurement = _number("noise.measurement", self.measurement, 0.0, 1.0)


@dataclass
class Disturbance:
    """Disturbance forces of the SVM paper (``disturbance``).

    Attributes
    ----------
    level : int
        Noise level NL0-NL3 (0-3) of the earth-fixed slowly varying bias.
    process : int
        Noise level NL0-NL3 (0-3) of the body-fixed process noise.
    scaling : str
        How eq. 14 (``max|clean prime force| k0 k_i zeta``) sizes the bias
        (:data:`DISTURBANCE_SCALINGS`): ``record`` (the bias's standard
        deviation at the end of each record equals the eq. 14 size) or
        ``per_second`` (the eq. 14 size per square-root second, so the
        bias grows as ``sqrt(t / 1 s)`` times it). The process noise is
        white of the eq. 14 size in both.
    """

    level: int = 0
    process: int = 0
    scaling: str = "record"

    def __post_init__(self):
        for key in ("level", "process"):
            value = getattr(self, key)
            if isinstance(value, bool) or value not in (0, 1, 2, 3):
                raise ConfigError(f"disturbance.{key} must be one of NL0-NL3 (0-3), got {value!r}")
            setattr(self, key, int(value))
        self.scaling = _choice("disturbance.scaling", self.scaling, DISTURBANCE_SCALINGS)


@dataclass
class Train:
    """Training manoeuvres (``train``).

    Attributes
    ----------
    manoeuvres : list of str
        Names of simulated training manoeuvres (``conf/manoeuvre/``);
        empty: the ``manoeuvre`` group alone.
    """

    manoeuvres: List[str] = field(default_factory=list)

    def __post_init__(self):
        self.manoeuvres = _names(self.manoeuvres)
        _check_manoeuvre_names("train.manoeuvres", self.manoeuvres)


#: ``data.scale``: the scale measured records are studied at
RECORD_SCALES = ("auto", "model", "full")


@dataclass
class Data:
    """Measured training records (``data``).

    Attributes
    ----------
    path : None, str or list of str
        A record file or a list of them; None: simulate ``manoeuvre`` of
        ``vessel``.
    derivative : str
        State/acceleration estimator: one of :data:`DERIVATIVES`
        (``forward``: the thesis' eq. 3.9, exact on records made by
        forward Euler steps).
    resample : float or None
        Step [s] to resample measured records to, > 0; None: their own
        median step.
    scheme : str
        How simulated training records are integrated (:data:`DATA_SCHEMES`):
        ``rk4`` (default) or ``euler``, forward Euler steps as the Marine
        Systems Simulator's ``zigzag.m`` takes them (the thesis' data).
        Validation manoeuvres and the trajectory objective simulate by RK4.
    scale : str
        Scale the measured records are studied at (:data:`RECORD_SCALES`):
        ``auto`` keeps each record's own scale when every training and
        validation record is at the same one and brings all to full scale
        when they mix (MARIN's full-scale files with HSVA's model-scale
        ones); ``model`` or ``full`` converts every record that states its
        scale by Froude similarity (:mod:`studies.data.scaling`).
    """

    path: Any = None
    derivative: str = "auto"
    resample: Optional[float] = None
    scheme: str = "rk4"
    scale: str = "auto"

    def __post_init__(self):
        self.derivative = _choice("data.derivative", self.derivative, DERIVATIVES)
        self.scale = _choice("data.scale", self.scale, RECORD_SCALES)
        self.scheme = _choice("data.scheme", self.scheme, DATA_SCHEMES)
        if self.resample is not None:
            try:
                step = float(self.resample)
            except (TypeError, ValueError):
                raise ConfigError(f"data.resample must be a step in seconds, got {self.resample!r}") from None
            if not (math.isfinite(step) and step > 0):
                raise ConfigError(f"data.resample must be a positive step in seconds, got {step}")
            self.resample = step


@dataclass
class Identify:
    """Options of the measured regression (``identify``).

    Attributes
    ----------
    weights : str
        Row weights: one of :data:`WEIGHTINGS` (``speed``: (U/U0)^4).
    """

    weights: str = "speed"

    def __post_init__(self):
        self.weights = _choice("identify.weights", self.weights, WEIGHTINGS)


@dataclass
class Kalman:
    """The Kalman smoother of measured records (``kalman``).

    Attributes
    ----------
    iterations : int
        EKF/RTS passes with the identified ship model after the kinematic
        one, >= 0.
    channels : list of str or None
        Measured channels used, a subset of x0 y0 psi u v r (null: all).
    noise_window : float or None
        Window [s] of the smooth fit whose residual gives the measurement noise (null: 10).
    noise_span : float or None
        Window [s] of the rolling variance of that residual (null: 30).
    measurement_std : mapping or None
        Fixed measurement standard deviations per channel, SI units
        (``{u: 0.05}``), overriding the data-driven ones.
    process_scale : float or None
        Multiplier of the default process-noise densities (null: chosen by
        maximum innovation likelihood over ``scale_grid``).
    scale_grid : list of float or None
        Candidate multipliers for that search (null: 10^-3 .. 10^3, half decades).
    discrepancy : float or None
        With the ship model as process model, the spectral density of the
        model discrepancy relative to the kinematic one (null: 0.1).
    bias : bool, list of str or None
        Estimate slowly varying biases of the velocity channels (true, false
        or a subset of u v r).
    bias_fraction : float or None
        Prior standard deviation of a bias, fraction of the channel's scale.
    bias_time : float or None
        Time [s] over which a bias may wander by its prior size.

    Null keeps the default of :class:`studies.identify.kalman.KalmanSettings`.
    """

    iterations: int = 2
    channels: Optional[List[str]] = None
    noise_window: Optional[float] = None
    noise_span: Optional[float] = None
    measurement_std: Optional[Any] = None
    process_scale: Optional[float] = None
    scale_grid: Optional[List[float]] = None
    discrepancy: Optional[float] = None
    bias: Optional[Any] = None
    bias_fraction: Optional[float] = None
    bias_time: Optional[float] = None

    def __post_init__(self):
        self.iterations = _integer("kalman.iterations", self.iterations)
        if self.iterations < 0:
            raise ConfigError(f"kalman.iterations must be >= 0, got {self.iterations}")


@dataclass
class ValidationWind:
    """Wind during the validation manoeuvres (``validate.wind``).

    Attributes
    ----------
    speed : float or None
        True wind speed [m/s], in [0, 100]; None: as in training.
    direction : float or None
        Direction the wind comes from [deg]; None: as in training.
    """

    speed: Optional[float] = None
    direction: Optional[float] = None

    def __post_init__(self):
        self.speed = _optional_number("validate.wind.speed", self.speed, 0.0, 100.0)
        self.direction = _optional_number("validate.wind.direction", self.direction)


@dataclass
class Validate:
    """What the identified model is judged on (``validate``).

    Attributes
    ----------
    path : None, str or list of str
        Measured records to predict (replayed with their own rudder).
    manoeuvres : list of str
        Simulated validation manoeuvres, names of ``conf/manoeuvre/`` (one
        name is taken as a list of one).
    duration : float or None
        Length [s] of the validation manoeuvres, > 0; None: their own.
    band_draws : int
        Posterior draws replayed for the predictive band (method=bayes), >= 0.
    compare_derivatives : bool
        Measured data: also validate with Savitzky-Golay derivatives.
    wind : ValidationWind
        Wind of the validation manoeuvres.
    """

    path: Any = None
    manoeuvres: Any = field(default_factory=lambda: ["zigzag_10_10", "zigzag_20_20",
                                                      "zigzag_40_40", "turning_35"])
    duration: Optional[float] = None
    band_draws: int = 50
    compare_derivatives: bool = True
    wind: ValidationWind = field(default_factory=ValidationWind)

    def __post_init__(self):
        self.manoeuvres = _names(self.manoeuvres)
        if self.duration is not None:
            duration = _number("validate.duration", self.duration)
            if duration <= 0:
                raise ConfigError(f"validate.duration must be positive [s], got {duration:g}")
            self.duration = duration
        _check_manoeuvre_names("validate.manoeuvres", self.manoeuvres)
        self.band_draws = _integer("validate.band_draws", self.band_draws)
        if self.band_draws < 0:
            raise ConfigError(f"validate.band_draws must be >= 0, got {self.band_draws}")
        self.compare_derivatives = _flag("validate.compare_derivatives", self.compare_derivatives)


@dataclass
class Simplify:
    """``studies simplify`` / model=simplified: correlation + PAWN (Li et al. 2023) (``simplify``).

    The realisations and PAWN samples of ``seeds`` independent seeds are
    pooled and the rule runs on ``draws`` random subsets of the pool, each
    of one seed's size (stability selection); a term is kept when it is
    selected in more than ``frequency`` of the draws, then what a
    manoeuvring model needs is put back (see
    :mod:`studies.workflows.simplify`).

    Attributes
    ----------
    output : str
        The model definition it writes (project-relative path).
    manoeuvre : str
        The simulated manoeuvre (a name of ``conf/manoeuvre/``).
    duration : float
        Length of that manoeuvre [s].
    dt : float
        Its sampling step [s].
    realisations : int
        Noisy realisations identified by least squares, per seed (>= 5).
    noise : float
        k0 of the measurement noise (fraction).
    derivative : str
        Derivative estimator of the regressions (one of :data:`DERIVATIVES`).
    threshold : float
        ``|Spearman rho|`` above which coefficients are grouped [-], in [0, 1].
    pawn_samples : int
        Trajectories per DOF for PAWN, per seed (>= 100).
    pawn_spread : float
        Coefficients sampled within ``(1 -/+ spread)`` of the estimates [-], in [0, 0.99].
    seed : int
        Seed of the noise and of the PAWN samples (the ``seeds`` sets are
        independent streams spawned from it), >= 0.
    seeds : int
        Independent sets of realisations and PAWN samples (>= 1).
    draws : int
        Draws of the rule, each on ``realisations`` of the pooled
        realisations and ``pawn_samples`` of the pooled PAWN samples (>= 1).
    frequency : float
        A term is kept when selected in more than this fraction of all
        draws [-], in [0, 0.99].
    """

    output: str = "models/simplified.json"
    manoeuvre: str = "zigzag_20_20"
    duration: float = 600.0
    dt: float = 0.1
    realisations: int = 50
    noise: float = 0.05
    derivative: str = "savgol"
    threshold: float = 0.7
    pawn_samples: int = 1000
    pawn_spread: float = 0.2
    seed: int = 0
    seeds: int = 6
    draws: int = 100
    frequency: float = 0.9

    def __post_init__(self):
        _check_manoeuvre_names("simplify.manoeuvre", [self.manoeuvre])
        self.duration = _number("simplify.duration", self.duration, 1.0)
        self.dt = _number("simplify.dt", self.dt, 1e-3, self.duration)
        self.noise = _number("simplify.noise", self.noise, 0.0, 1.0)
        self.derivative = _choice("simplify.derivative", self.derivative, DERIVATIVES)
        self.threshold = _number("simplify.threshold", self.threshold, 0.0, 1.0)
        self.pawn_spread = _number("simplify.pawn_spread", self.pawn_spread, 0.0, 0.99)
        self.frequency = _number("simplify.frequency", self.frequency, 0.0, 0.99)
        for key, low in (("realisations", 5), ("pawn_samples", 100), ("seeds", 1), ("draws", 1),
                         ("seed", 0)):
            value = _integer(f"simplify.{key}", getattr(self, key))
            if value < low:
                raise ConfigError(f"simplify.{key} must be an integer >= {low}, got {value}")
            setattr(self, key, value)


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


# ------------------------------------------------------------------ config groups

@dataclass
class VesselConfig:
    """An option of the ``vessel`` group.

    Attributes
    ----------
    name : str
        Registered vessel (``mariner``, ``kvlcc2``), or ``auto`` (the
        default of ``studies run`` and ``studies discover``): the ship the
        measured records name, the Mariner when the study simulates its
        records; a measured record that names no known ship is refused
        (:mod:`studies.workflows.vessel_choice`).
    """

    name: str = MISSING


@dataclass
class ModelConfig:
    """An option of the ``model`` group (``abkowitz``, ``symmetric``).

    Attributes
    ----------
    name : str
        Registered model.
    study : str
        The study that runs the model: one of :data:`STUDIES`.
    """

    name: str = MISSING
    study: str = "manoeuvring"

    def __post_init__(self):
        if self.study not in STUDIES:
            raise ConfigError(f"model.study must be one of {', '.join(STUDIES)}, got '{self.study}'")


@dataclass
class SimplifiedModelConfig(ModelConfig):
    """``model=simplified``: the model derived by ``studies simplify``.

    Attributes
    ----------
    definition : str
        The model definition file (default ``${simplify.output}``); derived
        on first use when it does not exist.
    """

    definition: str = II("simplify.output")


@dataclass
class RollSynthetic:
    """The roll decay simulated when ``data.path`` is empty (``model.synthetic``).

    Attributes
    ----------
    omega0 : float
        Natural frequency [rad/s], > 0.
    b1 : float
        Linear damping [1/s].
    b2 : float
        Quadratic damping [-].
    b3 : float
        Cubic damping [s] (angles in radians).
    c3 : float
        Cubic restoring [1/s^2] (angles in radians).
    phi0_deg : float
        Release angle [deg].
    duration : float
        Length of the record [s], > 0.
    dt : float
        Sampling step [s], in (0, duration).
    noise : float
        Standard deviation of the added noise as a fraction of the release
        angle, in [0, 1).
    """

    omega0: float = 2.5
    b1: float = 0.06
    b2: float = 0.40
    b3: float = 0.0
    c3: float = 0.0
    phi0_deg: float = 10.0
    duration: float = 60.0
    dt: float = 0.01
    noise: float = 0.0

    def __post_init__(self):
        if not (self.omega0 > 0 and self.duration > 0 and 0 < self.dt < self.duration):
            raise ConfigError("model.synthetic: omega0, duration and dt must be positive (dt < duration)")
        if not (0 <= self.noise < 1):
            raise ConfigError(f"model.synthetic.noise is a fraction in [0, 1), got {self.noise}")


@dataclass
class RollModelConfig(ModelConfig):
    """``model=roll``: 1-DOF roll decay (Chen et al. 2019).

    Attributes
    ----------
    terms : list of str
        Identified terms besides omega0: a subset of :data:`ROLL_TERMS`
        with at least one damping term (b1, b2, b3).
    synthetic : RollSynthetic
        The decay simulated when ``data.path`` is empty.
    holdout : float or None
        With one training decay and no ``validate.path``: the share of its
        half-cycles (the last ones) held out and predicted from their own
        initial state, in [0.05, 0.8]; None: nothing held out.
    """

    terms: List[str] = field(default_factory=lambda: ["b1", "b2"])
    synthetic: RollSynthetic = field(default_factory=RollSynthetic)
    study: str = "roll_decay"
    holdout: Optional[float] = None

    def __post_init__(self):
        super().__post_init__()
        self.terms = [str(t) for t in self.terms]
        unknown = set(self.terms) - set(ROLL_TERMS)
        if unknown:
            raise ConfigError(f"model.terms: unknown roll terms {sorted(unknown)}; "
                              f"known: {', '.join(ROLL_TERMS)}")
        if not any(t in ROLL_DAMPING_TERMS for t in self.terms):
            raise ConfigError(f"model.terms={self.terms}: the roll model needs at least one "
                              "damping term (b1, b2, b3)")
        self.holdout = _optional_number("model.holdout", self.holdout)
        if self.holdout is not None and not 0.05 <= self.holdout <= 0.8:
            raise ConfigError(f"model.holdout must be in [0.05, 0.8] or null, got {self.holdout}")


#: interaction factors ``model.output_error`` may list (``model=mmg``)
MMG_REFINABLE = ("tP", "wP0", "C1", "C2_plus", "C2_minus", "tR", "aH", "xH", "gammaR_minus",
                 "gammaR_plus", "lR", "epsilon", "kappa", "f_alpha")
#: scales of ``model.scale`` (``model=mmg``)
MMG_SCALES = ("auto", "model", "full")


@dataclass
class MMGModelConfig(ModelConfig):
    """``model=mmg``: the MMG standard method (hull terms, propeller, rudder).

    Attributes
    ----------
    prior_scale : float
        Prior standard deviation of each hull coefficient as a fraction of
        its prior (published) value [-], > 0; ``.inf`` for no prior.
    prior_floor : float
        Smallest prior standard deviation [-] (for coefficients near zero), > 0.
    output_error : list of str
        Interaction factors fitted by output error on the training
        trajectories (names of :data:`MMG_REFINABLE`); empty: the published
        values are kept.
    output_error_sample_s : float
        Sampling interval of the output-error residuals [s], > 0.
    output_error_evaluations : int
        Most trajectory evaluations of the output-error search, >= 1.
    weights : str
        Row weighting of the hull regression: ``none`` or ``speed``
        (``(U/U0)^4``).
    scale : str
        Scale of the records: ``model``, ``full`` (Froude scaled by the
        vessel's scale factor) or ``auto`` (the one whose approach speed is
        nearest the training records' initial speed).
    compare_abkowitz : bool
        Also identify the Abkowitz ``symmetric`` model (least squares, same
        records) and report it beside the MMG (``abkowitz/...`` metrics).
    captive : bool
        Compare the identified model with the vessel's captive tests
        (``captive.csv``, ``captive/...`` metrics) when it has them.
    captive_weight : float
        The captive tests' hull forces as rows of the regression, with this
        weight relative to the records (1: as much say as all the records
        together), >= 0; 0: not used.
    cross_validate : bool
        Also hold each measured training record out in turn, identify from
        the others and predict it (``cross_validation.md``, ``cv/...``
        metrics; :mod:`studies.workflows.cross_validation`); with
        ``method=bayes`` also judge each held-out record's predictive band
        (``calibration.md``, :mod:`studies.workflows.band_calibration`).
    cross_validate_jobs : int
        Folds identified at once (processes), >= 1; results do not depend on it.
    asymmetry : bool
        Add the constant side force and yaw moment ``Y0``, ``N0`` (prime,
        no prior) to the hull: a single-screw ship is not symmetric in calm
        water (it needs some rudder to go straight, and its zig-zags to
        port and to starboard differ).
    fit_wake : bool
        Fit the propeller's wake ``w_P0``, ``C_1``, ``C_2`` to the measured
        thrust of the training records that carry a ``thrust`` column
        (:mod:`studies.identify.mmg_propeller`); without one the published
        values are kept.
    """

    prior_scale: float = 0.5
    prior_floor: float = 0.005
    output_error: List[str] = field(default_factory=list)
    output_error_sample_s: float = 5.0
    output_error_evaluations: int = 80
    weights: str = "none"
    scale: str = "auto"
    compare_abkowitz: bool = True
    captive: bool = True
    captive_weight: float = 0.0
    cross_validate: bool = False
    cross_validate_jobs: int = 1
    asymmetry: bool = False
    fit_wake: bool = False

    def __post_init__(self):
        super().__post_init__()
        if not (self.prior_scale > 0 and self.prior_floor > 0):
            raise ConfigError(f"model.prior_scale and model.prior_floor must be positive, got "
                              f"{self.prior_scale} and {self.prior_floor}")
        self.output_error = [str(f) for f in self.output_error]
        unknown = sorted(set(self.output_error) - set(MMG_REFINABLE))
        if unknown:
            raise ConfigError(f"model.output_error: unknown interaction factors {unknown}; "
                              f"known: {', '.join(MMG_REFINABLE)}")
        if not (self.output_error_sample_s > 0 and self.output_error_evaluations >= 1):
            raise ConfigError("model.output_error_sample_s must be positive and "
                              "model.output_error_evaluations at least 1")
        if self.weights not in ("none", "speed"):
            raise ConfigError(f"model.weights must be none or speed, got '{self.weights}'")
        if not self.captive_weight >= 0:
            raise ConfigError(f"model.captive_weight must be >= 0, got {self.captive_weight}")
        self.cross_validate_jobs = _integer("model.cross_validate_jobs", self.cross_validate_jobs)
        if self.cross_validate_jobs < 1:
            raise ConfigError(f"model.cross_validate_jobs must be >= 1, got {self.cross_validate_jobs}")
        if self.scale not in MMG_SCALES:
            raise ConfigError(f"model.scale must be one of {', '.join(MMG_SCALES)}, got '{self.scale}'")


@dataclass
class MethodConfig:
    """An option of the ``method`` group without settings (``ls``, ``nls``, ``fls``, ``nls_svm``).

    Attributes
    ----------
    name : str
        Identification method.
    """

    name: str = MISSING


@dataclass
class SvmMethod(MethodConfig):
    """``method=svm``: linear epsilon-SVR per DOF (Zhu 2021; Wang et al. 2021).

    Attributes
    ----------
    c_grid : list of float
        Penalty C candidates [-], each > 0.
    epsilon_grid : list of float
        Tube half-width candidates, fraction of the RMS force/moment of the
        DOF [-], each >= 0.
    folds : int
        Contiguous time blocks of the cross-validation, >= 2.
    max_rows : int or None
        Rows for the search (None: all).
    loss : str
        One of :data:`SVM_LOSSES`.
    dual : bool or str
        liblinear formulation: ``auto``, true or false.
    max_iter : int
        Iteration limit of every liblinear fit.
    tol : float
        Relative stopping tolerance.
    scoring : str
        sklearn scorer of the search.
    seed : int
        Random state of the dual coordinate descent (default ``${seed}``).
    """

    c_grid: List[float] = field(default_factory=lambda: [1.0, 1.0e+2, 1.0e+4, 1.0e+6, 1.0e+8])
    epsilon_grid: List[float] = field(default_factory=lambda: [0.0, 1.0e-3, 1.0e-2])
    folds: int = 5
    max_rows: Optional[int] = 5000
    loss: str = "squared_epsilon_insensitive"
    dual: Any = "auto"
    max_iter: int = 10000
    tol: float = 1.0e-9
    scoring: str = "neg_mean_squared_error"
    seed: int = II("seed")

    def __post_init__(self):
        self.loss = _choice("method.loss", self.loss, SVM_LOSSES)
        if int(self.folds) < 2:
            raise ConfigError(f"method.folds must be at least 2, got {self.folds}")
        if not len(self.c_grid) or not len(self.epsilon_grid):
            raise ConfigError("method.c_grid and method.epsilon_grid need at least one value each")
        if min(self.c_grid) <= 0 or min(self.epsilon_grid) < 0:
            raise ConfigError("method.c_grid (C) must be > 0 and method.epsilon_grid >= 0")


@dataclass
class GaMethod(MethodConfig):
    """``method=ls_ga`` / ``svm_ga``: Sobol selection and GA refinement (Zhu 2021, 3.2.3-3.2.4).

    Attributes
    ----------
    base : str
        Regression giving the starting solution (``ls``, ``svm``).
    genes_per_dof : int
        Least Sobol-sensitive coefficients refined per DOF.
    genes : list of str or None
        Explicit coefficient names instead.
    sobol_samples : int
        N of the Sobol design.
    generations, population, parents_mating, keep_parents : int
        GA sizes (the population holds the identified solution and copies).
    crossover_probability, mutation_probability : float
        Probabilities in [0, 1].
    parent_selection : str
        pygad parent selection (``rank``).
    spread : float
        Gene bounds ``(1 -/+ spread)`` x identified value [-].
    stop_fitness : float
        Stop when the fitness (thesis eq. 3.43) reaches this.
    seed : int
        Seed of the GA (default ``${seed}``).
    """

    base: str = "ls"
    genes_per_dof: int = 5
    genes: Optional[List[str]] = None
    sobol_samples: int = 5000
    generations: int = 200
    population: int = 5
    parents_mating: int = 4
    keep_parents: int = 3
    crossover_probability: float = 0.6
    mutation_probability: float = 1.0
    parent_selection: str = "rank"
    spread: float = 0.5
    stop_fitness: float = 1.0e-5
    seed: int = II("seed")


@dataclass
class BayesMethod(MethodConfig):
    """``method=bayes``: regression posterior per DOF, optionally a trajectory posterior (emcee).

    With ``model=roll`` the roll posterior of :mod:`studies.roll.bayes` reads
    ``n_walkers``, ``n_samples``, ``burn_in``, ``thin``, ``seed``,
    ``init_scale``, ``moves``, ``corner_max``, ``autocorr_correction`` (AR(2)
    residuals; false: independent ones, the model taken as exact),
    ``discrepancy`` (``process_noise``: wander of the roll stiffness and
    linear damping, :mod:`studies.roll.discrepancy`) and
    ``discrepancy_evaluations`` and ``max_steps``; the ``trajectory_*`` settings and
    ``discrepancy_step`` belong to the manoeuvring posterior.

    Attributes
    ----------
    n_walkers : int or None
        Walkers per DOF, even and >= 4; None: max(32, 2 (p + 1)).
    n_samples : int
        Posterior samples kept per DOF, >= 1.
    burn_in : int
        Steps discarded, >= 0.
    thin : int
        Keep every thin-th step, >= 1.
    seed : int
        Seed of the samplers (default ``${seed}``; DOF k uses seed + k).
    init_scale : float
        Initial ball around the LS solution [LS standard errors], > 0.
    moves : str
        One of :data:`BAYES_MOVES`.
    autocorr_correction : bool
        Likelihood tempered by n_eff / n.
    corner_max : int
        Coefficients per corner plot.
    trajectory_terms : None, str or list of str
        None (skip), ``ga`` or coefficient names.
    trajectory_walkers : int or None
        Even and >= 4; None: max(8, 2 k + 2) for k terms.
    trajectory_steps : int
        Steps kept after burn-in, >= 1.
    trajectory_burn_in : int
        >= 0.
    trajectory_thin : int
        >= 1.
    trajectory_max_samples : int
        Compared samples per record and channel, >= 10.
    trajectory_duration : float or None
        First part of each record simulated [s]; None: whole record.
    trajectory_prior_width : float
        Flat prior ``|c - c_reg| <= width |c_reg|``, > 0.
    trajectory_init_scale : float
        Initial ball relative to ``|c_reg|``, > 0.
    trajectory_autocorr_correction : bool
        Effective-sample-size correction of the trajectory likelihood.
    discrepancy : str
        One of :data:`BAYES_DISCREPANCIES`: ``process_noise`` estimates a model
        discrepancy (AR(1) accelerations in surge, sway and yaw) from the
        training records and puts it into the predictive bands; ``none``
        takes the model as exact; ``auto`` (default) is ``process_noise`` on
        measured records and ``none`` on records the run simulates from a
        known model (:func:`settled_discrepancy`).
    discrepancy_step : float or None
        Records thinned to about this step [s] for its Kalman filter, > 0;
        None: as sampled.
    discrepancy_evaluations : int
        Most likelihood evaluations of its estimate, >= 1.
    max_steps : int or None
        The budget of a chain that has not converged (shorter than 50
        autocorrelation times): it runs on by itself up to this many steps
        after burn-in, then warns in one line naming this setting; None:
        never extended.
    """

    n_walkers: Optional[int] = None
    n_samples: int = 10000
    burn_in: int = 500
    thin: int = 12
    seed: int = II("seed")
    init_scale: float = 0.1
    moves: str = "de"
    autocorr_correction: bool = True
    corner_max: int = 8
    trajectory_terms: Any = None
    trajectory_walkers: Optional[int] = None
    trajectory_steps: int = 300
    trajectory_burn_in: int = 200
    trajectory_thin: int = 1
    trajectory_max_samples: int = 300
    trajectory_duration: Optional[float] = 600.0
    trajectory_prior_width: float = 1.0
    trajectory_init_scale: float = 0.01
    trajectory_autocorr_correction: bool = True
    discrepancy: str = "auto"
    discrepancy_step: Optional[float] = 0.5
    discrepancy_evaluations: int = 600
    max_steps: Optional[int] = 50000

    def __post_init__(self):
        self.discrepancy = _choice("method.discrepancy", self.discrepancy, BAYES_DISCREPANCIES)
        if self.max_steps is not None:
            self.max_steps = _integer("method.max_steps", self.max_steps)
            if self.max_steps < 1:
                raise ConfigError(f"method.max_steps must be null or >= 1, got {self.max_steps}")
        self.discrepancy_step = _optional_number("method.discrepancy_step", self.discrepancy_step)
        if self.discrepancy_step is not None and self.discrepancy_step <= 0:
            raise ConfigError("method.discrepancy_step must be positive [s] or null, "
                              f"got {self.discrepancy_step}")
        self.discrepancy_evaluations = _integer("method.discrepancy_evaluations",
                                                self.discrepancy_evaluations)
        if self.discrepancy_evaluations < 1:
            raise ConfigError("method.discrepancy_evaluations must be >= 1, "
                              f"got {self.discrepancy_evaluations}")
        for key, low in (("n_samples", 1), ("burn_in", 0), ("thin", 1), ("trajectory_steps", 1),
                         ("trajectory_burn_in", 0), ("trajectory_thin", 1),
                         ("trajectory_max_samples", 10)):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or int(value) != value or value < low:
                raise ConfigError(f"method.{key} must be an integer >= {low}, got {value!r}")
        for key in ("n_walkers", "trajectory_walkers"):
            value = getattr(self, key)
            if value is not None and (int(value) != value or value < 4 or value % 2):
                raise ConfigError(f"method.{key} must be an even integer >= 4, got {value!r}")
        if self.moves not in BAYES_MOVES:
            raise ConfigError(f"method.moves must be 'de' or 'stretch', got {self.moves!r}")
        if not (self.init_scale > 0 and self.trajectory_init_scale > 0 and self.trajectory_prior_width > 0):
            raise ConfigError("method.init_scale, trajectory_init_scale and "
                              "trajectory_prior_width must be positive")
        terms = self.trajectory_terms
        if terms is not None and terms != "ga" and (
                isinstance(terms, str) or not all(isinstance(t, str) for t in terms)):
            raise ConfigError("method.trajectory_terms must be null, 'ga' or a list of "
                              f"coefficient names, got {terms!r}")


@dataclass
class SindyMethod(MethodConfig):
    """``method=sindy``: sparse regression (STLSQ, Brunton et al. 2016).

    Attributes
    ----------
    threshold : float or None
        Smallest kept RMS contribution of a term / RMS force of its DOF [-],
        >= 0; None (the default): chosen per DOF by cross-validation over
        held-out records (or time blocks), the sparsest model within one
        standard error of the best.
    thresholds : list of float
        The thresholds the cross-validation tries (0: least squares), >= 0.
    alpha : float
        Ridge weight of the STLSQ passes relative to the mean squared residual [-], >= 0.
    library : str
        One of :data:`SINDY_LIBRARIES`.
    max_order : int
        Highest total order of the extended library, >= 1.
    max_iter : int
        Most STLSQ passes, >= 1.
    ensemble : int
        Block-bootstrap draws giving each term's inclusion probability, >= 0 (0: none).
    inclusion : float
        Smallest inclusion probability of a kept term, in (0, 1].
    block_s : float
        Length of the bootstrap's time blocks [s], > 0.
    seed : int
        Seed of the bootstrap.
    """

    threshold: Optional[float] = None
    thresholds: List[float] = field(default_factory=lambda: [0.0, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1])
    alpha: float = 1.0e-12
    library: str = "model"
    max_order: int = 3
    max_iter: int = 20
    ensemble: int = 20
    inclusion: float = 0.5
    block_s: float = 30.0
    seed: int = 0

    def __post_init__(self):
        self.library = _choice("method.library", self.library, SINDY_LIBRARIES)
        self.thresholds = [float(t) for t in self.thresholds]
        if (self.threshold is not None and self.threshold < 0) or self.alpha < 0 or not self.thresholds \
                or min(self.thresholds) < 0:
            raise ConfigError("method.threshold, method.thresholds and method.alpha must be >= 0")
        if int(self.max_order) < 1 or int(self.max_iter) < 1:
            raise ConfigError("method.max_order and method.max_iter must be >= 1")
        if int(self.ensemble) < 0 or not 0.0 < float(self.inclusion) <= 1.0 or not float(self.block_s) > 0:
            raise ConfigError("method.ensemble must be >= 0, method.inclusion in (0, 1] and method.block_s > 0")


@dataclass
class ManoeuvreConfig:
    """An option of the ``manoeuvre`` group: the simulated training manoeuvre.

    Attributes
    ----------
    name : str
        Record name (``zigzag_20_20``, ...).
    kind : str
        One of :data:`MANOEUVRE_KINDS`.
    amplitude : float or None
        Rudder amplitude [deg], in (0, 90] (zigzag, turning).
    heading : float or None
        Heading change that reverses the rudder (zigzag, > 0) or starts the
        pull-out (turning) [deg].
    duration : float or None
        Length of the record [s], > 0.
    dt : float or None
        Sampling step [s], in (0, duration].
    schedule : list of [t_start, t_end, value_deg] or None
        Heading reference (course) or commanded rudder (rudder) segments.
    first_sign : int or None
        Sign of the first rudder deflection (zigzag, turning): 1 (the
        default) lays a positive rudder first, which turns the Mariner to
        port (``Nd < 0``); -1 turns it to starboard first, as the Marine
        Systems Simulator's ``zigzag.m`` does (its ``mariner.m`` takes the
        command with the opposite sign).
    execute : float or None
        Time [s] the first rudder command is given (zigzag, turning), in
        [0, duration); before it the rudder is held amidships. MSS
        ``zigzag.m`` lays it when ``round(t)`` reaches its
        ``t_rudderexecute``: 9.5 s for the 10 s of the thesis' call.

    None leaves the simulator's default.
    """

    name: str = MISSING
    kind: str = MISSING
    amplitude: Optional[float] = None
    heading: Optional[float] = None
    duration: Optional[float] = None
    dt: Optional[float] = None
    schedule: Optional[List[List[float]]] = None
    first_sign: Optional[int] = None
    execute: Optional[float] = None

    def __post_init__(self):
        where = f"(manoeuvre '{self.name}')"
        if self.kind not in MANOEUVRE_KINDS:
            raise ConfigError(f"manoeuvre.kind: unknown kind '{self.kind}' {where} "
                              f"(known: {', '.join(MANOEUVRE_KINDS)})")
        if self.duration is not None and not self.duration > 0:
            raise ConfigError(f"manoeuvre.duration must be positive, got {self.duration} {where}")
        if self.dt is not None and not (0 < self.dt <= (self.duration or math.inf)):
            raise ConfigError(f"manoeuvre.dt must be in (0, duration], got {self.dt} {where}")
        if self.kind in ("zigzag", "turning") and self.amplitude is not None \
                and not (0 < abs(self.amplitude) <= 90):
            raise ConfigError(f"manoeuvre.amplitude: rudder amplitude must be in (0, 90] deg, "
                              f"got {self.amplitude} {where}")
        if self.kind == "zigzag" and self.heading is not None and not self.heading > 0:
            raise ConfigError(f"manoeuvre.heading: zig-zag heading must be positive, "
                              f"got {self.heading} {where}")
        if self.first_sign is not None and self.first_sign not in (1, -1):
            raise ConfigError(f"manoeuvre.first_sign must be 1 or -1, got {self.first_sign} {where}")
        if self.execute is not None and not (0 <= self.execute < (self.duration or math.inf)):
            raise ConfigError(f"manoeuvre.execute must be in [0, duration), got {self.execute} {where}")


def manoeuvre_config(name: str) -> ManoeuvreConfig:
    """The named manoeuvre ``manoeuvre/<name>.yaml`` (the user's, else the packaged one), checked.

    Raises :class:`ConfigError` for an unknown name (listing the known ones)
    or a file whose values are impossible.
    """
    path = _manoeuvre_files().get(name)
    if path is None:
        raise ConfigError(f"unknown manoeuvre '{name}'; known: {', '.join(known_manoeuvres())}")
    node = OmegaConf.load(path)
    with flag_override(node, "struct", False):
        node.pop("defaults", None)
    return OmegaConf.to_object(OmegaConf.merge(ManoeuvreConfig, node))


# ------------------------------------------------------------------ commands

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
    terms_threshold : float
        STLSQ threshold (unit-variance columns) of the missing-term search.
    max_terms : int
        Most terms added per DOF.
    second_cause : bool
        Try a second cause on top of the best one.
    posterior_steps : int
        emcee steps (after 15 of burn-in) for the winner's intervals.
    output_error : str or bool
        Refine by simulation (output error) before validating: ``auto``
        (noisy records), true or false.
    score : str
        How refined causes are scored and judged: ``prediction_error`` (the
        extended Kalman filter's innovation likelihood with process noise,
        the held-out records' one-step-ahead likelihood deciding) or
        ``output_error`` (BIC on the replay's residual, the held-out windows'
        replay error deciding).
    splits : bool
        Also hold out every record of data.path + validate.path in turn.
    method : str
        ``inference`` (every cause and pair of causes compared at once, the
        verdict's posterior probability its confidence:
        :mod:`studies.discover.inference`; any baseline, the MMG model
        included) or ``search`` (the earlier search: causes fitted one by
        one, named by rules on training scores and held-out windows;
        polynomial baselines only; ``terms_threshold``, ``max_terms``,
        ``posterior_steps``, ``output_error``, ``score`` and ``splits`` are
        its options).
    """

    holdout: float = 0.3
    horizon: Optional[float] = 120.0
    terms_threshold: float = 0.1
    max_terms: int = 3
    second_cause: bool = True
    posterior_steps: int = 40
    output_error: Any = "auto"
    score: str = "prediction_error"
    splits: bool = False
    method: str = "inference"

    def __post_init__(self):
        self.method = _choice("discover.method", self.method, DISCOVERY_METHODS)
        value = self.output_error
        if not isinstance(value, bool) and str(value).lower() not in ("auto", "true", "false"):
            raise ConfigError(f"discover.output_error must be auto, true or false, got {value!r}")
        if self.score not in ("prediction_error", "output_error"):
            raise ConfigError(f"discover.score must be prediction_error or output_error, got {self.score!r}")
        share = _number("discover.holdout", self.holdout)
        if not 0.05 <= share <= 0.8:
            raise ConfigError(f"discover.holdout must be in [0.05, 0.8], got {share}")
        self.holdout = share
        self.splits = _flag("discover.splits", self.splits)


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


# ------------------------------------------------------------------ Hydra

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
    return node


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


#: environment variable naming a folder of the user's own configs (default ``./conf``)
USER_CONF_ENV = "STUDIES_CONF"


def user_conf_dir() -> Optional[Path]:
    """The user's config folder: ``$STUDIES_CONF`` when set, else ``conf/`` in
    the working directory; None when it does not exist."""
    folder = Path(os.environ.get(USER_CONF_ENV) or Path.cwd() / "conf").expanduser()
    return folder.resolve() if folder.is_dir() else None


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


register()


def settled_discrepancy(method, measured: bool) -> str | None:
    """Settle ``method.discrepancy=auto`` in place; the sentence to log, or None.

    On measured records the model is never exact: the bands carry the
    model discrepancy (``process_noise``), the setting the leave-one-record-out
    calibration of the KVLCC2 records judges (``experiment=kvlcc2_calibration``);
    a model without it is overconfident there. On records simulated from a
    known model the model is exact and ``auto`` is ``none``. An explicit
    ``none`` or ``process_noise`` is kept. ``method`` is the typed
    ``method`` settings; other methods are left alone.
    """
    if getattr(method, "discrepancy", None) != "auto":
        return None
    method.discrepancy = "process_noise" if measured else "none"
    if measured:
        return ("method.discrepancy=auto: process_noise on measured records (the model discrepancy in the "
                "bands; without it they are overconfident on records the model was not trained on); "
                "method.discrepancy=none takes the model as exact")
    return "method.discrepancy=auto: none on records simulated from a known model (the model is exact)"
