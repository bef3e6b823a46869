"""The cause protocol of ``studies discover``: every cause of the catalogue
declares its contract id, its no-effect parameters and an explanation, and at
its no-effect parameters it leaves the baseline as it is (the records the
regression is built on, the record replayed, the environment, the model, the
external forces).

Fast and in process: two short simulated zig-zags of the Mariner, one calm
(no wind columns) and one in wind (the record carries the wind), so that
every cause is checked on records it applies to.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from studies.discovery.causes import (CATALOGUE, Combined, Current, MissingTerm, RudderOffset,
                                     WindSpeedBias, compact_parameters)
from studies.discovery.fitting import Context
from studies.environment.conditions import Environment
from studies.identification.regression import build_problems
from studies.simulate import simulate, zigzag
from studies.simulate.simulator import record_environment

#: the causes of DESIGN.md's catalogue, in the order they are tried
CONTRACT_IDS = ["none", "rudder_offset", "current", "wind_unmodelled", "wind_speed_bias",
                "environmental_bias", "missing_term", "propulsion", "propeller_asymmetry"]
#: causes whose extension is another model (no parameter value is the baseline)
REPLACING = [c for c in CONTRACT_IDS if CATALOGUE[c].replaces_dynamics]
EXTENDING = [c for c in CONTRACT_IDS if c not in REPLACING]


@pytest.fixture(scope="module")
def contexts(vessel, model):
    """A calm and a windy context, each with one 60 s zig-zag 20/20 to train on."""
    plan = zigzag(20, 20, duration=60.0)
    calm = simulate(model, vessel.coefficients, vessel, plan)
    windy = simulate(model, vessel.coefficients, vessel, plan, Environment(12.0, np.deg2rad(45.0)))
    return {"calm": Context(vessel, model, [calm], []), "windy": Context(vessel, model, [windy], [])}


def no_effect_theta(cause) -> np.ndarray:
    """The cause's nonlinear parameters at its no-effect values."""
    if isinstance(cause, Combined):
        return np.concatenate([no_effect_theta(cause.first), no_effect_theta(cause.second)])
    return np.array([cause.no_effect[p] for p in cause.nl_params], float)


def checked_contexts(cause, contexts) -> dict:
    """The contexts a cause applies to; all of them for a cause that applies to none
    at its no-effect values (a missing term without terms)."""
    return {k: c for k, c in contexts.items() if cause.applicable(c)} or contexts


def assert_no_effect(cause, ctx):
    """At its no-effect parameters the cause leaves the baseline of ``ctx`` as it is."""
    theta = no_effect_theta(cause)
    record = ctx.train[0]
    seen = cause.transform(record, theta)
    pd.testing.assert_frame_equal(seen[record.columns], record, check_exact=True)
    base, extended = build_problems(ctx.model, ctx.vessel, [record]), build_problems(ctx.model, ctx.vessel, [seen])
    for dof, p in base.items():
        np.testing.assert_array_equal(extended[dof].y, p.y, err_msg=f"{cause.id} {dof}: y")
        np.testing.assert_array_equal(extended[dof].theta, p.theta, err_msg=f"{cause.id} {dof}: theta")
    pd.testing.assert_frame_equal(cause.sim_record(record, theta), record, check_exact=True)
    assert cause.environment(record, theta) == record_environment(record), cause.id
    setup = cause.setup(ctx, theta)
    assert setup.environment(record) == record_environment(record), cause.id
    pd.testing.assert_frame_equal(setup.sim_record(record), record, check_exact=True)
    assert setup.model.terms == ctx.model.terms, cause.id
    assert setup.fixed == {}, cause.id
    external = setup.external()
    assert external is None or not np.any(external), (cause.id, external)


def test_the_catalogue_holds_the_contract_ids_in_order():
    assert list(CATALOGUE) == CONTRACT_IDS
    assert all(cls.id == key for key, cls in CATALOGUE.items())


