"""The MARIN free-running KVLCC2 files (SIMMAN 2008) in the data contract."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.data import (REQUIRED_COLUMNS, load_manoeuvre, read_marin,
                          validate_manoeuvre)
from studies.errors import ConfigError, DataError

from conftest import marin_file

MANOEUVRES = ("tc_35", "zz_10", "zz_20")
SCALE = 45.7
APPROACH_SPEED = 7.97        # m/s, 15.5 kn full scale


_cache: dict[tuple, pd.DataFrame] = {}


def load(manoeuvre: str, **kwargs) -> pd.DataFrame:
    key = (manoeuvre, tuple(sorted(kwargs.items())))
    if key not in _cache:
        _cache[key] = read_marin(marin_file(manoeuvre), **kwargs)
    return _cache[key].copy()


def raw_rows(manoeuvre: str) -> np.ndarray:
    lines = marin_file(manoeuvre).read_text().splitlines()[2:]
    return np.array([[float(x) for x in line.split()] for line in lines
                     if line.strip()])


# ------------------------------------------------------------ real files

@pytest.mark.parametrize("manoeuvre", MANOEUVRES)
def test_loads_in_the_contract(manoeuvre):
    df = load(manoeuvre)
    assert list(df.columns) == list(REQUIRED_COLUMNS) + ["n", "phi", "p"]
    assert all(df[c].dtype == np.float64 for c in df.columns)
    assert np.isfinite(df.to_numpy()).all()
    pd.testing.assert_frame_equal(validate_manoeuvre(df, "again"), df)
    t = df["t"].to_numpy()
    assert (np.diff(t) > 0).all()
    assert len(np.unique(t)) == len(t)
    assert t[0] == 0.0
    # every time stamp of the file survives once, with its first row
    raw = raw_rows(manoeuvre)
    stamps, first = np.unique(raw[:, 0], return_index=True)
    np.testing.assert_array_equal(t, stamps)
    np.testing.assert_allclose(df["x0"].to_numpy(), raw[first, 1])
    np.testing.assert_allclose(df["psi"].to_numpy(), np.deg2rad(raw[first, 4]))


@pytest.mark.parametrize("manoeuvre", MANOEUVRES)
def test_units_and_start(manoeuvre):
    df = load(manoeuvre)
    assert df["u"].iloc[0] == pytest.approx(APPROACH_SPEED, abs=0.2)
    assert abs(df["v"].iloc[0]) < 0.1
    assert np.abs(df["delta"]).max() < 1.0                      # radians
    assert np.abs(df["r"]).max() < 0.05                          # rad/s
    assert np.abs(df["phi"]).max() < math.radians(2.0)
    assert df["n"].iloc[0] == pytest.approx(91.7 / 60.0, abs=0.05)   # rps
    # body-fixed: speed is preserved by the rotation
    raw = raw_rows(manoeuvre)
    _, first = np.unique(raw[:, 0], return_index=True)
    np.testing.assert_allclose(np.hypot(df["u"], df["v"]),
                               np.hypot(raw[first, 5], raw[first, 6]), rtol=1e-12)


def test_turning_circle():
    df = load("tc_35")
    assert df["psi"].iloc[-1] == pytest.approx(math.radians(-738.0), abs=0.02)
    assert np.abs(df["delta"]).max() == pytest.approx(math.radians(35.0),
                                                      abs=math.radians(1.0))
    # Rudder sign: positive rudder, negative yaw rate (the data contract's
    # convention, positive delta gives a negative yaw moment).
    turning = df[(df["t"] > 100) & (df["t"] < 600)]
    assert (turning["delta"] > math.radians(30)).all()
    assert (turning["r"] < 0).all()
    # steady speed loss in the turn
    assert turning["u"].iloc[-1] < 0.5 * APPROACH_SPEED


def test_zigzag_rudder_amplitudes():
    for manoeuvre, amplitude in (("zz_10", 10.0), ("zz_20", 20.0)):
        delta = np.degrees(load(manoeuvre)["delta"])
        assert delta.max() == pytest.approx(amplitude, abs=1.0)
        assert delta.min() == pytest.approx(-amplitude, abs=1.0)


def test_model_scale():
    full = load("tc_35")
    model = load("tc_35", model_scale=True)
    root = math.sqrt(SCALE)
    assert model["u"].iloc[0] == pytest.approx(APPROACH_SPEED / root, abs=0.02)
    np.testing.assert_allclose(model["t"], full["t"] / root)
    np.testing.assert_allclose(model["x0"], full["x0"] / SCALE)
    np.testing.assert_allclose(model["v"], full["v"] / root)
    np.testing.assert_allclose(model["r"], full["r"] * root)
    np.testing.assert_allclose(model["n"], full["n"] * root)
    np.testing.assert_allclose(model["psi"], full["psi"])
    np.testing.assert_allclose(model["delta"], full["delta"])
    assert model.attrs["model_scale"] is True and model.attrs["scale"] == SCALE


def test_uniform_time_keeps_every_row():
    df = load("zz_10", uniform_time=True)
    raw = raw_rows("zz_10")
    assert len(df) == len(raw)
    dt = np.diff(df["t"].to_numpy())
    np.testing.assert_allclose(dt, dt[0])
    assert dt[0] == pytest.approx(0.02 * math.sqrt(SCALE), rel=0.01)
    assert df["t"].iloc[-1] == pytest.approx(raw[-1, 0], abs=1.0)


def test_load_manoeuvre_dispatches_dat():
    df = load_manoeuvre(marin_file("zz_20"))
    assert df.attrs["name"] == "MARIN_FREE_KVLCC2_zz_20_m"
    assert df.attrs["source"] == str(marin_file("zz_20"))
    assert "20 / -20" in df.attrs["title"]
    pd.testing.assert_frame_equal(df, load("zz_20"))


# ----------------------------------------------------------- malformed files

TITLE = "MARIN(Maritime Research Institute Netherlands)\nZig-zag test\n"


def dat_text(n: int = 30, repeat: int = 2) -> list[str]:
    rows = []
    for i in range(n):
        t = (i // repeat) * 0.5
        rows.append("\t".join(f"{x:.2E}" for x in (
            t, 4.0 * t, 0.0, 0.1, -0.01 * t, 8.0, 0.0, 0.0, -0.01, 1.0, 91.7)))
    return rows


def write_dat(path: Path, rows: list[str], tail: str = "\t\t\n\t\t\n\n") -> Path:
    path.write_text(TITLE + "\n" + "\n".join(rows) + "\n" + tail)
    return path


def test_synthetic_file_repeats_and_tail(tmp_path):
    df = read_marin(write_dat(tmp_path / "ok.dat", dat_text(30, repeat=3)))
    assert len(df) == 10
    np.testing.assert_allclose(df["t"], np.arange(10) * 0.5)
    assert df["n"].iloc[0] == pytest.approx(91.7 / 60)
    assert df["delta"].iloc[0] == pytest.approx(math.radians(1.0))


def test_wrong_number_of_values(tmp_path):
    rows = dat_text()
    rows[7] = "\t".join(rows[7].split("\t")[:9])
    with pytest.raises(DataError) as info:
        read_marin(write_dat(tmp_path / "short_row.dat", rows))
    text = str(info.value)
    assert "short_row.dat" in text and "row 7" in text and "line 11" in text


def test_non_number(tmp_path):
    rows = dat_text()
    fields = rows[4].split("\t")
    fields[9] = "abc"
    rows[4] = "\t".join(fields)
    with pytest.raises(DataError) as info:
        read_marin(write_dat(tmp_path / "word.dat", rows))
    assert "word.dat, column 'delta', row 4" in str(info.value)


def test_nan_in_file(tmp_path):
    rows = dat_text()
    fields = rows[12].split("\t")
    fields[4] = "nan"
    rows[12] = "\t".join(fields)
    with pytest.raises(DataError) as info:
        read_marin(write_dat(tmp_path / "nan.dat", rows))
    assert "nan.dat, column 'psi', row 12" in str(info.value)


def test_decreasing_time_maps_to_file_row(tmp_path):
    rows = dat_text(30, repeat=2)
    fields = rows[21].split("\t")
    fields[0] = "1.00E+00"
    rows[21] = "\t".join(fields)
    with pytest.raises(DataError) as info:
        read_marin(write_dat(tmp_path / "back.dat", rows))
    text = str(info.value)
    assert "back.dat, column 't', row 21" in text and "decreases" in text


def test_missing_titles(tmp_path):
    path = tmp_path / "notitle.dat"
    path.write_text("\n".join(dat_text()) + "\n")
    with pytest.raises(DataError, match="notitle.dat: line 1 holds numbers"):
        read_marin(path)


def test_empty_and_missing(tmp_path):
    (tmp_path / "empty.dat").write_text("")
    with pytest.raises(DataError, match="empty.dat: the file is empty"):
        read_marin(tmp_path / "empty.dat")
    with pytest.raises(DataError, match="absent.dat: the file does not exist"):
        load_manoeuvre(tmp_path / "absent.dat")
    write_dat(tmp_path / "titles_only.dat", [])
    with pytest.raises(DataError, match="no data rows"):
        read_marin(tmp_path / "titles_only.dat")


def test_too_few_samples_after_deduplication(tmp_path):
    with pytest.raises(DataError, match="only 5 samples"):
        read_marin(write_dat(tmp_path / "few.dat", dat_text(20, repeat=4)))


def test_bad_scale(tmp_path):
    with pytest.raises(ConfigError):
        read_marin(write_dat(tmp_path / "s.dat", dat_text()), model_scale=True,
                   scale=0.0)
