"""``none``: the baseline as it is, the cause every other is scored against."""

from __future__ import annotations

from .base import Cause

__all__ = ["NoCause"]


class NoCause(Cause):
    """The identified model already explains the data; no parameters, no change.

    Every hook is the base class's: the records are read as measured, the
    model is the baseline's, the replay is in the record's own wind.
    """

    id = "none"
    no_effect: dict = {}
    explanation = "The identified model already explains the data: no extension gains on unseen data."
