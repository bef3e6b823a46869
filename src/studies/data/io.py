"""Reading manoeuvre records from files.

:func:`read_table` reads CSV (``.csv``, ``.txt``) and Parquet (``.parquet``,
``.pq``) files into a :class:`pandas.DataFrame` without judging the content;
:func:`load_manoeuvre` reads one record (also MARIN ``.dat``) and checks it
against the data contract (:mod:`studies.data.contract`);
:func:`load_manoeuvres` does the same for one path or a list of paths.

Every refusal is a :class:`studies.errors.DataError` naming the file (as the
user gave it) and, where known, the column and the zero-based data row
(header not counted). No pickle and no ``eval`` are ever used.
"""

from __future__ import annotations

import csv
import io
import os
import re
import warnings
from collections.abc import Iterable

import pandas as pd

from studies.data.contract import validate_manoeuvre
from studies.data.files import (SNIFF_BYTES, decode_text, label_and_path, read_file_bytes,
                                refuse_binary)
from studies.data.hsva import is_hsva_text, read_hsva
from studies.data.marin import read_marin
from studies.errors import DataError

__all__ = ["read_table", "read_dat", "load_manoeuvre", "load_manoeuvres",
           "CSV_SUFFIXES", "PARQUET_SUFFIXES", "MARIN_SUFFIXES"]

CSV_SUFFIXES = (".csv", ".txt")
PARQUET_SUFFIXES = (".parquet", ".pq")
MARIN_SUFFIXES = (".dat",)

_DELIMITER_NAMES = {";": "a semicolon (';')", "\t": "a tab", "|": "a pipe ('|')"}


def _read_csv(label: str, data: bytes) -> pd.DataFrame:
    refuse_binary(label, data, "a CSV text file")
    text = decode_text(data)
    lines = text.splitlines()
    header_index = next(i for i, line in enumerate(lines) if line.strip())
    header = lines[header_index]
    if "," not in header:
        found = [d for d in _DELIMITER_NAMES if d in header]
        if found:
            d = max(found, key=header.count)
            raise DataError(label, f"the columns are separated by "
                            f"{_DELIMITER_NAMES[d]}, but a comma is expected: "
                            "save the file as comma-separated values with '.' "
                            "as the decimal point")
    try:
        names = next(csv.reader([header]))
    except csv.Error:
        names = header.split(",")
    if names and all(_is_number(n) for n in names):
        raise DataError(label, "the first line looks like data, not a header: "
                        "the first line must name the columns (t, x0, y0, psi, "
                        "u, v, r, delta, ...)")
    seen: set[str] = set()
    for name in (n.strip() for n in names):
        if name and name in seen:
            raise DataError(label, "the column appears more than once in the "
                            "header; every column name must be unique",
                            column=name)
        seen.add(name)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            warnings.simplefilter("ignore", pd.errors.DtypeWarning)
            df = pd.read_csv(io.StringIO(text), sep=",", index_col=False,
                             skipinitialspace=True, low_memory=False)
    except pd.errors.ParserWarning:
        raise DataError(label, "some rows have more values than the header "
                        "has column names; check the delimiter (a comma is "
                        "expected) and the header") from None
    except pd.errors.EmptyDataError:
        raise DataError(label, "the file holds no table (no header line)") from None
    except pd.errors.ParserError as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else "parse error"
        m = re.search(r"line (\d+)", message)
        row = None
        if m:
            line = int(m.group(1))
            row = max(line - header_index - 2, 0)
            message = (f"line {line} of the file has a different number of "
                       f"values than the header ({message})")
        raise DataError(label, f"cannot be read as CSV: {message}; a comma is "
                        "the expected delimiter", row=row) from None
    except Exception as exc:  # noqa: BLE001 - no pandas error may escape
        raise DataError(label, f"cannot be read as CSV: "
                        f"{type(exc).__name__}: {_one_line(exc)}") from None
    return _drop_empty_tail(df)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    first = text.splitlines()[0] if text else ""
    return first[:200]


def _drop_empty_tail(df: pd.DataFrame) -> pd.DataFrame:
    """Drop trailing rows in which every cell is empty (e.g. ',,,,' lines)."""
    if len(df) == 0 or df.shape[1] == 0:
        return df
    try:
        filled = ~df.isna().all(axis=1).to_numpy()
    except Exception:  # noqa: BLE001 - odd dtypes: keep the rows
        return df
    if filled.all():
        return df
    last = int(filled.nonzero()[0][-1]) + 1 if filled.any() else 0
    return df.iloc[:last]


def _read_parquet(label: str, data: bytes) -> pd.DataFrame:
    if len(data) < 12 or not (data.startswith(b"PAR1") and data.endswith(b"PAR1")):
        hint = ""
        head = data[:SNIFF_BYTES]
        if b"\x00" not in head and head.count(b",") > 0:
            hint = "; it looks like CSV text: give it the suffix .csv"
        raise DataError(label, "is not a Parquet file (no PAR1 signature at its "
                        f"start and end){hint}")
    try:
        df = pd.read_parquet(io.BytesIO(data), engine="pyarrow")
    except Exception as exc:  # noqa: BLE001 - no pyarrow error may escape
        raise DataError(label, f"cannot be read as Parquet: "
                        f"{type(exc).__name__}: {_one_line(exc)}") from None
    try:
        if any(name is not None for name in df.index.names):
            df = df.reset_index()      # a column stored as the index
        else:
            df = df.reset_index(drop=True)
        if isinstance(df.columns, pd.MultiIndex):
            df.columns = ["_".join(str(x) for x in c if str(x)) for c in df.columns]
    except Exception as exc:  # noqa: BLE001
        raise DataError(label, f"cannot be read as Parquet: "
                        f"{type(exc).__name__}: {_one_line(exc)}") from None
    return df


