"""Reading files: refusals of unreadable files, CSV/Parquet round trip, and a
property test that nothing but a valid table or a DataError comes out."""

from __future__ import annotations

import csv
import itertools
import re
import os

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from studies.data import (OPTIONAL_COLUMNS, REQUIRED_COLUMNS, load_manoeuvre,
                          load_manoeuvres, read_table)
from studies.errors import DataError

N = 120
DT = 0.25


def make_columns(n: int = N, dt: float = DT) -> dict[str, np.ndarray]:
    t = np.arange(n) * dt
    r = 0.02 * np.sin(0.2 * t)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * dt)])
    u = 7.0 + 0.1 * np.cos(0.2 * t)
    return {"t": t, "x0": np.cumsum(u * np.cos(psi) * dt),
            "y0": np.cumsum(u * np.sin(psi) * dt), "psi": psi, "u": u,
            "v": -0.1 * np.sin(0.2 * t), "r": r,
            "delta": 0.17 * np.sign(np.sin(0.2 * t + 0.5)),
            "wind_speed": np.full(n, 8.0), "wind_direction": np.full(n, 0.5),
            "phi": 0.01 * np.sin(t)}


def write_csv(path, columns, delimiter=","):
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh, delimiter=delimiter)
        writer.writerow(list(columns))
        for row in zip(*columns.values()):
            writer.writerow([repr(float(x)) for x in row])


def refused(path, *expected) -> str:
    with pytest.raises(DataError) as info:
        load_manoeuvre(path)
    text = str(info.value)
    assert os.path.basename(str(path)) in text, text
    for piece in expected:
        assert piece in text, text
    return text


# --------------------------------------------------------------- round trip

def test_valid_csv_loads_and_parquet_loads_identically(tmp_path):
    cols = make_columns()
    write_csv(tmp_path / "zz.csv", cols)
    pq.write_table(pa.table({k: pa.array(v) for k, v in cols.items()}),
                   tmp_path / "zz.parquet")
    a = load_manoeuvre(tmp_path / "zz.csv")
    b = load_manoeuvre(str(tmp_path / "zz.parquet"))
    assert list(a.columns) == list(REQUIRED_COLUMNS) + [
        "wind_speed", "wind_direction", "phi"]
    assert all(a[c].dtype == np.float64 for c in a.columns)
    np.testing.assert_array_equal(a["psi"].to_numpy(), cols["psi"])
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert a.attrs["name"] == "zz" and b.attrs["name"] == "zz"
    assert a.attrs["source"] == str(tmp_path / "zz.csv")
    assert b.attrs["source"] == str(tmp_path / "zz.parquet")


def test_txt_and_pq_suffixes_and_pandas_index(tmp_path):
    cols = make_columns()
    write_csv(tmp_path / "a.txt", cols)
    df = pd.DataFrame(cols).set_index("t")
    df.to_parquet(tmp_path / "b.pq")                  # t stored as the index
    a, b = load_manoeuvres([tmp_path / "a.txt", tmp_path / "b.pq"])
    pd.testing.assert_frame_equal(a, b)


def test_load_manoeuvres_one_or_many(tmp_path):
    write_csv(tmp_path / "one.csv", make_columns())
    assert len(load_manoeuvres(tmp_path / "one.csv")) == 1
    assert len(load_manoeuvres(str(tmp_path / "one.csv"))) == 1
    many = load_manoeuvres((tmp_path / "one.csv", tmp_path / "one.csv"))
    assert [d.attrs["name"] for d in many] == ["one", "one"]
    with pytest.raises(DataError, match="missing.csv"):
        load_manoeuvres([tmp_path / "one.csv", tmp_path / "missing.csv"])


def test_read_table_does_not_validate(tmp_path):
    path = tmp_path / "any.csv"
    path.write_text("a,b\n1,x\n")
    df = read_table(path)
    assert list(df.columns) == ["a", "b"] and len(df) == 1


# ------------------------------------------------------------------ refusals

def test_nonexistent_path(tmp_path):
    refused(tmp_path / "nope.csv", "does not exist")


def test_directory(tmp_path):
    (tmp_path / "dir.csv").mkdir()
    refused(tmp_path / "dir.csv", "directory")


