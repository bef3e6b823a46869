"""Models by the names of the ``model=`` config group."""

from __future__ import annotations

from ..errors import ConfigError
from .abkowitz import ManoeuvringModel, abkowitz
from .mmg import mmg
from .simplified import PAPER_SIMPLIFIED, load_definition

__all__ = ["get_model"]


def symmetric() -> ManoeuvringModel:
    """The Abkowitz model without its port-starboard asymmetric terms
    (Y0, Y0u, Y0uu, N0, N0u, N0uu): a symmetric hull and propulsion."""
    full = abkowitz()
    keep = [t.name for t in full.terms if not (t.dof in ("Y", "N") and t.powers[1:] == (0, 0, 0))]
    return full.subset(keep, "symmetric")


def simplified_li2023() -> ManoeuvringModel:
    """The simplified model of Li et al. (2023) eq. 23-25 as a fixed subset
    of the Abkowitz model: ``X: Xu, Xrr``; ``Y: Yv, Yr, Yru, Yd, Yud``;
    ``N: Nv, Nr, Nru, Nd, Nud``."""
    names = [n for dof in ("X", "Y", "N") for n in PAPER_SIMPLIFIED[dof]]
    return abkowitz().subset(names, "simplified_li2023")


_REGISTRY = {"abkowitz": abkowitz, "symmetric": symmetric, "simplified_li2023": simplified_li2023,
             "mmg": mmg}


def get_model(name: str, definition=None) -> ManoeuvringModel:
    """Return the manoeuvring model registered as ``name``.

    ``simplified`` is read from its ``definition`` file (written by
    ``studies simplify``), as a subset of the Abkowitz model.
    """
    if name == "simplified":
        if definition is None:
            raise ConfigError("model=simplified needs model.definition (a file written by `studies simplify`)")
        return load_definition(definition, abkowitz())
    try:
        return _REGISTRY[name]()
    except KeyError:
        known = sorted(_REGISTRY) + ["simplified"]
        raise ConfigError(f"unknown model '{name}'; known: {', '.join(known)}") from None
