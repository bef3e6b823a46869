"""``propulsion`` judged on measured records: the MARIN KVLCC2 runs (no code
of the project made them), a polynomial baseline identified from the two
zig-zags, the 35 deg turning circle held out; and where a polynomial is the
truth.

In the turn the tanker slows to 40 % of its approach speed at constant rpm;
a polynomial in the surge speed fitted at service speed cannot follow the
thrust that rises as it slows, nor the rudder in the stronger slipstream.
On the tracks, the MMG model (thrust from the measured rpm, the rudder in
the slipstream) replaces the baseline's process model in the filter and is
judged by the same criterion as every other cause
(:func:`studies.discovery.track_inference.propulsion_on_tracks`). On MARIN's
records that criterion does not name it: with both filters at their
likelier noises, the polynomial predicts the tracks one step ahead better
(``docs/discovery.md``). Where propulsion is named, on records the MMG
model made, ``tests/test_mmg_run.py`` checks its parameter and report.
"""

import json
import logging

import pytest
from hydra import initialize_config_module

from conftest import marin_file
from studies.config import compose_settings
from studies.workflows.kinds import execute_discover, prepare_discover


def _discover(tmp_path, model: str) -> dict:
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("discover", overrides=[
            "vessel=kvlcc2", f"model={model}",
            f"data.path=[{marin_file('zz_10')},{marin_file('zz_20')}]", f"validate.path=[{marin_file('tc_35')}]"])
    execute_discover(prepare_discover(cfg, tmp_path), tmp_path / "out")
    return json.loads((tmp_path / "out" / "discovery.json").read_text())


@pytest.mark.slow
def test_on_the_measured_tanker_the_propellers_filter_is_judged_at_its_likelier_noises(tmp_path, caplog):
    """The likelihood over a filter's noises has more than one maximum on
    these records (a small velocity noise with a large white process noise,
    or 2 cm/s of velocity noise with a small process noise coloured over
    seconds): the MMG model's filter is searched from the records' noise
    levels and from the polynomial baseline's estimate, and judged at the
    likelier of the two. (Judged so, ``propulsion`` is not named on these
    records: the polynomial predicts their tracks one step ahead better,
    ``docs/discovery.md``.)"""
    import re

    with caplog.at_level(logging.INFO, logger="studies.discovery.track_inference"):
        d = _discover(tmp_path, "symmetric")
    starts = [float(m.group(1)) for r in caplog.records
              if (m := re.search(r"propulsion's filter from .*: ln L (-?[\d.]+)", r.getMessage()))]
    judged = [float(m.group(1)) for r in caplog.records
              if (m := re.search(r"propulsion on the tracks: ln L (-?[\d.]+) against", r.getMessage()))]
    assert len(starts) == 2 and len(judged) == 1, (starts, judged)
    assert judged[0] == pytest.approx(max(starts), abs=0.1), (starts, judged)
    assert "propulsion" in d["evidence"]["margin"], d["evidence"]["margin"]


@pytest.mark.slow
def test_propulsion_is_not_named_where_a_polynomial_is_the_truth(tmp_path):
    """The reverse case: zig-zags of the tanker simulated by a symmetric
    polynomial model (its coefficients identified from zig-zags of the MMG
    model), the propeller's constant rate written in the records as a basin
    logs it. The MMG model has fewer coefficients than the polynomial, which
    the criterion credits, but it does not predict these tracks as well:
    ``propulsion`` is not named."""
    from test_mmg_run import _mmg_records
    from studies.discovery.causes import Setup
    from studies.discovery.fitting import Context, regression_fit
    from studies.models.registry import symmetric
    from studies.simulate import simulate, zigzag
    from studies.vessels import get_vessel

    vessel, model = get_vessel("kvlcc2"), symmetric()
    made = _mmg_records(False, 0)
    params, _, _ = regression_fit(Context(vessel, model, [made["zz10"], made["zz20"]], []),
                                  Setup(model, [made["zz10"], made["zz20"]]))
    rps = float(made["zz10"]["n"].iloc[0])
    paths = {}
    for name, man in (("zz10", zigzag(10, 10, duration=900, dt=0.5)), ("zz20", zigzag(20, 20, duration=900, dt=0.5)),
                      ("zz15", zigzag(15, 15, duration=900, dt=0.5))):
        rec = simulate(model, params, vessel, man).assign(n=rps)
        paths[name] = tmp_path / f"{name}.csv"
        rec.to_csv(paths[name], index=False)
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("discover", overrides=[
            "vessel=kvlcc2", "model=symmetric", f"data.path=[{paths['zz10']},{paths['zz20']}]",
            f"validate.path=[{paths['zz15']}]", "discover.second_cause=false"])
    execute_discover(prepare_discover(cfg, tmp_path), tmp_path / "out")
    d = json.loads((tmp_path / "out" / "discovery.json").read_text())
    assert d["cause"] == "none", (d["cause"], d["evidence"]["margin"])
    # judged, and far from being named
    assert d["evidence"]["margin"]["propulsion"] < -100.0, d["evidence"]["margin"]