@pytest.mark.parametrize("cause_id", CONTRACT_IDS)
def test_every_cause_declares_the_protocol(cause_id):
    """Declared by the class itself (not inherited): id, no-effect values, explanation;
    the no-effect values name the cause's parameters as ``discovery.json`` writes them."""
    cls = CATALOGUE[cause_id]
    own = vars(cls)
    assert {"id", "no_effect", "explanation"} <= set(own), sorted(own)
    assert isinstance(cls.explanation, str) and len(cls.explanation) > 40
    cause = cls()
    if cls.replaces_dynamics:
        assert cls.no_effect is None
        return
    assert cause.parameters(no_effect_theta(cause)) == cls.no_effect
    assert set(cause.nl_params) <= set(cls.no_effect)
    compact_parameters(cls.no_effect)


def test_propulsion_replaces_the_dynamics_only_where_a_propeller_is_known(contexts):
    """``propulsion`` is the one cause that replaces the baseline: it applies to no
    record of the Mariner (no MMG particulars, no propeller rate) and declares it."""
    assert REPLACING == ["propulsion"]
    cause = CATALOGUE["propulsion"]()
    assert not any(cause.applicable(ctx) for ctx in contexts.values())


@pytest.mark.parametrize("cause_id", EXTENDING)
def test_at_its_no_effect_values_a_cause_leaves_the_record_unchanged(cause_id, contexts):
    cause = CATALOGUE[cause_id]()
    for ctx in checked_contexts(cause, contexts).values():
        assert_no_effect(cause, ctx)


def test_two_causes_at_their_no_effect_values_leave_the_record_unchanged(contexts):
    for cause in (Combined(RudderOffset(), Current()), Combined(Current(), MissingTerm()),
                  Combined(RudderOffset(), WindSpeedBias())):
        assert cause.parameters(no_effect_theta(cause)) == cause.no_effect
        for ctx in checked_contexts(cause.second, contexts).values():
            assert_no_effect(cause, ctx)


def test_a_cause_away_from_its_no_effect_values_changes_the_baseline(contexts):
    """The check above can fail: a current of 0.5 m/s changes the velocities
    through the water and the replay's environment."""
    cause, ctx = Current(), contexts["calm"]
    record = ctx.train[0]
    assert not cause.transform(record, [0.5, 0.0])["u"].equals(record["u"])
    cause.no_effect = {"speed": 0.5, "direction": 0.0}
    with pytest.raises(AssertionError):
        assert_no_effect(cause, ctx)


def test_an_mmg_baseline_replays_a_missing_term_the_simulator_does_not_hold():
    """A missing term found on an MMG baseline (``Nddd``, outside the MMG hull) is replayed:
    at zero it changes nothing, and a yaw moment against the rudder's slows the turn."""
    from studies.discovery.causes.propulsion import MMGDynamics
    from studies.models.mmg import MMGTerm, mmg
    from studies.models.abkowitz import ManoeuvringModel
    from studies.simulate import turning
    from studies.simulate.mmg import simulate_mmg
    from studies.vessels import get_mmg_vessel

    vessel = get_mmg_vessel("kvlcc2")
    base = mmg()
    record = simulate_mmg(base, vessel.coefficients, vessel, turning(35.0, duration=60.0, dt=0.05))
    dynamics = MMGDynamics(vessel)
    extended = ManoeuvringModel("mmg+Nddd", base.terms + (MMGTerm("Nddd", "N", (0, 0, 0, 3), 1.0),))
    values = dict(vessel.coefficients)
    plain = dynamics.replay(values, record)
    at_zero = dynamics.replay({**values, "Nddd": 0.0}, record, model=extended)
    np.testing.assert_allclose(at_zero["psi"], plain["psi"], atol=1e-12)
    # the rudder's yaw moment is opposite to delta (contract sign); a positive Nddd opposes it
    opposed = dynamics.replay({**values, "Nddd": 0.03}, record, model=extended)
    turned, less = plain["psi"].iloc[-1] - plain["psi"].iloc[0], opposed["psi"].iloc[-1] - opposed["psi"].iloc[0]
    assert abs(turned) > np.deg2rad(20.0)
    assert 0.0 < less / turned < 0.95


