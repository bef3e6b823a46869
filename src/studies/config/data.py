"""Settings of the records: which manoeuvres train, how records are read and differentiated, the
regression's weights, the Kalman smoother, and what the identified model is validated on.
"""

import math
from dataclasses import dataclass, field
from typing import Any, List, Optional

from ..errors import ConfigError
from .values import (DERIVATIVES, DATA_SCHEMES, WEIGHTINGS, RECORD_SCALES, _number, _optional_number,
                     _integer, _flag, _choice, _names)
from .conditions import Wind
from .manoeuvres import _check_manoeuvre_names

__all__ = ["Train", "Data", "Identify", "Kalman", "ValidationWind", "Validate"]


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

    Null keeps the default of :class:`studies.identification.kalman.KalmanSettings`.
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


#: ``validate.band_replay``: zig-zags run by their rule, or every record with its measured rudder
BAND_REPLAYS = ("steered", "rudder")


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
    band_replay : str
        One of :data:`BAND_REPLAYS`: how the band's replays steer a
        measured record. ``steered`` (default): a zig-zag is run by its rule,
        the rudder reversed when each replay's heading reaches the test's
        angle (read from the record), as the ship was steered; other records
        follow their measured rudder. ``rudder``: every record follows its
        measured rudder.
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
    band_replay: str = "steered"
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
        self.band_replay = _choice("validate.band_replay", self.band_replay, BAND_REPLAYS)
        self.compare_derivatives = _flag("validate.compare_derivatives", self.compare_derivatives)
