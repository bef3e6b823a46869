"""Settings of the conditions a record is made in: wind, current, sensor noise, the SVM paper's
disturbance, and the GA's objective.
"""

from dataclasses import dataclass

from ..errors import ConfigError
from .values import WIND_CONVENTIONS, OBJECTIVE_SIMULATIONS, DISTURBANCE_SCALINGS, _number, _choice

__all__ = ["Wind", "Objective", "Current", "Noise", "Disturbance"]


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