def test_empty_file(tmp_path):
    (tmp_path / "empty.csv").write_bytes(b"")
    refused(tmp_path / "empty.csv", "empty")


def test_empty_parquet(tmp_path):
    (tmp_path / "empty.parquet").write_bytes(b"")
    refused(tmp_path / "empty.parquet", "empty")


def test_whitespace_only_file(tmp_path):
    (tmp_path / "blank.csv").write_text("  \n\t\n\r\n   ")
    refused(tmp_path / "blank.csv", "only whitespace")


def test_binary_file_as_csv(tmp_path):
    rng = np.random.default_rng(1)
    (tmp_path / "bin.csv").write_bytes(rng.integers(0, 256, 5000,
                                                    dtype=np.uint8).tobytes())
    refused(tmp_path / "bin.csv", "binary")


def test_binary_without_nul_bytes(tmp_path):
    (tmp_path / "ctl.csv").write_bytes(bytes(range(1, 32)) * 100)
    refused(tmp_path / "ctl.csv", "binary")


def test_parquet_named_csv(tmp_path):
    pq.write_table(pa.table({k: pa.array(v) for k, v in make_columns().items()}),
                   tmp_path / "pq.csv")
    refused(tmp_path / "pq.csv", "binary", ".parquet")


def test_semicolon_delimited(tmp_path):
    write_csv(tmp_path / "semi.csv", make_columns(), delimiter=";")
    refused(tmp_path / "semi.csv", "semicolon", "comma is expected")


def test_semicolon_with_decimal_commas(tmp_path):
    cols = make_columns()
    with open(tmp_path / "euro.csv", "w") as fh:
        fh.write(";".join(cols) + "\n")
        for row in zip(*cols.values()):
            fh.write(";".join(f"{x:.4f}".replace(".", ",") for x in row) + "\n")
    refused(tmp_path / "euro.csv", "semicolon", "comma is expected")


def test_tab_delimited(tmp_path):
    write_csv(tmp_path / "tab.csv", make_columns(), delimiter="\t")
    refused(tmp_path / "tab.csv", "a tab", "comma is expected")


def test_pipe_delimited(tmp_path):
    write_csv(tmp_path / "pipe.txt", make_columns(), delimiter="|")
    refused(tmp_path / "pipe.txt", "pipe", "comma is expected")


def test_row_with_too_many_values(tmp_path):
    path = tmp_path / "ragged.csv"
    write_csv(path, make_columns())
    lines = path.read_text().splitlines()
    lines[1 + 17] += ",99"                      # data row 17
    path.write_text("\n".join(lines) + "\n")
    refused(path, "row 17", "line 19")


def test_every_row_with_too_many_values(tmp_path):
    path = tmp_path / "extra.csv"
    write_csv(path, make_columns())
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0]] + [l + ",1" for l in lines[1:]]) + "\n")
    refused(path, "more values than the header")


def test_duplicated_header(tmp_path):
    cols = make_columns()
    path = tmp_path / "dup.csv"
    write_csv(path, cols)
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace("x0", "u")
    path.write_text("\n".join(lines) + "\n")
    refused(path, "column 'u'", "more than once")


def test_text_named_parquet(tmp_path):
    write_csv(tmp_path / "text.parquet", make_columns())
    refused(tmp_path / "text.parquet", "not a Parquet file", ".csv")


def test_truncated_parquet(tmp_path):
    pq.write_table(pa.table({k: pa.array(v) for k, v in make_columns().items()}),
                   tmp_path / "whole.parquet")
    data = (tmp_path / "whole.parquet").read_bytes()
    (tmp_path / "cut.parquet").write_bytes(data[:200] + data[-100:])
    refused(tmp_path / "cut.parquet", "Parquet")


def test_unsupported_suffix(tmp_path):
    (tmp_path / "data.xlsx").write_text("t,x0\n")
    refused(tmp_path / "data.xlsx", "unsupported file type '.xlsx'")


def test_parquet_string_column(tmp_path):
    cols = {k: pa.array(v) for k, v in make_columns().items()}
    values = [str(x) for x in make_columns()["u"]]
    values[5] = "fast"
    cols["u"] = pa.array(values)
    pq.write_table(pa.table(cols), tmp_path / "str.parquet")
    refused(tmp_path / "str.parquet", "column 'u', row 5", "not a number")


