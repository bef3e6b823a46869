"""Putting a record on an even time grid.

Estimators of derivatives, the Kalman filter and the replay of a record in
the simulator all want samples at a constant step. :func:`uniform_grid`
builds such a grid, :func:`resample` interpolates a record's columns onto a
grid (linearly), :func:`block_means` thins a finely sampled record by
averaging consecutive samples, and :func:`uniform_step` returns the step of
a record that is already uniform and refuses one that is not.

Linear interpolation of every column is safe for records in the data
contract because the heading ``psi`` is continuous (not wrapped to
[-pi, pi)).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["uniform_grid", "resample", "block_means", "uniform_step"]


def uniform_grid(start: float, stop: float, step: float) -> np.ndarray:
    """Times ``start, start + step, ...`` up to ``stop`` (included when on the grid).

    Parameters
    ----------
    start, stop : float
        First and last time of the span [s].
    step : float
        Grid step [s], positive.

    Returns
    -------
    ndarray
        ``start + step * k`` for ``k = 0 .. floor((stop - start) / step)``;
        a relative tolerance of 1e-9 steps keeps ``stop`` when rounding puts
        it just short of the last grid point.
    """
    count = int(math.floor((stop - start) / step + 1e-9)) + 1
    return start + step * np.arange(count)


def resample(record: pd.DataFrame, grid, columns=None) -> pd.DataFrame:
    """A record's columns linearly interpolated onto the times ``grid``.

    Parameters
    ----------
    record : DataFrame
        Time ``t`` [s] (increasing) and the columns to interpolate.
    grid : array_like
        New sample times [s], on the same time axis as ``record["t"]``.
        Outside the record's span the first / last value is held
        (:func:`numpy.interp`).
    columns : sequence of str, optional
        Columns to interpolate, in this order; default every column of the
        record besides ``t``, in the record's order.

    Returns
    -------
    DataFrame
        ``t`` (the grid) followed by the interpolated ``float64`` columns;
        ``attrs`` is a copy of the record's.
    """
    grid = np.asarray(grid, float)
    t = record["t"].to_numpy(float)
    if columns is None:
        columns = [c for c in record.columns if c != "t"]
    out = pd.DataFrame({"t": grid})
    for col in columns:
        out[col] = np.interp(grid, t, record[col].to_numpy(float))
    out.attrs = dict(record.attrs)
    return out


def block_means(record: pd.DataFrame, step: float) -> pd.DataFrame:
    """A uniformly sampled record thinned to about ``step`` seconds by block means.

    Consecutive samples are averaged in blocks of ``m = round(step / dt)``
    (``dt`` the record's step); a last, incomplete block is dropped. Every
    column is averaged, ``t`` included (the block's mid time), so that a
    quantity varying linearly over a block keeps its value at that time,
    while white measurement noise shrinks by ``sqrt(m)`` (unlike taking every
    m-th sample, which discards it). The heading ``psi`` is continuous in
    the data contract, so its mean is the mean heading. A record sampled at
    ``step`` or coarser (``m <= 1``) is returned as it is.

    Parameters
    ----------
    record : DataFrame
        ``t`` [s], uniformly sampled, and numeric columns.
    step : float
        Wanted sampling interval [s].

    Returns
    -------
    DataFrame
        The thinned record (float columns), ``attrs`` copied.
    """
    t = record["t"].to_numpy(float)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else step
    m = int(round(step / dt))
    if m <= 1 or len(t) < 2 * m:
        return record
    n = (len(t) // m) * m
    values = record.to_numpy(float)[:n]
    out = pd.DataFrame(values.reshape(n // m, m, values.shape[1]).mean(axis=1), columns=record.columns)
    if "wind_direction" in record:
        # a direction is averaged on the circle (a wind from due south may read -pi and pi)
        blocks = np.exp(1j * record["wind_direction"].to_numpy(float)[:n]).reshape(n // m, m)
        out["wind_direction"] = np.angle(blocks.mean(axis=1))
    out.attrs = dict(record.attrs)
    return out


def uniform_step(t: np.ndarray) -> float:
    """The sampling step [s] of uniformly sampled times ``t``.

    Raises
    ------
    ValueError
        A step differs from the median step by more than ``1e-6`` of it
        (plus 1e-9 s): the record must be resampled first.
    """
    dt = np.diff(t)
    step = float(np.median(dt))
    if np.max(np.abs(dt - step)) > 1e-6 * max(step, 1e-12) + 1e-9:
        raise ValueError("the record is not uniformly sampled; resample it first")
    return step
