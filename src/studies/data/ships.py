"""What a record's files say about the ship that made it.

A measured record says which ship it is in one of three ways, looked for in
this order by :func:`ship_evidence`:

1. a sidecar YAML file beside it, ``<file name>.yaml`` (e.g.
   ``run3.csv.yaml``), ``<stem>.yaml`` or ``vessel.yaml`` for every record of
   the folder, with a key ``vessel`` naming the ship (e.g. ``vessel:
   kvlcc2``);
2. the record's own header: the title lines of a MARIN or HSVA ``.dat``
   file (``Zig-zag manoeuvring for KVLCC2 : 10 / -10``) or, failing that,
   its file name (``MARIN_FREE_KVLCC2_zz_10_m.dat``);
3. a particulars file beside it (``ship_data.yml`` or ``ship_data.yaml``,
   keys ``L`` [m], ``B``, ``T``, ``volume`` [m^3] and ``scale_factor``),
   whose main dimensions are matched against the known vessels by
   :func:`studies.vessels.vessel_with_particulars`.

Nothing here decides which registered vessel a name means or refuses a
record: :class:`ShipEvidence` only reports what the files hold.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from studies.errors import DataError

__all__ = ["ShipEvidence", "ship_evidence", "ship_named", "SIDECAR_KEY", "PARTICULARS_FILES",
           "HULL_NAMES"]

#: key of a sidecar YAML file that names the ship
SIDECAR_KEY = "vessel"
#: particulars files looked for beside a record
PARTICULARS_FILES = ("ship_data.yml", "ship_data.yaml")
#: hull names recognised in a file's title lines or name (benchmark hulls and the registered ships)
HULL_NAMES = ("KVLCC2", "KVLCC1", "KCS", "DTC", "JBC", "ONRT", "DTMB5415", "MARINER")
#: lines read from the top of a ``.dat`` file for its titles
_TITLE_LINES = 4


@dataclass(frozen=True)
class ShipEvidence:
    """What the files of one record say about its ship.

    Attributes
    ----------
    name : str or None
        The ship named by a sidecar or the header (lower case), or None.
    particulars : dict
        Main dimensions from a particulars file beside the record, at full
        scale (``length`` [m], ``beam`` [m], ``draught`` [m], ``volume``
        [m^3]; those given), empty when there is none.
    source : str
        Where the evidence was read (``sidecar run3.csv.yaml``, ``title
        line 2``, ``file name``, ``particulars ship_data.yml``), or "".
    """

    name: str | None = None
    particulars: dict = field(default_factory=dict)
    source: str = ""


def ship_named(text: str) -> str | None:
    """The hull of :data:`HULL_NAMES` named in ``text`` (lower case), or None."""
    squeezed = re.sub(r"[\s_\-]+", " ", str(text).upper())
    for hull in HULL_NAMES:
        if re.search(rf"(?<![A-Z0-9]){hull}(?![A-Z0-9])", squeezed.replace("DTMB 5415", "DTMB5415")):
            return hull.lower()
    return None


def _read_yaml(path: Path) -> dict:
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8", errors="replace"))
    except (OSError, yaml.YAMLError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise DataError(str(path), f"cannot be read as YAML: {first}") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise DataError(str(path), "must hold a mapping of keys to values (e.g. 'vessel: kvlcc2')")
    return data


def _sidecar(path: Path) -> ShipEvidence | None:
    for candidate in (path.with_name(path.name + ".yaml"), path.with_suffix(".yaml"),
                      path.with_name("vessel.yaml")):
        if candidate == path or not candidate.is_file():
            continue
        data = _read_yaml(candidate)
        if SIDECAR_KEY not in data:
            continue
        name = str(data[SIDECAR_KEY]).strip().lower()
        if not name:
            raise DataError(str(candidate), f"'{SIDECAR_KEY}' is empty; name the ship (e.g. "
                            f"'{SIDECAR_KEY}: kvlcc2')", column=SIDECAR_KEY)
        return ShipEvidence(name=name, source=f"sidecar {candidate.name}")
    return None


def _header(path: Path) -> ShipEvidence | None:
    if path.suffix.lower() == ".dat":
        try:
            with path.open("rb") as handle:
                head = [handle.readline().decode("cp1252", errors="replace") for _ in range(_TITLE_LINES)]
        except OSError:
            head = []
        for number, line in enumerate(head, start=1):
            if re.search(r"\d[\d.eE+\-]*\s+[\d.\-]", line) and len(line.split()) > 6:
                break                                     # a data row: the titles are over
            name = ship_named(line)
            if name:
                return ShipEvidence(name=name, source=f"title line {number}")
    name = ship_named(path.stem)
    if name:
        return ShipEvidence(name=name, source="file name")
    return None


def _float(data: dict, key: str) -> float | None:
    try:
        value = float(data[key])
    except (KeyError, TypeError, ValueError):
        return None
    return value if value > 0 else None


def _particulars(path: Path) -> ShipEvidence | None:
    for name in PARTICULARS_FILES:
        candidate = path.with_name(name)
        if not candidate.is_file():
            continue
        data = _read_yaml(candidate)
        scale = _float(data, "scale_factor") or 1.0
        dims = {}
        for key, label, power in (("L", "length", 1), ("B", "beam", 1), ("T", "draught", 1),
                                  ("volume", "volume", 3)):
            value = _float(data, key)
            if value is not None:
                dims[label] = value * scale ** power
        if "length" in dims:
            return ShipEvidence(particulars=dims, source=f"particulars {name}")
    return None


def ship_evidence(path) -> ShipEvidence:
    """What the files of the record at ``path`` say about its ship (see the module).

    Returns an empty :class:`ShipEvidence` when they say nothing. A sidecar
    or particulars file that cannot be read is a :class:`DataError`.
    """
    p = Path(str(path)).expanduser()
    for look in (_sidecar, _header, _particulars):
        found = look(p)
        if found is not None:
            return found
    return ShipEvidence()