def test_latin1_header(tmp_path):
    cols = make_columns()
    cols["température"] = np.full(N, 15.0)
    path = tmp_path / "latin.csv"
    with open(path, "w", newline="", encoding="latin-1") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(cols))
        for row in zip(*cols.values()):
            writer.writerow([repr(float(x)) for x in row])
    assert "température" in load_manoeuvre(path).columns


# ----------------------------------------------------------- property test

CONTRACT = list(REQUIRED_COLUMNS) + list(OPTIONAL_COLUMNS)
JUNK = ["yaw_rate", "R", "time", "", " u", "t ", "phi", "p", "x;y", "a|b",
        "tab\tname", "ü", "1.5", "Unnamed: 0", 'q"uote', "psi_deg", "delta "]
WEIRD_STRINGS = ["", "nan", "NaN", "inf", "-inf", "1e400", "-1e400", "True",
                 "1,5", "NA", " 3 ", "0x10", "1_000", "None", "\u00a0",
                 "１２"]

cells = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-1e3, 1e3),
    st.integers(-(10**20), 10**20),
    st.text(max_size=6),
    st.sampled_from(WEIRD_STRINGS),
)


def _good_values(name: str, t: np.ndarray, amplitude: float, seed: int):
    """Plausible values for a contract column (radians, SI)."""
    rng = np.random.default_rng(seed)
    n = len(t)
    r = amplitude * 0.02 * np.sin(0.1 * t)
    if name == "r":
        return r
    if name == "psi":
        dt = np.diff(t, prepend=t[0] if n else 0.0)
        return np.cumsum(r * dt)
    if name == "delta":
        return np.clip(amplitude, 0, 1) * 0.6 * np.sign(np.sin(0.1 * t + 1))
    if name == "wind_speed":
        return np.abs(rng.normal(8, 3, n))
    if name == "wind_direction":
        return rng.uniform(-np.pi, np.pi, n)
    if name == "u":
        return 7 + rng.normal(0, 0.1, n)
    if name in ("phi", "p"):
        return rng.normal(0, 0.05, n)
    return rng.normal(0, 10, n)


@st.composite
def tables(draw):
    """(names, columns as lists of cells) of a random table."""
    n = draw(st.one_of(st.integers(0, 12), st.integers(10, 40)))
    plausible = draw(st.integers(0, 2)) > 0
    if plausible:
        names = list(REQUIRED_COLUMNS)
        names += draw(st.lists(st.sampled_from(list(OPTIONAL_COLUMNS) + JUNK),
                               max_size=2, unique=True))
        names = draw(st.permutations(names))
    else:
        names = draw(st.lists(st.sampled_from(CONTRACT + JUNK), max_size=12,
                              unique=draw(st.booleans())))
    time_kind = draw(st.sampled_from(["increasing", "increasing", "increasing",
                                      "random", "duplicates", "decreasing",
                                      "huge"]))
    steps = np.array(draw(st.lists(st.floats(1e-3, 10.0), min_size=n, max_size=n)),
                     dtype=float)
    if time_kind == "increasing":
        t = np.cumsum(steps)
    elif time_kind == "random":
        t = np.array(draw(st.lists(st.floats(-1e6, 1e6), min_size=n, max_size=n)),
                     dtype=float)
    elif time_kind == "duplicates":
        t = np.floor(np.cumsum(steps))
    elif time_kind == "decreasing":
        t = -np.cumsum(steps)
    else:
        t = 1e300 + np.cumsum(steps) * 1e290
    amplitude = draw(st.sampled_from([1.0, 0.5, 57.3, 1e-3]))
    seed = draw(st.integers(0, 2**16))
    columns = []
    for name in names:
        if name == "t" or (name.strip() == "t" and not plausible):
            values = list(t)
        elif draw(st.integers(0, 3)) or plausible:
            values = list(_good_values(name.strip(), t, amplitude, seed))
        else:
            values = draw(st.lists(cells, min_size=n, max_size=n))
        columns.append(values)
    # A few random cells anywhere.
    if n and columns and draw(st.booleans()):
        for _ in range(draw(st.integers(1, 3))):
            j = draw(st.integers(0, len(columns) - 1))
            i = draw(st.integers(0, n - 1))
            columns[j][i] = draw(cells)
    return names, columns


