"""The data contract: every refusal names the file, the column and the row."""

from __future__ import annotations

import csv
import pickle

import numpy as np
import pandas as pd
import pytest

from studies.data import (OPTIONAL_COLUMNS, REQUIRED_COLUMNS, load_manoeuvre,
                          validate_manoeuvre)
from studies.errors import DataError

N = 200
DT = 0.5


def make_columns(n: int = N, dt: float = DT) -> dict[str, np.ndarray]:
    """A plausible zig-zag-like record in the data contract (plain numpy)."""
    t = np.arange(n) * dt
    delta = 0.35 * np.sign(np.sin(2 * np.pi * t / 60.0) + 1e-9)   # +-20 deg
    r = 0.01 * np.sin(2 * np.pi * t / 60.0 - 1.0)                    # rad/s
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * dt)])
    u = 7.9 - 0.3 * np.abs(np.sin(2 * np.pi * t / 60.0))
    v = -0.2 * r / 0.01 * 0.5
    x0 = np.concatenate([[0.0], np.cumsum(u[1:] * np.cos(psi[1:]) * dt)])
    y0 = np.concatenate([[0.0], np.cumsum(u[1:] * np.sin(psi[1:]) * dt)])
    return {"t": t, "x0": x0, "y0": y0, "psi": psi, "u": u, "v": v, "r": r,
            "delta": delta}


def write_csv(path, columns: dict[str, list | np.ndarray]) -> None:
    """Write columns with the csv module only (not through studies)."""
    names = list(columns)
    n = len(next(iter(columns.values())))
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for i in range(n):
            writer.writerow([repr(float(columns[c][i]))
                             if isinstance(columns[c][i], (float, np.floating))
                             else columns[c][i] for c in names])


def refusal(tmp_path, columns, name="record.csv", **kwargs) -> str:
    path = tmp_path / name
    write_csv(path, columns)
    with pytest.raises(DataError) as info:
        load_manoeuvre(path, **kwargs)
    text = str(info.value)
    assert name in text, text
    assert "\n" not in text, "one line"
    return text


def test_valid_table_is_returned_clean():
    cols = make_columns()
    cols["phi"] = np.zeros(N)
    cols["wind_speed"] = np.full(N, 10.0)
    df = pd.DataFrame({"extra": np.arange(N), **cols})
    df["n"] = np.arange(N, dtype=np.int64)
    out = validate_manoeuvre(df, "mem.csv")
    assert list(out.columns[:8]) == list(REQUIRED_COLUMNS)
    assert list(out.columns[8:10]) == ["wind_speed", "n"]
    assert set(out.columns[10:]) == {"extra", "phi"}
    assert all(out[c].dtype == np.float64 for c in out.columns)
    assert out is not df
    assert isinstance(out.index, pd.RangeIndex)
    np.testing.assert_array_equal(out["psi"].to_numpy(), cols["psi"])


def test_constants():
    assert REQUIRED_COLUMNS == ("t", "x0", "y0", "psi", "u", "v", "r", "delta")
    assert OPTIONAL_COLUMNS == ("wind_speed", "wind_direction", "n")


def test_missing_column(tmp_path):
    cols = make_columns()
    del cols["v"]
    text = refusal(tmp_path, cols)
    assert "column 'v'" in text and "missing" in text


@pytest.mark.parametrize("renamed", ["yaw_rate", "R", "Yaw rate"])
def test_renamed_column_suggests_the_name(tmp_path, renamed):
    cols = make_columns()
    cols[renamed] = cols.pop("r")
    text = refusal(tmp_path, cols)
    assert "column 'r'" in text
    assert f"'{renamed}'" in text and "rename" in text


def test_header_missing_is_explained(tmp_path):
    path = tmp_path / "noheader.csv"
    cols = make_columns()
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        for i in range(N):
            writer.writerow([cols[c][i] for c in cols])
    with pytest.raises(DataError, match="first line looks like data"):
        load_manoeuvre(path)


@pytest.mark.parametrize("column,row", [("u", 12), ("t", 0), ("delta", 199)])
def test_nan(tmp_path, column, row):
    cols = make_columns()
    cols[column][row] = np.nan
    text = refusal(tmp_path, cols)
    assert f"column '{column}', row {row}" in text and "NaN" in text


def test_empty_cell_is_nan(tmp_path):
    cols = {k: list(v) for k, v in make_columns().items()}
    cols["x0"][33] = ""
    text = refusal(tmp_path, cols)
    assert "column 'x0', row 33" in text


@pytest.mark.parametrize("value", [np.inf, -np.inf])
def test_inf(tmp_path, value):
    cols = make_columns()
    cols["v"][7] = value
    text = refusal(tmp_path, cols)
    assert "column 'v', row 7" in text and "infinite" in text


def test_non_numeric_value(tmp_path):
    cols = {k: list(v) for k, v in make_columns().items()}
    cols["y0"][41] = "12,5"
    text = refusal(tmp_path, cols)
    assert "column 'y0', row 41" in text and "not a number" in text


def test_time_decreasing(tmp_path):
    cols = make_columns()
    cols["t"][20] = cols["t"][19] - 0.1
    text = refusal(tmp_path, cols)
    assert "column 't', row 20" in text and "decreases" in text


def test_time_duplicated(tmp_path):
    cols = make_columns()
    cols["t"][15] = cols["t"][14]
    text = refusal(tmp_path, cols)
    assert "column 't', row 15" in text and "duplicated" in text


def test_too_few_samples(tmp_path):
    cols = {k: v[:5] for k, v in make_columns().items()}
    text = refusal(tmp_path, cols)
    assert "only 5 samples" in text and "at least 10" in text


