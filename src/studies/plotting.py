"""The one place that chooses matplotlib's backend, and where figures are drawn.

Every figure `studies` writes is a PNG file made without a screen, so the
non-interactive Agg backend is selected once, here, before pyplot is first
imported. Matplotlib is loaded on first use only: commands that draw nothing
(``studies bench``, the configuration check) do not pay for it.
"""

from __future__ import annotations

import contextlib
import functools

__all__ = ["pyplot", "readable_ticks", "thinned", "thinned_track", "MAX_POINTS", "Drawer", "DRAWER", "draw"]

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


class Drawer:
    """Draws a command's figures in a second process while the command goes on.

    A figure is a module-level function and its arguments (``draw(fn,
    *args)``). Until :meth:`start` is called, or after :meth:`close`, figures
    are drawn at once in this process (what a test or a notebook gets). After
    :meth:`start`, worker processes (started with their plotting imports
    while the command computes) draw them (one worker: in order); :meth:`finish` waits
    for them (and raises the first error a figure raised) before the
    command logs its files. A worker that dies leaves its figures to be
    drawn here. On two or more cores this takes the figures (1-3 s of a
    run) and matplotlib's import off the command's path.
    """

    def __init__(self):
        self._pool = None
        self._pending: list = []
        self._skip = False

    @contextlib.contextmanager
    def skipping(self):
        """Within it, figures are not drawn at all (an untracked identification from
        Python: nothing is written that was not asked for; figures are made on demand)."""
        before, self._skip = self._skip, True
        try:
            yield
        finally:
            self._skip = before

    def start(self, workers: int = 1) -> None:
        """Start ``workers`` worker processes (fresh interpreters) and their imports,
        when the machine has a core beside this one (at most one worker a core:
        this process mostly waits once it has handed its figures over)."""
        import os

        cores = os.cpu_count() or 1
        if self._pool is not None or cores < 2:
            return
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        workers = max(1, min(int(workers), cores))
        self._pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                         initializer=_leave_interrupts_to_the_command)
        for _ in range(workers):
            self._pending.append((self._pool.submit(_warm_up), _warm_up, (), {}))

    def draw(self, fn, *args, **kwargs) -> None:
        """Draw ``fn(*args, **kwargs)`` now, or in the worker once started."""
        if self._skip:
            return
        if self._pool is None:
            fn(*args, **kwargs)
            return
        import copy

        # copied now: the figure shows the data as they are at this call (the worker
        # receives them later, when the executor sends them)
        args, kwargs = copy.deepcopy(args), copy.deepcopy(kwargs)
        self._pending.append((self._pool.submit(fn, *args, **kwargs), fn, args, kwargs))

    def finish(self) -> None:
        """Wait for every figure handed to the worker (drawing here those a dead worker left)."""
        from concurrent.futures.process import BrokenProcessPool

        pending, self._pending = self._pending, []
        broken = False
        for future, fn, args, kwargs in pending:
            try:
                future.result()
            except BrokenProcessPool:
                broken = True
                fn(*args, **kwargs)
        if broken:
            self.close()

    def close(self) -> None:
        """Stop the workers (figures not finished are dropped: call :meth:`finish` first).

        Workers with nothing left to draw are ended at once: waiting for their
        interpreters to unload matplotlib and pandas took 0.2-0.4 s of every
        command and writes nothing. A worker still drawing is waited for, so
        that no half-written figure is left behind.
        """
        pool, self._pool = self._pool, None
        pending, self._pending = self._pending, []
        if pool is None:
            return
        if all(future.done() for future, *_ in pending):
            for process in list(getattr(pool, "_processes", {}).values()):
                process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)


def _leave_interrupts_to_the_command() -> None:
    """The worker ignores Ctrl+C (SIGINT reaches the whole process group): the
    command handles it, marks its run KILLED and stops the worker."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _warm_up() -> None:
    """The worker's first task: load what drawing needs before the first figure arrives."""
    import pandas  # noqa: F401  (the records come as DataFrames)

    pyplot()


#: the figures of this process (see :class:`Drawer`)
DRAWER = Drawer()


def draw(fn, *args, **kwargs) -> None:
    """Draw one figure through :data:`DRAWER` (at once unless a command started it)."""
    DRAWER.draw(fn, *args, **kwargs)
