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

The rule alone can remove what a manoeuvring model needs (the Mariner's
``Yv`` and ``Yr`` correlate, so one of them goes; its surge keeps ``Xu``
alone, so the speed never leaves the approach speed). After the rule the
structure is checked (:func:`structural_needs`): linear surge, sway and
yaw damping ``Xu, Yv, Yr, Nv, Nr`` and a surge term quadratic in ``v'``/``r'``
that gives the speed loss in turns (``Xvv``, ``Xrr`` or ``Xrv``). The
straight-line stability index is :func:`stability_index`.

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
           "PAPER_SIMPLIFIED", "LINEAR_DAMPING", "SURGE_DAMPING", "SPEED_LOSS", "structural_needs",
           "stability_index", "twin"]

#: Li et al. (2023) eq. 23-25
PAPER_SIMPLIFIED = {"X": ["Xu", "Xrr"], "Y": ["Yv", "Yr", "Yru", "Yd", "Yud"],
                    "N": ["Nv", "Nr", "Nru", "Nd", "Nud"]}

#: linear sway and yaw damping: each one is needed (the straight-line
#: stability index is made of them)
LINEAR_DAMPING = ("Yv", "Yr", "Nv", "Nr")
#: linear surge damping: brings the surge back to the approach speed
SURGE_DAMPING = "Xu"
#: surge terms quadratic in v', r' that slow the ship in a turn; one is needed
SPEED_LOSS = ("Xvv", "Xrr", "Xrv")


def twin(name: str) -> str | None:
    """The other of a sway/yaw pair (``Yv`` <-> ``Nv``); None for surge terms."""
    if name[:1] == "Y":
        return "N" + name[1:]
    if name[:1] == "N":
        return "Y" + name[1:]
    return None


def structural_needs(keep: dict) -> list[tuple[tuple[str, ...], str]]:
    """What a manoeuvring model needs and ``keep`` lacks.

    Parameters
    ----------
    keep : dict
        ``{dof: [names]}`` of the simplified model.

    Returns
    -------
    list of (candidates, reason)
        One entry per missing need: the terms of which one must be put back
        (the most sensitive, chosen by the caller) and why.
    """
    kept = {n for names in keep.values() for n in names}
    needs = []
    if SURGE_DAMPING not in kept:
        needs.append(((SURGE_DAMPING,), "linear surge damping in u': without it the surge does not "
                                        "return to the approach speed"))
    for name in LINEAR_DAMPING:
        if name not in kept:
            kind = "sway" if name[0] == "Y" else "yaw"
            state = "v'" if name[1] == "v" else "r'"
            needs.append(((name,), f"linear {kind} damping in {state}: without it the "
                                   "straight-line stability index is not defined"))
    if not kept & set(SPEED_LOSS):
        needs.append((SPEED_LOSS, "no surge term in v', r': the surge would stay at the "
                                  "approach speed in a turn (no speed loss)"))
    return needs


def stability_index(values: dict) -> float:
    """Straight-line (controls-fixed) stability index ``C`` of a model's values.

    ``C = Y'v (N'r - m' x'G) - N'v (Y'r - m')``; the models of this package
    carry the rigid-body terms inside their coefficients (the simulator has
    no separate ``m' u' r'`` term: ``Yr`` stands for ``Y'r - m'`` and ``Nr``
    for ``N'r - m' x'G``, as in the Mariner tables), so here
    ``C = Yv Nr - Nv Yr`` [-] (prime, squared). ``C > 0``: straight-line
    stable. A missing one of ``Yv, Yr, Nv, Nr`` counts as zero (without
    ``Yv`` and ``Nv``, ``C = 0``: neutral at best); NaN when all are missing.
    """
    if not any(n in values for n in LINEAR_DAMPING):
        return float("nan")
    yv, yr, nv, nr = (float(values.get(n, 0.0)) for n in LINEAR_DAMPING)
    return yv * nr - nv * yr


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


def save_definition(path, base: ManoeuvringModel, keep: dict, provenance: dict,
                    admissibility: dict | None = None) -> Path:
    """Write the simplified model definition (JSON) and return its path.

    ``admissibility`` (the terms put back after the rule and why, the
    stability index, the check of the training manoeuvre) is written as is.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ordered = {dof: [n for n in base.names_of(dof) if n in set(keep.get(dof, []))]
               for dof in ("X", "Y", "N")}
    body = {"name": "simplified", "base": base.name, "terms": ordered}
    if admissibility is not None:
        body["admissibility"] = admissibility
    body["provenance"] = provenance
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
