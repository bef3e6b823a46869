"""The identifiability page of an MMG identification on measured records: HSVA's
20/10 and 35/5 zig-zags (model scale, Froude scaled to MARIN's full scale) predict
MARIN's 35 deg turning circle, records no code of the project made."""

from __future__ import annotations

import json

import pytest

from conftest import hsva_file, marin_file, run_studies


@pytest.mark.slow
def test_the_page_gives_conditioning_leave_one_out_drift_and_the_states_beyond_training(tmp_path):
    train = [hsva_file("20_10_S"), hsva_file("35_05")]
    held = marin_file("tc_35")
    out = tmp_path / "run"
    proc = run_studies(["run", "model=mmg", f"data.path=[{train[0]},{train[1]}]", f"validate.path=[{held}]",
                        f"hydra.run.dir={out}"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    page = (out / "identifiability.md").read_text()
    metrics = json.loads((out / "metrics.json").read_text())
    # 1. conditioning of the records' rows: the cubic hull terms are nearly collinear on two zig-zags
    assert metrics["identifiability/Y/condition_number"] > 10.0
    assert metrics["identifiability/Yvvr/vif"] > 10.0 and metrics["identifiability/R0/vif"] < 10.0
    # 2. each record left out in turn: a column per record, every coefficient's largest change
    assert "HSVA_CPMC_KVLCC2_Z_20_10_S" in page and "HSVA_CPMC_KVLCC2_Z_35_05" in page
    assert all(f"identifiability/{c}/loo_drift_max_pct" in metrics for c in ("R0", "Yv", "Nr", "Nrrr"))
    # 3. the turn's steady part goes beyond the zig-zags in drift and yaw rate, not in rudder (35/5 went to 35)
    name = "MARIN_FREE_KVLCC2_tc_35_m"
    assert metrics[f"{name}/outside_training/drift_deg"] > 0.3
    assert metrics[f"{name}/outside_training/yaw_rate_prime"] > 0.3
    assert f"{name}/outside_training/rudder_deg" not in metrics
    assert "**Warning:** MARIN_FREE_KVLCC2_tc_35_m goes beyond the training records in drift angle, yaw rate" in page
