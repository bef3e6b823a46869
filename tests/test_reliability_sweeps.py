"""Issue 9, items 2-5: failed jobs, concurrent writers, interruption and resume, no NaN in reports."""

import json
import os
import re
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import mlflow_runs, run_studies, sweep_parents

SMALL = ["manoeuvre.duration=300", "validate.manoeuvres=[zigzag_10_10]", "validate.duration=200"]
ARTIFACTS = {"coefficients.csv", "metrics.json", "validation_zigzag_10_10.csv",
             "validation_zigzag_10_10.png", "deviations.png", "hydra"}


def _runs_with_hash(root: Path) -> list[tuple]:
    """(run_uuid, status, config_hash, error) of every job's run of the default
    store (the sweep's parent run left out)."""
    db = root / "mlruns" / "mlflow.db"
    parents = {p[0] for p in sweep_parents(root)}
    with sqlite3.connect(db, timeout=30) as con:
        rows = [r for r in con.execute("select run_uuid, status from runs").fetchall() if r[0] not in parents]
        tags = con.execute("select run_uuid, key, value from tags "
                           "where key in ('config_hash', 'error')").fetchall()
    by_run = {}
    for run, key, value in tags:
        by_run.setdefault(run, {})[key] = value
    return [(r, s, by_run.get(r, {}).get("config_hash"), by_run.get(r, {}).get("error"))
            for r, s in rows]


def _artifacts(root: Path, run_id: str) -> set:
    found = list((root / "mlruns" / "artifacts").glob(f"*/{run_id}/artifacts"))
    assert len(found) == 1, run_id
    return {p.name for p in found[0].iterdir()}


# ------------------------------------------------------------------ 2. a failing job in a sweep

@pytest.fixture(scope="module")
def failed_sweep(tmp_path_factory):
    """Two GA jobs; the second names a gene the model does not have, which
    the GA finds only at fit time (a genuinely failing configuration)."""
    root = tmp_path_factory.mktemp("failing")
    proc = run_studies(["run", "-m", "method=ls_ga", "method.genes=[Xu,Nv],[Nope]",
                        "method.generations=2", "hydra.launcher.n_jobs=2",
                        "tracking.experiment=failing", f"hydra.sweep.dir={root / 'multirun'}", *SMALL],
                       cwd=root)
    return root, proc


@pytest.mark.slow
def test_failed_job_is_failed_in_mlflow_and_the_others_finish(failed_sweep):
    root, proc = failed_sweep
    assert proc.returncode == 1, proc.stderr[-3000:]
    errors = [line for line in proc.stderr.splitlines() if line.startswith("studies: error:")]
    assert len(errors) == 1, proc.stderr
    assert errors[0].startswith("studies: error: 1 of 2 jobs failed: job 2 (method.genes=[Nope]): "
                                "ValueError: GA genes not in the model"), errors[0]
    assert "Traceback" not in proc.stderr
    assert "[studies] job 2/2 failed in" in proc.stderr
    runs = _runs_with_hash(root)
    assert sorted(s for _, s, _, _ in runs) == ["FAILED", "FINISHED"]
    failed = next(r for r in runs if r[1] == "FAILED")
    finished = next(r for r in runs if r[1] == "FINISHED")
    assert "GA genes not in the model" in failed[3]
    assert failed[0] in errors[0]
    assert {"coefficients.csv", "metrics.json", "ga_genes.json"} <= _artifacts(root, finished[0])
    assert all(h for _, _, h, _ in runs) and failed[2] != finished[2]


@pytest.mark.slow
def test_report_lists_the_failed_run(failed_sweep):
    root, _ = failed_sweep
    proc = run_studies(["report", "report.experiment=failing"], cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = (root / "reports" / "failing" / "index.md").read_text()
    runs = text.split("## Runs")[1].split("##")[0]
    assert "**failed**" in runs and "GA genes not in the model" in runs
    assert "2 runs (1 finished)" in text
    html = (root / "reports" / "failing" / "index.html").read_text()
    assert "failed" in html
    for page in (text, html):
        assert not re.search(r"\b(nan|NaN|inf)\b", page)


# ------------------------------------------------------------------ 3. concurrent writers

@pytest.mark.slow
@pytest.mark.parametrize("repeat", range(3))
def test_eight_jobs_on_two_workers_into_one_store(tmp_path, repeat):
    speeds = ",".join(str(v) for v in range(1, 9))
    proc = run_studies(["run", "-m", f"wind.speed={speeds}", "method=ls", "hydra.launcher.n_jobs=2",
                        "tracking.experiment=concurrent", f"hydra.sweep.dir={tmp_path / 'multirun'}",
                        *SMALL], cwd=tmp_path)
    output = proc.stdout + proc.stderr
    assert "database is locked" not in output
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "[studies] sweep of 8 jobs done: 8 finished" in proc.stderr
    runs = _runs_with_hash(tmp_path)
    assert len(runs) == 8
    assert {s for _, s, _, _ in runs} == {"FINISHED"}
    assert len({h for _, _, h, _ in runs}) == 8
    for run_id, _, _, _ in runs:
        assert ARTIFACTS <= _artifacts(tmp_path, run_id)
    with sqlite3.connect(tmp_path / "mlruns" / "mlflow.db") as con:
        per_run = dict(con.execute("select run_uuid, count(*) from latest_metrics group by run_uuid"))
    parents = [p[0] for p in sweep_parents(tmp_path)]
    jobs = {run: n for run, n in per_run.items() if run not in parents}
    assert len(jobs) == 8 and len(set(jobs.values())) == 1
    assert len(parents) == 1 and per_run[parents[0]] == 4       # jobs/finished, skipped, failed, killed


# ------------------------------------------------------------------ 4. interruption and resume

def _launch(args, cwd: Path):
    env = dict(os.environ, MLFLOW_DISABLE_TELEMETRY="true")
    proc = subprocess.Popen([sys.executable, "-m", "studies", *args], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    lines = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stderr), daemon=True)
    reader.start()
    threading.Thread(target=proc.stdout.read, daemon=True).start()
    return proc, lines, reader


