"""``studies run`` as a user runs it: from a CSV another program wrote, and on bad input."""

import json
import sqlite3

import numpy as np
import pandas as pd
import pytest

import reference_mariner as ref
from conftest import mlflow_runs, run_studies
from studies.vessels import MARINER_COEFFICIENTS

# The reference program's own coefficient listing (tests/reference_mariner.py).
REF_VALUES = {name: getattr(ref, name) for name in MARINER_COEFFICIENTS}


@pytest.fixture(scope="module")
def other_program_csv(tmp_path_factory):
    """A 1500 s 20/20 zig-zag written by the independent SciPy-based simulator."""
    path = tmp_path_factory.mktemp("data") / "mariner_zigzag_other_program.csv"
    ref.write_csv(path, ref.zigzag_record(20.0, 20.0, duration=1500.0, dt=0.1))
    return path


@pytest.mark.slow
def test_run_on_csv_written_by_another_program(tmp_path, other_program_csv):
    run_dir = tmp_path / "run"
    proc = run_studies(["run", f"data.path={other_program_csv}", "vessel=mariner",
                        "validate.manoeuvres=[zigzag_10_10,turning_35]", "validate.duration=600",
                        f"hydra.run.dir={run_dir}"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    table = pd.read_csv(run_dir / "coefficients.csv")
    assert list(table.columns) == ["name", "value", "lower", "upper", "true", "deviation_pct"]
    values = dict(zip(table["name"], table["value"]))
    dev = np.array([100 * (values[k] - v) / v for k, v in REF_VALUES.items()])
    assert np.median(np.abs(dev)) < 0.5
    assert np.abs(dev).max() < 10.0
    # measured data: no "true" column values are invented
    assert table["true"].isna().all()
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["zigzag_10_10/fitness"] < 1e-4
    assert "turning_35/tactical_diameter_error_pct" in metrics
    assert abs(metrics["turning_35/tactical_diameter_error_pct"]) < 2.0
    runs = mlflow_runs(tmp_path)
    assert len(runs) == 1 and runs[0][1] == "FINISHED"
    artifacts = list((tmp_path / "mlruns" / "artifacts").rglob("*"))
    names = {p.name for p in artifacts}
    assert {"coefficients.csv", "metrics.json", "validation_turning_35.png"} <= names
    with sqlite3.connect(tmp_path / "mlruns" / "mlflow.db") as con:
        params = dict(con.execute("select key, value from params").fetchall())
        logged = dict(con.execute("select key, value from latest_metrics").fetchall())
    assert params["vessel.name"] == "mariner" and params["method.name"] == "ls"
    assert logged["zigzag_10_10/fitness"] == pytest.approx(metrics["zigzag_10_10/fitness"])


def _write(frame, path):
    frame.to_csv(path, index=False)
    return path


def _bad_missing(f, p):
    return _write(f.drop(columns=["r"]), p), ("'r'",)


def _bad_nan(f, p):
    g = f.copy()
    g.loc[17, "v"] = np.nan
    return _write(g, p), ("'v'", "17")


def _bad_time(f, p):
    g = f.copy()
    g.loc[20, "t"] = g.loc[18, "t"]
    return _write(g, p), ("'t'", "20")


def _bad_degrees(f, p):
    g = f.copy()
    g["delta"] = np.rad2deg(g["delta"])
    return _write(g, p), ("'delta'", "radians")


def _bad_empty(f, p):
    p.write_text("")
    return p, ("empty",)


def _bad_binary(f, p):
    p.write_bytes(bytes(range(256)) * 8)
    return p, ()


# one end-to-end case in the fast loop; the loader's refusals themselves are
# tested in process (test_data_contract.py, test_data_io.py, test_reliability_input.py)
@pytest.mark.parametrize("maker", [_bad_missing] + [
    pytest.param(m, marks=pytest.mark.slow)
    for m in (_bad_nan, _bad_time, _bad_degrees, _bad_empty, _bad_binary)],
    ids=lambda m: m.__name__[5:])
@pytest.mark.slow
def test_bad_input_is_one_line_nonzero_and_no_run(tmp_path, good_frame, maker):
    path, expected = maker(good_frame, tmp_path / "bad_record.csv")
    proc = run_studies(["run", f"data.path={path}", "vessel=mariner", f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "bad_record.csv" in lines[0]
    for text in expected:
        assert text in lines[0], lines[0]
    assert "Traceback" not in proc.stderr + proc.stdout
    assert mlflow_runs(tmp_path) == []


@pytest.mark.slow
def test_missing_data_file_and_impossible_values_are_refused(tmp_path, refused_in_process):
    # end to end through the console script: exit status 2, one line, no run
    proc = run_studies(["run", f"data.path={tmp_path / 'nope.csv'}", f"hydra.run.dir={tmp_path / 'run'}"],
                       cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "nope.csv" in proc.stderr
    assert mlflow_runs(tmp_path) == []
    # the same check before Hydra, in process
    for args, text in ((["wind.speed=-3"], "wind.speed"),
                       (["noise.measurement=5"], "noise.measurement")):
        refused_in_process("config", args + [f"hydra.run.dir={tmp_path / 'run'}"], tmp_path, "run", text)
    assert mlflow_runs(tmp_path) == []


def test_an_appended_key_the_schema_does_not_know_is_refused(tmp_path, refused_in_process):
    """``+wind.sped=12`` once ran with wind.speed = 0 and logged a meaningless param."""
    line = refused_in_process("config", ["+wind.sped=12"], tmp_path, "run", "wind.sped: unknown key",
                              "wind.speed")
    assert "+wind" not in line                       # no advice to append the misspelt key
    refused_in_process("discover", ["+discover.nosuch=1"], tmp_path, "discover", "discover.nosuch: unknown key")


@pytest.mark.slow
def test_studies_bench_runs_from_anywhere_and_refuses_an_unknown_name(tmp_path):
    """The benchmarks ship in the package: run from a folder with no benchmarks/ beside it."""
    import json as _json

    proc = run_studies(["bench", "simulator"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    figures = _json.loads(proc.stdout)
    assert figures["sim_40001_steps_ms"] > 0 and "bench_simulator_wall_s" in figures
    proc = run_studies(["bench", "nosuch"], tmp_path)
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0
    assert "unknown benchmark nosuch" in proc.stderr and "simulator" in proc.stderr


@pytest.mark.slow
def test_runs_started_together_write_to_their_own_folders(tmp_path):
    """Two runs started in the same second once shared outputs/<date>/<time>/ and overwrote
    each other's files; the folder is named to the microsecond."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    env = dict(os.environ, MLFLOW_DISABLE_TELEMETRY="true")
    cmd = [sys.executable, "-m", "studies", "run", "manoeuvre.duration=200", "validate.manoeuvres=[zigzag_10_10]"]
    procs = [subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outputs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err[-1000:] for _, err in outputs]
    folders = {line.rsplit("-> ", 1)[1].strip() for out, _ in outputs for line in out.splitlines()
               if line.startswith("run '")}
    assert len(folders) == 2
    for folder in folders:
        assert (Path(folder) / "metrics.json").is_file()
