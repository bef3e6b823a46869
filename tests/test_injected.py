"""Exact effects injected into measured records (studies.scenarios.injected)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.errors import ConfigError
from studies.scenarios.injected import Injection, inject, injection_grid

MARIN = Path(__file__).resolve().parents[2] / "shared" / "data" / "kvlcc2_free_running"


def _record(model_scale=False):
    t = np.arange(0.0, 100.0, 0.5)
    psi = 0.02 * t
    rec = pd.DataFrame({"t": t, "x0": 5.0 * t, "y0": 0.1 * t ** 1.5, "psi": psi, "u": np.full_like(t, 5.0),
                        "v": 0.1 * np.sin(t), "r": np.full_like(t, 0.02), "delta": 0.1 * np.sin(0.1 * t)})
    rec.attrs = {"name": "zz", "model_scale": model_scale, "scale": 45.7}
    return rec


def test_a_rudder_sensor_offset_is_added_to_the_recorded_rudder_only():
    rec = _record()
    out = inject(rec, Injection(rudder_offset=np.deg2rad(1.5)))
    assert np.allclose(out["delta"] - rec["delta"], np.deg2rad(1.5))
    for c in ("t", "x0", "y0", "psi", "u", "v", "r"):
        assert np.array_equal(out[c], rec[c])
    assert out.attrs["injected"] == {"rudder_offset": {"delta0": pytest.approx(np.deg2rad(1.5))}}
    assert out.attrs["name"].startswith("zz_offset")


def test_a_uniform_current_moves_the_track_and_the_over_ground_velocities_exactly():
    rec = _record()
    speed, direction = 0.5, np.deg2rad(60.0)
    out = inject(rec, Injection(current_speed=speed, current_direction=direction))
    t = rec["t"].to_numpy()
    assert np.allclose(out["x0"] - rec["x0"], speed * np.cos(direction) * (t - t[0]))
    assert np.allclose(out["y0"] - rec["y0"], speed * np.sin(direction) * (t - t[0]))
    # earth-fixed velocity from body-fixed u, v and the heading: the current is added, whatever the heading
    psi = rec["psi"].to_numpy()

    def earth(r):
        return (r["u"] * np.cos(psi) - r["v"] * np.sin(psi), r["u"] * np.sin(psi) + r["v"] * np.cos(psi))
    (n0, e0), (n1, e1) = earth(rec), earth(out)
    assert np.allclose(n1 - n0, speed * np.cos(direction)) and np.allclose(e1 - e0, speed * np.sin(direction))
    assert np.array_equal(out["delta"], rec["delta"]) and np.array_equal(out["psi"], rec["psi"])


def test_a_full_scale_current_is_froude_scaled_into_a_model_scale_record():
    out = inject(_record(model_scale=True), Injection(current_speed=0.5, current_direction=0.0))
    drift = out["x0"].iloc[-1] - _record()["x0"].iloc[-1]
    assert drift == pytest.approx(0.5 / np.sqrt(45.7) * 99.5)
    assert out.attrs["injected"]["current"]["speed"] == 0.5       # the truth stays at full scale


def test_bad_injections_and_records_are_refused():
    with pytest.raises(ConfigError, match="current_speed"):
        Injection(current_speed=-0.1)
    with pytest.raises(ConfigError, match="finite"):
        Injection(rudder_offset=float("nan"))
    with pytest.raises(ConfigError, match="lacks the columns"):
        inject(_record().drop(columns=["psi"]), Injection(rudder_offset=0.01))


def test_the_grid_covers_sizes_directions_and_both_together():
    grid = injection_grid()
    offsets = sorted({round(np.rad2deg(g.rudder_offset), 3) for g in grid if g.causes == ("rudder_offset",)})
    assert offsets == [-2.0, -1.0, -0.5, 0.5, 1.0, 2.0]
    currents = {(g.current_speed, round(np.rad2deg(g.current_direction))) for g in grid if g.causes == ("current",)}
    assert len(currents) == 12 and {d for _, d in currents} == {0, 90, 180, 270}
    assert sum(g.causes == ("rudder_offset", "current") for g in grid) == 4


@pytest.mark.skipif(not MARIN.is_dir(), reason="the shared MARIN records are not beside the repository")
def test_an_injected_current_leaves_the_marin_record_consistent_with_its_own_track():
    from studies.workflows.measured import load_measured

    rec = load_measured([MARIN / "MARIN_FREE_KVLCC2_zz_20_m.dat"])[0]
    out = inject(rec, Injection(current_speed=0.8, current_direction=np.deg2rad(200.0)))
    # the integrated earth-fixed velocity ends where the track ends, in both (the record's own
    # consistency is kept; positions are printed to three digits, so over the whole record)
    for r in (rec, out):
        t, psi = r["t"].to_numpy(), r["psi"].to_numpy()
        u, v = r["u"].to_numpy(), r["v"].to_numpy()
        north = np.trapezoid(u * np.cos(psi) - v * np.sin(psi), t)
        east = np.trapezoid(u * np.sin(psi) + v * np.cos(psi), t)
        dx, dy = r["x0"].iloc[-1] - r["x0"].iloc[0], r["y0"].iloc[-1] - r["y0"].iloc[0]
        assert np.hypot(north - dx, east - dy) < 0.01 * np.hypot(dx, dy) + 10.0
