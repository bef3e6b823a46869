"""Calibration of the predictive bands over measured records, each held out in turn.

- the probability integral transform of a measurement is uniform when the
  measurement behaves as one more replay, U-shaped when the band is too
  narrow and humped when it is too wide (``analysis.bands.pit_values``);
- ``method.discrepancy=auto`` (the default) is the model discrepancy on
  measured records and none on records simulated from a known model, and
  the run's log says which;
- on KVLCC2 records of two basins that no code of the project produced
  (HSVA's 10/10 zig-zag to starboard, MARIN's zig-zags and turning circle),
  each held out in turn: the band with the discrepancy holds the held-out
  tracks at least as often as nominal pooled, and is not uselessly wide
  against the point prediction's error; the coefficient-only band, which
  takes the model as exact, is overconfident. The verdicts against the
  targets are one function (``band_calibration.verdicts``), checked on
  tables that are overconfident or uselessly wide.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from conftest import hsva_file, marin_file, run_studies
from studies.analysis.bands import pit_values
from studies.workflows.band_calibration import pooled, verdicts


def _pit(spread_of_replays: float, seed: int = 0) -> dict:
    """Replays N(0, spread^2) around a truth, measurements N(0, 1) at 400 samples."""
    rng = np.random.default_rng(seed)
    n, m = 400, 200
    values = {ch: spread_of_replays * rng.standard_normal((m, n)) for ch in ("x0", "y0")}
    measured = {ch: rng.standard_normal(n) for ch in ("x0", "y0")}
    sd = {ch: np.zeros(n) for ch in ("x0", "y0")}
    return pit_values(values, measured, sd, seed, samples=n)


def test_pit_is_uniform_for_a_calibrated_ensemble_u_shaped_when_narrow_humped_when_wide():
    calibrated, narrow, wide = _pit(1.0), _pit(0.4), _pit(3.0)
    for key in ("pit_x0", "pit_y0", "joint_level"):
        assert len(calibrated[key]) == 400
        assert np.all((calibrated[key] >= 0) & (calibrated[key] <= 1))
    tails = lambda p: float(np.mean((p < 0.1) | (p > 0.9)))   # noqa: E731
    assert 0.12 <= tails(calibrated["pit_x0"]) <= 0.28        # 0.2 for a uniform PIT
    assert tails(narrow["pit_x0"]) > 0.5                       # U shape
    assert tails(wide["pit_x0"]) < 0.05                        # hump
    # the joint level: its share at or below p is the joint coverage at p
    assert abs(np.mean(calibrated["joint_level"] <= 0.9) - 0.9) < 0.06
    assert np.mean(narrow["joint_level"] <= 0.9) < 0.6
    assert np.mean(wide["joint_level"] <= 0.9) > 0.99


def _rows(band: str, coverage90: list, width_over_rmse: list, crps: list) -> list:
    rows = []
    for i, (c, w, s) in enumerate(zip(coverage90, width_over_rmse, crps)):
        rows.append({"record": f"r{i}", "band": band, "coverage_50": min(1.0, c * 5 / 9),
                     "coverage_80": min(1.0, c * 8 / 9), "coverage_90": c, "coverage_95": min(1.0, c * 95 / 90),
                     "crps_m": s, "interval_score_m": 10 * s, "half_width_m": w, "rmse_m": 1.0,
                     "width_over_rmse": w, "diverged": 0.0, "samples": 100})
    return rows


def test_the_verdicts_fail_an_overconfident_and_a_uselessly_wide_band():
    base = _rows("coefficients_only", [0.3, 0.5, 0.4, 0.6], [0.3, 0.4, 0.5, 0.4], [100, 120, 90, 110])
    good = pd.DataFrame(_rows("band", [0.9, 0.85, 0.95, 0.9], [1.1, 1.2, 0.9, 1.0], [60, 70, 50, 60]) + base)
    narrow = pd.DataFrame(_rows("band", [0.5, 0.6, 0.4, 0.7], [0.4, 0.5, 0.5, 0.4], [95, 115, 90, 100]) + base)
    wide = pd.DataFrame(_rows("band", [1.0, 1.0, 1.0, 1.0], [6.0, 5.0, 7.0, 8.0], [90, 110, 95, 105]) + base)
    assert all(met for _, _, met in verdicts(pooled(good)))
    failed = {what for what, _, met in verdicts(pooled(narrow)) if not met}
    assert any("90 % coverage" in w for w in failed) and any("below 0.5" in w for w in failed)
    failed = {what for what, _, met in verdicts(pooled(wide)) if not met}
    assert any("half-width" in w for w in failed) and any("CRPS" in w for w in failed)


def test_auto_discrepancy_is_the_process_noise_on_measured_records_and_says_so(tmp_path):
    from hydra import initialize_config_module

    from studies.config import compose_settings, settled_discrepancy

    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("config", overrides=["method=bayes"])
    assert cfg.method.discrepancy == "auto"
    assert "process_noise" in settled_discrepancy(cfg.method, measured=True)
    assert cfg.method.discrepancy == "process_noise"
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("config", overrides=["method=bayes"])
    settled_discrepancy(cfg.method, measured=False)
    assert cfg.method.discrepancy == "none"
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("config", overrides=["method=bayes", "method.discrepancy=none"])
    assert settled_discrepancy(cfg.method, measured=True) is None
    assert cfg.method.discrepancy == "none"


@pytest.mark.slow
def test_bands_of_held_out_kvlcc2_records_are_calibrated_and_the_model_alone_is_not(tmp_path):
    """Four records of two basins, each held out in turn (the defaults of
    ``method=bayes``: the discrepancy on, estimated out of sample; zig-zags
    steered): pooled 90 % coverage 1.00, width / RMSE 1.51, against 0.53 and
    0.41 for the coefficient-only band when written. With three training
    records per fold each is filtered by a model of two, and the band is
    wider than needed (in sample, ``method.discrepancy_out_of_sample=false``:
    0.90 and 0.86; docs/calibration.md): the check here is that it is not
    overconfident and not uselessly wide."""
    paths = [hsva_file("10_10_S"), marin_file("zz_10"), marin_file("zz_20"), marin_file("tc_35")]
    out = tmp_path / "run"
    proc = run_studies(["run", "vessel=kvlcc2", "model=mmg", "method=bayes", "method.discrepancy_step=2.0",
                        "model.cross_validate=true", "model.cross_validate_jobs=2", "data.scale=full",
                        "model.compare_abkowitz=false", "validate.compare_derivatives=false",
                        f"data.path=[{','.join(str(p) for p in paths)}]", f"hydra.run.dir={out}",
                        f"tracking.uri=sqlite:///{tmp_path}/m.db"], tmp_path, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "method.discrepancy=auto: process_noise" in (out / "cli.log").read_text() + proc.stdout + proc.stderr
    table = pd.read_csv(out / "calibration.csv")
    assert set(table["record"]) == {p.stem for p in paths}
    figures = pooled(table)
    band, base = figures["band"], figures["coefficients_only"]
    print(figures)
    assert band["coverage_90"] >= 0.75
    assert band["width_over_rmse"] <= 2.0
    assert base["coverage_90"] < 0.7                      # the model taken as exact: overconfident
    assert band["interval_score_m"] < base["interval_score_m"]
    for name in ("calibration.md", "pit.png", "calibration_pooled.png"):
        assert (out / name).is_file()


def test_the_report_shows_the_calibration_page_of_a_run_that_held_each_record_out(tmp_path):
    from studies.report.builder import build_report
    from studies.workflows.band_calibration import write_band_calibration

    base = _rows("coefficients_only", [0.3, 0.5, 0.4, 0.6], [0.3, 0.4, 0.5, 0.4], [100, 120, 90, 110])
    table = pd.DataFrame(_rows("band", [0.9, 0.85, 0.95, 0.9], [1.1, 1.2, 0.9, 1.0], [60, 70, 50, 60]) + base)
    pit = {band: [_pit(1.0 if band == "band" else 0.4)] for band in ("band", "coefficients_only")}
    artifacts = tmp_path / "artifacts"
    artifacts.mkdir()
    metrics = write_band_calibration((table, pit), artifacts, "model=mmg, method=bayes", "full scale")
    assert metrics["calibration/band/coverage_90"] == pytest.approx(0.9)
    assert metrics["calibration/band/crps_gain"] == pytest.approx(1 - 60 / 105)

    class _Run:
        run_id = "ab" * 16
        name = "bands held out"
        status, start_time, tags, url = "FINISHED", 1, {}, "http://127.0.0.1:5000/"
        params = {"method.name": "bayes", "model.name": "mmg"}

        def __init__(self):
            self.metrics = metrics

        def artifact(self, path, destination):
            found = artifacts / path
            return found if found.is_file() else None

    page = build_report("calibration", [_Run()], tmp_path / "report")
    text = page.read_text()
    section = text.split("## Calibration of the bands, each record held out in turn", 1)[1]
    assert "| r0 | 0.50 | 0.80 | 0.90 | 0.95 |" in section
    assert "pooled 90 % coverage within 0.85-0.95: 0.90: met" in section
    for figure in ("pit", "calibration_pooled"):
        assert (page.parent / f"{figure}_abababab.png").is_file() and f"({figure}_abababab.png)" in section


def test_the_spread_of_a_constant_per_record_is_what_the_records_hold_beyond_the_process():
    from studies.identification.discrepancy import Discrepancy, record_offsets

    rng = np.random.default_rng(7)
    sigma, tau, step, n = np.array([1e-3, 2e-3, 2e-5]), 40.0, 2.0, 600       # 1200 s records
    offset = np.array([0.0, 1.5e-3, 3e-5])
    with_offsets = Discrepancy("process_noise", sigma, tau, offset_sd=offset)
    without = Discrepancy("process_noise", sigma, tau)
    for made, expected in ((with_offsets, offset), (without, np.zeros(3))):
        means = np.array([made.realise(n, step, rng).mean(axis=0) for _ in range(300)])
        found = record_offsets(means, np.full(300, n * step), sigma, tau)
        # the OU part alone leaves about sigma sqrt(2 tau / T) = 0.26 sigma in a record's mean
        assert np.all(np.abs(found - expected) <= 0.25 * expected + 0.12 * sigma), (found, expected)
    assert np.all(record_offsets(means[:2], np.full(2, 1200.0), sigma, tau) == 0.0)
