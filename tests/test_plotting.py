"""Figures draw fewer points, not a different line: the thinning keeps every extreme."""

from __future__ import annotations

import numpy as np

from studies.plotting import thinned, thinned_track


def test_thinning_keeps_the_extremes_and_bounds_the_points():
    rng = np.random.default_rng(3)
    t = np.arange(40001) * 0.1
    y = np.sin(t / 30) + 0.05 * rng.standard_normal(t.size)
    y[12345] = 5.0                       # a spike (a sensor glitch) must stay visible
    tx, ty = thinned(t, y, max_points=2000)
    assert len(ty) <= 2001 and np.all(np.diff(tx) > 0)
    assert ty.max() == 5.0 and ty.min() == y.min()
    # the envelope: over any stretch, the thinned line reaches the record's extremes of
    # that stretch less one bucket (41 samples) at each end
    bucket = -(-t.size // 1000)
    for lo in range(0, t.size - 4000, 3000):
        inner = y[lo + bucket:lo + 4000 - bucket]
        part = ty[(tx >= t[lo]) & (tx <= t[lo + 4000])]
        assert part.max() >= inner.max() and part.min() <= inner.min()


def test_short_lines_and_missing_values():
    t, y = np.arange(10.0), np.arange(10.0)
    assert np.array_equal(thinned(t, y)[1], y)
    y = np.sin(np.arange(50000) / 100.0)
    y[:100] = np.nan                      # a diverged start stays a gap; the rest keeps its extremes
    _, ty = thinned(np.arange(50000), y)
    assert np.nanmax(ty) == np.nanmax(y) and np.nanmin(ty) == np.nanmin(y)
    assert np.isnan(ty).sum() <= 4
    east, north = thinned_track(np.arange(40001.0), np.arange(40001.0) ** 0.5)
    assert len(east) <= 2002 and east[-1] == 40000.0


def test_a_second_process_draws_the_figures_and_reports_their_errors(tmp_path):
    import pandas as pd
    import pytest

    from studies.analysis.figures import plot_deviations
    from studies.plotting import Drawer

    table = pd.DataFrame({"name": ["Xu", "Yv", "Nr"], "deviation_pct": [1.0, -20.0, 300.0]})
    drawer = Drawer()
    drawer.start()
    try:
        drawer.draw(plot_deviations, table, tmp_path / "deviations.png", "in the worker")
        table.loc[0, "deviation_pct"] = float("nan")   # changed after the call: the figure keeps its data
        drawer.draw(plot_deviations, table.drop(columns="name"), tmp_path / "broken.png", "no names")
        with pytest.raises(KeyError):
            drawer.finish()
    finally:
        drawer.close()
    assert (tmp_path / "deviations.png").stat().st_size > 1000
    # without start (a test, a notebook): drawn at once in this process
    Drawer().draw(plot_deviations, table, tmp_path / "here.png", "here")
    assert (tmp_path / "here.png").is_file()


def test_two_workers_draw_every_figure_and_end_when_done(tmp_path):
    """The report's pool: every figure handed over is drawn (by one worker or
    the other), and the idle workers are ended by ``close`` (not left behind)."""
    import pandas as pd

    from studies.analysis.figures import plot_deviations
    from studies.plotting import Drawer

    table = pd.DataFrame({"name": ["Xu", "Yv", "Nr"], "deviation_pct": [1.0, -20.0, 300.0]})
    drawer = Drawer()
    drawer.start(workers=2)
    processes = list(getattr(drawer._pool, "_processes", {}).values()) if drawer._pool else []
    try:
        for k in range(6):
            drawer.draw(plot_deviations, table, tmp_path / f"figure_{k}.png", f"figure {k}")
        drawer.finish()
        processes = processes or list(drawer._pool._processes.values())
    finally:
        drawer.close()
    assert all((tmp_path / f"figure_{k}.png").stat().st_size > 1000 for k in range(6))
    for process in processes:
        process.join(timeout=5)
        assert not process.is_alive()
