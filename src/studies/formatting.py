"""Numbers and parameters as people read them, with nothing but the standard library:
shared by the command line's console and the reports of the layers below it."""

from __future__ import annotations

import math

__all__ = ["number", "compact_parameters"]


def number(value) -> str:
    """A number to 4 significant digits for people (``0``, never ``-0``)."""
    if value is None:
        return "-"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if not math.isfinite(value):
        return "-"
    if value == 0:
        return "0"
    return f"{value:.4g}"


def compact_parameters(parameters: dict) -> str:
    """A cause's parameters on one line: nested mappings flattened (a pair's by cause,
    a missing term's by term name), values of none left out, numbers by :func:`number`."""
    flat = {}

    def add(mapping):
        for key, value in mapping.items():
            if isinstance(value, dict):
                add(value)
            elif value is not None:
                flat[key] = value

    add(parameters)
    return ", ".join(f"{k} = {number(v)}" for k, v in flat.items())
