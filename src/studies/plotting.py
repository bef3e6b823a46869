"""The one place that chooses matplotlib's backend.

Every figure `studies` writes is a PNG file made without a screen, so the
non-interactive Agg backend is selected once, here, before pyplot is first
imported. Matplotlib is loaded on first use only: commands that draw nothing
(``studies bench``, the configuration check) do not pay for it.
"""

from __future__ import annotations

import functools

__all__ = ["pyplot"]


@functools.cache
def pyplot():
    """``matplotlib.pyplot`` with the Agg backend (loaded on the first call).

    Matplotlib's one-time "building the font cache" notice on a fresh
    machine is library bookkeeping, not a message for the user: its logger
    is kept to errors.
    """
    import logging

    logging.getLogger("matplotlib.font_manager").setLevel(logging.ERROR)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
