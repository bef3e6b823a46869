"""The one place that chooses matplotlib's backend.

Every figure `studies` writes is a PNG file made without a screen, so the
non-interactive Agg backend is selected once, here, before pyplot is first
imported. Matplotlib is loaded on first use only: commands that draw nothing
(``studies bench``, the configuration check) do not pay for it.
"""

from __future__ import annotations

import functools

__all__ = ["pyplot", "readable_ticks", "thinned", "thinned_track", "MAX_POINTS"]

#: points per drawn line: a 90-dpi panel is a few hundred pixels wide, so more points
#: draw the same picture and only cost rendering time
MAX_POINTS = 2000


@functools.cache
def pyplot():
    """``matplotlib.pyplot`` with the Agg backend (loaded on the first call).

    Matplotlib's one-time "building the font cache" notice on a fresh
    machine is library bookkeeping, not a message for the user: its logger
    is kept to errors.
    """
    import logging

    logging.getLogger("matplotlib.font_manager").setLevel(logging.ERROR)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def readable_ticks(ax, axis: str = "y") -> None:
    """Tick labels of ``ax``'s ``axis`` to 3 significant digits, after the data
    are drawn. A log axis spanning less than a decade labels its minor ticks,
    by default as ``4.68719x10^-4``; wider log axes keep matplotlib's labels
    (the decades only)."""
    from matplotlib.ticker import FuncFormatter

    def label(value, _pos):
        return "0" if value == 0 else f"{value:.3g}"

    target = ax.yaxis if axis == "y" else ax.xaxis
    low, high = sorted(ax.get_ylim() if axis == "y" else ax.get_xlim())
    if target.get_scale() != "log":
        target.set_major_formatter(FuncFormatter(label))
    elif low > 0 and high / low < 10.0:
        target.set_major_formatter(FuncFormatter(label))
        target.set_minor_formatter(FuncFormatter(label))


def thinned(x, y, max_points: int = MAX_POINTS):
    """``(x, y)`` with at most about ``max_points`` points that draw the same
    line: the samples are cut into ``max_points / 2`` consecutive buckets and
    each keeps its lowest and highest ``y`` (in time order), so peaks,
    overshoots and noise bands stay where they were. Shorter lines are
    returned as they are."""
    import numpy as np

    x = np.asarray(x)
    y = np.asarray(y)
    n = len(y)
    buckets = max(max_points // 2, 1)
    if n <= max_points:
        return x, y
    size = -(-n // buckets)
    pad = size * buckets - n
    values = np.concatenate([y.astype(float), np.full(pad, np.nan)]).reshape(buckets, size)
    finite = np.isfinite(values)
    low = np.where(finite, values, np.inf).argmin(axis=1)
    high = np.where(finite, values, -np.inf).argmax(axis=1)
    starts = np.arange(buckets) * size
    keep = np.unique(np.concatenate([starts + low, starts + high, [n - 1]]))
    keep = keep[keep < n]
    return x[keep], y[keep]


def thinned_track(east, north, max_points: int = MAX_POINTS):
    """A track with at most about ``max_points`` points: every k-th sample and
    the last (a track is smooth at the scale of a panel; its turns span
    hundreds of samples)."""
    import numpy as np

    east, north = np.asarray(east), np.asarray(north)
    step = max(1, -(-len(east) // max_points))
    keep = np.unique(np.r_[np.arange(0, len(east), step), len(east) - 1]) if len(east) else np.arange(0)
    return east[keep], north[keep]