def test_an_asymmetric_mmg_baseline_carries_its_constants(tmp_path):
    """``studies discover model=mmg model.asymmetry=true``: the baseline's hull has Y0 and N0
    (a single-screw ship's asymmetry is then the baseline's, not a cause's)."""
    from types import SimpleNamespace

    from conftest import marin_file
    from studies.config import compose_settings
    from studies.data import read_marin
    from studies.workflows.discover_inference import baseline_dynamics

    record = read_marin(marin_file("zz_10"))
    for asymmetric in (False, True):
        cfg = compose_settings("discover", overrides=["vessel=kvlcc2", "model=mmg",
                                                      f"model.asymmetry={str(asymmetric).lower()}"])
        dynamics = baseline_dynamics(SimpleNamespace(cfg=cfg, train=[record]))
        assert ({"Y0", "N0"} <= set(dynamics.model.names)) is asymmetric


def test_an_mmg_baseline_of_another_hull_family_is_fitted_and_replayed_as_that_family():
    """``studies discover model=mmg model.hull=reduced``: the baseline's hull is the reduced
    family (the rudder in its terms, the rudder module off, no prior of the standard hull's
    values), fitted on the MMG rows and replayed by the compiled simulator; ``auto`` is the
    run's choice and is refused here in one line."""
    from types import SimpleNamespace

    from conftest import hsva_file
    from studies.config import compose_settings
    from studies.data import read_hsva
    from studies.discovery.fitting import Setup
    from studies.errors import ConfigError
    from studies.identification.ls import LeastSquares
    from studies.workflows.discover_inference import baseline_dynamics

    record = read_hsva(hsva_file("20_10_S"))
    errors = {}
    for hull in ("standard", "reduced"):
        cfg = compose_settings("discover", overrides=["vessel=kvlcc2", "model=mmg", f"model.hull={hull}"])
        dynamics = baseline_dynamics(SimpleNamespace(cfg=cfg, train=[record]))
        ctx = Context(dynamics.vessel, dynamics.model, [record], [], "central", dynamics=dynamics)
        problems, ratio = dynamics.problems(ctx, Setup(dynamics.model, [record], dynamics=dynamics))
        assert ratio == dynamics.vessel.draught / dynamics.vessel.length
        # the free terms by LS, with the terms the problems hold as known (the reduced
        # family's tied rudder pairs, a yaw moment = the side force at the rudder's lever)
        params = LeastSquares().fit(problems).params
        replay = dynamics.replay(params, record)
        err = np.hypot(replay["x0"].to_numpy() - record["x0"].to_numpy()[:len(replay)],
                       replay["y0"].to_numpy() - record["y0"].to_numpy()[:len(replay)])
        assert np.isfinite(err).all() and len(replay) == len(record)
        errors[hull] = float(np.median(err))
    assert {"Yd", "YTd", "Nur"} <= set(dynamics.model.names) and "Yvvv" not in dynamics.model.names
    assert dynamics.modules.f_alpha == 0.0 and dynamics.prior is None
    assert params["Nd"] == pytest.approx(dynamics.ties[0][2] * params["Yd"], rel=1e-9)
    # its own record replayed by each family fitted to it: the reduced family follows it (measured
    # 3.2 m against the standard hull's 15.1 m on a 7 m model), so its own terms were fitted and run
    assert errors["reduced"] < 0.5 * errors["standard"], errors
    auto = compose_settings("discover", overrides=["vessel=kvlcc2", "model=mmg", "model.hull=auto"])
    with pytest.raises(ConfigError, match="model.hull=auto is chosen by `studies run`"):
        baseline_dynamics(SimpleNamespace(cfg=auto, train=[record]))
