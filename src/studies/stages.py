"""What a long command is doing now: one line per stage on stderr.

``[studies] discover: smoothing 3 records (4.2 s)``: the stage that starts
and the seconds since the command started. The workflows say their stages
once the inputs are checked and the run is open (a refused input stays one
line); the jobs of a sweep stay quiet (the sweep prints a line per job).
"""

from __future__ import annotations

import os
import sys
import time

__all__ = ["say", "restart", "QUIET_ENV"]

#: set (to anything) to silence the stage lines (a sweep's jobs set it)
QUIET_ENV = "STUDIES_QUIET_STAGES"

_started = time.perf_counter()


def restart() -> None:
    """Count the seconds from now (a command's start, for commands run in one process)."""
    global _started
    _started = time.perf_counter()


def say(stage: str) -> None:
    """Print ``[studies] <stage> (<seconds since the start> s)`` on stderr."""
    if os.environ.get(QUIET_ENV):
        return
    print(f"[studies] {stage} ({time.perf_counter() - _started:.1f} s)", file=sys.stderr, flush=True)
