"""The test that would settle a class of look-alike causes: which standard
manoeuvre tells its members apart best, and with what evidence.

The records at hand cannot tell the members of a class apart
(:mod:`studies.discovery.look_alike`), but each member is fitted: each is a
model that predicts any manoeuvre. Where their predictions of a manoeuvre
differ by more than the error the named model makes on the records it was
fitted to, running that manoeuvre would separate them.

1. **The menu**: turning circles to both sides at 35 deg of rudder, 10/10
   and 20/20 zig-zags started to both sides, a straight run with the rudder
   amidships, and (with a propeller rate in the model) a turning circle at
   60 % of the rate. Each lasts as long as the longest training record, at
   its sampling interval, from the first training record's speed.
2. **Its rudder (and rate)**: each manoeuvre is steered once, closed loop,
   by the baseline identified on the records; every member then replays
   those inputs from the same initial state, as a test would apply them.
3. **Separation** of the named member ``a`` from a rival ``b`` on a record::

       S = sum over u, v, r of  mean_t (x_a - x_b)^2 / sigma^2  *  T / tau

   ``sigma`` each state's error of the named model replaying its training
   records over the judge's windows, ``tau`` the error's correlation time (a
   quarter of the judge's blocks), ``T`` the record's duration. Whole
   open-loop replays drift apart far more than the judge's evidence says
   (on MARIN's records S is in the hundreds where the judge's t is 2), so
   ``S`` is used only as a **ratio**: the manoeuvre's separation over the
   training records' own (each training record's inputs replayed whole by
   both members), ``R``.
4. **The recommendation** is the manoeuvre whose smallest ratio over the
   rivals is largest. Its **expected evidence** over each rival is the
   judge's evidence on the records scaled as the separation's energy grows
   to ``1 + R`` times: ``e (1 + R) ** (1 / 2)`` for the blocks' t,
   ``e (1 + R)`` for the tracks' likelihood ratio (0 where the records'
   evidence is not positive: nothing to scale).

An approximation: one correlation time, Gaussian errors, the menu's inputs
steered by the baseline, not the true ship; checked by adding the
recommended manoeuvre, simulated, to the records and discovering again.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from ..simulate.manoeuvres import Manoeuvre
from .fitting import CauseFit, Context, validate

__all__ = ["menu", "settle", "STATES"]

#: the states compared between members' predictions
STATES = ("u", "v", "r")
#: the propeller rate of the slow turning circle, as a fraction of the records' own
SLOW_RATE = 0.6


def menu(duration: float, dt: float, with_rate: bool) -> list[tuple[Manoeuvre, dict]]:
    """The standard manoeuvres with what each needs beyond the programme
    (``{"rate": fraction of the propeller rate}``)."""
    def turning(sign, name):
        return Manoeuvre(name, "turning", duration, dt, amplitude=35.0, heading=720.0, first_sign=sign)

    def zigzag(a, sign, name):
        return Manoeuvre(name, "zigzag", duration, dt, amplitude=a, heading=a, first_sign=sign)

    out = [(turning(1, "turning circle 35 deg to port (rudder +35 deg)"), {}),
           (turning(-1, "turning circle 35 deg to starboard (rudder -35 deg)"), {}),
           (zigzag(10.0, 1, "10/10 zig-zag, first rudder +10 deg"), {}),
           (zigzag(10.0, -1, "10/10 zig-zag, first rudder -10 deg"), {}),
           (zigzag(20.0, 1, "20/20 zig-zag, first rudder +20 deg"), {}),
           (zigzag(20.0, -1, "20/20 zig-zag, first rudder -20 deg"), {}),
           (Manoeuvre("straight run, rudder amidships", "rudder", duration, dt, schedule=((0.0, duration, 0.0),)),
            {})]
    if with_rate:
        out.append((turning(1, f"turning circle 35 deg to port at {100 * SLOW_RATE:.0f} % of the propeller rate"),
                    {"rate": SLOW_RATE}))
    return out


def _steered(ctx: Context, baseline: CauseFit, manoeuvre: Manoeuvre, extra: dict) -> pd.DataFrame | None:
    """The manoeuvre steered closed loop by the baseline: a record of its inputs
    (rudder, propeller rate) and the baseline's own states, at the records' scale."""
    first = ctx.train[0]
    speed = float(np.hypot(first["u"].iloc[0], first["v"].iloc[0]))
    initial = {"u": speed, "v": 0.0, "r": 0.0, "x0": 0.0, "y0": 0.0, "psi": 0.0, "delta": 0.0}
    if ctx.dynamics is not None:
        from ..simulate.mmg import simulate_mmg

        vessel = ctx.dynamics.vessel
        rate = float(first["n"].iloc[0]) if "n" in first else float(vessel.rps)
        record = simulate_mmg(ctx.dynamics.model, baseline.params, vessel, manoeuvre,
                              rps=rate * extra.get("rate", 1.0), initial=initial)
    else:
        if extra.get("rate"):
            return None
        from ..simulate.simulator import simulate

        record = simulate(ctx.model, baseline.params, ctx.vessel, manoeuvre, initial=initial)
        if "n" in first:
            # the records' propeller rate, held (a member that adds a propeller replays it)
            record["n"] = float(first["n"].iloc[0])
    if "diverged_at" in record.attrs:
        return None
    record.attrs.update({k: v for k, v in first.attrs.items() if k not in ("name", "injected")})
    record.attrs["name"] = manoeuvre.name
    return record


def _noise(ctx: Context, named: CauseFit) -> dict:
    """Each state's error of the named model replaying its training records over windows."""
    own = replace(ctx, validation=list(ctx.train))
    probe = replace(named, validation={})
    errors = validate(own, probe)
    return {s: float(errors[f"rmse_{s}"]) for s in STATES}


