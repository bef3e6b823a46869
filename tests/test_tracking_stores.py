"""The stores a team uses: a sweep logged through a real MLflow tracking server
and reported from it, a run in a PostgreSQL database, and the step metrics of
the GA and of emcee as the store keeps them.

The server and the PostgreSQL cluster are started by the tests on 127.0.0.1
(free ports, files in temporary folders) and stopped with every process they
started. The PostgreSQL test needs the server programs (Debian's
``postgresql`` package: ``initdb``, ``pg_ctl``) and the driver
(``pip install -e ".[postgres]"``); it is skipped, saying which is missing,
without them.
"""

from __future__ import annotations

import glob
import os
import pwd
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from conftest import free_port, run_studies, wait_until_healthy

SHORT = ["manoeuvre.duration=300", "validate.manoeuvres=[zigzag_10_10]", "validate.duration=100"]


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def _stop_group(proc: subprocess.Popen) -> None:
    """End the process group of ``proc`` (the server and its workers)."""
    for sig, wait in ((signal.SIGTERM, 20), (signal.SIGKILL, 10)):
        if not _group_alive(proc.pid):
            break
        os.killpg(proc.pid, sig)
        deadline = time.time() + wait
        while _group_alive(proc.pid) and time.time() < deadline:
            proc.poll()             # reap the leader so the group can empty
            time.sleep(0.2)
    proc.wait(timeout=10)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """``mlflow server`` on 127.0.0.1 with a sqlite database and proxied artifacts."""
    place = tmp_path_factory.mktemp("server")
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    cmd = [sys.executable, "-m", "mlflow", "server", "--host", "127.0.0.1", "--port", str(port),
           "--workers", "1", "--backend-store-uri", f"sqlite:///{place / 'mlflow.db'}",
           "--artifacts-destination", str(place / "artifacts")]
    env = dict(os.environ, MLFLOW_DISABLE_TELEMETRY="true", MLFLOW_SERVER_ENABLE_JOB_EXECUTION="false")
    log = open(place / "server.log", "w")
    proc = subprocess.Popen(cmd, cwd=place, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)
    try:
        wait_until_healthy(url, proc, 120)
        yield url
    finally:
        _stop_group(proc)
        log.close()
        assert not _group_alive(proc.pid), "a process of the MLflow server outlived the test"


