"""Tables as Markdown pipe tables, for the pages every layer writes (``*.md`` beside a run,
the discovery's report, ``studies report``).

Numbers are printed to 4 significant digits (``1e-3 <= |x| < 1e5``, else in
exponent form); zero prints as ``0`` (never ``-0``), a non-finite number as ``-``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["markdown_table", "format_number"]


def format_number(x) -> str:
    """A cell of :func:`markdown_table`."""
    if isinstance(x, (float, np.floating)):
        if not np.isfinite(x):
            return "-"
        if x == 0:
            return "0"                      # never "-0"
        if 1e-3 <= abs(x) < 1e5:
            return f"{x:.4g}"
        return f"{x:.3e}"
    return str(x)


def markdown_table(table: pd.DataFrame, index_name: str = "") -> str:
    """A pipe table; MultiIndex columns are joined with a line break-free ' / '."""
    if table.empty:
        return "_(no data)_\n"
    cols = [" / ".join(str(c) for c in col) if isinstance(col, tuple) else str(col)
            for col in table.columns]
    lines = ["| " + " | ".join([index_name or ""] + cols) + " |",
             "|" + "---|" * (len(cols) + 1)]
    for idx, row in table.iterrows():
        lines.append("| " + " | ".join([str(idx)] + [format_number(v) for v in row.tolist()]) + " |")
    return "\n".join(lines) + "\n"
