"""Corner plots of posterior samples, drawn with the ``corner`` package.

:func:`plot_corner` writes one PNG: 1-D histograms with the 5, 50 and 95 %
quantiles on the diagonal, 2-D histograms and contours below, at most
``max_params`` coefficients (the least certain ones). :func:`corner_writer`
defers it: the identification returns writers, the workflow calls them
with the file path.
"""

from __future__ import annotations

import numpy as np

from ...plotting import pyplot
from .diagnostics import least_certain

__all__ = ["CORNER_MAX", "QUANTILES", "corner_writer", "plot_corner"]

#: at most this many coefficients per corner plot (the least certain ones)
CORNER_MAX = 8
#: quantiles marked on the diagonal
QUANTILES = (0.05, 0.5, 0.95)
#: room above the panels for the two-line title [inch]
_TITLE_HEIGHT = 0.6
#: colour of the samples and of the known values
_COLOR, _TRUTH_COLOR = "tab:blue", "tab:red"
#: font size of the axis labels [pt]
_LABEL_SIZE = 10


def corner_writer(names, samples, title: str, max_params: int):
    """``write(path)`` that draws :func:`plot_corner` of a copy of the samples."""
    names = list(names)
    samples = np.asarray(samples)

    def write(path):
        plot_corner(names, samples, path, title, max_params=max_params)

    return write


def _ranges(data: np.ndarray, truths: list) -> list[tuple[float, float]]:
    """Axis range of each column: its samples, widened to show its truth (when
    given) off the frame; a column without spread gets +-0.5 around its value
    (as matplotlib's histogram would)."""
    out = []
    for j in range(data.shape[1]):
        lo, hi = float(np.min(data[:, j])), float(np.max(data[:, j]))
        truth = truths[j]
        if truth is not None and not lo <= truth <= hi:
            lo, hi = min(lo, truth), max(hi, truth)
            margin = 0.03 * (hi - lo)
            lo, hi = lo - margin, hi + margin
        out.append((lo - 0.5, hi + 0.5) if lo == hi else (lo, hi))
    return out


def _make_room_for_title(fig, height: float) -> None:
    """Enlarge the figure by ``height`` inches at the top, panels unchanged."""
    width, old = fig.get_size_inches()
    new = old + height
    params = fig.subplotpars
    fig.set_size_inches(width, new)
    fig.subplots_adjust(bottom=params.bottom * old / new, top=params.top * old / new)


def _offset_into_label(axis, name: str) -> None:
    """Write the axis' scale and offset (matplotlib's notation: ``1e-8-2.64e-3``
    reads "ticks x 1e-8 - 2.64e-3") under its label instead of at the axis'
    end, where it would overlap the neighbouring panel."""
    formatter = axis.get_major_formatter()
    formatter.set_locs(axis.get_majorticklocs())
    offset = formatter.get_offset()
    if not offset:
        return
    axis.get_offset_text().set_visible(False)
    axis.set_label_text(f"{name}\n{offset}", fontsize=_LABEL_SIZE)


def plot_corner(names, samples: np.ndarray, path, title: str, truths: dict | None = None,
                max_params: int = CORNER_MAX) -> list[str]:
    """Corner plot: 1-D histograms on the diagonal, 2-D histograms below.

    Draws at most ``max_params`` coefficients, the least certain ones
    (:func:`~studies.identification.bayes.diagnostics.least_certain`), and says
    which in the title. Dashed lines mark the 5, 50 and 95 % quantiles.

    Parameters
    ----------
    names : list of str
    samples : ndarray (n_samples, len(names))
        Prime coefficient samples.
    path : str or Path
        PNG file to write.
    title : str
    truths : dict, optional
        Known values to mark (red lines and squares), by name.
    max_params : int

    Returns
    -------
    list of str
        The coefficients drawn.
    """
    plt = pyplot()
    import corner  # imports matplotlib.pyplot (0.6 s): loaded only when a figure is drawn

    names = list(names)
    samples = np.asarray(samples, float)
    pick = list(range(len(names)))
    if len(names) > max_params:
        pick = least_certain(names, samples, max_params)
        title = f"{title}: the {max_params} least certain of {len(names)} coefficients"
    shown = [names[i] for i in pick]
    data = samples[:, pick]
    marks = [truths.get(name) if truths else None for name in shown]
    k = len(shown)
    given = any(m is not None for m in marks)
    # corner 2.3 fails to draw truths on a single panel: drawn here instead
    fig = corner.corner(data, bins=20, range=_ranges(data, marks), smooth=1.0, labels=shown,
                        quantiles=list(QUANTILES), truths=marks if given and k > 1 else None,
                        color=_COLOR, truth_color=_TRUTH_COLOR, max_n_ticks=4,
                        label_kwargs={"fontsize": _LABEL_SIZE})
    try:
        axes = np.asarray(fig.axes).reshape(k, k)
        if given and k == 1:
            axes[0, 0].axvline(marks[0], color=_TRUTH_COLOR)
        for i, name in enumerate(shown):
            _offset_into_label(axes[-1, i].xaxis, name)
            if i > 0:
                _offset_into_label(axes[i, 0].yaxis, name)
        _make_room_for_title(fig, _TITLE_HEIGHT)
        fig.suptitle(f"{title}\n({', '.join(shown)}; dashed lines: 5, 50, 95 %)", fontsize=11)
        fig.savefig(path, dpi=80)
    finally:
        plt.close(fig)
    return shown
