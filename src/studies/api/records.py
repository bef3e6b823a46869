"""Records from files or DataFrames, and DataFrames handed to a job as files.

:func:`load` reads records as a study reads them: MARIN's and HSVA's
``.dat`` files (at the scale they were measured, ``attrs["model_scale"]``
and ``attrs["scale"]`` saying which), CSV and Parquet in the data contract
(``docs/conventions.md``: ``t`` [s], ``x0``, ``y0`` [m], ``psi`` [rad],
``u``, ``v`` [m/s], ``r`` [rad/s], ``delta`` [rad, positive turns to port],
optional ``n`` [rps], wind and roll columns). Each record is a DataFrame
whose ``attrs`` hold its ``name`` (the file's stem), ``source`` (the path)
and a ``digest`` of its values.

A job reads its records from files (so that a run logs where they came
from, and so that a record from Python passes every check a file does).
:func:`as_paths` gives a job its paths: a path as it is; a DataFrame that
:func:`load` read and that still holds the values it read, its file; any
other DataFrame (the user's own, or a loaded one changed, e.g. a rudder
offset added) written as Parquet with its ``attrs`` into the job's
``records/`` folder, then read back through the data contract like any file.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

import pandas as pd

from ..errors import ConfigError

__all__ = ["load", "as_paths", "digest"]


def digest(frame: pd.DataFrame) -> str:
    """16 hex digits of a record's columns and values (not its ``attrs``)."""
    hashed = pd.util.hash_pandas_object(frame, index=False).to_numpy()
    text = ",".join(map(str, frame.columns)).encode()
    return hashlib.sha1(text + hashed.tobytes()).hexdigest()[:16]


def _one(source, vessel: str | None) -> pd.DataFrame:
    from ..workflows.measured import read_record

    if isinstance(source, pd.DataFrame):
        from ..data.contract import validate_manoeuvre

        name = str(source.attrs.get("name", "record"))
        record = validate_manoeuvre(source, name)
    elif isinstance(source, (str, os.PathLike)):
        record = read_record(source)
        record.attrs["source"] = str(source)
    else:
        raise ConfigError(f"load: a path or a DataFrame, got {type(source).__name__}")
    if vessel is not None:
        record.attrs["vessel"] = str(vessel)
    record.attrs["digest"] = digest(record)
    return record


def load(source, vessel: str | None = None):
    """Records as a study reads them; one DataFrame for one path or frame, a list for a list.

    Parameters
    ----------
    source : str, path, DataFrame, or a list of them
        Record files (``.dat`` of MARIN or HSVA, ``.csv``, ``.parquet``) or
        DataFrames in the data contract, checked like files.
    vessel : str, optional
        The ship the records are of (``kvlcc2``, ``mariner``, a registered
        name): what a sidecar ``vessel.yaml`` says beside a file. Studies of
        these records use it unless given another ``vessel=``.

    Returns
    -------
    DataFrame or list of DataFrame
        Columns in the data contract (SI units, radians); ``attrs`` as the
        module's docstring says. A bad file or frame raises
        :class:`~studies.errors.DataError` with one line (file, column, row).
    """
    if isinstance(source, (list, tuple)):
        return [_one(s, vessel) for s in source]
    return _one(source, vessel)


def _unchanged_file(record: pd.DataFrame) -> str | None:
    source = record.attrs.get("source")
    if source and Path(source).is_file() and record.attrs.get("digest") == digest(record):
        return str(source)
    return None


def _file_name(record: pd.DataFrame, i: int, taken: set) -> str:
    stem = re.sub(r"[^\w.\-]", "_", str(record.attrs.get("name") or f"record_{i}"))
    name, n = f"{stem}.parquet", 1
    while name in taken:
        n += 1
        name = f"{stem}_{n}.parquet"
    taken.add(name)
    return name


def as_paths(records, folder: Path, what: str = "records") -> list[str]:
    """Paths of ``records`` for a job (see the module's docstring); DataFrames
    that are not their file are written into ``folder/records/``."""
    if records is None:
        return []
    if isinstance(records, (str, os.PathLike, pd.DataFrame)):
        records = [records]
    paths, taken = [], set()
    for i, record in enumerate(records):
        if isinstance(record, (str, os.PathLike)):
            paths.append(str(record))
            continue
        if not isinstance(record, pd.DataFrame):
            raise ConfigError(f"{what}[{i}]: a path or a DataFrame, got {type(record).__name__}")
        path = _unchanged_file(record)
        if path is None:
            target = Path(folder) / "records"
            target.mkdir(parents=True, exist_ok=True)
            path = str(target / _file_name(record, i, taken))
            frame = record.reset_index(drop=True)
            frame.attrs = {k: v for k, v in record.attrs.items()
                           if isinstance(v, (str, int, float, bool)) and k not in ("source", "digest")}
            frame.to_parquet(path, index=False)
        paths.append(path)
    return paths


def vessel_of(*groups) -> str | None:
    """The vessel :func:`load` was told the records are of, when they agree."""
    named = {str(r.attrs["vessel"]) for group in groups if group is not None
             for r in ([group] if isinstance(group, pd.DataFrame) else group)
             if isinstance(r, pd.DataFrame) and r.attrs.get("vessel")}
    return named.pop() if len(named) == 1 else None
