"""Simulation: compiled RK4 integrator, manoeuvres, and the record-producing wrapper."""

from .manoeuvres import Manoeuvre, turning, zigzag
from .simulator import replay, simulate, simulate_many

__all__ = ["Manoeuvre", "zigzag", "turning", "simulate", "simulate_many", "replay"]
