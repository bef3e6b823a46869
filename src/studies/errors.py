"""Errors that the command line turns into one clear line and a non-zero exit.

Every refusal of user input raises a subclass of :class:`StudiesError`; the CLI
catches it, prints ``str(error)`` on one line and exits with status 2 before
any MLflow run is created.
"""

from __future__ import annotations

__all__ = ["StudiesError", "DataError", "ConfigError"]


class StudiesError(Exception):
    """Base class of the errors reported to the user as one line."""


class DataError(StudiesError):
    """A data file that does not satisfy the data contract.

    Parameters
    ----------
    file : str
        Path of the offending file as the user gave it.
    message : str
        What is wrong, in words a user understands.
    column : str, optional
        Column name, where one is at fault.
    row : int, optional
        Zero-based data row (not counting the header), where one is at fault.
    """

    def __init__(self, file: str, message: str, column: str | None = None,
                 row: int | None = None):
        self.file = str(file)
        self.message = message
        self.column = column
        self.row = row
        super().__init__(str(self))

    def __reduce__(self):
        # picklable with its fields, so that a refusal inside a sweep worker reaches the launcher
        return (DataError, (self.file, self.message, self.column, self.row))

    def __str__(self) -> str:
        where = [self.file]
        if self.column is not None:
            where.append(f"column '{self.column}'")
        if self.row is not None:
            where.append(f"row {self.row}")
        return f"{', '.join(where)}: {self.message}"


class ConfigError(StudiesError):
    """A configuration value that is unknown or impossible (e.g. negative wind speed)."""
