"""The typed configuration of the command line: one dataclass per block of settings.

The YAML files under ``studies/conf/`` hold the values; the dataclasses of
this package are their schema. :func:`register` stores them in Hydra's
``ConfigStore`` (called at import of this package), and every YAML names its schema first in
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

Where each thing lives:

- :mod:`.values`: the allowed values of the settings and the checks of a value;
- :mod:`.conditions`: wind, current, sensor noise, disturbance, the GA's objective;
- :mod:`.data`: training manoeuvres, records, regression weights, Kalman smoother, validation;
- :mod:`.models`: vessel, manoeuvring and roll models, the simplified model's derivation;
- :mod:`.methods`: the identification methods' settings;
- :mod:`.manoeuvres`: a manoeuvre's settings and the packaged manoeuvres;
- :mod:`.tracking`: the MLflow store and the report's options;
- :mod:`.commands`: the settings of ``run``, ``discover``, ``report`` and ``simulate``;
- :mod:`.hydra`: the schemas in Hydra's ConfigStore, composing settings, explaining a type error.
"""

from .commands import (DiscoverConfig, DiscoverOptions, ReportCommandConfig, RunConfig, SimulateCommandConfig,
                       SimulationInput)
from .conditions import Current, Disturbance, Noise, Objective, Wind
from .data import Data, Identify, Kalman, Train, Validate, ValidationWind
from .hydra import SCHEMAS, UserConfigSearchPath, compose_settings, explain_validation_error, register
from .manoeuvres import ManoeuvreConfig, known_manoeuvres, manoeuvre_config
from .methods import BayesMethod, GaMethod, MethodConfig, SindyMethod, SvmMethod, settled_discrepancy
from .models import (MMGModelConfig, ModelConfig, RollModelConfig, RollSynthetic, SimplifiedModelConfig, Simplify,
                     VesselConfig)
from .tracking import ReportOptions, Tracking, TrackingStore
from .values import (BAYES_DISCREPANCIES, BAYES_MOVES, CONF_DIR, DATA_SCHEMES, DERIVATIVES, DISCOVERY_JUDGES, DISCOVERY_METHODS,
                     GA_BASES, GA_PARENT_SELECTIONS,
                     DISTURBANCE_SCALINGS, MANOEUVRE_KINDS, MMG_REFINABLE, MMG_SCALES, MMG_HULLS, OBJECTIVE_SIMULATIONS,
                     RECORD_SCALES, ROLL_DAMPING_TERMS, ROLL_TERMS, SINDY_COEFFICIENTS, SINDY_FOLDS,
                     SINDY_LIBRARIES, SINDY_RULES, SINDY_SELECTIONS, STUDY_KINDS, SVM_LOSSES,
                     USER_CONF_ENV, WEIGHTINGS, WIND_CONVENTIONS, user_conf_dir)

__all__ = [
    "Wind", "Current", "Noise", "Disturbance", "Objective", "Train", "Data", "Identify", "Kalman",
    "ValidationWind", "Validate", "Simplify", "ReportOptions", "Tracking", "TrackingStore",
    "VesselConfig", "ModelConfig", "SimplifiedModelConfig", "RollSynthetic", "RollModelConfig", "MMGModelConfig",
    "MethodConfig", "SvmMethod", "GaMethod", "BayesMethod", "SindyMethod", "ManoeuvreConfig",
    "RunConfig", "DiscoverOptions", "SimulationInput", "DiscoverConfig", "ReportCommandConfig",
    "SimulateCommandConfig", "UserConfigSearchPath",
    "register", "settled_discrepancy", "SCHEMAS", "known_manoeuvres", "manoeuvre_config", "explain_validation_error",
    "CONF_DIR", "USER_CONF_ENV", "user_conf_dir", "compose_settings",
    "DERIVATIVES", "DISCOVERY_JUDGES", "DISCOVERY_METHODS", "WEIGHTINGS", "STUDY_KINDS", "ROLL_TERMS", "ROLL_DAMPING_TERMS",
    "MANOEUVRE_KINDS", "SVM_LOSSES", "SINDY_LIBRARIES", "SINDY_SELECTIONS", "SINDY_RULES", "SINDY_COEFFICIENTS",
    "SINDY_FOLDS", "BAYES_MOVES", "BAYES_DISCREPANCIES", "DISTURBANCE_SCALINGS",
    "DATA_SCHEMES", "GA_BASES", "GA_PARENT_SELECTIONS", "WIND_CONVENTIONS", "OBJECTIVE_SIMULATIONS",
    "RECORD_SCALES", "MMG_REFINABLE", "MMG_SCALES", "MMG_HULLS",
]

register()
