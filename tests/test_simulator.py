"""The compiled simulator against an independent transcription of MSS mariner.m."""

import numpy as np
import pytest

import reference_mariner as ref
from studies.environment.conditions import Environment
from studies.simulate import Manoeuvre, simulate, simulate_many, turning, zigzag


def test_matches_independent_mariner_with_held_rudder(model, vessel):
    """No switching logic involved: a 20 deg rudder held for 300 s."""
    theirs = ref.zigzag_record(20.0, 720.0, duration=300.0)
    ours = simulate(model, vessel.coefficients, vessel, turning(20.0, pullout=0.0, duration=300.0))
    for col, tol in (("u", 1e-6), ("v", 1e-6), ("r", 1e-8), ("psi", 1e-6), ("x0", 1e-3),
                     ("y0", 1e-3), ("delta", 1e-9)):
        np.testing.assert_allclose(ours[col].to_numpy(), theirs[col], atol=tol, err_msg=col)


def test_zigzag_respects_rudder_limits_and_switches_on_heading(model, vessel):
    rec = simulate(model, vessel.coefficients, vessel, zigzag(40, 10, duration=300.0))
    delta = rec["delta"].to_numpy()
    rate = np.diff(delta) / 0.1
    assert np.max(np.abs(delta)) <= np.deg2rad(40.0) + 1e-12
    assert np.max(np.abs(rate)) <= np.deg2rad(5.0) + 1e-9
    # the rudder reverses when the heading passes -10 deg then +10 deg
    psi = np.rad2deg(rec["psi"].to_numpy())
    first_reversal = np.flatnonzero(np.diff(delta) < 0)[0]
    assert psi[first_reversal] == pytest.approx(-10.0, abs=0.2)
    assert psi.min() < -10.0 and psi.max() > 10.0


def test_many_parameter_sets_at_once_equal_one_by_one(model, vessel):
    man = zigzag(20, 20, duration=200.0)
    base = model.vector(vessel.coefficients)
    sets = np.vstack([base, base * 1.1, base * 0.9])
    t, states, diverged = simulate_many(model, sets, vessel, man)
    assert np.all(diverged == -1)
    for i, row in enumerate(sets):
        one = simulate(model, model.as_dict(row), vessel, man)
        np.testing.assert_allclose(states[i, :, 2], one["r"].to_numpy(), rtol=1e-12, atol=1e-15)


def test_absurd_coefficients_are_cut_off_not_crashing(model, vessel):
    values = dict(vessel.coefficients)
    values["Nr"] = 5.0  # destabilising yaw damping of the wrong sign and size
    values["Yv"] = 3.0
    rec = simulate(model, values, vessel, zigzag(20, 20, duration=600.0))
    assert "diverged_at" in rec.attrs
    t_div = rec.attrs["diverged_at"]
    assert 0 < t_div < 600.0
    assert rec.loc[rec["t"] > t_div + 0.2, "u"].isna().all()


def test_wind_pushes_the_ship_downwind(model, vessel):
    """A beam wind from east (y0 side) drifts a ship on a straight course west."""
    man = Manoeuvre("straight", "rudder", 300.0, 0.1)
    calm = simulate(model, vessel.coefficients, vessel, man)
    windy = simulate(model, vessel.coefficients, vessel, man, Environment(15.0, np.pi / 2))
    assert windy["y0"].iloc[-1] < calm["y0"].iloc[-1] - 5.0


def test_current_moves_the_track_not_the_water_velocities(model, vessel):
    man = Manoeuvre("straight", "rudder", 200.0, 0.1)
    calm = simulate(model, vessel.coefficients, vessel, man)
    env = Environment(current_speed=0.5, current_direction=np.pi / 2)
    drift = simulate(model, vessel.coefficients, vessel, man, env)
    # the over-ground record carries the current; the track is shifted east by 0.5 m/s * 200 s
    assert drift["y0"].iloc[-1] - calm["y0"].iloc[-1] == pytest.approx(100.0, rel=1e-3)
    assert drift["v"].iloc[0] == pytest.approx(0.5, abs=1e-9)


def test_arbitrary_rudder_series_is_followed_through_the_servo(model, vessel, tmp_path):
    path = tmp_path / "rudder.csv"
    path.write_text("t,delta\n0,0\n50,10\n100,-10\n200,-10\n")
    man = Manoeuvre.from_config({"name": "custom", "kind": "rudder", "duration": 200.0, "dt": 0.5,
                                 "series_file": str(path)})
    rec = simulate(model, vessel.coefficients, vessel, man)
    at = rec.set_index("t")["delta"]
    assert np.rad2deg(at[50.0]) == pytest.approx(10.0, abs=1.5)   # servo lag of ~1 s
    assert np.rad2deg(at[200.0]) == pytest.approx(-10.0, abs=1e-3)


def test_a_vessel_without_wind_particulars_simulates_as_in_calm_water(model, vessel):
    """The compiled wind load is typed for every entry of the particulars it
    reads, also for a vessel that has none (the KVLCC2): its calm-water
    zig-zag is the one of the same vessel with particulars."""
    import dataclasses

    bare = dataclasses.replace(vessel, wind=None)
    man = zigzag(20, 20, duration=200.0)
    np.testing.assert_array_equal(simulate(model, vessel.coefficients, bare, man)[["x0", "y0", "psi"]],
                                  simulate(model, vessel.coefficients, vessel, man)[["x0", "y0", "psi"]])


def test_a_vessel_without_wind_gets_as_many_zeros_as_the_wind_particulars():
    """The compiled force evaluation reads every index of the wind particulars
    (the convention's flags at 9 and 10) whether the wind blows or not: a vessel
    without them (the KVLCC2) must type-check from a fresh compilation cache."""
    from studies.simulate.integrator import WIND_PARTICULARS, _wind_tuple
    from studies.vessels import get_vessel

    assert len(get_vessel("mariner").wind.as_array()) == WIND_PARTICULARS
    assert _wind_tuple(np.zeros(0)) == (0.0,) * WIND_PARTICULARS