def _status(root: Path) -> list[str]:
    try:
        return [s for _, s, _ in mlflow_runs(root)]
    except sqlite3.OperationalError:       # locked for a moment by a writer
        return []


def _running_before_outputs(root: Path) -> bool:
    """A FINISHED run exists and a RUNNING one has not started logging its
    outputs: a signal now lands in that job's body, never in its last store
    write (which, once begun, is allowed to finish)."""
    db = root / "mlruns" / "mlflow.db"
    if not db.exists():
        return False
    try:
        with sqlite3.connect(db, timeout=1) as con:
            statuses = dict(con.execute("select run_uuid, status from runs").fetchall())
            logged = {r for (r,) in con.execute("select distinct run_uuid from latest_metrics")}
    except sqlite3.OperationalError:       # locked for a moment by a writer
        return False
    return ("FINISHED" in statuses.values()
            and any(s == "RUNNING" and r not in logged for r, s in statuses.items()))


def _group_members(pgid: int) -> list[int]:
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            members.append(int(stat.parent.name))
    return members


def _wait(condition, proc, timeout=400):
    deadline = time.time() + timeout
    while not condition():
        assert proc.poll() is None, "the sweep ended before it could be interrupted"
        assert time.time() < deadline, "timed out"
        time.sleep(0.1)


@pytest.mark.slow
def test_killed_sweep_keeps_finished_runs_and_resume_runs_the_rest(tmp_path):
    sweep = ["run", "-m", "wind.speed=2,4,6,8", "method=ls", "hydra.launcher.n_jobs=2",
             "tracking.experiment=resumable", f"hydra.sweep.dir={tmp_path / 'multirun'}", *SMALL]
    proc, lines, reader = _launch(sweep, tmp_path)
    try:
        # after the first job finished, and while another one is computing
        _wait(lambda: _running_before_outputs(tmp_path), proc)
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    reader.join(10)
    stderr = "".join(lines)
    assert proc.returncode == 128 + signal.SIGTERM, stderr[-3000:]
    assert "studies: interrupted by SIGTERM" in stderr and "resume=true" in stderr
    assert "Traceback" not in stderr
    before = _runs_with_hash(tmp_path)
    statuses = Counter(s for _, s, _, _ in before)
    assert set(statuses) <= {"FINISHED", "KILLED"}, statuses     # nothing left RUNNING
    assert statuses["FINISHED"] >= 1 and statuses["KILLED"] >= 1, statuses
    assert [s for _, s, _ in sweep_parents(tmp_path)] == ["KILLED"]    # the sweep's parent run too
    finished_before = {r: h for r, s, h, _ in before if s == "FINISHED"}
    for run_id in finished_before:
        assert ARTIFACTS <= _artifacts(tmp_path, run_id)
    assert all("interrupted" in (e or "") for _, s, _, e in before if s == "KILLED")
    deadline = time.time() + 15
    while _group_members(proc.pid) and time.time() < deadline:
        time.sleep(0.2)
    assert _group_members(proc.pid) == []      # no worker survives the sweep

    again = run_studies(sweep + ["resume=true"], cwd=tmp_path)
    assert again.returncode == 0, again.stderr[-3000:]
    skipped = re.findall(r"\[studies\] job \d/4 skipped: already finished as run (\w+)", again.stderr)
    assert sorted(skipped) == sorted(finished_before)
    after = _runs_with_hash(tmp_path)
    finished = Counter(h for _, s, h, _ in after if s == "FINISHED")
    assert len(finished) == 4 and set(finished.values()) == {1}, finished
    assert len(after) - len(before) == 4 - len(finished_before)  # exactly the unfinished jobs ran
    for run_id, status, _, _ in after:
        if run_id in finished_before:
            assert status == "FINISHED"
        if status == "FINISHED":
            assert ARTIFACTS <= _artifacts(tmp_path, run_id)


