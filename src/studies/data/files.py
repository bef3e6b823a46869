"""Reading a data file's bytes safely, shared by the table and MARIN loaders.

:func:`read_file_bytes` checks that a path names a readable, non-empty file
and returns its content; :func:`refuse_binary` refuses content that is not
text; :func:`decode_text` decodes text as UTF-8 (with or without a byte-order
mark), falling back to Latin-1. Every refusal is a
:class:`studies.errors.DataError` naming the file as the user gave it.
"""

from __future__ import annotations

import os
from pathlib import Path

import math

import numpy as np

from studies.errors import DataError

__all__ = ["SNIFF_BYTES", "label_and_path", "read_file_bytes", "refuse_binary", "decode_text",
           "number_rows"]

#: bytes inspected at the start of a file to tell text from binary content
SNIFF_BYTES = 4096
#: byte values that are control characters other than tab, line feed and carriage return
_CONTROL = set(range(0, 9)) | set(range(14, 32)) | {127}


def label_and_path(path) -> tuple[str, Path]:
    """The path as the user gave it (for messages) and as a ``Path``."""
    try:
        label = os.fspath(path)
    except TypeError:
        raise DataError(str(path), f"expected a file path, got "
                        f"{type(path).__name__}") from None
    if isinstance(label, bytes):
        label = os.fsdecode(label)
    if not label.strip():
        raise DataError(repr(label), "the file path is empty")
    return label, Path(label).expanduser()


def read_file_bytes(path) -> tuple[str, Path, bytes]:
    """Check that ``path`` is a readable, non-empty file and return its bytes.

    Returns
    -------
    (label, path, data)
        The path as given (for messages), as a ``Path``, and the content.
    """
    label, p = label_and_path(path)
    try:
        exists = p.exists()
    except OSError as exc:
        raise DataError(label, f"cannot access the file: {exc.strerror or exc}") from None
    if not exists:
        raise DataError(label, "the file does not exist; check the path "
                        "(relative paths start at the working directory "
                        f"{os.getcwd()})")
    if p.is_dir():
        raise DataError(label, "is a directory, not a file; give the path of "
                        "a data file")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise DataError(label, f"cannot read the file: {exc.strerror or exc}") from None
    if len(data) == 0:
        raise DataError(label, "the file is empty (0 bytes)")
    if not data.strip():
        raise DataError(label, "the file contains only whitespace, no data")
    return label, p, data


def refuse_binary(label: str, data: bytes, expected: str) -> None:
    """Refuse content that is not text (NUL bytes or mostly non-text)."""
    head = data[:SNIFF_BYTES]
    hint = ""
    if head.startswith(b"PAR1"):
        hint = "; it looks like a Parquet file: give it the suffix .parquet"
    elif head.startswith((b"\xff\xfe", b"\xfe\xff")):
        hint = "; it looks like UTF-16 text: save it as UTF-8"
    elif head.startswith(b"PK\x03\x04"):
        hint = "; it looks like a zip archive or an Excel workbook: export it as CSV"
    if b"\x00" in head:
        raise DataError(label, f"is a binary file, not {expected} (NUL bytes in "
                        f"the first {SNIFF_BYTES // 1024} KiB){hint}")
    control = sum(1 for b in head if b in _CONTROL)
    if control > 0.1 * len(head):
        raise DataError(label, f"is a binary file, not {expected} (mostly "
                        f"non-text bytes in the first {SNIFF_BYTES // 1024} "
                        f"KiB){hint}")
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        # A multi-byte character cut at the end of the sniffed block is fine.
        if exc.start < len(head) - 4:
            high = sum(1 for b in head if b >= 0x80)
            if high > 0.3 * len(head):
                raise DataError(label, f"is a binary file, not {expected} "
                                "(mostly non-text bytes in the first "
                                f"{SNIFF_BYTES // 1024} KiB){hint}") from None


def decode_text(data: bytes) -> str:
    """The file's text: UTF-8 (a byte-order mark is dropped), else Latin-1."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _number_rows_at_once(lines: list[str], first_line: int, width: int):
    """:func:`number_rows` for a well-formed file, converted by numpy in one go
    (about ten times faster); None when anything is off, so that the row by
    row reading finds and names the fault."""
    kept = [(n, tokens) for n, tokens in enumerate((line.split() for line in lines), start=first_line) if tokens]
    if not kept or any(len(tokens) != width for _, tokens in kept):
        return None
    try:
        values = np.array([token for _, tokens in kept for token in tokens], dtype=np.float64)
    except ValueError:
        return None
    if not np.isfinite(values).all():
        return None
    return values.reshape(len(kept), width), np.asarray([n for n, _ in kept])


def number_rows(label: str, lines: list[str], first_line: int, columns, layout: str
                ) -> tuple[np.ndarray, np.ndarray]:
    """Rows of whitespace-separated numbers of a test facility's ``.dat`` file.

    ``lines`` are the data lines, the first being line ``first_line`` of the
    file; blank lines are skipped. Returns the numbers (one row per data
    line, one column per name of ``columns``) and each row's line number.
    A row with another number of values, a value that is not a number or
    is not finite, or no row at all is a :class:`DataError` naming the line,
    the column and the zero-based data row (``layout`` says what is expected).
    """
    fast = _number_rows_at_once(lines, first_line, len(columns))
    if fast is not None:
        return fast
    rows, numbers = [], []
    for line_number, line in enumerate(lines, start=first_line):
        tokens = line.split()
        if not tokens:               # blank or tab-only lines (a file's tail)
            continue
        row = len(rows)
        if len(tokens) != len(columns):
            raise DataError(label, f"line {line_number} has {len(tokens)} values "
                            f"instead of {len(columns)}; {layout}", row=row)
        values = []
        for name, token in zip(columns, tokens):
            try:
                value = float(token)
            except ValueError:
                shown = token if len(token) <= 20 else token[:17] + "..."
                raise DataError(label, f"value '{shown}' on line {line_number} "
                                "is not a number", column=name, row=row) from None
            if not math.isfinite(value):
                raise DataError(label, f"value '{token}' on line {line_number} "
                                "is not a finite number", column=name, row=row)
            values.append(value)
        rows.append(values)
        numbers.append(line_number)
    if not rows:
        raise DataError(label, f"no data rows after the title lines; {layout}")
    return np.asarray(rows, dtype=np.float64), np.asarray(numbers)
