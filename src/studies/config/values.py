"""The allowed values of the settings (defined once: modules that need them import them from here)
and the checks the dataclasses run on their values (one line naming the key in full).
"""

import math
import os
from pathlib import Path
from typing import Optional

from ..errors import ConfigError

__all__ = ["CONF_DIR", "DERIVATIVES", "DISCOVERY_METHODS", "DISCOVERY_JUDGES", "DATA_SCHEMES", "WEIGHTINGS", "STUDY_KINDS", "ROLL_TERMS",
           "ROLL_DAMPING_TERMS", "MANOEUVRE_KINDS", "SVM_LOSSES", "SINDY_LIBRARIES", "SINDY_SELECTIONS", "SINDY_RULES",
           "SINDY_COEFFICIENTS", "SINDY_FOLDS", "BAYES_MOVES", "GA_BASES",
           "GA_PARENT_SELECTIONS",
           "BAYES_DISCREPANCIES", "WIND_CONVENTIONS", "OBJECTIVE_SIMULATIONS", "DISTURBANCE_SCALINGS",
           "RECORD_SCALES", "MMG_REFINABLE", "MMG_SCALES", "MMG_HULLS", "USER_CONF_ENV", "user_conf_dir"]


#: the packaged config folder (``studies/conf``)
CONF_DIR = Path(__file__).resolve().parent.parent / "conf"


#: ``data.derivative``: state/acceleration estimators
DERIVATIVES = ("auto", "central", "savgol", "forward", "ekf", "ekf_kinematic")


#: ``discover.method`` values
DISCOVERY_METHODS = ("inference",)
#: what the inference judges causes on (``discover.judge``): ``auto`` = tracks for a polynomial
#: baseline, blocks for the MMG model
DISCOVERY_JUDGES = ("auto", "tracks", "blocks")


#: ``data.scheme``: how the training records of a simulated study are integrated
#: (:data:`studies.simulate.integrator.SCHEMES`)
DATA_SCHEMES = ("rk4", "euler")


#: ``identify.weights``: row weightings of the measured regression
WEIGHTINGS = ("none", "speed", "record", "speed_record")


#: ``model.study``: the study that runs a model
STUDY_KINDS = ("manoeuvring", "roll_decay")


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
#: ``method.selection`` of SINDy: what the threshold's cross-validation scores
SINDY_SELECTIONS = ("equation", "simulation")
#: ``method.rule`` of SINDy: how the cross-validation picks among thresholds
SINDY_RULES = ("one_se", "paired_se", "min")
#: ``method.coefficients`` of SINDy: the kept terms' values with an ensemble
SINDY_COEFFICIENTS = ("refit", "median")
#: ``method.folds`` of SINDy: what ``selection=simulation`` holds out
SINDY_FOLDS = ("blocks", "records")


#: ``method.moves`` of the Bayesian regression
BAYES_MOVES = ("de", "stretch")


#: ``method.base`` of the GA: the regression that gives its starting solution
#: (:data:`studies.identification.ga.BASE_METHODS`)
GA_BASES = ("ls", "svm")


#: ``method.parent_selection`` of the GA (pygad's parent selection types)
GA_PARENT_SELECTIONS = ("sss", "rws", "sus", "rank", "random", "tournament")


#: ``method.discrepancy`` of the Bayesian regression (:mod:`studies.identification.discrepancy`)
BAYES_DISCREPANCIES = ("auto", "none", "process_noise")


#: ``wind.convention``: the relative wind and moment of the Blendermann loads
#: (:class:`studies.vessels.base.WindParticulars`)
WIND_CONVENTIONS = ("downwind", "zhu2021")


#: ``objective.simulation``: how a trajectory objective simulates a training record
OBJECTIVE_SIMULATIONS = ("replay", "closed_loop")


#: ``disturbance.scaling``: how Wang et al. (2021) eq. 14 sizes the Wiener bias
#: (:mod:`studies.environment.noise`)
DISTURBANCE_SCALINGS = ("record", "per_second")


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


#: ``data.scale``: the scale measured records are studied at
RECORD_SCALES = ("auto", "model", "full")


#: interaction factors ``model.output_error`` may list (``model=mmg``)
MMG_REFINABLE = ("tP", "wP0", "C1", "C2_plus", "C2_minus", "tR", "aH", "xH", "gammaR_minus",
                 "gammaR_plus", "lR", "epsilon", "kappa", "f_alpha")


#: scales of ``model.scale`` (``model=mmg``)
MMG_SCALES = ("auto", "model", "full")
#: the MMG hull families of ``model.hull`` (the names of :data:`studies.models.mmg.HULL_FAMILIES`),
#: and ``auto``: the one the training records support (:mod:`studies.workflows.hull_choice`)
MMG_HULLS = ("standard", "thrust", "reduced", "crossflow", "auto")


#: environment variable naming a folder of the user's own configs (default ``./conf``)
USER_CONF_ENV = "STUDIES_CONF"


def user_conf_dir() -> Optional[Path]:
    """The user's config folder: ``$STUDIES_CONF`` when set, else ``conf/`` in
    the working directory; None when it does not exist."""
    folder = Path(os.environ.get(USER_CONF_ENV) or Path.cwd() / "conf").expanduser()
    return folder.resolve() if folder.is_dir() else None