@pytest.mark.slow
def test_sigint_to_a_single_run_marks_it_killed(tmp_path):
    proc, lines, reader = _launch(["run", "method=bayes", "tracking.experiment=single",
                                   f"hydra.run.dir={tmp_path / 'run'}", *SMALL], tmp_path)
    try:
        _wait(lambda: "RUNNING" in _status(tmp_path), proc)
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    reader.join(10)
    stderr = "".join(lines)
    assert proc.returncode == 128 + signal.SIGINT, stderr[-2000:]
    assert "Traceback" not in stderr
    runs = _runs_with_hash(tmp_path)
    assert [(s, e) for _, s, _, e in runs] == [("KILLED", "interrupted by SIGINT")]


def test_launcher_closes_runs_left_open_by_a_dead_worker(tmp_path):
    """A worker killed with SIGKILL cannot close its run: the launcher marks it KILLED."""
    from mlflow.tracking import MlflowClient

    from studies.runtime import tracking
    from studies.cli import _interrupted
    from studies.runtime.jobstate import JobState

    uri = tracking.configure(None, tmp_path)
    client = MlflowClient(uri)
    run_id = client.create_run(client.create_experiment("orphans")).info.run_id
    state = JobState(tmp_path / "state")
    state.path.mkdir()
    (state.path / "active-99999999-0.json").write_text(json.dumps(
        {"pid": 99999999, "num": 0, "overrides": ["wind.speed=4"], "run_id": run_id, "uri": uri}))
    assert _status(tmp_path) == ["RUNNING"]
    assert _interrupted(state, KeyboardInterrupt(), tmp_path) == 130
    runs = _runs_with_hash(tmp_path)
    assert [(s, "interrupted" in e) for _, s, _, e in runs] == [("KILLED", True)]


def test_resume_hash_ignores_bookkeeping_keys_and_sees_data_changes(tmp_path):
    from omegaconf import OmegaConf

    from studies.runtime.resume import config_hash

    data = tmp_path / "a.csv"
    data.write_text("t,x\n0,1\n")
    base = {"wind": {"speed": 4}, "data": {"path": str(data)}, "verbose": False, "resume": False,
            "run_name": None, "tracking": {"uri": None, "experiment": "x"}}
    h = config_hash(OmegaConf.create(base), tmp_path)
    same = dict(base, verbose=True, resume=True, run_name="mine", tracking={"uri": "sqlite:///x"})
    assert config_hash(OmegaConf.create(same), tmp_path) == h
    assert config_hash(OmegaConf.create(dict(base, wind={"speed": 5})), tmp_path) != h
    data.write_text("t,x\n0,2\n")
    assert config_hash(OmegaConf.create(base), tmp_path) != h


# ------------------------------------------------------------------ 5. no NaN in a report

def test_report_of_diverged_and_failed_runs_shows_no_nan(tmp_path):
    """A diverged prediction is scored with the finite penalty and flagged; NaN
    coefficients and failed runs do not crash the report or print NaN."""
    from studies.runtime import tracking
    from studies.analysis.metrics import DIVERGED_PENALTY
    from studies.report.builder import build_report

    for speed, diverge in ((4, False), (8, True)):
        out = tmp_path / f"run{speed}"
        out.mkdir()
        table = pd.DataFrame({"name": ["Xu", "Yv", "Nr"], "value": [1.0, np.nan, -2.0],
                              "lower": np.nan, "upper": np.nan, "true": [1.0, 2.0, -2.0],
                              "deviation_pct": [0.0, np.nan, np.inf if diverge else 0.0]})
        table.to_csv(out / "coefficients.csv", index=False)
        metrics = {"zigzag_10_10/fitness": DIVERGED_PENALTY if diverge else 1e-3,
                   "zigzag_10_10/diverged": float(diverge), "zigzag_10_10/overshoot1_deg": np.nan,
                   "validation/mae_speed": DIVERGED_PENALTY if diverge else 0.01}
        params = {"method": {"name": "ls"}, "wind": {"speed": speed}, "seed": 0}
        with tracking.start_run("diverging", f"ls wind={speed}", None, tmp_path, params) as run:
            run.log_outputs(metrics, out)
    with pytest.raises(ValueError):
        with tracking.start_run("diverging", "ls wind=12", None, tmp_path,
                                {"method": {"name": "ls"}, "wind": {"speed": 12}, "seed": 0}):
            raise ValueError("singular matrix")
    page = build_report(*tracking.read_experiment(None, tmp_path, "diverging"), tmp_path / "reports")
    text = page.read_text()
    html = page.with_suffix(".html").read_text()
    for body in (text, html):
        assert not re.search(r"\b(nan|NaN|inf|-inf)\b", body), body
    assert "diverged: zigzag_10_10" in text
    assert "**failed**" in text and "singular matrix" in text
    assert "1e+06" in text or "1.000e+06" in text