def read_table(path) -> pd.DataFrame:
    """Read a CSV or Parquet file into a table, refusing unreadable files.

    Parameters
    ----------
    path : str or os.PathLike
        ``.csv`` or ``.txt`` (comma-separated, one header line naming the
        columns, '.' as the decimal point, UTF-8 or Latin-1) or ``.parquet``
        / ``.pq``. The suffix decides the format (case-insensitive).

    Returns
    -------
    pandas.DataFrame
        The table as stored, not yet checked against the data contract (see
        :func:`studies.data.validate_manoeuvre`). Trailing rows in which
        every cell is empty are dropped.

    Raises
    ------
    studies.errors.DataError
        The path does not exist or is a directory; the file is empty or only
        whitespace; a binary file is given as CSV; the CSV uses another
        delimiter than a comma (';', tab, '|'); a column name is repeated;
        rows have more values than the header; a Parquet file cannot be read;
        the suffix is not supported; any other parse failure.
    """
    label, p, data = read_file_bytes(path)
    suffix = p.suffix.lower()
    if suffix in CSV_SUFFIXES:
        return _read_csv(label, data)
    if suffix in PARQUET_SUFFIXES:
        return _read_parquet(label, data)
    if suffix in MARIN_SUFFIXES:
        raise DataError(label, "is a .dat file of a test facility: read it with "
                        "studies.data.read_dat or load_manoeuvre")
    raise DataError(label, f"unsupported file type '{suffix or '(no suffix)'}'; "
                    "give a CSV (.csv, .txt), Parquet (.parquet, .pq) or MARIN "
                    "(.dat) file")


def read_dat(path, min_samples: int = 10, *, uniform_time: bool = False) -> pd.DataFrame:
    """Read a free-running ``.dat`` file of MARIN or HSVA, whichever layout it has.

    The layout is told from the file's top lines (:func:`studies.data.hsva.is_hsva_text`):
    HSVA's (four title lines, twelve columns, model scale) is read by
    :func:`studies.data.read_hsva`, any other by :func:`studies.data.read_marin`
    (two title lines, eleven columns, full scale; ``uniform_time`` is its
    option). Each record keeps the scale of its file, stated in
    ``attrs["model_scale"]`` and ``attrs["scale"]``.
    """
    label, _, data = read_file_bytes(path)
    head = data[:SNIFF_BYTES].decode("cp1252", errors="replace")
    if is_hsva_text(head):
        return read_hsva(path, min_samples=min_samples)
    return read_marin(path, uniform_time=uniform_time, min_samples=min_samples)


def load_manoeuvre(path, min_samples: int = 10) -> pd.DataFrame:
    """Load one manoeuvre record and check it against the data contract.

    Parameters
    ----------
    path : str or os.PathLike
        A MARIN or HSVA ``.dat`` file (read with :func:`read_dat`, each at
        the scale of its file) or a CSV / Parquet file in the data contract
        (see :func:`read_table`).
    min_samples : int, default 10
        Fewest samples accepted.

    Returns
    -------
    pandas.DataFrame
        ``float64`` columns ``t`` [s], ``x0``, ``y0`` [m], ``psi`` [rad],
        ``u``, ``v`` [m/s] body-fixed, ``r`` [rad/s], ``delta`` [rad]
        (positive delta gives a negative yaw moment), then the optional and
        extra columns present. ``attrs["name"]`` is the file stem (used to
        name per-record metrics) and ``attrs["source"]`` the path as given.

    Raises
    ------
    studies.errors.DataError
        With the file, column and row, for anything outside the contract.
    """
    label, p = label_and_path(path)
    if p.suffix.lower() in MARIN_SUFFIXES:
        df = read_dat(path, min_samples=min_samples)
    else:
        df = validate_manoeuvre(read_table(path), label, min_samples=min_samples)
    df.attrs["name"] = p.stem
    df.attrs["source"] = label
    return df


def load_manoeuvres(paths, min_samples: int = 10) -> list[pd.DataFrame]:
    """Load one path or a list of paths with :func:`load_manoeuvre`.

    Parameters
    ----------
    paths : str, os.PathLike or iterable of them
        One file, or a list/tuple (any non-string iterable, e.g. a Hydra
        ``ListConfig``) of files.
    min_samples : int, default 10
        Fewest samples accepted per record.

    Returns
    -------
    list of pandas.DataFrame
        One validated table per path, in the given order.

    Raises
    ------
    studies.errors.DataError
        For the first file that does not satisfy the data contract.
    """
    if isinstance(paths, (str, bytes, os.PathLike)):
        return [load_manoeuvre(paths, min_samples=min_samples)]
    if not isinstance(paths, Iterable):
        raise DataError(str(paths), f"expected a file path or a list of paths, "
                        f"got {type(paths).__name__}")
    return [load_manoeuvre(p, min_samples=min_samples) for p in paths]
