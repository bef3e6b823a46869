"""Manoeuvring data: the data contract, its validation, and file loaders.

Public API
----------
REQUIRED_COLUMNS, OPTIONAL_COLUMNS
    Column names of the data contract (``DESIGN.md``, "Data contract").
validate_manoeuvre(df, file, min_samples=10)
    Check a table against the contract; return a clean float64 copy.
read_table(path)
    Read a CSV or Parquet file (no validation).
load_manoeuvre(path, min_samples=10), load_manoeuvres(paths, min_samples=10)
    Read and validate one record / a list of records (CSV, Parquet, MARIN or HSVA .dat).
read_dat(path, min_samples=10, *, uniform_time=False)
    Read a free-running ``.dat`` file of MARIN or HSVA, told apart by its layout.
read_marin(path, model_scale=False, scale=45.7, *, uniform_time=False, min_samples=10)
    Read a MARIN free-running ``.dat`` file (full scale) into the contract.
read_hsva(path, full_scale=False, scale=45.7, *, min_samples=10)
    Read an HSVA free-running ``.dat`` file (model scale) into the contract.
froude_scale(record, to)
    A record at model or full scale (Froude similarity, ``attrs`` say which).
ship_evidence(path)
    What a record's files say about its ship (sidecar, header, particulars).

Every refusal raises :class:`studies.errors.DataError`.

Modules: :mod:`~studies.data.contract` (the contract and its validation),
:mod:`~studies.data.files` (safe reading of a file's bytes),
:mod:`~studies.data.io` (CSV / Parquet tables and the loaders),
:mod:`~studies.data.marin` (MARIN ``.dat`` files),
:mod:`~studies.data.hsva` (HSVA ``.dat`` files),
:mod:`~studies.data.scaling` (Froude scaling between model and ship),
:mod:`~studies.data.ships` (which ship a record's files name),
:mod:`~studies.data.resample` (records on an even time grid) and
:mod:`~studies.data.derivatives` (model-free state and acceleration
estimates).
"""

from studies.data.contract import (OPTIONAL_COLUMNS, REQUIRED_COLUMNS,
                                   validate_manoeuvre)
from studies.data.hsva import read_hsva
from studies.data.io import load_manoeuvre, load_manoeuvres, read_dat, read_table
from studies.data.marin import read_marin
from studies.data.scaling import froude_scale
from studies.data.ships import ship_evidence

__all__ = [
    "REQUIRED_COLUMNS",
    "OPTIONAL_COLUMNS",
    "validate_manoeuvre",
    "read_table",
    "load_manoeuvre",
    "load_manoeuvres",
    "read_dat",
    "read_marin",
    "read_hsva",
    "froude_scale",
    "ship_evidence",
]