def _cell_text(x) -> str:
    if isinstance(x, (float, np.floating)):
        return repr(float(x))
    return str(x)


def _write(path, names, columns, fmt, delimiter, title_lines):
    rows = list(zip(*columns)) if columns else []
    if fmt == "csv":
        with open(path, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh, delimiter=delimiter)
            writer.writerow(names)
            for row in rows:
                writer.writerow([_cell_text(x) for x in row])
    elif fmt == "parquet":
        arrays, used = {}, set()
        for name, values in zip(names, columns):
            while name in used:
                name += "_"
            used.add(name)
            if all(isinstance(x, (float, np.floating)) for x in values):
                arrays[name] = pa.array(np.asarray(values, dtype=float))
            else:
                arrays[name] = pa.array([_cell_text(x) for x in values])
        pq.write_table(pa.table(arrays) if arrays else pa.table({}), path)
    elif fmt == "dat":
        with open(path, "w", encoding="utf-8") as fh:
            for k in range(title_lines):
                fh.write(f"title {k}\n")
            for row in rows:
                fh.write("\t".join(_cell_text(x) for x in row) + "\n")
            fh.write("\t\t\n\n")
    else:
        raise AssertionError(fmt)


COUNTS = {"tried": 0, "loaded": 0, "refused": 0}


@pytest.fixture(scope="module")
def hypothesis_dir(tmp_path_factory):
    yield tmp_path_factory.mktemp("hypothesis")
    print(f"\nhypothesis property test: {COUNTS['tried']} examples tried, "
          f"{COUNTS['loaded']} loaded, {COUNTS['refused']} refused with DataError")


_names = itertools.count()


@pytest.mark.slow
@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(table=tables(),
       fmt_delimiter=st.sampled_from(
           [("csv", ",")] * 8 + [("csv", d) for d in (";", "\t", "|", " ")]
           + [("parquet", None)] * 4 + [("dat", None), ("bytes", None)]),
       suffix=st.sampled_from([".csv", ".txt", ".parquet", ".pq", ".dat", ".bin"]),
       title_lines=st.integers(0, 3),
       raw=st.binary(max_size=300))
def test_property_valid_table_or_data_error(hypothesis_dir, table, fmt_delimiter,
                                            suffix, title_lines, raw):
    names, columns = table
    fmt, delimiter = fmt_delimiter
    COUNTS["tried"] += 1
    if fmt == "bytes":
        path = hypothesis_dir / f"f{next(_names)}{suffix}"
        path.write_bytes(raw)
    else:
        ext = {"csv": ".csv" if delimiter == "," else suffix, "parquet": ".parquet",
               "dat": ".dat"}[fmt]
        if fmt == "csv" and ext not in (".csv", ".txt"):
            ext = ".txt"
        path = hypothesis_dir / f"f{next(_names)}{ext}"
        _write(path, names, columns, fmt, delimiter, title_lines)
    try:
        df = load_manoeuvre(path)
    except DataError as exc:
        COUNTS["refused"] += 1
        event("refused: " + re.sub(r"-?\d[\d.eE+-]*|'[^']*'", "#", exc.message)[:50])
        assert str(path) in str(exc)
        return
    COUNTS["loaded"] += 1
    event(f"loaded {fmt}")
    assert isinstance(df, pd.DataFrame)
    for c in REQUIRED_COLUMNS:
        assert df[c].dtype == np.float64
        assert np.isfinite(df[c].to_numpy()).all()
    t = df["t"].to_numpy()
    assert (t[1:] > t[:-1]).all()
    assert len(df) >= 10
    assert np.abs(df["delta"].to_numpy()).max() <= 1.0
    if "wind_speed" in df:
        assert (df["wind_speed"].to_numpy() >= 0).all()
    assert df.attrs["name"] == path.stem


@pytest.mark.slow
def test_property_test_exercised_both_outcomes():
    """Runs after the property test (file order): it must not be vacuous."""
    if COUNTS["tried"] == 0:
        pytest.skip("property test not run in this session")
    assert COUNTS["tried"] >= 300
    assert COUNTS["loaded"] > 0 and COUNTS["refused"] > 0