@pytest.mark.slow
def test_a_sweep_through_a_tracking_server_and_its_report(server, tmp_path):
    import mlflow

    # measurement noise keeps the training fitness above the GA's stop fitness: the GA runs
    proc = run_studies(["run", "-m", "wind.speed=4,8", "method=ls,ls_ga", "noise.measurement=0.05",
                        "tracking.experiment=served", f"tracking.uri={server}", *SHORT], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert not (tmp_path / "mlruns").exists(), "the local store was used instead of the server"
    client = mlflow.MlflowClient(server)
    experiment = client.get_experiment_by_name("served")
    assert experiment.tags["mlflow.experimentKind"] == "custom_model_development"
    runs = client.search_runs([experiment.experiment_id])
    parents = [r for r in runs if r.data.tags.get("kind") == "sweep"]
    assert len(parents) == 1 and parents[0].info.status == "FINISHED"
    children = [r for r in runs if r.data.tags.get("mlflow.parentRunId") == parents[0].info.run_id]
    assert len(children) == 4 and {r.info.status for r in children} == {"FINISHED"}
    assert parents[0].data.metrics["jobs/finished"] == 4.0
    for run in children:
        params = run.data.params
        assert not [k for k in params if k.startswith(("simplify.", "report.", "discover."))]
        assert {"wind.speed", "method.name", "model.name", "manoeuvre.name",
                "noise.measurement"} <= set(params)
        names = {a.path for a in client.list_artifacts(run.info.run_id)}
        assert {"coefficients.csv", "metrics.json"} <= names
        if params["method.name"] == "ls_ga":      # one step per generation, the best never worse
            history = client.get_metric_history(run.info.run_id, "ga/best_fitness")
            values = [m.value for m in sorted(history, key=lambda m: m.step)]
            assert len(values) > 1 and all(b <= a for a, b in zip(values, values[1:]))
            assert run.data.metrics["ga/best_fitness"] == values[-1]
    # the report reads the runs and their artifacts through the server
    report = run_studies(["report", "report.experiment=served", f"tracking.uri={server}"], tmp_path)
    assert report.returncode == 0, report.stderr[-3000:]
    page = tmp_path / "reports" / "served" / "index.md"
    text = page.read_text()
    assert "4 runs (4 finished)" in text and "condition: `wind.speed`" in text
    fitness = text.split("## Validation fitness, zigzag_10_10")[1].split("\n## ")[0]
    rows = [line.split("|")[1].strip() for line in fitness.splitlines() if line.startswith("| ")][1:]
    assert rows == ["4 m/s", "8 m/s"]
    html = page.with_suffix(".html").read_text()
    for run in children:
        assert f"{server}/#/experiments/{experiment.experiment_id}/runs/{run.info.run_id}" in html


@pytest.mark.slow
def test_bayes_logs_its_acceptance_per_iteration(tmp_path):
    import mlflow

    db = tmp_path / "store.db"
    proc = run_studies(["run", "method=bayes", "method.n_samples=640", "method.burn_in=100", "method.thin=2",
                        "method.max_steps=null", f"tracking.uri=sqlite:///{db}", *SHORT], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    client = mlflow.MlflowClient(f"sqlite:///{db}")
    run = client.search_runs([client.get_experiment_by_name("studies").experiment_id])[0]
    for dof in "XYN":
        history = sorted(client.get_metric_history(run.info.run_id, f"bayes/{dof}/acceptance_fraction"),
                         key=lambda m: m.step)
        assert len(history) > 10 and history[-1].step == 140          # burn-in 100 + 2 x 640 / 32
        assert history[-1].value == run.data.metrics[f"bayes/{dof}/acceptance_fraction"]
        tau = client.get_metric_history(run.info.run_id, f"bayes/{dof}/autocorr_time_max")
        assert max(m.step for m in tau) == 140


# ------------------------------------------------------------------ PostgreSQL

def _postgres_programs() -> dict | None:
    """Paths of initdb and pg_ctl (on PATH, else the newest Debian cluster's)."""
    found = {name: shutil.which(name) for name in ("initdb", "pg_ctl")}
    if not all(found.values()):
        for folder in sorted(glob.glob("/usr/lib/postgresql/*/bin"), key=lambda p: float(Path(p).parent.name),
                             reverse=True):
            if all((Path(folder) / name).is_file() for name in found):
                return {name: str(Path(folder) / name) for name in found}
        return None
    return found


def _cluster_user() -> str | None:
    """The account the cluster runs as: the current one, or ``postgres`` for
    root (PostgreSQL refuses to run as root); None when there is none."""
    if os.geteuid() != 0:
        return pwd.getpwuid(os.geteuid()).pw_name
    try:
        return pwd.getpwnam("postgres").pw_name
    except KeyError:
        return None


@pytest.fixture
def postgres():
    """A throwaway PostgreSQL cluster on 127.0.0.1 with an empty database
    ``studies``; yields its SQLAlchemy URI for psycopg 3."""
    programs = _postgres_programs()
    if programs is None:
        pytest.skip("PostgreSQL server programs not found (initdb, pg_ctl): apt-get install postgresql")
    psycopg = pytest.importorskip("psycopg", reason="the PostgreSQL driver is not installed: "
                                                    "pip install -e '.[postgres]'")
    user = _cluster_user()
    if user is None:
        pytest.skip("running as root without a 'postgres' account to run the cluster as")
    # not under pytest's tmp_path: the cluster's account must be able to reach it
    place = Path(tempfile.mkdtemp(prefix="studies-pg-"))
    shutil.chown(place, user)
    port = free_port()
    as_user = {"user": user} if os.geteuid() == 0 else {}

    def pg(*args):
        return subprocess.run([*args], capture_output=True, text=True, timeout=120, cwd=place, **as_user)

    data = place / "data"
    try:
        made = pg(programs["initdb"], "-D", str(data), "-U", "studies", "--auth=trust", "-E", "UTF8",
                  "--no-sync")
        assert made.returncode == 0, made.stderr
        options = f"-p {port} -k {place} -c listen_addresses=127.0.0.1 -c fsync=off"
        started = pg(programs["pg_ctl"], "-D", str(data), "-l", str(place / "server.log"), "-o", options,
                     "-w", "-t", "60", "start")
        assert started.returncode == 0, started.stderr + (place / "server.log").read_text()
        with psycopg.connect(host="127.0.0.1", port=port, user="studies", dbname="postgres",
                             autocommit=True) as connection:
            connection.execute("CREATE DATABASE studies")
        yield f"postgresql+psycopg://studies@127.0.0.1:{port}/studies"
    finally:
        if (data / "postmaster.pid").exists():
            pg(programs["pg_ctl"], "-D", str(data), "-m", "immediate", "-w", "stop")
        shutil.rmtree(place, ignore_errors=True)


@pytest.mark.slow
def test_a_run_in_a_postgresql_store(postgres, tmp_path):
    import mlflow

    proc = run_studies(["run", f"tracking.uri={postgres}", *SHORT], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    client = mlflow.MlflowClient(postgres)
    runs = client.search_runs([client.get_experiment_by_name("studies").experiment_id])
    assert len(runs) == 1 and runs[0].info.status == "FINISHED"
    run = runs[0]
    assert run.data.params["method.name"] == "ls" and "zigzag_10_10/fitness" in run.data.metrics
    assert {"coefficients.csv", "metrics.json"} <= {a.path for a in client.list_artifacts(run.info.run_id)}
