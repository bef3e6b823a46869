"""The one inference of ``studies discover`` (``discover/inference.py``): its
signatures, its comparison and its refusals."""

import numpy as np
import pytest

from studies.discover import inference as inf
from studies.discover.causes import EnvironmentalBias, RudderOffset
from studies.discover.fitting import Context
from studies.errors import ConfigError
from studies.models.abkowitz import abkowitz
from studies.scenarios.hidden import hidden_records


@pytest.fixture(scope="module")
def clean(vessel_module):
    records, _ = hidden_records(vessel_module, "none", seed=5)
    return records


@pytest.fixture(scope="module")
def vessel_module():
    from studies.vessels import get_vessel

    return get_vessel("mariner")


def _every(vessel, records):
    return Context(vessel, abkowitz(), records[:2], [], "central")


def test_an_earth_fixed_force_has_its_exact_signature(vessel_module, clean):
    """A linear cause's signature by central differences through its own hooks
    equals the column written out: the bias turned to body axes with the heading."""
    ctx = _every(vessel_module, clean)
    design = inf._design(ctx, inf._baseline_setup(ctx))
    (variant,) = [v for v in inf._variants(ctx, design, [EnvironmentalBias(fit_moment=False)])
                  if v.cause.id == "environmental_bias"]
    n = design.n_data
    x_bx = variant.columns[:n[0], 0] * design.sigma[0] / design.nominal[0]
    y_by = variant.columns[n[0]:n[0] + n[1], 1] * design.sigma[1] / design.nominal[1]
    y_bx = variant.columns[n[0]:n[0] + n[1], 0] * design.sigma[1] / design.nominal[1]
    assert np.allclose(x_bx, np.cos(design.states[0]["psi"]), atol=1e-6)
    assert np.allclose(y_by, np.cos(design.states[1]["psi"]), atol=1e-6)
    assert np.allclose(y_bx, -np.sin(design.states[1]["psi"]), atol=1e-6)
    # the yaw rows carry no earth-fixed force when bn is not fitted
    assert np.allclose(variant.columns[n[0] + n[1]:n[0] + n[1] + n[2]], 0.0)


def test_the_residualised_comparison_equals_least_squares_on_the_whole_design(vessel_module, clean):
    ctx = _every(vessel_module, clean)
    design = inf._design(ctx, inf._baseline_setup(ctx))
    variants = inf._variants(ctx, design, [RudderOffset()])
    extra = variants[0].columns
    res = inf._Residualised(design, extra)
    x = np.hstack([design.x, extra])
    beta, *_ = np.linalg.lstsq(x, design.y, rcond=None)
    resid = design.y - x @ beta
    per_dof = [float(np.sum(resid[design.dof == k] ** 2)) for k in range(3)]
    assert np.allclose(res.rss(np.arange(extra.shape[1])), per_dof, rtol=1e-6)
    assert res.fit(np.arange(extra.shape[1]))[0] == pytest.approx(beta[-1], rel=1e-6)


def test_evidence_below_its_price_leaves_none_more_probable_and_dispersion_divides_evidence():
    rss = np.array([[100.0, 100.0, 100.0], [99.9, 100.0, 100.0], [50.0, 100.0, 100.0]])
    n_params = np.array([0.0, 1.0, 1.0])
    log_prior = np.log(np.array([1 / 3, 1 / 3, 1 / 3]))
    _, p = inf.scores_of(rss, n_params, log_prior, 1000.0, 1.0)
    assert p[2] > 0.99                                   # halving one DOF's residual is plain evidence
    _, p = inf.scores_of(rss[:2], n_params[:2], log_prior[:2], 1000.0, 1.0)
    assert p[0] > p[1]                                   # 0.1 % less residual does not pay for a parameter
    _, weak = inf.scores_of(rss, n_params, log_prior, 1000.0, np.array([1.0, 1.0, 400.0]))
    assert weak[0] > weak[2]                             # the same ratio, 400 times less trustworthy


def test_the_inference_refuses_the_options_of_the_search(tmp_path, vessel_module, clean):
    from hydra import initialize_config_module

    from studies.config import compose_settings
    from studies.scenarios.hidden import write_records
    from studies.workflows.kinds import prepare_discover

    paths = write_records(clean, tmp_path)
    with initialize_config_module("studies.conf", version_base="1.3"):
        cfg = compose_settings("discover", overrides=[f"data.path=[{paths[0]},{paths[1]}]",
                                                      f"validate.path=[{paths[2]}]", "discover.splits=true"])
    with pytest.raises(ConfigError, match="discover.method=search"):
        prepare_discover(cfg, tmp_path)
