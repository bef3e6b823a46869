"""``import studies``: the command line's studies from Python.

The Python functions and the command line run the same jobs: the same
coefficients and metrics for the README's main job and for an MMG
identification from MARIN's records; the command line's one-line refusals;
MLflow's conventions for what is logged; ``import studies`` light.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

REPO = Path(__file__).resolve().parents[1]
MARIN = REPO.parent / "shared" / "data" / "kvlcc2_free_running"
ZZ10, ZZ20, TC35 = (MARIN / f"MARIN_FREE_KVLCC2_{n}_m.dat" for n in ("zz_10", "zz_20", "tc_35"))
needs_marin = pytest.mark.skipif(not ZZ10.is_file(), reason="the shared data folder is not next to the repository")

#: metrics that are times of this machine, not results
TIMINGS = ("runtime", "cpu_s", "wall_s")


def _env() -> dict:
    env = {**os.environ}
    env.pop("MLFLOW_TRACKING_URI", None)
    return env


@pytest.mark.slow
def test_import_is_light_and_lists_the_functions():
    code = ("import time, sys; t = time.perf_counter(); import studies; dt = time.perf_counter() - t; "
            "print(dt); print(sorted(m for m in ('numpy', 'pandas', 'mlflow', 'hydra', 'numba', 'scipy') "
            "if m in sys.modules)); help(studies)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(),
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    seconds, heavy, *help_text = proc.stdout.splitlines()
    assert float(seconds) < 0.5
    assert heavy == "[]"
    text = "\n".join(help_text)
    for name in ("load(", "identify(", "discover(", "sweep(", "settings("):
        line = next(line for line in text.splitlines() if line.strip().startswith(name))
        assert len(line.strip()) > len(name) + 10, line      # each with what it does


def test_settings_are_the_command_lines_with_its_refusals():
    import studies

    cfg = studies.settings(model="mmg", wind={"speed": 12}, noise__measurement=0.01,
                           overrides=["wind.direction=30"])
    assert (cfg.model.name, cfg.wind.speed, cfg.wind.direction, cfg.noise.measurement) == ("mmg", 12.0, 30.0, 0.01)
    with pytest.raises(studies.ConfigError, match=r"^wind\.speed must be a number, got 'fast'$"):
        studies.settings(wind__speed="fast")
    with pytest.raises(studies.ConfigError, match=r"wind\.sped: unknown key \(did you mean wind\.speed"):
        studies.settings(wind={"sped": 3})
    with pytest.raises(studies.ConfigError, match="method: unknown option 'lsq'"):
        studies.settings(method="lsq")


def test_a_bad_record_is_refused_in_one_line_and_nothing_is_written(tmp_path, monkeypatch):
    import studies

    monkeypatch.chdir(tmp_path)
    frame = pd.DataFrame({"t": np.arange(20.0), "x0": 0.0, "y0": 0.0, "psi": 0.0, "u": 5.0, "v": 0.0,
                          "r": 0.0, "delta": 0.0})
    frame.loc[7, "u"] = np.nan
    frame.attrs["name"] = "mine"
    with pytest.raises(studies.DataError) as caught:
        studies.load(frame)
    message = str(caught.value)
    assert "mine" in message and "u" in message and "\n" not in message.strip()
    with pytest.raises(studies.DataError):
        studies.identify(frame, vessel="mariner")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_an_untracked_identification_logs_and_writes_nothing(tmp_path, monkeypatch):
    """The README's main job from Python: the true coefficients back, a model to simulate,
    figures on demand, and nothing in the working folder."""
    import studies

    monkeypatch.chdir(tmp_path)
    fit = studies.identify()
    assert fit.run_id is None
    deviations = fit.coefficients["deviation_pct"].abs()
    assert len(fit.coefficients) == 40 and deviations.max() < 0.01
    turn = fit.simulate("turning_35", duration=600.0)
    assert list(turn.columns[:8]) == ["t", "x0", "y0", "psi", "u", "v", "r", "delta"]
    assert turn["t"].iloc[-1] == pytest.approx(600.0)
    chars = fit.characteristics("turning_35")
    assert chars.loc["tactical_diameter_m", "predicted"] > 0
    figure = fit.plot("zigzag_20_20")
    assert type(figure).__name__ == "Figure" and len(figure.axes) == 3
    markdown = fit._repr_markdown_()
    assert "| Xu |" in markdown and "zigzag_40_40" in markdown and "<table>" in fit._repr_html_()
    assert list(tmp_path.iterdir()) == []              # no mlruns/, no outputs/, no figure files
    folder = fit.directory
    assert folder.is_dir() and not any(p.suffix == ".png" for p in folder.iterdir())
    del fit
    import gc

    gc.collect()
    assert not folder.exists()                         # the temporary folder went with the result


@pytest.mark.slow
def test_inside_an_active_run_the_study_is_logged_to_it(tmp_path, monkeypatch):
    import mlflow

    import studies

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MLFLOW_TRACKING_URI", raising=False)
    mlflow.set_tracking_uri(f"sqlite:///{tmp_path / 'nb.db'}")
    try:
        with mlflow.start_run() as run:
            fit = studies.identify()
            with pytest.raises(studies.ConfigError, match="already holds 'ls'"):
                studies.identify(method="svm")       # a second study needs a run of its own
        assert fit.run_id == run.info.run_id and fit.model_uri.startswith("runs:/")
        client = mlflow.MlflowClient()
        logged = client.get_run(run.info.run_id)
        assert logged.info.status == "FINISHED"
        assert logged.data.params["method.name"] == "ls"
        assert logged.data.metrics["deviation/median_abs_pct"] == pytest.approx(
            fit.metrics["deviation/median_abs_pct"])
        names = {a.path for a in client.list_artifacts(run.info.run_id)}
        assert {"coefficients.csv", "identified_model.json", "metrics.json", "deviations.png",
                "validation_turning_35.png", "hydra"} <= names
        # a sweep inside an active run: one child run per job
        with mlflow.start_run() as parent:
            swept = studies.sweep({"wind.speed": [0, 12]})
        children = client.search_runs([parent.info.experiment_id],
                                      f"tags.mlflow.parentRunId = '{parent.info.run_id}'")
        assert len(children) == 2 and set(swept.table["run_id"]) == {c.info.run_id for c in children}
    finally:
        mlflow.set_tracking_uri(None)


def _cli(args: list[str], cwd: Path) -> Path:
    proc = subprocess.run([sys.executable, "-m", "studies", *args], cwd=cwd, capture_output=True, text=True,
                          env=_env(), timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    line = next(line for line in proc.stdout.splitlines() if line.startswith(("run '", "discovery '")))
    return Path(line.rsplit(" -> ", 1)[1])


def _same_results(cli_dir: Path, api) -> None:
    cli_table = pd.read_csv(cli_dir / "coefficients.csv").set_index("name")
    pd.testing.assert_frame_equal(cli_table, api.coefficients, check_exact=False, rtol=1e-12, atol=0)
    cli_metrics = json.loads((cli_dir / "metrics.json").read_text())
    results = {k: v for k, v in cli_metrics.items() if not any(t in k for t in TIMINGS)}
    assert results, "no metrics"
    for key, value in results.items():
        other = api.metrics[key]
        if isinstance(value, float) and math.isnan(value):
            assert math.isnan(other), key
        else:
            assert other == pytest.approx(value, rel=1e-12, abs=1e-15), key


@pytest.mark.slow
def test_the_main_job_gives_the_same_numbers_from_python_and_the_command_line(tmp_path, monkeypatch):
    import studies

    cli_dir = _cli(["run"], tmp_path)
    monkeypatch.chdir(tmp_path)
    _same_results(cli_dir, studies.identify())


@pytest.mark.slow
@needs_marin
def test_an_mmg_identification_from_marin_gives_the_same_numbers(tmp_path, monkeypatch):
    import studies

    cli_dir = _cli(["run", "model=mmg", f"data.path=[{ZZ10},{ZZ20}]", f"validate.path=[{TC35}]"], tmp_path)
    monkeypatch.chdir(tmp_path)
    train = studies.load([ZZ10, ZZ20])
    fit = studies.identify(train, validate=studies.load(TC35), model="mmg")
    _same_results(cli_dir, fit)
    # unchanged records are read from their files; a changed one is handed over as a new file
    assert all(p == str(f) for p, f in zip(fit.settings.data.path, (ZZ10, ZZ20)))
    shifted = train[0].copy()
    shifted["delta"] = shifted["delta"] + np.radians(2.0)
    moved = studies.identify([shifted, train[1]], model="mmg")
    assert moved.settings.data.path[0].endswith("records/MARIN_FREE_KVLCC2_zz_10_m.parquet")
    assert moved.metrics["runtime/identify_s"] > 0
    assert not np.allclose(moved.coefficients["value"], fit.coefficients["value"])


def test_the_bands_are_one_row_per_held_out_record():
    from studies.api.identified import Identified

    fit = Identified.__new__(Identified)
    fit.metrics = {"zz_10/band/coverage_90": 0.88, "zz_10/band/crps_m": 3.0, "tc_35/band/coverage_90": 0.5,
                   "tc_35/band/trusted": 0.0, "tc_35/rmse_position": 9.0, "deviation/median_abs_pct": 1.0}
    table = fit.bands
    assert list(table.index) == ["zz_10", "tc_35"]
    assert table.loc["tc_35", "coverage_90"] == 0.5 and table.loc["zz_10", "crps_m"] == 3.0
    assert "rmse_position" not in table.columns
    fit.metrics = {"deviation/median_abs_pct": 1.0}
    assert fit.bands.empty
