"""SINDy on measured records (the MARIN KVLCC2 runs, which no code of the project made).

- every identification method runs on a measured record with the default
  derivative estimator and gives a result or a one-line refusal, never an
  internal error (the extended library once failed on the label of the
  model-based smoother's estimates);
- SINDy's threshold is chosen by cross-validation: on the MARIN zig-zags it
  keeps fewer terms than least squares, its prediction of the held-out turn
  does not diverge, its inclusion probabilities reach the run's metrics and
  ``sindy.md`` sets its prediction beside LS's.
"""

from __future__ import annotations

import json

import pytest
from conftest import marin_file, mlflow_runs, run_studies

from studies.config import compose_settings
from studies.errors import StudiesError
from studies.workflows.kinds import kind_for

#: every method of the ``method`` group, with settings that keep a test short
METHODS = {
    "ls": [],
    "svm": ["method.max_rows=1000"],
    "ls_ga": ["method.generations=2", "method.sobol_samples=64"],
    "svm_ga": ["method.generations=2", "method.sobol_samples=64"],
    "bayes": ["method.n_samples=256", "method.burn_in=50", "method.thin=2"],
    "sindy": [],
    "sindy_extended": ["method.library=extended"],
}


@pytest.mark.slow
@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_method_runs_on_a_measured_record_or_refuses_in_one_line(tmp_path, method):
    zz20, zz10 = marin_file("zz_20"), marin_file("zz_10")
    name = method.split("_extended")[0]
    cfg = compose_settings("config", overrides=[f"method={name}", f"data.path=[{zz20}]",
                                                f"validate.path=[{zz10}]", "validate.compare_derivatives=false",
                                                *METHODS[method]])
    assert cfg.vessel.name == "auto" and cfg.data.derivative == "auto"
    try:
        study = kind_for(cfg).prepare(cfg, tmp_path)
        metrics = study.execute(tmp_path / "out")
    except StudiesError as error:                  # a refusal a user can act on: one line
        assert "\n" not in str(error).strip(), str(error)
        return
    assert study.cfg.vessel.name == "kvlcc2"
    assert metrics["validation/validated"] == 1
    assert (tmp_path / "out" / "coefficients.csv").is_file()


@pytest.mark.slow
def test_sindy_is_sparser_than_ls_on_the_marin_records_and_logs_its_inclusion(tmp_path):
    zz10, zz20, tc35 = (marin_file(m) for m in ("zz_10", "zz_20", "tc_35"))
    out = tmp_path / "run"
    proc = run_studies(["run", "method=sindy", f"data.path=[{zz10},{zz20}]", f"validate.path=[{tc35}]",
                        f"hydra.run.dir={out}"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    m = json.loads((out / "metrics.json").read_text())
    kept = sum(m[f"sindy/{dof}/n_selected"] for dof in "XYN")
    assert kept < 40 * 0.75, kept                       # measured: 21 of the 40 terms
    for dof in "XYN":
        assert 0.0 < m[f"sindy/{dof}/threshold"] and f"sindy/{dof}/cv_error" in m
    assert m["MARIN_FREE_KVLCC2_tc_35_m/diverged"] == 0.0
    assert m["ls/MARIN_FREE_KVLCC2_tc_35_m/diverged"] == 0.0
    # the held-out turn: whole-record error no worse than LS's (measured 793 m against 837 m)
    assert m["MARIN_FREE_KVLCC2_tc_35_m/rmse_position"] <= m["ls/MARIN_FREE_KVLCC2_tc_35_m/rmse_position"]
    inclusion = [k for k in m if k.startswith("sindy/N/inclusion/")]
    assert len(inclusion) == 15 and all(0.0 <= m[k] <= 1.0 for k in inclusion)
    page = (out / "sindy.md").read_text()
    assert "dropped:" in page and "| MARIN_FREE_KVLCC2_tc_35_m | tactical_diameter_error_pct |" in page
    # the inclusion probabilities are in the run's MLflow metrics
    (run_id, status, _), = mlflow_runs(tmp_path)
    assert status == "FINISHED"
    import sqlite3
    with sqlite3.connect(tmp_path / "mlruns" / "mlflow.db") as con:
        keys = {row[0] for row in con.execute("select key from metrics where run_uuid = ?", (run_id,))}
    assert set(inclusion) <= keys
    # and the report shows them
    proc = run_studies(["report", "report.experiment=studies"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = (tmp_path / "reports" / "studies" / "index.md").read_text()
    assert "SINDy: inclusion probability" in report and "| N: Nvvr |" in report
