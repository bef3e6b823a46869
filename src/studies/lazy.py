"""Registries whose entries are imported when used, not when listed.

A command checks a ``method=`` name against the registry before anything is
read; importing every estimator for that check would load emcee, pygad,
pysindy and ``scipy.stats`` (seconds) for a run that uses none of them.
:class:`LazyClasses` answers membership, listing and ``len`` from the names
alone and imports a class the first time it is looked up.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping

__all__ = ["LazyClasses", "load"]


def load(target: str):
    """The object named ``"package.module:attribute"``."""
    module, _, attribute = target.partition(":")
    return getattr(importlib.import_module(module), attribute)


class LazyClasses(Mapping):
    """``{name: class}`` built from ``{name: "package.module:Class"}``; a class
    is imported on its first lookup and kept."""

    def __init__(self, targets: dict[str, str]):
        self._targets = dict(targets)
        self._loaded: dict[str, type] = {}

    def __getitem__(self, name: str):
        if name not in self._loaded:
            self._loaded[name] = load(self._targets[name])
        return self._loaded[name]

    def __iter__(self):
        return iter(self._targets)

    def __len__(self) -> int:
        return len(self._targets)

    def __contains__(self, name) -> bool:
        return name in self._targets

    def __repr__(self) -> str:
        return f"LazyClasses({self._targets!r})"