def test_min_samples_is_configurable(tmp_path):
    cols = {k: v[:5] for k, v in make_columns().items()}
    write_csv(tmp_path / "short.csv", cols)
    assert len(load_manoeuvre(tmp_path / "short.csv", min_samples=5)) == 5
    text = refusal(tmp_path, make_columns(), min_samples=N + 1)
    assert f"only {N} samples" in text


def test_delta_in_degrees(tmp_path):
    cols = make_columns()
    cols["delta"] = np.rad2deg(cols["delta"])
    text = refusal(tmp_path, cols)
    first = int(np.flatnonzero(np.abs(cols["delta"]) > 1.0)[0])
    assert f"column 'delta', row {first}" in text
    assert "radians" in text


def test_delta_in_degrees_small_first_values(tmp_path):
    cols = make_columns()
    cols["delta"] = np.rad2deg(cols["delta"])
    cols["delta"][:30] = 0.5             # degrees that look like radians
    text = refusal(tmp_path, cols)
    assert "column 'delta', row 30" in text


def test_psi_in_degrees(tmp_path):
    cols = make_columns()
    cols["psi"] = np.rad2deg(cols["psi"])
    text = refusal(tmp_path, cols)
    assert "column 'psi', row " in text and "radians" in text


def test_r_in_degrees_by_range(tmp_path):
    cols = make_columns()
    cols["r"] = cols["r"] * 20.0                # 0.2 rad/s peak (a fast model)
    cols["psi"] = cols["psi"] * 20.0
    cols["r"] = np.rad2deg(cols["r"])           # 11.5 deg/s > 1.5
    text = refusal(tmp_path, cols)
    first = int(np.flatnonzero(np.abs(cols["r"]) > 1.5)[0])
    assert f"column 'r', row {first}" in text and "rad/s" in text


def test_r_in_degrees_by_consistency(tmp_path):
    cols = make_columns()
    cols["r"] = np.rad2deg(cols["r"])           # 0.57 deg/s: below the range limit
    assert np.abs(cols["r"]).max() < 1.5
    text = refusal(tmp_path, cols)
    assert "column 'r', row " in text and "radians" in text


def test_turning_circle_heading_is_not_degrees():
    """A continuous heading far beyond 2 pi is legitimate."""
    t = np.arange(2000) * 1.0
    r = np.full_like(t, -0.0065)
    cols = make_columns(n=2000, dt=1.0)
    cols.update(r=r, psi=r * t, delta=np.full_like(t, 0.61))
    out = validate_manoeuvre(pd.DataFrame(cols), "tc.csv")
    assert out["psi"].iloc[-1] < -12.9


def test_wind_direction_in_degrees(tmp_path):
    cols = make_columns()
    cols["wind_speed"] = np.full(N, 12.0)
    cols["wind_direction"] = np.linspace(0.0, 90.0, N)
    text = refusal(tmp_path, cols)
    first = int(np.flatnonzero(cols["wind_direction"] > 2 * np.pi + 0.1)[0])
    assert f"column 'wind_direction', row {first}" in text


def test_negative_wind_speed(tmp_path):
    cols = make_columns()
    cols["wind_speed"] = np.full(N, 5.0)
    cols["wind_speed"][9] = -0.1
    text = refusal(tmp_path, cols)
    assert "column 'wind_speed', row 9" in text and "negative" in text


def test_roll_in_degrees(tmp_path):
    cols = make_columns()
    cols["phi"] = np.full(N, 2.0)
    cols["phi"][3] = 5.0
    text = refusal(tmp_path, cols)
    assert "column 'phi', row 0" in text


def test_duplicated_column_in_dataframe():
    df = pd.DataFrame(make_columns())
    df.insert(1, " u", 1.0)
    with pytest.raises(DataError, match="more than once") as info:
        validate_manoeuvre(df, "dup.csv")
    assert "column 'u'" in str(info.value)


def test_boolean_column_refused():
    df = pd.DataFrame(make_columns())
    df["delta"] = df["delta"] > 0
    with pytest.raises(DataError) as info:
        validate_manoeuvre(df, "bool.parquet")
    assert "column 'delta', row 0" in str(info.value)


def test_not_a_dataframe():
    with pytest.raises(DataError, match="expected a table"):
        validate_manoeuvre(np.zeros((3, 8)), "array")


def test_trailing_comma_column_is_dropped(tmp_path):
    path = tmp_path / "trailing.csv"
    cols = make_columns()
    with open(path, "w") as fh:
        fh.write(",".join(cols) + ",\n")
        for i in range(N):
            fh.write(",".join(repr(float(cols[c][i])) for c in cols) + ",\n")
        fh.write(",,,,,,,,\n" * 3)
    df = load_manoeuvre(path)
    assert list(df.columns) == list(REQUIRED_COLUMNS)
    assert len(df) == N


def test_message_states_units_fix():
    df = pd.DataFrame(make_columns())
    df["delta"] = np.rad2deg(df["delta"])
    with pytest.raises(DataError) as info:
        validate_manoeuvre(df, "zz.csv")
    err = info.value
    assert err.file == "zz.csv" and err.column == "delta" and err.row == 0
    assert "angles must be in radians" in str(err)


def test_data_error_survives_pickling():
    """A refusal raised in a sweep worker process is sent back to the launcher pickled."""
    err = pickle.loads(pickle.dumps(DataError("run.csv", "not increasing", "t", 12)))
    assert str(err) == "run.csv, column 't', row 12: not increasing"
