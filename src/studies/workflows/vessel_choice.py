"""Which ship a study is about: ``vessel=auto`` (the default) reads it from the records.

``vessel=<name>`` names the ship and overrides what the records say (a line
in the log says when they disagree). With ``vessel=auto``:

- a study that simulates its records (no ``data.path``) simulates the
  Mariner, the vessel with published reference coefficients;
- a study of measured records takes the ship the records name: a sidecar
  ``<file>.yaml`` / ``vessel.yaml`` with ``vessel: <name>``, the title lines
  or the name of a MARIN or HSVA ``.dat`` file, or a particulars file
  ``ship_data.yml`` beside them whose dimensions are those of a registered
  vessel (:func:`studies.data.ship_evidence`,
  :func:`studies.vessels.vessel_with_particulars`);
- a record that names no ship, records that name different ships, or a
  ship that is not registered are refused with one line naming the file:
  a measured record is never analysed as another ship.

Roll-decay studies take the ship from their own records
(:mod:`studies.roll.records`) and are left alone here.
"""

from __future__ import annotations

import logging
from pathlib import Path

from ..data.ships import ship_evidence
from ..errors import DataError
from ..vessels import known_vessels, vessel_with_particulars
from .settings import as_path_list

__all__ = ["AUTO", "SIMULATED_VESSEL", "vessel_of_records", "settle_vessel", "simulated_vessel"]

log = logging.getLogger(__name__)

#: the ``vessel=`` option that reads the ship from the records
AUTO = "auto"
#: the vessel a study simulates when ``vessel=auto`` and no record is given
SIMULATED_VESSEL = "mariner"


def _located(path, root: Path | None) -> Path:
    p = Path(str(path)).expanduser()
    return p if p.is_absolute() or root is None else Path(root) / p


def _ship_of(path, root: Path | None) -> tuple[str | None, str]:
    """The registered vessel one record names, and where it says so."""
    evidence = ship_evidence(_located(path, root))
    known = known_vessels()
    if evidence.name is not None:
        if evidence.name not in known:
            raise DataError(str(path), f"the record is of the {evidence.name.upper()} ({evidence.source}), a "
                            f"ship studies has no particulars for (known: {', '.join(known)})")
        return evidence.name, evidence.source
    if evidence.particulars:
        name = vessel_with_particulars(evidence.particulars)
        if name is None:
            dims = ", ".join(f"{k} {v:.4g}" for k, v in evidence.particulars.items())
            raise DataError(str(path), f"the {evidence.source} beside it ({dims}, full scale) fits no known "
                            f"vessel ({', '.join(known)}); give vessel=<name>")
        return name, evidence.source
    return None, ""


def vessel_of_records(paths, root: Path | None = None) -> str:
    """The registered vessel every record of ``paths`` names (see the module).

    Raises
    ------
    DataError
        A record names no ship, an unknown ship, or another ship than the
        others.
    """
    named: dict[str, str] = {}
    for path in paths:
        name, source = _ship_of(path, root)
        if name is None:
            raise DataError(str(path), "the record does not say which ship it is: give vessel=<name> "
                            f"({', '.join(known_vessels())}), or put a sidecar '{Path(str(path)).name}.yaml' "
                            "beside it holding 'vessel: <name>'")
        named.setdefault(name, f"{path} ({source})")
    if len(named) > 1:
        (first, where), (second, other) = list(named.items())[:2]
        raise DataError(other.split(" (")[0], f"the records are of different ships: {second} here, "
                        f"{first} in {where}; one study is of one ship")
    return next(iter(named))


def settle_vessel(cfg, root: Path | None = None) -> str:
    """Resolve ``cfg.vessel.name`` in place (``auto`` to a name) and return it.

    ``cfg`` is a typed ``RunConfig`` or ``DiscoverConfig``. Roll-decay
    studies are returned as they are. With a named vessel the records are
    still read for a ship name, and a disagreement is logged, not refused
    (``vessel=`` overrides).
    """
    name = str(cfg.vessel.name)
    if getattr(cfg.model, "study", "manoeuvring") != "manoeuvring":
        return name
    paths = as_path_list(cfg.data.path) + as_path_list(getattr(cfg.validate, "path", None))
    if name != AUTO:
        for path in paths:
            try:
                said, source = _ship_of(path, root)
            except DataError:
                continue
            if said is not None and said != name:
                log.warning("vessel=%s overrides the record %s, which names the %s (%s)", name, path,
                            said, source)
        return name
    cfg.vessel.name = vessel_of_records(paths, root) if paths else SIMULATED_VESSEL
    return cfg.vessel.name


def simulated_vessel(cfg) -> str:
    """The vessel whose reference model a simulated study uses (``auto``: the Mariner)."""
    name = str(cfg.vessel.name)
    return SIMULATED_VESSEL if name == AUTO else name
