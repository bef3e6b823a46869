"""Several simulated training manoeuvres at once (``train.manoeuvres``)."""

import numpy as np
from hydra import initialize_config_module

from studies.config import compose_settings
from studies.workflows.manoeuvring import execute, prepare


def test_several_zigzags_are_all_used_for_training(tmp_path):
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("config", overrides=["train.manoeuvres=[zigzag_10_10,zigzag_30_30]",
                                           "validate.manoeuvres=[zigzag_20_20_600]"])
    study = prepare(cfg, tmp_path)
    assert [r.attrs["name"] for r in study.records] == ["zigzag_10_10", "zigzag_30_30"]
    metrics = execute(study, tmp_path / "out")
    assert metrics["training/samples"] == 2 * 6001
    assert "training_zigzag_30_30/fitness" in metrics
    assert metrics["deviation/median_abs_pct"] < 0.5
    assert np.isfinite(metrics["validation/mae_speed"])
