"""Settings of the identification methods (``method=``): SVM, GA, Bayesian regression, SINDy.
"""

from dataclasses import dataclass, field
from typing import Any, List, Optional

from omegaconf import II, MISSING

from ..errors import ConfigError
from .values import (GA_BASES, GA_PARENT_SELECTIONS, SVM_LOSSES, SINDY_LIBRARIES, SINDY_SELECTIONS, SINDY_RULES,
                     SINDY_COEFFICIENTS, SINDY_FOLDS, BAYES_MOVES,
                     BAYES_DISCREPANCIES, _optional_number,
                     _integer, _choice)

__all__ = ["MethodConfig", "SvmMethod", "GaMethod", "BayesMethod", "SindyMethod", "settled_discrepancy"]


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

    def __post_init__(self):
        self.base = _choice("method.base", self.base, GA_BASES)
        self.parent_selection = _choice("method.parent_selection", self.parent_selection, GA_PARENT_SELECTIONS)
        for key, low in (("genes_per_dof", 1), ("sobol_samples", 1), ("generations", 1), ("population", 2),
                         ("parents_mating", 1), ("keep_parents", -1)):
            setattr(self, key, _integer(f"method.{key}", getattr(self, key)))
            if getattr(self, key) < low:
                raise ConfigError(f"method.{key} must be >= {low}, got {getattr(self, key)}")
        if self.parents_mating > self.population or self.keep_parents > self.population:
            raise ConfigError(f"method.parents_mating ({self.parents_mating}) and method.keep_parents "
                              f"({self.keep_parents}) must not exceed method.population ({self.population})")
        for key in ("crossover_probability", "mutation_probability"):
            if not 0.0 <= float(getattr(self, key)) <= 1.0:
                raise ConfigError(f"method.{key} must be in [0, 1], got {getattr(self, key)}")
        if not self.spread > 0 or not self.stop_fitness >= 0:
            raise ConfigError(f"method.spread must be > 0 and method.stop_fitness >= 0, got {self.spread} "
                              f"and {self.stop_fitness}")


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
    discrepancy_out_of_sample : bool
        Each training record filtered by the coefficients identified
        without it (default), so that the discrepancy is what the model
        misses on a record it did not train on; false: every record at the
        posterior medians.
    discrepancy_mean : bool
        A mean of the discrepancy that depends on the state (the speed lost
        in a turn, ...), fitted to the training records' smoothed
        discrepancy and added to the bands; false (default): centred on the
        model (the mean, learnt on the training records, misleads a record
        beyond them: docs/calibration.md).
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
    discrepancy_out_of_sample: bool = True
    discrepancy_mean: bool = False
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
    selection : str
        What the threshold's cross-validation scores: ``equation`` (the
        held-out one-step equation error, per DOF) or ``simulation`` (the
        replayed position of held-out time blocks [m^2], one threshold for
        all DOFs; ``library=model`` only).
    rule : str
        How it picks: ``one_se`` (sparsest within one standard error of the
        best), ``paired_se`` (the same with the standard error of the
        fold-by-fold difference to the best) or ``min`` (the best).
    coefficients : str
        Kept terms' values with an ensemble: ``refit`` (least squares on
        every row) or ``median`` (median of the bootstrap draws, E-SINDy bragging).
    folds : str
        What ``selection=simulation`` holds out: ``blocks`` (the k-th fifth of
        every record) or ``records`` (each whole record in turn).
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
    selection: str = "equation"
    rule: str = "one_se"
    coefficients: str = "refit"
    folds: str = "blocks"

    def __post_init__(self):
        self.library = _choice("method.library", self.library, SINDY_LIBRARIES)
        self.selection = _choice("method.selection", self.selection, SINDY_SELECTIONS)
        self.rule = _choice("method.rule", self.rule, SINDY_RULES)
        self.coefficients = _choice("method.coefficients", self.coefficients, SINDY_COEFFICIENTS)
        self.folds = _choice("method.folds", self.folds, SINDY_FOLDS)
        self.thresholds = [float(t) for t in self.thresholds]
        if (self.threshold is not None and self.threshold < 0) or self.alpha < 0 or not self.thresholds \
                or min(self.thresholds) < 0:
            raise ConfigError("method.threshold, method.thresholds and method.alpha must be >= 0")
        if int(self.max_order) < 1 or int(self.max_iter) < 1:
            raise ConfigError("method.max_order and method.max_iter must be >= 1")
        if int(self.ensemble) < 0 or not 0.0 < float(self.inclusion) <= 1.0 or not float(self.block_s) > 0:
            raise ConfigError("method.ensemble must be >= 0, method.inclusion in (0, 1] and method.block_s > 0")


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
