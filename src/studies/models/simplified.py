"""Simplified model derived from data: correlation groups + PAWN (Li et al. 2023, 4.2).

Rule (section 4.2 of the paper):

1. coefficients whose estimates correlate strongly over noisy realisations
   (every pair |rho| > 0.7) form a group (:mod:`studies.analysis.correlation`);
2. of each group only the coefficient with the largest PAWN index is kept,
   and only when that index is at least the mean index of its DOF
   (:mod:`studies.analysis.pawn`); a group whose best member is below the
   mean is dropped whole;
3. sway and yaw are coupled, so both keep the union of their retained term
   structures (a term kept in Y keeps its N twin and vice versa).

The result is persisted as a model definition (JSON) that ``model=simplified``
loads; the analysis that produced it is logged to MLflow by
:mod:`studies.workflows.simplify`.

References
----------
Li, S., Wang, T., Li, G., Skulstad, R., Zhang, H. (2023). Ship maneuvering
model optimization for improved identification with less excitation. Ocean
Engineering 280, 114540, section 4.2, eq. 23-25.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from ..errors import ConfigError
from .abkowitz import ManoeuvringModel

__all__ = ["select_terms", "union_sway_yaw", "save_definition", "load_definition",
           "PAPER_SIMPLIFIED"]

#: Li et al. (2023) eq. 23-25
PAPER_SIMPLIFIED = {"X": ["Xu", "Xrr"], "Y": ["Yv", "Yr", "Yru", "Yd", "Yud"],
                    "N": ["Nv", "Nr", "Nru", "Nd", "Nud"]}


def select_terms(groups: list[list[str]], sensitivity: pd.Series) -> list[str]:
    """Steps 1-2 of the rule for one DOF: the best of each group if above the mean."""
    mean = float(sensitivity.mean())
    keep = []
    for group in groups:
        best = max(group, key=lambda n: sensitivity[n])
        if sensitivity[best] >= mean:
            keep.append(best)
    return keep


def union_sway_yaw(model: ManoeuvringModel, keep: dict) -> dict:
    """Step 3: Y and N keep the union of their term structures (by monomial)."""
    by_powers = {dof: {t.powers: t.name for t in model.terms_of(dof)} for dof in ("Y", "N")}
    powers = set()
    for dof in ("Y", "N"):
        names = set(keep.get(dof, []))
        powers |= {p for p, n in by_powers[dof].items() if n in names}
    out = dict(keep)
    for dof in ("Y", "N"):
        out[dof] = [t.name for t in model.terms_of(dof) if t.powers in powers]
    return out


def save_definition(path, base: ManoeuvringModel, keep: dict, provenance: dict) -> Path:
    """Write the simplified model definition (JSON) and return its path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ordered = {dof: [n for n in base.names_of(dof) if n in set(keep.get(dof, []))]
               for dof in ("X", "Y", "N")}
    body = {"name": "simplified", "base": base.name, "terms": ordered, "provenance": provenance}
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(body, indent=1))
    tmp.replace(path)
    return path


def load_definition(path, base: ManoeuvringModel) -> ManoeuvringModel:
    """The model a definition file describes, as a subset of ``base``."""
    path = Path(path)
    try:
        body = json.loads(path.read_text())
        names = [n for dof in ("X", "Y", "N") for n in body["terms"].get(dof, [])]
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise ConfigError(f"{path}: not a readable model definition ({exc})") from None
    try:
        return base.subset(names, str(body.get("name", "simplified")))
    except KeyError as exc:
        raise ConfigError(f"{path}: {exc.args[0]}") from None
