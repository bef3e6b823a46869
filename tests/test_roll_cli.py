"""``studies run model=roll`` as a user runs it."""


import numpy as np
import pandas as pd
import pytest

from conftest import mlflow_runs, run_studies


@pytest.mark.slow
def test_roll_run_on_synthetic_decay_recovers_b1_b2(tmp_path):
    proc = run_studies(["run", "model=roll", "method=nls_svm", "model.synthetic.noise=0.01",
                        f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    table = pd.read_csv(tmp_path / "run" / "coefficients.csv").set_index("name")
    assert set(table.index) >= {"omega0", "b1", "b2"}
    assert np.all(np.abs(table.loc[["b1", "b2"], "deviation_pct"]) < 2.0)
    runs = mlflow_runs(tmp_path)
    assert len(runs) == 1 and runs[0][1] == "FINISHED"


@pytest.mark.slow
def test_roll_run_refuses_a_record_that_is_not_a_decay(tmp_path):
    t = np.arange(0, 30, 0.01)
    path = tmp_path / "not_a_decay.csv"
    pd.DataFrame({"t": t, "phi": 0.1 * np.sin(2.5 * t) * np.exp(0.05 * t)}).to_csv(path, index=False)
    proc = run_studies(["run", "model=roll", "method=fls", f"data.path={path}",
                        f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "not_a_decay.csv" in proc.stderr
    assert mlflow_runs(tmp_path) == []
