"""On real records, a discovery whose held-out turn goes where the training zig-zags never
went: HSVA's 10/10, 20/10, 10/5 and 20/5 zig-zags (model scale, Froude scaled) with MARIN's
35 deg turning circle held out, on the MMG baseline. The inference on the zig-zags alone
names a cause whose extension predicts the held-out turn worse; the verdict must say where
the turn went instead, and never call a worse prediction a gain."""

from __future__ import annotations

import json

import pytest
from hydra import initialize_config_module

from conftest import hsva_file, marin_file
from studies.config import compose_settings
from studies.workflows.kinds import execute_discover, prepare_discover


@pytest.mark.slow
def test_a_turn_beyond_the_zig_zags_is_named_outside_training_states(tmp_path):
    train = [hsva_file(t) for t in ("10_10_S", "20_10_S", "10_05", "20_05")]
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("discover", overrides=[
            "model=mmg", "data.scale=full", f"data.path=[{','.join(map(str, train))}]",
            f"validate.path=[{marin_file('tc_35')}]"])
    execute_discover(prepare_discover(cfg, tmp_path), tmp_path / "out")
    d = json.loads((tmp_path / "out" / "discovery.json").read_text())
    assert d["cause"] == "outside_training_states", (d["cause"], d["gain_pct"], d["notes"])
    states = d["parameters"]["states"]
    # the steady turn's drift and yaw rate lie beyond every training zig-zag's
    for state in ("drift_deg", "yaw_rate_prime"):
        (train_low, train_high), (held_low, held_high) = states[state]
        assert held_low < train_low or held_high > train_high, (state, states[state])
    assert "turning circle" in d["parameters"]["manoeuvre"]
    # no extension: nothing gained, nothing claimed, and the page agrees with the numbers
    assert d["gain_pct"] == 0.0 and not d["explains_validation"]
    assert d["baseline"]["validation_rmse"] == d["extended"]["validation_rmse"]
    assert d["confidence"] is None and d["inference_verdict"] != "outside_training_states"
    page = (tmp_path / "out" / "report.md").read_text()
    assert "# Discovery: **outside_training_states**" in page and "it explains them" not in page
