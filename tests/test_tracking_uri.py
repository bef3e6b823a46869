"""Where the runs go, as a user of MLflow expects: the environment's store,
an unreachable server refused at once, no empty log files, help and version."""

from __future__ import annotations

import sqlite3
import time

import pytest

from conftest import mlflow_runs, run_studies

SHORT_RUN = ["manoeuvre.duration=200", "validate.manoeuvres=[zigzag_10_10]", "validate.duration=100"]


@pytest.mark.slow
def test_an_unreachable_server_is_one_line_and_exit_2_within_seconds(tmp_path):
    started = time.perf_counter()
    proc = run_studies(["run", "tracking.uri=http://127.0.0.1:1", *SHORT_RUN], tmp_path, timeout=60)
    elapsed = time.perf_counter() - started
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "no MLflow server answers at http://127.0.0.1:1" in lines[0]
    assert elapsed < 10
    assert not (tmp_path / "mlruns").exists() and not (tmp_path / "outputs").exists()


@pytest.mark.slow
def test_a_postgresql_store_without_driver_or_database_is_one_line(tmp_path):
    """Without the driver (``pip install 'studies[postgres]'``) or with a
    database that does not answer: one line naming what to do, exit 2."""
    proc = run_studies(["run", "tracking.uri=postgresql://nobody@127.0.0.1:1/none", *SHORT_RUN],
                       tmp_path, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    assert "studies[postgres]" in lines[0] or "PostgreSQL database does not answer" in lines[0]
    assert not (tmp_path / "outputs").exists()


@pytest.mark.slow
def test_an_unreachable_server_refuses_a_sweep_before_any_job(tmp_path):
    proc = run_studies(["run", "-m", "seed=0,1", "tracking.uri=http://127.0.0.1:1", *SHORT_RUN],
                       tmp_path, timeout=60)
    assert proc.returncode == 2 and "no MLflow server answers" in proc.stderr
    assert not (tmp_path / "multirun").exists()


@pytest.mark.slow
def test_the_environment_variable_chooses_the_store_and_no_empty_log_is_logged(tmp_path):
    db = tmp_path / "elsewhere" / "store.db"
    db.parent.mkdir()
    proc = run_studies(["run", *SHORT_RUN], tmp_path,
                       env_extra={"MLFLOW_TRACKING_URI": f"sqlite:///{db}"})
    assert proc.returncode == 0, proc.stderr
    assert not mlflow_runs(tmp_path), "the default store was used despite MLFLOW_TRACKING_URI"
    with sqlite3.connect(db) as con:
        runs = con.execute("select run_uuid, status from runs").fetchall()
    assert len(runs) == 1 and runs[0][1] == "FINISHED"
    logged = [p.name for p in (db.parent / "artifacts").rglob("*") if p.is_file()]
    assert "coefficients.csv" in logged and "metrics.json" in logged
    assert "coefficients_table.json" in logged          # the same table as an MLflow table
    assert not [name for name in logged if name.endswith(".log")], logged


@pytest.mark.slow
def test_report_writes_no_log_file_in_the_working_directory(tmp_path):
    proc = run_studies(["report"], tmp_path, timeout=120)
    assert proc.returncode == 2          # no runs yet: one line, nothing written
    assert not list(tmp_path.glob("*.log"))


@pytest.mark.slow
def test_command_help_lists_the_settings_with_units(tmp_path):
    proc = run_studies(["run", "--help"], tmp_path, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "powered by Hydra" not in proc.stdout
    assert "wind.speed [0.0]" in proc.stdout and "[m/s]" in proc.stdout
    assert "method=" in proc.stdout and "svm_ga" in proc.stdout
    discover = run_studies(["discover", "--help"], tmp_path, timeout=60)
    assert "discover.horizon" in discover.stdout and "simulation.path" in discover.stdout
    # its own options only, first, and short; the others behind --help-all
    lines = discover.stdout.splitlines()
    assert len(lines) < 60, len(lines)
    assert "simplify.threshold" not in discover.stdout and "noise.measurement" not in discover.stdout
    assert "--help-all" in discover.stdout and "retired" not in discover.stdout
    every = run_studies(["discover", "--help-all"], tmp_path, timeout=60).stdout
    assert every.index("discover.horizon") < every.index("noise.measurement") < every.index("simplify.threshold")
    usage = run_studies(["--help"], tmp_path, timeout=60).stdout
    assert "and log how\n" not in usage and "simplify" in usage


def test_version_and_ui_help(tmp_path):
    version = run_studies(["--version"], tmp_path, timeout=60)
    assert version.returncode == 0 and version.stdout.startswith("studies ")
    helped = run_studies(["ui", "--help"], tmp_path, timeout=60)
    assert helped.returncode == 0 and "tracking.uri" in helped.stdout and "port" in helped.stdout


@pytest.mark.slow
def test_a_run_on_measured_files_logs_them_as_dataset_inputs_with_its_source(tmp_path):
    from conftest import marin_file
    from studies.runtime.tracking import file_digest

    train, held = marin_file("zz_10"), marin_file("zz_20")
    db = tmp_path / "store.db"
    proc = run_studies(["run", "vessel=kvlcc2", "model=symmetric", f"data.path=[{train}]",
                        f"validate.path=[{held}]", f"tracking.uri=sqlite:///{db}",
                        "validate.compare_derivatives=false"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    import mlflow

    client = mlflow.MlflowClient(f"sqlite:///{db}")
    run = client.search_runs([client.get_experiment_by_name("studies").experiment_id])[0]
    inputs = {d.dataset.name: d for d in run.inputs.dataset_inputs}
    assert set(inputs) == {train.name, held.name}
    assert inputs[train.name].dataset.digest == file_digest(train)
    assert [t.value for t in inputs[train.name].tags] == ["training"]
    assert [t.value for t in inputs[held.name].tags] == ["validation"]
    assert '"num_rows"' in inputs[held.name].dataset.profile
    assert run.data.tags["mlflow.source.name"] == "studies run"
