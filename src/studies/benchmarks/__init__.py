"""The performance figures ``studies bench`` reports, one module per subject.

Each module defines ``run() -> dict`` of named figures (medians or single
timings on the machine at hand; compare ratios within one run) and may set
``ON_REQUEST = True`` to run only when named (``studies bench sweep``: it
takes minutes). :func:`shared_data` finds the shared measured records the
KVLCC2 benchmarks read; a benchmark whose records are absent returns no
figures.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["NAMES", "shared_data"]

#: the benchmark modules, by the names ``studies bench`` takes
NAMES = ("simulator", "ga", "bayes", "kvlcc2", "sindy", "discovery_time", "sweep", "cli")


def shared_data(folder: str) -> Path:
    """``<shared data>/<folder>``: ``STUDIES_SHARED_DATA`` when set, else ``../shared/data``
    beside the source tree, else beside the working directory."""
    if os.environ.get("STUDIES_SHARED_DATA"):
        return Path(os.environ["STUDIES_SHARED_DATA"]) / folder
    beside_source = Path(__file__).resolve().parents[3].parent / "shared" / "data" / folder
    if beside_source.is_dir():
        return beside_source
    return Path.cwd().parent / "shared" / "data" / folder
