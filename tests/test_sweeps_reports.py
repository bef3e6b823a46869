"""A sweep through the default parallel launcher, its report, and the UI."""

import json
import re
import subprocess
import sys
import time
import urllib.request

import pandas as pd
import pytest

from conftest import free_port, mlflow_runs, run_studies, wait_until_healthy

SMALL = ["manoeuvre.duration=300", "validate.manoeuvres=[zigzag_10_10]", "validate.duration=200"]


@pytest.fixture(scope="module")
def swept_store(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    proc = run_studies(["run", "-m", "wind.speed=4,8", "method=ls,ls_ga", "tracking.experiment=small",
                        "noise.wind_speed_error=-0.05", f"hydra.sweep.dir={root / 'multirun'}",
                        *SMALL], cwd=root)
    assert proc.returncode == 0, proc.stderr[-3000:]
    # progress: the sweep says how many jobs it has and which one runs
    assert "[studies] sweep of 4 jobs" in proc.stderr
    assert "[studies] job 4/4 started" in proc.stderr or "[studies] job 4/4 finished" in proc.stderr
    return root


@pytest.mark.slow
def test_sweep_runs_in_parallel_and_logs_every_run(swept_store):
    runs = mlflow_runs(swept_store)
    assert len(runs) == 4
    assert {status for _, status, _ in runs} == {"FINISHED"}
    names = {name for *_, name in runs}
    assert "ls_ga zigzag_20_20 wind=8 dir=45 err=-5% seed=0" in names
    for run_id, _, _ in runs:
        arts = list((swept_store / "mlruns" / "artifacts").glob(f"*/{run_id}/artifacts"))
        assert len(arts) == 1
        files = {p.name for p in arts[0].iterdir()}
        assert {"coefficients.csv", "metrics.json", "validation_zigzag_10_10.csv",
                "validation_zigzag_10_10.png", "deviations.png", "hydra"} <= files


@pytest.mark.slow
def test_report_tables_hold_the_logged_numbers(swept_store):
    proc = run_studies(["report", "report.experiment=small"], cwd=swept_store)
    assert proc.returncode == 0, proc.stderr[-2000:]
    page = swept_store / "reports" / "small" / "index.md"
    html = page.with_suffix(".html")
    assert page.exists() and html.exists()
    text = page.read_text()
    assert "condition: `wind.speed`" in text
    # every linked figure exists next to the page
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert any(l.startswith("fitness_") for l in links) and any(l.startswith("overlay_") for l in links)
    for link in links:
        assert (page.parent / link).is_file(), link
    for src in re.findall(r'<img src="([^"]+)"', html.read_text()):
        assert (page.parent / src).is_file()
    # the deviation table holds the logged coefficients.csv of the LS run at 8 m/s
    runs = mlflow_runs(swept_store)
    run_id = next(r for r, _, name in runs if name.startswith("ls zigzag") and "wind=8" in name)
    art = next((swept_store / "mlruns" / "artifacts").glob(f"*/{run_id}/artifacts"))
    logged = pd.read_csv(art / "coefficients.csv").set_index("name")["deviation_pct"]
    header = next(l for l in text.splitlines() if l.startswith("| coefficient |"))
    columns = [c.strip() for c in header.strip("|").split("|")]
    col = columns.index("8 m/s / LS")
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[0] in ("Xrr", "Yvdd", "N0uu"):
            assert float(cells[col]) == pytest.approx(logged[cells[0]], rel=1e-3)
    # and the fitness table holds the logged metric
    metrics = json.loads((art / "metrics.json").read_text())
    fit_lines = text.split("## Validation fitness, zigzag_10_10")[1].splitlines()
    row = next(l for l in fit_lines if l.startswith("| 8 m/s"))
    assert float(row.strip("|").split("|")[1]) == pytest.approx(metrics["zigzag_10_10/fitness"], rel=1e-3)


@pytest.mark.slow
def test_ui_serves_the_store_on_loopback(swept_store):
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "studies", "ui", f"port={port}"], cwd=swept_store,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        first = proc.stdout.readline()
        assert f"http://127.0.0.1:{port}" in first
        wait_until_healthy(f"http://127.0.0.1:{port}", proc, 90)
        req = urllib.request.Request(
            f"http://127.0.0.1:{port}/api/2.0/mlflow/experiments/get-by-name?experiment_name=small")
        with urllib.request.urlopen(req, timeout=10) as r:
            exp = json.loads(r.read())["experiment"]
        # the UI opens the experiment in its model-training view, not the GenAI one
        assert {"key": "mlflow.experimentKind", "value": "custom_model_development"} in exp["tags"]
        body = json.dumps({"experiment_ids": [exp["experiment_id"]], "max_results": 100}).encode()
        req = urllib.request.Request(f"http://127.0.0.1:{port}/api/2.0/mlflow/runs/search", data=body,
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=10) as r:
            runs = json.loads(r.read())["runs"]
        kinds = [{t["key"]: t["value"] for t in run["data"]["tags"]}.get("kind") for run in runs]
        assert len(runs) == 5 and kinds.count("sweep") == 1      # 4 jobs and the sweep's parent run
        # bound to loopback only: the UI's socket is not on a wildcard address
        listening = subprocess.run(["ss", "-ltn"], capture_output=True, text=True).stdout
        assert f"127.0.0.1:{port}" in listening and f"0.0.0.0:{port}" not in listening
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
    # stopping `studies ui` stops the server's worker processes too
    deadline = time.time() + 20
    while f"127.0.0.1:{port}" in subprocess.run(["ss", "-ltn"], capture_output=True, text=True).stdout:
        assert time.time() < deadline, "the MLflow server outlived `studies ui`"
        time.sleep(1)


@pytest.mark.slow
def test_same_sweep_through_the_ray_launcher(tmp_path):
    pytest.importorskip("hydra_plugins.hydra_ray_launcher",
                        reason="Ray launcher not installed (pip install -e '.[ray]')")
    proc = run_studies(["run", "-m", "hydra/launcher=ray", "wind.speed=4,8", "method=ls",
                        "tracking.experiment=ray_small", f"hydra.sweep.dir={tmp_path / 'multirun'}",
                        *SMALL], cwd=tmp_path, env_extra={"RAY_AUTH_MODE": "disabled"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    runs = mlflow_runs(tmp_path)
    assert len(runs) == 2 and {s for _, s, _ in runs} == {"FINISHED"}
    for run_id, _, _ in runs:
        art = next((tmp_path / "mlruns" / "artifacts").glob(f"*/{run_id}/artifacts"))
        assert {"coefficients.csv", "metrics.json"} <= {p.name for p in art.iterdir()}
