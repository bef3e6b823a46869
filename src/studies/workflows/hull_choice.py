"""Which MMG hull family the training records support (``model.hull=auto``).

A model identified from zig-zags is used where zig-zags never went (a 35 deg
turn reaches drift angles and yaw rates three times theirs), so the family of
hull terms decides the prediction more than the fit does. The choice is made
on the training records alone, by a rule stated before any other record is
looked at; the validation records (``validate.path``) play no part in it.

For every family of :data:`CANDIDATES` (:data:`studies.models.mmg.HULL_FAMILIES`;
``standard`` and ``thrust`` with the run's ``model.asymmetry``, ``reduced``
carrying its asymmetry in its own terms):

1. **held out**: every training record held out in turn, identified from the
   others with the run's settings and replayed with its measured rudder and
   propeller rate (:func:`studies.workflows.cross_validation.cross_validate`);
   the score is the median over the records of the whole-record position
   RMSE [m], at the records' scale;
2. **admissible in the turn**: identified from every training record, the
   model's 35 deg turning circles to both sides from the approach speed and
   rate must be physical: bounded, turning to the side the rudder commands,
   steady over the last quarter of the run (yaw rate within
   :data:`STEADY_SPREAD`), slower than the approach
   (:data:`SPEED_RANGE` of it) and with a steady diameter in
   :data:`DIAMETER_RANGE` ship lengths. These bounds are generic (any ship in a
   hard-over turn), not read off a record.

The choice is the admissible family with the lowest median held-out RMSE
(:func:`choose_hull`); when none is admissible, the lowest score, said so.
Outputs: ``hull_choice.md`` and ``hull_choice.csv`` (one row per family), the
folds' files under ``hull_choice/<family>/`` and the metrics
``hull_choice/<family>/<quantity>``.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import numpy as np
import pandas as pd

from ..models.mmg import FAMILY_TIES, HULL_FAMILIES, family_modules, mmg
from ..simulate.manoeuvres import turning
from ..simulate.mmg import simulate_mmg
from .cross_validation import cross_validate

logger = logging.getLogger(__name__)

__all__ = ["CANDIDATES", "choose_hull", "turn_admissibility", "with_hull", "HULL_CHOICE_FILE"]

#: the families ``model.hull=auto`` chooses from
CANDIDATES = tuple(HULL_FAMILIES)
HULL_CHOICE_FILE = "hull_choice.md"
#: the steady turn's speed over the approach speed: a hard-over turn slows a ship, and no
#: ship keeps less than this share of its speed
SPEED_RANGE = (0.15, 0.95)
#: the steady turning diameter in ship lengths (a hard-over turn of a merchant ship: about
#: 1.5 to 5 L; outside these bounds the model is not describing a ship)
DIAMETER_RANGE = (1.0, 10.0)
#: steady: the yaw rate's spread (max - min) over the last quarter of the run, as a share
#: of its mean
STEADY_SPREAD = 0.05
#: rudder angle [deg] and length [s at model scale, Froude scaled] of the admissibility turn
TURN_RUDDER_DEG = 35.0
TURN_DURATION_MODEL_S = 120.0


def with_hull(run, hull: str):
    """The prepared MMG run with the hull family ``hull`` (terms, modules and settings)."""
    cfg = run.cfg
    model_cfg = dataclasses.replace(cfg.model, hull=hull)
    model = mmg(str(model_cfg.name), asymmetry=model_cfg.asymmetry, hull=hull)
    return dataclasses.replace(run, cfg=dataclasses.replace(cfg, model=model_cfg), model=model,
                               modules=family_modules(hull, run.vessel.modules))


def turn_admissibility(run, params: dict, modules) -> dict:
    """The 35 deg turns to both sides of the identified model, judged (module docstring).

    Returns ``{"admissible": bool, "reason": str, "<side>/speed_ratio": ...,
    "<side>/diameter_L": ..., "<side>/steady_spread": ...}`` (``side`` port or
    starboard by the heading's change).
    """
    vessel = run.vessel
    duration = TURN_DURATION_MODEL_S * np.sqrt(vessel.length / 7.0)
    out, reasons = {}, []
    for sign in (1, -1):
        man = dataclasses.replace(turning(TURN_RUDDER_DEG, pullout=3600.0, duration=duration,
                                          dt=0.1 * np.sqrt(vessel.length / 7.0)),
                                  first_sign=sign, name=f"turning_{sign * TURN_RUDDER_DEG:+g}")
        sim = simulate_mmg(run.model, params, vessel, man, modules, vessel.rps)
        label = f"rudder {sign * TURN_RUDDER_DEG:+g} deg"
        if "diverged_at" in sim.attrs or not np.isfinite(sim[["u", "v", "r"]].to_numpy()).all():
            reasons.append(f"{label}: diverged")
            continue
        r = sim["r"].to_numpy(float)
        tail = slice(3 * len(r) // 4, None)
        mean_rate = float(np.mean(r[tail]))
        speed = float(np.mean(np.hypot(sim["u"].to_numpy(float)[tail], sim["v"].to_numpy(float)[tail])))
        spread = float(np.ptp(r[tail]) / max(abs(mean_rate), 1e-12))
        ratio = speed / vessel.speed
        diameter = 2.0 * speed / max(abs(mean_rate), 1e-12) / vessel.length
        side = "port" if mean_rate < 0 else "starboard"
        out.update({f"{label}/speed_ratio": ratio, f"{label}/diameter_L": diameter,
                    f"{label}/steady_spread": spread})
        # the contract's sign: a positive rudder turns the ship to a decreasing heading (port)
        if np.sign(mean_rate) != -sign:
            reasons.append(f"{label}: turns to {side}")
        if spread > STEADY_SPREAD:
            reasons.append(f"{label}: not steady (yaw rate spread {spread:.0%})")
        if not SPEED_RANGE[0] <= ratio <= SPEED_RANGE[1]:
            reasons.append(f"{label}: speed {ratio:.2f} U0")
        if not DIAMETER_RANGE[0] <= diameter <= DIAMETER_RANGE[1]:
            reasons.append(f"{label}: steady diameter {diameter:.1f} L")
    out["admissible"] = not reasons
    out["reason"] = "; ".join(reasons) if reasons else "physical"
    return out


def choose_hull(run, identify, out_dir: Path) -> tuple[str, dict]:
    """``(family, metrics)``: the family :data:`CANDIDATES` the training records support
    (module docstring), with ``hull_choice.md``/``.csv`` written to ``out_dir``;
    ``identify(run) -> (result, modules, metrics)`` is the run's identification."""
    out_dir = Path(out_dir)
    rows, metrics = [], {}
    for hull in CANDIDATES:
        candidate = with_hull(run, hull)
        _, cv, _ = cross_validate(candidate, identify, out_dir / "hull_choice" / hull, 0,
                                  run.settings.seed, run.cfg.model.cross_validate_jobs)
        result, modules, _ = identify(candidate)
        params = {name: result.params[name] for name in candidate.model.names}
        turn = turn_admissibility(candidate, params, modules)
        score = cv.get("cv/median_abs/rmse_position", np.nan)
        tied = len(FAMILY_TIES.get(hull, ())) if run.cfg.model.tie_rudder else 0
        row = {"family": hull, "terms": len(candidate.model.names),
               "coefficients": len(candidate.model.names) - tied,      # a tied pair is one
               "held-out position RMSE, median [m]": score,
               "held-out 2nd overshoot error, median [deg]": cv.get("cv/median_abs/closed_loop/overshoot2_error_deg",
                                                                     np.nan),
               "admissible": bool(turn["admissible"]), "turn": turn["reason"]}
        for key, value in turn.items():
            if key not in ("admissible", "reason"):
                row[key] = value
        rows.append(row)
        metrics[f"hull_choice/{hull}/cv_median_rmse_position"] = float(score)
        metrics[f"hull_choice/{hull}/admissible"] = float(turn["admissible"])
        logger.info("hull %s: held-out median RMSE %.1f m, turn %s", hull, score, turn["reason"])
    table = pd.DataFrame(rows)
    admissible = table[table["admissible"]]
    pool = admissible if len(admissible) else table
    chosen = str(pool.loc[pool["held-out position RMSE, median [m]"].idxmin(), "family"])
    table["chosen"] = table["family"] == chosen
    table.to_csv(out_dir / "hull_choice.csv", index=False)
    (out_dir / HULL_CHOICE_FILE).write_text(_markdown(table, chosen, bool(len(admissible)), run))
    metrics["hull_choice/chosen_index"] = float(CANDIDATES.index(chosen))
    return chosen, metrics


def _markdown(table: pd.DataFrame, chosen: str, any_admissible: bool, run) -> str:
    training = ", ".join(str(r.attrs.get("name")) for r in run.records)
    fmt = (lambda x: "–" if not np.isfinite(x) else f"{x:.1f}")
    lines = ["# The hull family the training records support", "",
             f"Training records: {training}. Each family's records held out in turn (median whole-record "
             "position RMSE of the held-out replays) and its 35 deg turns to both sides from the approach "
             f"speed judged physical (bounded, turning to the rudder's side, steady, speed "
             f"{SPEED_RANGE[0]}-{SPEED_RANGE[1]} U0, steady diameter {DIAMETER_RANGE[0]:g}-"
             f"{DIAMETER_RANGE[1]:g} L). The rule, stated before any other record is seen: the admissible "
             "family with the lowest held-out RMSE. No validation record plays a part.", "",
             "| family | terms (coefficients: a tied rudder pair is one) | held-out RMSE, median [m] | 2nd overshoot run as the test, median abs [deg] | "
             "turn: speed / U0, steady diameter / L (rudder +35, -35 deg) | turn | chosen |",
             "|---|---:|---:|---:|---|---|---|"]
    for _, r in table.iterrows():
        sides = []
        for sign in ("+35", "-35"):
            ratio, diameter = r.get(f"rudder {sign} deg/speed_ratio"), r.get(f"rudder {sign} deg/diameter_L")
            sides.append("–" if ratio is None or not np.isfinite(ratio) else f"{ratio:.2f}, {diameter:.2f}")
        terms = f"{r['terms']}" + (f" ({r['coefficients']})" if r["coefficients"] != r["terms"] else "")
        lines.append(f"| {r['family']} | {terms} | {fmt(r['held-out position RMSE, median [m]'])} | "
                     f"{fmt(r['held-out 2nd overshoot error, median [deg]'])} | {'; '.join(sides)} | "
                     f"{r['turn']} | {'**yes**' if r['family'] == chosen else ''} |")
    if not any_admissible:
        lines += ["", "No family's turn is physical: the choice is the lowest held-out RMSE alone."]
    return "\n".join(lines) + "\n"