def _separation(base: pd.DataFrame, pred: pd.DataFrame, sigma: dict, samples: float) -> float:
    """``sum over u, v, r of mean_t (x_a - x_b)^2 / sigma^2`` times the independent samples."""
    return float(sum(np.mean((base[s].to_numpy(float) - pred[s].to_numpy(float)) ** 2) / sigma[s] ** 2
                     for s in STATES) * samples)


def _replays(ctx: Context, members: dict, record: pd.DataFrame) -> dict:
    """``{member: its replay of record}``, those that stay bounded."""
    out = {}
    for mid, fit in members.items():
        pred = fit.setup.replay(fit.params, ctx.vessel, record)
        if "diverged_at" not in pred.attrs:
            out[mid] = pred
    return out


def _separations(predictions: dict, named: str, sigma: dict, samples: float) -> dict:
    """``{rival: separation}`` of every member's replay from the named one's."""
    if named not in predictions:
        return {}
    base = predictions[named]
    return {rival: _separation(base, pred, sigma, samples) for rival, pred in predictions.items() if rival != named}


def settle(ctx: Context, baseline: CauseFit, members: dict, named: str, correlation_s: float,
           observed: dict, needed: float, order: int) -> dict | None:
    """The manoeuvre of the menu that separates the class best (module docstring).

    Parameters
    ----------
    ctx : Context
        The training records, the baseline and its vessel.
    baseline : CauseFit
        The baseline identified on the records (it steers the menu).
    members : dict
        ``{member id: CauseFit}``: the class's fitted members (the named one among them).
    named : str
        The named member's id.
    correlation_s : float
        Correlation time of the records' error [s].
    observed : dict
        ``{rival: the judge's evidence for the named over it on the records}``.
    needed : float
        The judge's evidence that tells two causes apart.
    order : int
        The power of the separation's energy the judge's evidence grows as the
        inverse of: 2 for a t-like statistic (it grows as the square root), 1
        for a log-likelihood ratio.

    Returns
    -------
    dict or None
        ``manoeuvre`` (the recommendation), ``evidence`` (``{rival: expected
        evidence}`` with it added to the records), ``needed``, ``ratio`` (per
        manoeuvre, ``{rival: its separation over the training records'}``),
        ``noise`` (``sigma`` per state), ``correlation_s``, ``predictions``
        (``{member: DataFrame}``: the recommended manoeuvre as each member
        predicts it, data contract); None with fewer than two fitted members
        or nothing the menu could steer.
    """
    if named not in members or len(members) < 2:
        return None
    sigma = _noise(ctx, members[named])
    if not all(np.isfinite(v) and v > 0 for v in sigma.values()):
        return None
    durations = [float(r["t"].iloc[-1] - r["t"].iloc[0]) for r in ctx.train]
    dt = float(np.median(np.diff(ctx.train[0]["t"].to_numpy(float))))
    # the separation the training records' own inputs give (each replayed whole by every member)
    on_records = {}
    for rec in ctx.train:
        samples = float(rec["t"].iloc[-1] - rec["t"].iloc[0]) / max(correlation_s, dt)
        for rival, e in _separations(_replays(ctx, members, rec), named, sigma, samples).items():
            on_records[rival] = on_records.get(rival, 0.0) + e
    ratio, runs = {}, {}
    for manoeuvre, extra in menu(max(durations), dt, ctx.dynamics is not None):
        record = _steered(ctx, baseline, manoeuvre, extra)
        if record is None:
            continue
        predictions = _replays(ctx, members, record)
        row = _separations(predictions, named, sigma, manoeuvre.duration / max(correlation_s, dt))
        row = {rival: e / on_records[rival] for rival, e in row.items() if on_records.get(rival, 0.0) > 0}
        if row:
            ratio[manoeuvre.name] = row
            runs[manoeuvre.name] = (record, predictions)
    if not ratio:
        return None
    best = max(ratio, key=lambda name: min(ratio[name].values()))
    steered, predicted = runs[best]
    for mid, pred in predicted.items():
        # the inputs as a test records them (a member's replay holds the rudder its
        # hydrodynamics see: an offset's less the offset)
        t = pred["t"].to_numpy(float)
        for column in ("delta", "n"):
            if column in steered:
                pred[column] = np.interp(t, steered["t"].to_numpy(float), steered[column].to_numpy(float))
        pred.attrs["name"] = f"{best} as {mid} predicts it"
    expected = {rival: float(max(float(observed.get(rival, 0.0)), 0.0) * (1.0 + r) ** (1.0 / order))
                for rival, r in ratio[best].items()}
    return {"manoeuvre": best, "evidence": expected, "needed": float(needed), "ratio": ratio,
            "noise": sigma, "correlation_s": float(correlation_s), "predictions": predicted}
