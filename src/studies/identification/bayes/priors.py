"""Priors of the two posteriors of :mod:`studies.identification.bayes`.

The regression posterior (a) has flat priors in every coefficient and in
``log sigma`` (Jeffreys); they only add a constant and are implicit in
:meth:`~studies.identification.bayes.likelihood.RegressionPosterior.log_prob`.

The trajectory posterior (b) has the flat box prior :class:`BoxPrior`,
``|c - c_reg| <= width * |c_reg|`` around the regression values ``c_reg``.
It is sampled in the box's own coordinates ``x = (c - c_reg) / half_width``,
so the box is ``|x| <= 1`` whatever the size of the coefficients.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BoxPrior"]


@dataclass(frozen=True)
class BoxPrior:
    """Flat prior on the box ``|c - centre| <= half_width`` (prime coefficients).

    Attributes
    ----------
    centre : ndarray (k,)
        Centre of the box (the regression values).
    half_width : ndarray (k,)
        Half-width of the box per coefficient, > 0.
    """

    centre: np.ndarray
    half_width: np.ndarray

    @classmethod
    def around(cls, centre: np.ndarray, relative_width: float) -> "BoxPrior":
        """The box ``|c - centre| <= relative_width * |centre|``; a zero centre
        gets the half-width ``relative_width * 1e-6``."""
        half_width = relative_width * np.where(np.abs(centre) > 0, np.abs(centre), 1e-6)
        return cls(centre, half_width)

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Which rows of ``x`` (m, k), in box coordinates, are inside the box (m,)."""
        return np.all(np.abs(x) <= 1.0, axis=1)

    def values(self, x: np.ndarray) -> np.ndarray:
        """Coefficients ``centre + x * half_width`` of box coordinates ``x``."""
        return self.centre + x * self.half_width

    def coordinates(self, values: np.ndarray) -> np.ndarray:
        """Box coordinates ``(values - centre) / half_width`` of coefficients."""
        return (values - self.centre) / self.half_width

    @staticmethod
    def edge_fraction(x: np.ndarray, edge: float = 0.98) -> float:
        """Fraction of the box coordinates ``x`` beyond ``edge`` (of the half-width):
        how much the box cuts the posterior."""
        return float(np.mean(np.abs(x) > edge))
