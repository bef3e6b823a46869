"""The HSVA KVLCC2 zig-zags read into the data contract, and Froude scaling.

The HSVA files are another facility's measurements of the MARIN hull at
model scale: the checks below use only what the files themselves hold (the
heading against the integral of the yaw rate, the track against the
velocities) and the MARIN files as the second facility.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SHARED_DATA, hsva_file, marin_file

from studies.data import froude_scale, load_manoeuvre, read_dat, read_hsva, read_marin
from studies.errors import DataError

TESTS = ("05_01", "10_01", "10_05", "10_10_P", "10_10_S", "15_01", "15_05", "20_05", "20_10_P",
         "20_10_S", "25_05", "30_05", "35_05")


@pytest.mark.parametrize("test", TESTS)
def test_every_hsva_zigzag_reads_into_the_contract(test):
    rec = read_hsva(hsva_file(test))
    rudder = float(test.split("_")[0])
    assert rec.attrs["vessel"] == "kvlcc2" and rec.attrs["facility"] == "HSVA"
    assert rec.attrs["model_scale"] is True and rec.attrs["scale"] == pytest.approx(45.7)
    assert np.diff(rec["t"]).round(6).tolist() == [0.05] * (len(rec) - 1)
    # the rudder reaches exactly the test's angle (degrees in the file, radians here)
    assert np.rad2deg(rec["delta"].abs().max()) == pytest.approx(rudder, abs=0.05)
    # column 7 is the yaw rate: its integral follows the heading
    t, psi, r = (rec[c].to_numpy() for c in ("t", "psi", "r"))
    integral = psi[0] + np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(t))])
    assert np.max(np.abs(np.rad2deg(integral - psi))) < 0.2      # column 8 misses by degrees
    # body-fixed velocities: the track differenced and turned into body axes
    dx, dy = np.gradient(rec["x0"].to_numpy(), t), np.gradient(rec["y0"].to_numpy(), t)
    u_track = dx * np.cos(psi) + dy * np.sin(psi)
    v_track = -dx * np.sin(psi) + dy * np.cos(psi)
    assert np.median(np.abs(u_track - rec["u"])) < 0.005
    assert np.median(np.abs(v_track - rec["v"])) < 0.005
    assert {"n", "thrust", "torque"} <= set(rec.columns)
    assert rec["thrust"].median() > 0


def test_starboard_start_turns_to_positive_heading():
    """Rudder sign of the data contract: the ``_S`` test puts the rudder negative first
    and the heading rises (the README: about +17 deg 10 s after the execute)."""
    rec = read_hsva(hsva_file("20_10_S"))
    moved = np.flatnonzero(np.abs(rec["delta"].to_numpy()) > np.deg2rad(1.0))[0]
    assert rec["delta"].iloc[moved] < 0
    later = rec["t"].to_numpy() > rec["t"].iloc[moved] + 10.0
    assert np.rad2deg(rec["psi"].to_numpy()[later][0] - rec["psi"].iloc[0]) > 10.0
    port = read_hsva(hsva_file("20_10_P"))
    moved = np.flatnonzero(np.abs(port["delta"].to_numpy()) > np.deg2rad(1.0))[0]
    assert port["delta"].iloc[moved] > 0


def test_the_two_facilities_meet_at_one_scale():
    """Froude scaling makes HSVA's model and MARIN's ship one data set: the
    approach speed and propeller rate of both, at either scale, agree within 3 %."""
    hsva = read_hsva(hsva_file("10_10_S"))
    marin = read_marin(marin_file("zz_10"), model_scale=True)
    assert marin.attrs["model_scale"] is True
    for column in ("u", "n"):
        assert float(marin[column].iloc[0]) == pytest.approx(float(hsva[column].iloc[0]), rel=0.03)
    full = froude_scale(hsva, "full")
    assert full.attrs["model_scale"] is False
    assert float(full["u"].iloc[0]) == pytest.approx(7.97, rel=0.02)          # 15.5 kn
    assert float(full["t"].iloc[-1]) == pytest.approx(float(hsva["t"].iloc[-1]) * 45.7 ** 0.5)
    assert float(full["thrust"].iloc[0]) == pytest.approx(float(hsva["thrust"].iloc[0]) * 45.7 ** 3)
    back = froude_scale(full, "model")
    for column in ("t", "x0", "u", "r", "n", "torque", "psi", "delta"):
        np.testing.assert_allclose(back[column], hsva[column], rtol=1e-12, atol=1e-12)


def test_dat_files_are_told_apart_by_their_layout():
    assert read_dat(hsva_file("10_10_S")).attrs["facility"] == "HSVA"
    assert read_dat(marin_file("zz_10")).attrs["facility"] == "MARIN"
    assert load_manoeuvre(hsva_file("35_05")).attrs["model_scale"] is True


def test_a_bad_hsva_row_is_refused_with_its_line(tmp_path):
    lines = hsva_file("10_10_S").read_bytes().splitlines(keepends=True)
    row = lines[104].split()
    row[6] = b"n/a"
    lines[104] = b"  ".join(row) + b"\r\n"
    bad = tmp_path / "HSVA_bad.dat"
    bad.write_bytes(b"".join(lines))
    with pytest.raises(DataError) as caught:
        read_hsva(bad)
    assert caught.value.column == "r" and caught.value.row == 100
    assert "line 105" in str(caught.value)
    short = tmp_path / "HSVA_short.dat"
    short.write_bytes(b"".join(lines[:4] + [b" 0.0 1.0 2.0\r\n"]))
    with pytest.raises(DataError, match="3 values instead of 12"):
        read_hsva(short)


def test_a_record_that_does_not_state_its_scale_is_not_mixed_silently(tmp_path):
    """A CSV of MARIN's full-scale run beside HSVA's model-scale file: refused at model
    scale (its speed is 6.8 times theirs), taken as it is when the study is at full scale."""
    from studies.workflows.measured import load_study_records

    csv = tmp_path / "marin_zz10.csv"
    read_marin(marin_file("zz_10"))[["t", "x0", "y0", "psi", "u", "v", "r", "delta", "n"]].to_csv(csv, index=False)
    with pytest.raises(DataError, match="another scale"):
        load_study_records([hsva_file("35_05")], [csv])
    training, validation = load_study_records([hsva_file("35_05")], [csv], scale="full")
    assert training[0].attrs["model_scale"] is False
    assert float(training[0]["u"].iloc[0]) == pytest.approx(float(validation[0]["u"].iloc[0]), rel=0.03)
