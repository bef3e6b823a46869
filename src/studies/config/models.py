"""Settings of the ship and its model: the vessel, the manoeuvring models (Abkowitz, simplified,
MMG) and the roll decay model, and how the simplified model is derived.
"""

from dataclasses import dataclass, field
from typing import List, Optional

from omegaconf import II, MISSING

from ..errors import ConfigError
from .values import (DERIVATIVES, STUDY_KINDS, ROLL_TERMS, ROLL_DAMPING_TERMS, MMG_REFINABLE, MMG_SCALES, MMG_HULLS, _number,
                     _optional_number, _integer, _choice)
from .manoeuvres import _check_manoeuvre_names

__all__ = ["Simplify", "VesselConfig", "ModelConfig", "SimplifiedModelConfig", "RollSynthetic", "RollModelConfig",
           "MMGModelConfig"]


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
        The study that runs the model: one of :data:`STUDY_KINDS`.
    """

    name: str = MISSING
    study: str = "manoeuvring"

    def __post_init__(self):
        if self.study not in STUDY_KINDS:
            raise ConfigError(f"model.study must be one of {', '.join(STUDY_KINDS)}, got '{self.study}'")


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
        (:mod:`studies.identification.mmg_propeller`); without one the published
        values are kept.
    rudder_lift : str
        ``published``: the vessel's rudder lift gradient ``f_alpha`` and the
        standard method's normal force, linear in ``sin(alpha_R)``. ``fit``:
        ``f_alpha`` and the quadratic ``f_alpha_2`` identified with the hull
        from the training records (:mod:`studies.identification.mmg_rudder`).
    hull : str
        The hull's family of terms (:data:`studies.models.mmg.HULL_FAMILIES`):
        ``standard`` (the 17 terms of the MMG standard method), ``thrust``
        (those and a side force, yaw moment and rudder force growing with the
        thrust loading ``T'``: ``YT NT YTd NTd``) or ``reduced`` (Alexandersson
        et al. 2022: no cubic terms, the rudder in the hull's terms ``delta,
        T' delta, v'^2 delta`` with the rudder module off, ``u' = cos(beta)``
        terms; measured records only, no prior; ``model.asymmetry`` adds
        nothing to it: its ``Yu, Nu, YT, NT`` carry the asymmetry),
        ``crossflow`` (Yoshimura's unified model: the standard surge terms,
        ``Yv Yr Nv Nr`` and the cross-flow drag of the hull's strips
        ``YCF``, ``NCF`` in place of the cubic terms) or ``auto``: the family the training records support, by their
        leave-one-record-out cross-validation and the physics of the turn
        (:mod:`studies.workflows.hull_choice`; measured records only).
    tie_rudder : bool
        For a family that carries the rudder in its hull terms (``reduced``):
        the rudder's yaw moment is its side force times the lever
        ``(x_R + a_H x_H) / ((1 + a_H) L)`` (about -0.49 L), each pair
        ``Yd/Nd``, ``YTd/NTd``, ``Yvvd/Nvvd`` regressed as one coefficient on
        the sway and yaw rows together (:data:`studies.models.mmg.RUDDER_TIES`),
        as Alexandersson et al. (2022) do; ``false``: each term free.
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
    rudder_lift: str = "published"
    hull: str = "standard"
    tie_rudder: bool = True

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
        if self.rudder_lift not in ("published", "fit"):
            raise ConfigError(f"model.rudder_lift must be published or fit, got '{self.rudder_lift}'")
        if self.hull not in MMG_HULLS:
            raise ConfigError(f"model.hull must be one of {', '.join(MMG_HULLS)}, got '{self.hull}'")
        if self.hull in ("reduced", "auto") and (self.rudder_lift == "fit" or self.output_error):
            raise ConfigError(f"model.hull={self.hull}: the reduced family carries the rudder in its hull "
                              "terms, so model.rudder_lift=fit and model.output_error do not apply to it")
        if not self.captive_weight >= 0:
            raise ConfigError(f"model.captive_weight must be >= 0, got {self.captive_weight}")
        self.cross_validate_jobs = _integer("model.cross_validate_jobs", self.cross_validate_jobs)
        if self.cross_validate_jobs < 1:
            raise ConfigError(f"model.cross_validate_jobs must be >= 1, got {self.cross_validate_jobs}")
        if self.scale not in MMG_SCALES:
            raise ConfigError(f"model.scale must be one of {', '.join(MMG_SCALES)}, got '{self.scale}'")
